/* test_geom.c - geom.h against independent references: a long-double
 * point-triangle distance written a different way, dense sampling, the
 * closed-form enclosing ball, and float rounding checked with nextafterf. */
#include "check.h"
#include "geom.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#define RNG_SEED 0x6c6f64706970ULL
#include "rng.h"

static vec3d rng_point(double extent)
{
    return geom_vec3d(rng_uniform(-extent, extent), rng_uniform(-extent, extent),
                      rng_uniform(-extent, extent));
}

/* A point on a 1/64 grid: still exact in float after adding 1e5 (float ulp
 * at 1e5 is 1/128), so translated copies are the same shape exactly. */
static vec3d rng_grid_point(double extent)
{
    vec3d v = rng_point(extent);
    return geom_vec3d(floor(v.x * 64.0) / 64.0, floor(v.y * 64.0) / 64.0,
                      floor(v.z * 64.0) / 64.0);
}

/* ---- independent reference, long double ---------------------------------- */

typedef struct {
    long double x, y, z;
} vec3l;

static vec3l to_l(vec3d v)
{
    vec3l r = {v.x, v.y, v.z};
    return r;
}

static vec3l sub_l(vec3l a, vec3l b)
{
    vec3l r = {a.x - b.x, a.y - b.y, a.z - b.z};
    return r;
}

static long double dot_l(vec3l a, vec3l b)
{
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

static long double segment_distance2_l(vec3l p, vec3l a, vec3l b)
{
    vec3l ab = sub_l(b, a), ap = sub_l(p, a);
    long double len2 = dot_l(ab, ab), t = 0.0L;
    if (len2 > 0.0L) {
        t = dot_l(ap, ab) / len2;
        if (t < 0.0L) t = 0.0L;
        if (t > 1.0L) t = 1.0L;
    }
    vec3l q = {a.x + t * ab.x, a.y + t * ab.y, a.z + t * ab.z};
    vec3l d = sub_l(p, q);
    return dot_l(d, d);
}

static long double edges_distance2_l(vec3d pd, vec3d ad, vec3d bd, vec3d cd)
{
    vec3l p = to_l(pd), a = to_l(ad), b = to_l(bd), c = to_l(cd);
    long double best = segment_distance2_l(p, a, b), d = segment_distance2_l(p, b, c);
    if (d < best) best = d;
    d = segment_distance2_l(p, c, a);
    return d < best ? d : best;
}

/* Minimum of the three edges and, when the plane projection solves the 2x2
 * normal equations with non-negative barycentrics, the plane distance. */
static long double triangle_distance2_l(vec3d pd, vec3d ad, vec3d bd, vec3d cd)
{
    vec3l p = to_l(pd), a = to_l(ad), b = to_l(bd), c = to_l(cd);
    long double best = segment_distance2_l(p, a, b);
    long double d = segment_distance2_l(p, b, c);
    if (d < best) best = d;
    d = segment_distance2_l(p, c, a);
    if (d < best) best = d;

    vec3l e0 = sub_l(b, a), e1 = sub_l(c, a), ap = sub_l(p, a);
    long double m00 = dot_l(e0, e0), m01 = dot_l(e0, e1), m11 = dot_l(e1, e1);
    long double r0 = dot_l(e0, ap), r1 = dot_l(e1, ap);
    long double det = m00 * m11 - m01 * m01;
    if (det > 1e-9L * m00 * m11) {
        long double s = (r0 * m11 - r1 * m01) / det;
        long double t = (r1 * m00 - r0 * m01) / det;
        if (s >= 0.0L && t >= 0.0L && s + t <= 1.0L) {
            vec3l q = {a.x + s * e0.x + t * e1.x, a.y + s * e0.y + t * e1.y,
                       a.z + s * e0.z + t * e1.z};
            vec3l diff = sub_l(p, q);
            d = dot_l(diff, diff);
            if (d < best) best = d;
        }
    }
    return best;
}

/* Is q inside triangle abc, to a tolerance relative to the triangle size? */
static int point_on_triangle(vec3d q, vec3d a, vec3d b, vec3d c)
{
    double size = sqrt(geom_distance2(a, b) + geom_distance2(b, c) + geom_distance2(c, a));
    double tolerance = 1e-9 * (size + geom_max_abs_component(a) + 1e-300);
    return geom_point_triangle_distance2(&q, &a, &b, &c, NULL) <= tolerance * tolerance;
}

/* ---- point-triangle distance --------------------------------------------- */

static void test_distance_matches_reference_on_random_triangles(void)
{
    int mismatches = 0, below = 0, off_triangle = 0, inconsistent = 0;
    for (int i = 0; i < 20000; i++) {
        vec3d a = rng_point(1.0), b = rng_point(1.0), c = rng_point(1.0);
        double scale = i % 4 == 0 ? 10.0 : 1.5;
        vec3d p = rng_point(scale);
        if (i % 5 == 0) {
            /* Close to the plane, inside or just outside the triangle. */
            double s = rng_uniform(-0.2, 1.0), t = rng_uniform(-0.2, 1.0 - s);
            vec3d n = geom_triangle_normal(&a, &b, &c);
            p = geom_add_scaled(geom_add_scaled(geom_add_scaled(a, geom_sub(b, a), s),
                                                geom_sub(c, a), t),
                                n, rng_uniform(-0.01, 0.01));
        }
        vec3d q;
        double d2 = geom_point_triangle_distance2(&p, &a, &b, &c, &q);
        long double reference = triangle_distance2_l(p, a, b, c);
        /* Compare distances, not squares: the absolute rounding of the
         * closest point (~1e-16 of the unit coordinates) dominates near 0. */
        double d = sqrt(d2), reference_d = (double)sqrtl(reference);
        double tolerance = 1e-12 * reference_d + 1e-15;
        if (!(fabs(d - reference_d) <= tolerance)) mismatches++;
        if (d < reference_d - tolerance) below++;
        if (!point_on_triangle(q, a, b, c)) off_triangle++;
        if (d2 != geom_distance2(p, q)) inconsistent++;
    }
    CHECK(mismatches == 0, "%d of 20000 distances differ from the reference", mismatches);
    CHECK(below == 0, "%d distances below the reference", below);
    CHECK(off_triangle == 0, "%d closest points off their triangle", off_triangle);
    CHECK(inconsistent == 0, "%d distances not |p - closest|^2", inconsistent);
}

static void test_distance_is_a_minimum_over_samples(void)
{
    /* No sample point of the triangle may be closer than the answer. */
    int violations = 0;
    for (int i = 0; i < 300; i++) {
        vec3d a = rng_point(1.0), b = rng_point(1.0), c = rng_point(1.0), p = rng_point(2.0);
        double d2 = geom_point_triangle_distance2(&p, &a, &b, &c, NULL);
        for (int si = 0; si <= 40; si++)
            for (int ti = 0; si + ti <= 40; ti++) {
                vec3d x = geom_add_scaled(geom_add_scaled(a, geom_sub(b, a), si / 40.0),
                                          geom_sub(c, a), ti / 40.0);
                if (geom_distance2(p, x) < d2 * (1.0 - 1e-12)) violations++;
            }
    }
    CHECK(violations == 0, "%d sample points closer than the reported distance", violations);
}

static void test_distance_regions_exact(void)
{
    vec3d a = geom_vec3d(0, 0, 0), b = geom_vec3d(4, 0, 0), c = geom_vec3d(0, 4, 0), q;
    vec3d above = geom_vec3d(1, 1, 3);
    CHECK(geom_point_triangle_distance2(&above, &a, &b, &c, &q) == 9.0, "face region");
    CHECK(q.x == 1.0 && q.y == 1.0 && q.z == 0.0, "face point (%g %g %g)", q.x, q.y, q.z);
    vec3d beyond_a = geom_vec3d(-1, -2, 0);
    CHECK(geom_point_triangle_distance2(&beyond_a, &a, &b, &c, &q) == 5.0, "vertex a");
    CHECK(q.x == 0 && q.y == 0 && q.z == 0, "vertex a point");
    vec3d below_ab = geom_vec3d(2, -3, 4);
    CHECK(geom_point_triangle_distance2(&below_ab, &a, &b, &c, &q) == 25.0, "edge ab");
    CHECK(q.x == 2 && q.y == 0 && q.z == 0, "edge ab point (%g %g %g)", q.x, q.y, q.z);
    vec3d past_bc = geom_vec3d(3, 3, 0);
    CHECK(geom_point_triangle_distance2(&past_bc, &a, &b, &c, &q) == 2.0, "edge bc");
    vec3d on_triangle = geom_vec3d(1, 2, 0);
    CHECK(geom_point_triangle_distance2(&on_triangle, &a, &b, &c, &q) == 0.0, "on triangle");
}

static void test_distance_degenerate_triangles(void)
{
    int failures = 0, nans = 0;
    for (int i = 0; i < 5000; i++) {
        vec3d a = rng_point(1.0), b = rng_point(1.0), p = rng_point(2.0);
        double s = rng_uniform(-0.5, 1.5);
        vec3d on_line = geom_lerp(a, b, s);   /* collinear, maybe outside [a, b] */
        vec3d lo = s < 0 ? on_line : a, hi = s > 1 ? on_line : b;
        double segment = geom_point_segment_distance2(&p, &lo, &hi, NULL);
        double point = geom_distance2(p, a);

        double cases[6];
        cases[0] = geom_point_triangle_distance2(&p, &a, &b, &on_line, NULL);
        cases[1] = geom_point_triangle_distance2(&p, &on_line, &a, &b, NULL);
        cases[2] = geom_point_triangle_distance2(&p, &b, &on_line, &a, NULL);
        double repeated_ab = geom_point_triangle_distance2(&p, &a, &a, &b, NULL);
        double repeated_bb = geom_point_triangle_distance2(&p, &a, &b, &b, NULL);
        double single = geom_point_triangle_distance2(&p, &a, &a, &a, NULL);
        double segment_ab = geom_point_segment_distance2(&p, &a, &b, NULL);
        for (int k = 0; k < 3; k++) {
            if (cases[k] != cases[k]) nans++;
            if (!(fabs(cases[k] - segment) <= 1e-12 * (segment + 1e-300))) failures++;
        }
        if (!(fabs(repeated_ab - segment_ab) <= 1e-12 * segment_ab)) failures++;
        if (!(fabs(repeated_bb - segment_ab) <= 1e-12 * segment_ab)) failures++;
        if (single != point) failures++;
        if (repeated_ab != repeated_ab || single != single) nans++;
    }
    CHECK(nans == 0, "%d NaN distances on degenerate triangles", nans);
    CHECK(failures == 0, "%d degenerate distances differ from the segment/point", failures);

    /* Slivers: the third vertex 1e-15 .. 1e-5 off the line, queries on the
     * sliver, near it and 1e3 away. A sliver of width w (height over its
     * longest edge) lies within w of its longest edge, so the true distance
     * is within [edges - w, edges], "edges" being the nearest edge's distance
     * (long double). That bracket is what the answer must meet, and its
     * closest point must be within w of the edges too (on the sliver). */
    int outside_bracket = 0, off_sliver = 0;
    for (int i = 0; i < 30000; i++) {
        vec3d a = rng_point(1.0), b = rng_point(1.0);
        vec3d bump = geom_scale(rng_point(1.0), pow(10.0, rng_uniform(-15, -5)));
        vec3d c = geom_add(geom_lerp(a, b, rng_uniform(-0.5, 1.5)), bump), q;
        vec3d p = i % 3 == 0 ? rng_point(2.0) : i % 3 == 1 ? rng_point(1e3)
                             : geom_lerp(geom_lerp(a, b, rng_uniform(0, 1)), c, rng_uniform(0, 1));
        double longest = sqrt(fmax(geom_distance2(a, b),
                                   fmax(geom_distance2(b, c), geom_distance2(c, a))));
        double width = geom_length(geom_triangle_normal(&a, &b, &c)) / longest;
        double d = sqrt(geom_point_triangle_distance2(&p, &a, &b, &c, &q));
        double edges = (double)sqrtl(edges_distance2_l(p, a, b, c));
        double tolerance = 1e-12 * edges + 1e-14 * (1.0 + geom_length(geom_sub(p, a)));
        if (!(d >= edges - width - tolerance && d <= edges + tolerance)) outside_bracket++;
        if (!((double)sqrtl(edges_distance2_l(q, a, b, c)) <= width + 1e-15)) off_sliver++;
    }
    CHECK(outside_bracket == 0, "%d sliver distances outside [edges - w, edges]", outside_bracket);
    CHECK(off_sliver == 0, "%d sliver closest points off the sliver", off_sliver);

    /* Nearly degenerate: a 1e-13 bump off the line. */
    vec3d a = geom_vec3d(0, 0, 0), b = geom_vec3d(1, 0, 0), c = geom_vec3d(0.5, 1e-13, 0);
    vec3d p = geom_vec3d(0.25, 0.0, 1.0), q;
    double d2 = geom_point_triangle_distance2(&p, &a, &b, &c, &q);
    CHECK(fabs(d2 - 1.0) <= 1e-12, "sliver: %.17g", d2);
    CHECK(q.x == q.x && fabs(q.x - 0.25) <= 1e-9, "sliver point x %.17g", q.x);

    /* The point segment: every vertex the same point. */
    vec3d same = geom_vec3d(3, 4, 5), origin = geom_vec3d(0, 0, 0);
    CHECK(geom_point_triangle_distance2(&origin, &same, &same, &same, &q) == 50.0, "point");
    CHECK(q.x == 3 && q.y == 4 && q.z == 5, "point closest");
}

static void test_distance_translation_invariant(void)
{
    /* Grid-snapped shapes are exact after the shift; distances may differ
     * only by rounding of the 1e5-sized coordinates (relative to the shape,
     * a few ulps of 1e5). */
    vec3d shift = geom_vec3d(1e5, -1e5, 1e5);
    int failures = 0;
    for (int i = 0; i < 5000; i++) {
        vec3d a = rng_grid_point(2.0), b = rng_grid_point(2.0), c = rng_grid_point(2.0);
        vec3d p = rng_grid_point(3.0);
        vec3d ta = geom_add(a, shift), tb = geom_add(b, shift), tc = geom_add(c, shift),
              tp = geom_add(p, shift), q, tq;
        double d = sqrt(geom_point_triangle_distance2(&p, &a, &b, &c, &q));
        double td = sqrt(geom_point_triangle_distance2(&tp, &ta, &tb, &tc, &tq));
        if (!(fabs(d - td) <= 1e-9)) failures++;
        if (!(geom_distance(geom_add(q, shift), tq) <= 1e-6)) failures++;
    }
    CHECK(failures == 0, "%d translated distances differ", failures);
}

/* ---- enclosing ball ------------------------------------------------------ */

static double circumradius(vec3d a, vec3d b, vec3d c)
{
    double la = geom_distance(b, c), lb = geom_distance(c, a), lc = geom_distance(a, b);
    double area2 = geom_length(geom_triangle_normal(&a, &b, &c));   /* twice the area */
    return la * lb * lc / (2.0 * area2);
}

static void test_ball_obtuse_triangle(void)
{
    /* Angle at c is ~160 degrees. */
    vec3d a = geom_vec3d(0, 0, 0), b = geom_vec3d(10, 0, 0), c = geom_vec3d(4, 0.9, 0.3);
    vec3d centre;
    double radius;
    geom_triangle_enclosing_ball(&a, &b, &c, &centre, &radius);
    CHECK(fabs(radius - 5.0) <= 1e-13, "radius %.17g, want half the longest edge 5", radius);
    CHECK(geom_distance(centre, geom_vec3d(5, 0, 0)) <= 1e-14, "centre (%g %g %g)",
          centre.x, centre.y, centre.z);
    CHECK(geom_distance(centre, a) <= radius && geom_distance(centre, b) <= radius &&
              geom_distance(centre, c) <= radius,
          "a vertex outside the ball");
    double circum = circumradius(a, b, c);
    CHECK(radius < circum, "radius %g not below circumradius %g", radius, circum);

    /* The tempting wrong answers are both bigger: the circumball (above) and
     * the ball around the centroid through the farthest vertex. */
    vec3d centroid = geom_scale(geom_add(geom_add(a, b), c), 1.0 / 3.0);
    double centroid_radius = fmax(geom_distance(centroid, a),
                                  fmax(geom_distance(centroid, b), geom_distance(centroid, c)));
    CHECK(radius < centroid_radius, "radius %g not below the centroid ball's %g", radius,
          centroid_radius);
}

static void test_ball_acute_and_right_triangles(void)
{
    /* Equilateral: circumcentre = centroid, radius = side / sqrt(3). */
    vec3d a = geom_vec3d(0, 0, 0), b = geom_vec3d(2, 0, 0), c = geom_vec3d(1, sqrt(3.0), 0);
    vec3d centre;
    double radius;
    geom_triangle_enclosing_ball(&a, &b, &c, &centre, &radius);
    CHECK(fabs(radius - 2.0 / sqrt(3.0)) <= 1e-14, "equilateral radius %.17g", radius);
    CHECK(geom_distance(centre, geom_vec3d(1, 1 / sqrt(3.0), 0)) <= 1e-14, "equilateral centre");

    /* Right triangle: hypotenuse midpoint. */
    vec3d r0 = geom_vec3d(0, 0, 0), r1 = geom_vec3d(3, 0, 0), r2 = geom_vec3d(0, 4, 0);
    geom_triangle_enclosing_ball(&r0, &r1, &r2, &centre, &radius);
    CHECK(fabs(radius - 2.5) <= 1e-14, "right radius %.17g", radius);
    CHECK(geom_distance(centre, geom_vec3d(1.5, 2, 0)) <= 1e-14, "right centre");
}

/* Reference minimal ball of three points: the smallest of the balls on each
 * edge as diameter that contain the third vertex, else the circumball. */
static double reference_min_radius(vec3d a, vec3d b, vec3d c)
{
    vec3d v[3] = {a, b, c};
    double best = INFINITY;
    for (int i = 0; i < 3; i++) {
        vec3d u = v[i], w = v[(i + 1) % 3], third = v[(i + 2) % 3];
        vec3d mid = geom_scale(geom_add(u, w), 0.5);
        double r = 0.5 * geom_distance(u, w);
        if (geom_distance(mid, third) <= r * (1 + 1e-12) && r < best) best = r;
    }
    if (best < INFINITY) return best;
    return circumradius(a, b, c);
}

static void test_ball_random_triangles(void)
{
    int outside = 0, not_minimal = 0;
    for (int i = 0; i < 20000; i++) {
        vec3d a = rng_point(1.0), b = rng_point(1.0), c = rng_point(1.0);
        if (i % 10 == 0) c = geom_lerp(a, b, rng_uniform(-1.0, 2.0));   /* collinear */
        if (i % 10 == 1) b = a;                                           /* repeated */
        vec3d centre;
        double radius;
        geom_triangle_enclosing_ball(&a, &b, &c, &centre, &radius);
        /* Long double check of containment: exact enough to see one ulp. */
        vec3l cl = to_l(centre);
        vec3d vertices[3] = {a, b, c};
        for (int k = 0; k < 3; k++) {
            vec3l d = sub_l(to_l(vertices[k]), cl);
            if (!(sqrtl(dot_l(d, d)) <= (long double)radius)) outside++;
        }
        double reference = i % 10 <= 1 ? 0.5 * geom_max_abs_component(geom_vec3d(
                                                   geom_distance(a, b), geom_distance(b, c),
                                                   geom_distance(c, a)))
                                       : reference_min_radius(a, b, c);
        if (!(fabs(radius - reference) <= 1e-9 * reference)) not_minimal++;
    }
    CHECK(outside == 0, "%d vertices outside their ball", outside);
    CHECK(not_minimal == 0, "%d balls differ from the minimal radius", not_minimal);
}

static void test_ball_degenerate(void)
{
    vec3d a = geom_vec3d(1, 1, 1), b = geom_vec3d(5, 1, 1), c = geom_vec3d(2, 1, 1);
    vec3d centre;
    double radius;
    geom_triangle_enclosing_ball(&a, &b, &c, &centre, &radius);
    CHECK(fabs(radius - 2.0) <= 1e-14 && geom_distance(centre, geom_vec3d(3, 1, 1)) == 0.0,
          "collinear: centre (%g %g %g) radius %.17g", centre.x, centre.y, centre.z, radius);
    geom_triangle_enclosing_ball(&c, &a, &b, &centre, &radius);
    CHECK(fabs(radius - 2.0) <= 1e-14, "collinear, other order: radius %.17g", radius);
    geom_triangle_enclosing_ball(&a, &a, &a, &centre, &radius);
    CHECK(radius == 0.0 && centre.x == 1 && centre.y == 1 && centre.z == 1, "single point");
    geom_triangle_enclosing_ball(&a, &b, &b, &centre, &radius);
    CHECK(fabs(radius - 2.0) <= 1e-14 && centre.x == 3.0, "repeated vertex");
}

/* ---- normals ------------------------------------------------------------- */

static void test_normals(void)
{
    vec3d a = geom_vec3d(0, 0, 0), b = geom_vec3d(2, 0, 0), c = geom_vec3d(0, 3, 0), n;
    vec3d raw = geom_triangle_normal(&a, &b, &c);
    CHECK(raw.x == 0 && raw.y == 0 && raw.z == 6, "normal (%g %g %g)", raw.x, raw.y, raw.z);
    CHECK(geom_triangle_unit_normal(&a, &b, &c, &n) == 1 && n.z == 1.0, "unit normal");
    CHECK(geom_triangle_unit_normal(&a, &c, &b, &n) == 1 && n.z == -1.0, "reversed winding");

    vec3d on_line = geom_vec3d(7, 0, 0);
    CHECK(geom_triangle_unit_normal(&a, &b, &on_line, &n) == 0 && n.x == 0 && n.y == 0 &&
              n.z == 0,
          "collinear is degenerate");
    CHECK(geom_triangle_unit_normal(&a, &a, &c, &n) == 0, "repeated vertex is degenerate");
    vec3d sliver = geom_vec3d(1, 1e-12, 0);
    CHECK(geom_triangle_unit_normal(&a, &b, &sliver, &n) == 0, "1e-12 sliver is degenerate");
    vec3d thin = geom_vec3d(1, 1e-6, 0);
    CHECK(geom_triangle_unit_normal(&a, &b, &thin, &n) == 1 && fabs(n.z - 1.0) < 1e-15,
          "1e-6 sliver still has a normal");
    vec3d not_a_number = geom_vec3d(NAN, 0, 0);
    CHECK(geom_triangle_unit_normal(&a, &b, &not_a_number, &n) == 0, "NaN is degenerate");

    int bad = 0;
    for (int i = 0; i < 1000; i++) {
        vec3d p = rng_point(1), q = rng_point(1), r = rng_point(1);
        if (!geom_triangle_unit_normal(&p, &q, &r, &n)) continue;
        if (fabs(geom_length(n) - 1.0) > 1e-15) bad++;
        if (fabs(geom_dot(n, geom_sub(q, p))) > 1e-12 || fabs(geom_dot(n, geom_sub(r, p))) > 1e-12)
            bad++;
    }
    CHECK(bad == 0, "%d random unit normals wrong", bad);
}

/* ---- outward rounding ---------------------------------------------------- */

static void test_round_outward(void)
{
    int wrong = 0, not_tight = 0;
    for (int i = 0; i < 100000; i++) {
        double magnitude = pow(10.0, rng_uniform(-30, 30));
        double lo[3], hi[3];
        for (int axis = 0; axis < 3; axis++) {
            lo[axis] = rng_uniform(-1, 1) * magnitude;
            hi[axis] = lo[axis] + rng_uniform(0, 1) * magnitude;
        }
        float flo[3], fhi[3];
        geom_box_round_outward(lo, hi, flo, fhi);
        for (int axis = 0; axis < 3; axis++) {
            if (!((double)flo[axis] <= lo[axis] && (double)fhi[axis] >= hi[axis])) wrong++;
            /* Tight: the next float inward is on the wrong side. */
            if (!((double)nextafterf(flo[axis], INFINITY) > lo[axis])) not_tight++;
            if (!((double)nextafterf(fhi[axis], -INFINITY) < hi[axis])) not_tight++;
        }
    }
    CHECK(wrong == 0, "%d rounded bounds do not contain the double", wrong);
    CHECK(not_tight == 0, "%d rounded bounds not the nearest float", not_tight);

    /* Values that are floats already stay put; 0.1 moves outward. */
    double lo[3] = {1.5, -0.25, 0.1}, hi[3] = {2.0, 0.0, 0.1};
    float flo[3], fhi[3];
    geom_box_round_outward(lo, hi, flo, fhi);
    CHECK(flo[0] == 1.5f && fhi[0] == 2.0f && flo[1] == -0.25f && fhi[1] == 0.0f, "exact");
    CHECK((double)flo[2] < 0.1 && (double)fhi[2] > 0.1 && fhi[2] == nextafterf(flo[2], 1.0f),
          "0.1 brackets: %.9g %.9g", flo[2], fhi[2]);

    /* Out of float range and NaN. */
    double big_lo[3] = {-1e300, 1e300, NAN}, big_hi[3] = {1e300, 1e301, NAN};
    geom_box_round_outward(big_lo, big_hi, flo, fhi);
    CHECK(flo[0] == -INFINITY && fhi[0] == INFINITY, "huge box becomes infinite");
    CHECK(flo[1] == FLT_MAX && fhi[1] == INFINITY, "lo beyond range: FLT_MAX inside");
    CHECK(flo[2] == -INFINITY && fhi[2] == INFINITY, "NaN becomes infinite");
}

/* A prepared triangle gives geom_point_triangle_distance2's value bit for
 * bit: on random, thin (third vertex 1e-15 .. 1e-2 off an edge's line) and
 * degenerate triangles, for points near, on and far from them. */
static void test_prepared_distance_identical(void)
{
    int differ = 0;
    for (int i = 0; i < 20000; i++) {
        vec3d a = rng_point(1.0), b = rng_point(1.0), c = rng_point(1.0);
        const int shape = i % 4;
        if (shape == 1) c = geom_add_scaled(geom_lerp(a, b, rng_uniform(-0.5, 1.5)), rng_point(1.0),
                                            pow(10.0, rng_uniform(-15.0, -2.0)));
        if (shape == 2) c = geom_lerp(a, b, rng_uniform(-0.5, 1.5));
        if (shape == 3) c = b;
        geom_prepared_triangle t;
        geom_prepare_triangle(&a, &b, &c, &t);
        for (int k = 0; k < 8; k++) {
            vec3d p = k == 0 ? geom_lerp(geom_lerp(a, b, 0.3), c, 0.4) : rng_point(k < 4 ? 1.5 : 1e3);
            double want = geom_point_triangle_distance2(&p, &a, &b, &c, NULL);
            double got = geom_point_prepared_triangle_distance2(&p, &t);
            differ += memcmp(&want, &got, sizeof want) != 0;
        }
    }
    CHECK(differ == 0, "%d prepared distances differ in some bit", differ);
}

/* geom_fmin and geom_fmax keep the C library's NaN rule (a NaN argument
 * yields the other one) and return b on a tie, so -0 against +0 too. */
static void test_fmin_fmax_rules(void)
{
    const double values[] = {-1.5, -0.0, 0.0, 2.0, INFINITY, -INFINITY, NAN};
    const int n = (int)(sizeof values / sizeof values[0]);
    int wrong = 0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const double a = values[i], b = values[j], lo = geom_fmin(a, b), hi = geom_fmax(a, b);
            const double want_lo = a != a ? b : b != b ? a : a < b ? a : b;
            const double want_hi = a != a ? b : b != b ? a : a > b ? a : b;
            wrong += memcmp(&lo, &want_lo, sizeof lo) != 0 && !(lo != lo && want_lo != want_lo);
            wrong += memcmp(&hi, &want_hi, sizeof hi) != 0 && !(hi != hi && want_hi != want_hi);
            if (a == a || b == b) wrong += (lo != lo) + (hi != hi); /* fmin: NaN only when both are */
        }
    CHECK(wrong == 0, "%d fmin/fmax results break the NaN or tie rule", wrong);
}

/* geom_floor is floor (up to the sign of a zero result) on fractions,
 * integers, values beyond 2^52 and 2^62, infinities and NaN. */
static void test_floor(void)
{
    const double x[] = {0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 2.75, -2.75, 1e-300, -1e-300, 4503599627370495.5,
                        -4503599627370495.5, 4503599627370497.0, -4503599627370497.0, 4611686018427387904.0,
                        -4611686018427387904.0, 1e300, -1e300, INFINITY, -INFINITY};
    for (size_t i = 0; i < sizeof x / sizeof x[0]; ++i) {
        const double step[] = {0.0, nextafter(x[i], INFINITY) - x[i], nextafter(x[i], -INFINITY) - x[i]};
        for (int k = 0; k < 3; ++k) {
            const double y = x[i] + (isfinite(step[k]) ? step[k] : 0.0);
            CHECK(geom_floor(y) == floor(y), "geom_floor(%.17g) = %.17g, floor %.17g", y, geom_floor(y), floor(y));
        }
    }
    CHECK(isnan(geom_floor(NAN)), "geom_floor(NaN) is NaN");
}

int main(void)
{
    RUN(test_fmin_fmax_rules);
    RUN(test_prepared_distance_identical);
    RUN(test_distance_matches_reference_on_random_triangles);
    RUN(test_distance_is_a_minimum_over_samples);
    RUN(test_distance_regions_exact);
    RUN(test_distance_degenerate_triangles);
    RUN(test_distance_translation_invariant);
    RUN(test_ball_obtuse_triangle);
    RUN(test_ball_acute_and_right_triangles);
    RUN(test_ball_random_triangles);
    RUN(test_ball_degenerate);
    RUN(test_normals);
    RUN(test_round_outward);
    RUN(test_floor);
    return check_summary();
}
