/* geom.c - double-precision primitives on single triangles (see geom.h).
 *
 * Point-triangle distance follows the Voronoi-region walk of Ericson,
 * "Real-Time Collision Detection" (2005), §5.1.5, with two changes made for a
 * certificate rather than a game:
 * - the face-region barycentrics are taken from the normal (n . (e x ap))
 *   instead of the products of dot products, whose cancellation grows with
 *   the square of the query distance;
 * - a degenerate or nearly degenerate triangle never divides by a vanishing
 *   denominator: it is measured as its three edges (plus the face candidate
 *   when that one is valid), and the smallest wins.
 * Every candidate point is a convex combination of the vertices clamped into
 * their bounding box, so the distance from p to any box holding the triangle
 * is a lower bound of every value computed here, up to the few ulps of the
 * final |p - q|^2 (bvh.c relies on that). */
#include "geom.h"

#include <float.h>
#include <stddef.h>

/* Below this ratio of |normal| to the squared longest edge (i.e. of width to
 * length), point-triangle distance also measures all three edges; see
 * triangle_well_shaped. */
#define THIN_TRIANGLE_RATIO 1e-4

/* v clamped into [min(a, b, c), max(a, b, c)]. */
static double clamp_into_range3(double v, double a, double b, double c)
{
    double lo = a < b ? a : b, hi = a < b ? b : a;
    if (c < lo) lo = c;
    if (c > hi) hi = c;
    return v < lo ? lo : v > hi ? hi : v;
}

/* Clamps q into the bounding box of the points a, b, c. The exact point is in
 * that box; this only undoes rounding, so that no computed point ever leaves
 * the box of its triangle. */
static vec3d clamp_into_box3(vec3d q, const vec3d *a, const vec3d *b, const vec3d *c)
{
    return geom_vec3d(clamp_into_range3(q.x, a->x, b->x, c->x),
                      clamp_into_range3(q.y, a->y, b->y, c->y),
                      clamp_into_range3(q.z, a->z, b->z, c->z));
}

double geom_point_segment_distance2(const vec3d *p, const vec3d *a, const vec3d *b,
                                    vec3d *closest)
{
    vec3d ab = geom_sub(*b, *a);
    double along = geom_dot(ab, geom_sub(*p, *a));
    double ab2 = geom_dot(ab, ab);

    /* along > 0 implies ab2 > 0, and along >= ab2 is tested before dividing,
     * so the division only happens with 0 < along < ab2: t is in (0, 1). */
    double t = 0.0;
    if (along > 0.0) t = along >= ab2 ? 1.0 : along / ab2;

    vec3d q = clamp_into_box3(geom_add_scaled(*a, ab, t), a, b, b);
    if (closest) *closest = q;
    return geom_distance2(*p, q);
}

/* Keeps the better of the current answer and a candidate. */
static void keep_nearer(double candidate_d2, vec3d candidate, double *best_d2, vec3d *best)
{
    if (candidate_d2 < *best_d2) {
        *best_d2 = candidate_d2;
        *best = candidate;
    }
}

/* Whether the face point of triangle (ab, ac, bc, nn = |ab x ac|^2) can be
 * trusted. Thin: width w = |n| / longest below THIN_TRIANGLE_RATIO * longest.
 * The normalized weights then move the face point by up to ~ulp * |ap| *
 * longest / w (a convex combination still, so only ever too far), while the
 * nearest edge is off by at most w / 2: taking the nearer of both bounds the
 * error by ~sqrt(ulp * |ap| * longest) for any sliver. A positive test, so
 * that NaN counts as thin. */
static inline int triangle_well_shaped(vec3d ab, vec3d ac, vec3d bc, double nn)
{
    double longest2 = geom_dot(ab, ab);
    if (geom_dot(ac, ac) > longest2) longest2 = geom_dot(ac, ac);
    if (geom_dot(bc, bc) > longest2) longest2 = geom_dot(bc, bc);
    double thin_bound = THIN_TRIANGLE_RATIO * longest2;
    return nn > thin_bound * thin_bound;
}

/* The closest point of triangle abc to p; see geom_point_triangle_distance2.
 * With pre (abc's prepared values) the point-independent quantities are
 * taken from it instead of being computed here: the same operations on the
 * same operands, done once, so the same bits. Inlined into both callers, so
 * that each is compiled for its case (pre NULL or not), without branches. */
static inline __attribute__((always_inline)) vec3d closest_point(const vec3d *p, const vec3d *a, const vec3d *b,
                                                                  const vec3d *c, const geom_prepared_triangle *pre)
{
    vec3d ab = pre ? pre->ab : geom_sub(*b, *a);
    vec3d ac = pre ? pre->ac : geom_sub(*c, *a);
    vec3d ap = geom_sub(*p, *a);

    /* Vertex regions. (x - v) . (p - v) <= 0 for both edges at v means no
     * point x of the triangle is closer than v; this holds for any triangle,
     * degenerate or not, so these exits need no shape test. */
    double d1 = geom_dot(ab, ap);
    double d2 = geom_dot(ac, ap);
    if (d1 <= 0.0 && d2 <= 0.0) return *a;
    vec3d bp = geom_sub(*p, *b);
    double d3 = geom_dot(ab, bp);
    double d4 = geom_dot(ac, bp);
    if (d3 >= 0.0 && d4 <= d3) return *b;
    vec3d cp = geom_sub(*p, *c);
    double d5 = geom_dot(ab, cp);
    double d6 = geom_dot(ac, cp);
    if (d6 >= 0.0 && d5 <= d6) return *c;

    /* Barycentric weights (times |n|^2) of p's projection onto the plane:
     * weight_c is the signed area of (a, b, p) against n, and so on. Their
     * error is ~ulp * |n| * |edge| * |p - vertex|, not the square of the query
     * distance as with Ericson's dot-product form. */
    vec3d n = pre ? pre->n : geom_cross(ab, ac);
    vec3d bc = pre ? pre->bc : geom_sub(*c, *b);
    double nn = pre ? pre->nn : geom_dot(n, n);
    double weight_c = geom_dot(n, geom_cross(ab, ap));
    double weight_b = geom_dot(n, geom_cross(ap, ac));
    double weight_a = geom_dot(n, geom_cross(bc, bp));

    int well_shaped = pre ? pre->well_shaped : triangle_well_shaped(ab, ac, bc, nn);

    double best_d2 = INFINITY;
    vec3d best = *a;
    double weight_sum = weight_a + weight_b + weight_c;
    if (weight_a >= 0.0 && weight_b >= 0.0 && weight_c >= 0.0 && weight_sum > 0.0) {
        /* Inside: the weights are non-negative and normalized by their own
         * sum, so the point is a convex combination whatever rounding did. */
        vec3d face = geom_add_scaled(geom_add_scaled(*a, ab, weight_b / weight_sum),
                                     ac, weight_c / weight_sum);
        face = clamp_into_box3(face, a, b, c);
        if (well_shaped) return face;
        keep_nearer(geom_distance2(*p, face), face, &best_d2, &best);
    }

    /* Outside the face: the answer is on an edge whose opposite vertex has a
     * negative weight. A thin or degenerate triangle (whose weights cannot be
     * trusted that far) is measured on all three edges, keeping the face
     * candidate if there was one. */
    int all_edges = !well_shaped ||
                    !(weight_a < 0.0 || weight_b < 0.0 || weight_c < 0.0);
    vec3d edge_point;
    if (all_edges || weight_c < 0.0)
        keep_nearer(geom_point_segment_distance2(p, a, b, &edge_point), edge_point,
                    &best_d2, &best);
    if (all_edges || weight_b < 0.0)
        keep_nearer(geom_point_segment_distance2(p, a, c, &edge_point), edge_point,
                    &best_d2, &best);
    if (all_edges || weight_a < 0.0)
        keep_nearer(geom_point_segment_distance2(p, b, c, &edge_point), edge_point,
                    &best_d2, &best);
    /* Finite input always took a candidate; NaN input leaves vertex a. */
    return best;
}

double geom_point_triangle_distance2(const vec3d *p, const vec3d *a, const vec3d *b,
                                     const vec3d *c, vec3d *closest)
{
    vec3d q = closest_point(p, a, b, c, NULL);
    if (closest) *closest = q;
    return geom_distance2(*p, q);
}

void geom_prepare_triangle(const vec3d *a, const vec3d *b, const vec3d *c, geom_prepared_triangle *t)
{
    t->a = *a;
    t->b = *b;
    t->c = *c;
    t->ab = geom_sub(*b, *a);
    t->ac = geom_sub(*c, *a);
    t->bc = geom_sub(*c, *b);
    t->n = geom_cross(t->ab, t->ac);
    t->nn = geom_dot(t->n, t->n);
    t->well_shaped = triangle_well_shaped(t->ab, t->ac, t->bc, t->nn);
}

double geom_point_prepared_triangle_distance2(const vec3d *p, const geom_prepared_triangle *t)
{
    return geom_distance2(*p, closest_point(p, &t->a, &t->b, &t->c, t));
}

void geom_triangle_enclosing_ball(const vec3d *a, const vec3d *b, const vec3d *c,
                                  vec3d *centre, double *radius)
{
    /* Name the vertices so that [u, v] is the longest edge and w the vertex
     * opposite it. */
    const vec3d *u = a, *v = b, *w = c;
    double ab2 = geom_distance2(*a, *b);
    double bc2 = geom_distance2(*b, *c);
    double ca2 = geom_distance2(*c, *a);
    double longest2 = ab2, other2 = bc2 + ca2;
    if (bc2 > longest2) {
        u = b; v = c; w = a;
        longest2 = bc2; other2 = ab2 + ca2;
    }
    if (ca2 > longest2) {
        u = c; v = a; w = b;
        longest2 = ca2; other2 = ab2 + bc2;
    }

    vec3d m;
    if (longest2 >= other2) {
        /* Right or obtuse at w (Pythagoras), including every collinear and
         * repeated-vertex case: the longest edge is a diameter and w lies in
         * that ball. */
        m = geom_scale(geom_add(*u, *v), 0.5);
    } else {
        /* Acute: the circumcentre, which lies inside the triangle. Solve
         * centre = w + s (u - w) + t (v - w) from |centre - w| = |centre - u|
         * = |centre - v| in the triangle's own 2x2 frame:
         *   [e1.e1 e1.e2] [s]   1 [e1.e1]
         *   [e1.e2 e2.e2] [t] = - [e2.e2]
         *                         2
         * the determinant being |e1 x e2|^2 > 0 for an acute triangle. */
        vec3d e1 = geom_sub(*u, *w), e2 = geom_sub(*v, *w);
        double e11 = geom_dot(e1, e1), e22 = geom_dot(e2, e2), e12 = geom_dot(e1, e2);
        double det = geom_length2(geom_cross(e1, e2));
        if (det > 0.0) {
            double s = 0.5 * e22 * (e11 - e12) / det;
            double t = 0.5 * e11 * (e22 - e12) / det;
            m = geom_add_scaled(geom_add_scaled(*w, e1, s), e2, t);
        } else {
            /* Rounding made an almost-flat triangle look acute; the
             * longest-edge midpoint is then as good as the circumcentre. */
            m = geom_scale(geom_add(*u, *v), 0.5);
        }
    }

    /* The radius is measured from the centre actually returned, so the ball
     * contains the vertices whatever rounding did to the centre; the final
     * factor covers the few ulps of the distance computation itself. */
    double r2 = geom_distance2(m, *a);
    if (geom_distance2(m, *b) > r2) r2 = geom_distance2(m, *b);
    if (geom_distance2(m, *c) > r2) r2 = geom_distance2(m, *c);
    *centre = m;
    *radius = sqrt(r2) * (1.0 + 8.0 * DBL_EPSILON);
}

vec3d geom_triangle_normal(const vec3d *a, const vec3d *b, const vec3d *c)
{
    return geom_cross(geom_sub(*b, *a), geom_sub(*c, *a));
}

int geom_triangle_unit_normal(const vec3d *a, const vec3d *b, const vec3d *c,
                              vec3d *unit_normal)
{
    vec3d n = geom_triangle_normal(a, b, c);
    double length = geom_length(n);
    double longest2 = geom_distance2(*a, *b);
    if (geom_distance2(*b, *c) > longest2) longest2 = geom_distance2(*b, *c);
    if (geom_distance2(*c, *a) > longest2) longest2 = geom_distance2(*c, *a);

    /* Positive tests only: NaN and infinity report degenerate. */
    if (length > GEOM_DEGENERATE_NORMAL_RATIO * longest2 && length <= DBL_MAX) {
        *unit_normal = geom_scale(n, 1.0 / length);
        return 1;
    }
    *unit_normal = geom_vec3d(0.0, 0.0, 0.0);
    return 0;
}

/* The largest float <= value (as real numbers). */
static float float_at_or_below(double value)
{
    if (!(value == value)) return -INFINITY;   /* NaN: contain anything */
    if (value < -(double)FLT_MAX) return -INFINITY;
    if (value == INFINITY) return INFINITY;
    if (value >= (double)FLT_MAX) return FLT_MAX;
    float f = (float)value;
    if ((double)f > value) f = nextafterf(f, -INFINITY);
    return f;
}

/* The smallest float >= value (as real numbers). */
static float float_at_or_above(double value)
{
    if (!(value == value)) return INFINITY;
    if (value > (double)FLT_MAX) return INFINITY;
    if (value == -INFINITY) return -INFINITY;
    if (value <= -(double)FLT_MAX) return -FLT_MAX;
    float f = (float)value;
    if ((double)f < value) f = nextafterf(f, INFINITY);
    return f;
}

void geom_box_round_outward(const double lo[3], const double hi[3],
                            float lo_out[3], float hi_out[3])
{
    for (int axis = 0; axis < 3; axis++) {
        lo_out[axis] = float_at_or_below(lo[axis]);
        hi_out[axis] = float_at_or_above(hi[axis]);
    }
}
