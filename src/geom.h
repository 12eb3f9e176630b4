/* geom.h - double-precision geometry primitives the certificate stands on.
 *
 * lodpipe reads float32 positions and does all distance arithmetic in double
 * (DESIGN.md §3, §4). This module owns the primitive operations on single
 * triangles: point-to-triangle distance with the closest point, the minimal
 * enclosing ball used by the Lipschitz test, triangle normals, and the outward
 * rounding of a double box into a float box.
 *
 * What every function here promises, unless it says otherwise:
 * - No NaN comes out of finite input. Degenerate triangles (zero area,
 *   collinear or repeated vertices) are valid input and are treated as the
 *   segment or point they really are.
 * - Results are deterministic: the same input gives the same bits, so a
 *   brute-force loop and the BVH (bvh.h), which both call these functions,
 *   agree exactly.
 * - Computed points that should lie on a triangle are convex combinations of
 *   its vertices, clamped into the triangle's vertex bounding box, so rounding
 *   never moves them outside that box. Distances are therefore never smaller
 *   than the distance to a point within a few ulps of the triangle: an error
 *   in the answer can only make a distance look larger, the safe side for an
 *   upper-bound certificate, except for those few ulps of coordinate size.
 *
 * Everything here is pure (no global state) and thread-safe. */
#ifndef LODPIPE_GEOM_H
#define LODPIPE_GEOM_H

#include <math.h>

typedef struct {
    double x, y, z;
} vec3d;

/* ---- min and max ------------------------------------------------------------ */

/* fmin and fmax with the standard's NaN rule (a NaN argument yields the other
 * one), inline: the C library's are calls, about 3% of the simplifier's time
 * in its box computations. On a tie (so -0 against +0) they return b, as
 * x86-64's minsd and maxsd do. */
static inline double geom_fmin(double a, double b)
{
    const double m = a < b ? a : b; /* one minsd: b when a is NaN, as the rule says */
    return b != b ? a : m;          /* the one case minsd gets wrong */
}

static inline double geom_fmax(double a, double b)
{
    const double m = a > b ? a : b;
    return b != b ? a : m;
}

/* floor(x), the same value (up to the sign of a zero result), inline: the C
 * library's is a call, which the spatial hashes (facegrid, thin map) make
 * six times per triangle. Below 2^62 in magnitude the truncation through
 * int64 is exact; larger, infinite and NaN arguments go to floor. */
static inline double geom_floor(double x)
{
    if (!(fabs(x) < 4611686018427387904.0)) return floor(x);
    const double t = (double)(long long)x;
    return t > x ? t - 1.0 : t;
}

/* The box of a triangle's three corners. */
static inline void geom_triangle_box(const double p[3][3], double lo[3], double hi[3])
{
    for (int k = 0; k < 3; ++k) {
        lo[k] = geom_fmin(p[0][k], geom_fmin(p[1][k], p[2][k]));
        hi[k] = geom_fmax(p[0][k], geom_fmax(p[1][k], p[2][k]));
    }
}

/* ---- small vector helpers ------------------------------------------------ */

static inline vec3d geom_vec3d(double x, double y, double z)
{
    vec3d v = {x, y, z};
    return v;
}

/* Exact: every float is a double. */
static inline vec3d geom_vec3d_from_floats(const float xyz[3])
{
    return geom_vec3d((double)xyz[0], (double)xyz[1], (double)xyz[2]);
}

static inline vec3d geom_vec3d_from_doubles(const double xyz[3])
{
    return geom_vec3d(xyz[0], xyz[1], xyz[2]);
}

static inline vec3d geom_add(vec3d a, vec3d b)
{
    return geom_vec3d(a.x + b.x, a.y + b.y, a.z + b.z);
}

static inline vec3d geom_sub(vec3d a, vec3d b)
{
    return geom_vec3d(a.x - b.x, a.y - b.y, a.z - b.z);
}

static inline vec3d geom_scale(vec3d a, double s)
{
    return geom_vec3d(a.x * s, a.y * s, a.z * s);
}

/* a + s * b */
static inline vec3d geom_add_scaled(vec3d a, vec3d b, double s)
{
    return geom_vec3d(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s);
}

static inline double geom_dot(vec3d a, vec3d b)
{
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

static inline vec3d geom_cross(vec3d a, vec3d b)
{
    return geom_vec3d(a.y * b.z - a.z * b.y,
                      a.z * b.x - a.x * b.z,
                      a.x * b.y - a.y * b.x);
}

static inline double geom_length2(vec3d a)
{
    return geom_dot(a, a);
}

static inline double geom_length(vec3d a)
{
    return sqrt(geom_dot(a, a));
}

static inline double geom_distance2(vec3d a, vec3d b)
{
    return geom_length2(geom_sub(a, b));
}

static inline double geom_distance(vec3d a, vec3d b)
{
    return sqrt(geom_distance2(a, b));
}

static inline vec3d geom_lerp(vec3d a, vec3d b, double t)
{
    return geom_add_scaled(a, geom_sub(b, a), t);
}

/* ---- distances ----------------------------------------------------------- */

/* Squared distance from p to the segment [a, b], and the closest point
 * (closest may be NULL). a == b is allowed: the answer is the distance to the
 * point. The closest point is a + t (b - a) with t in [0, 1], clamped into the
 * segment's bounding box, and the value returned is |p - closest|^2 computed
 * from that point. */
double geom_point_segment_distance2(const vec3d *p, const vec3d *a, const vec3d *b,
                                    vec3d *closest);

/* Squared distance from p to the (closed, solid) triangle abc, and the closest
 * point (closest may be NULL).
 *
 * Promise: the value returned is |p - q|^2 computed in double for the point q
 * written to *closest, and q is a convex combination of a, b, c clamped into
 * the triangle's vertex bounding box. For a well-shaped triangle q is the true
 * closest point up to rounding, so the value is the true squared distance to
 * relative error ~1e-15 plus a few ulps of the coordinates. For a degenerate
 * triangle (collinear or repeated vertices, zero area) the value is the
 * distance to the segment or point the triangle is. For a thin one (width
 * below 1e-4 of its length, where the face projection loses accuracy) the
 * answer is the nearest of the face point and the three edges; its error, an
 * overestimate, is at most ~sqrt(ulp * |p - a| * longest edge), i.e. ~1e-8
 * of the triangle's size for points near it.
 * Finite input never gives NaN. */
double geom_point_triangle_distance2(const vec3d *p, const vec3d *a, const vec3d *b,
                                     const vec3d *c, vec3d *closest);

/* A triangle's point-independent quantities, for measuring many points
 * against one triangle: geom_point_prepared_triangle_distance2(p, t) is
 * geom_point_triangle_distance2(p, a, b, c, NULL) bit for bit (the same
 * operations; only the ones that do not involve p are done once). */
typedef struct geom_prepared_triangle {
    vec3d a, b, c;
    vec3d ab, ac, bc, n; /* b - a, c - a, c - b, ab x ac */
    double nn;           /* n . n */
    int well_shaped;     /* not thin (see above): the face point is taken alone */
} geom_prepared_triangle;

void geom_prepare_triangle(const vec3d *a, const vec3d *b, const vec3d *c, geom_prepared_triangle *t);
double geom_point_prepared_triangle_distance2(const vec3d *p, const geom_prepared_triangle *t);

/* ---- minimal enclosing ball ---------------------------------------------- */

/* The smallest ball containing triangle abc (and hence, by convexity, all of
 * it): for a right or obtuse triangle the ball with the longest edge as
 * diameter; for an acute one the circumscribed ball. Degenerate triangles are
 * handled: collinear vertices give the longest segment's midpoint, three equal
 * vertices give that point with radius 0.
 *
 * This is NOT centroid + circumradius, which fails to contain obtuse
 * triangles' vertices, and not the circumball either, which is needlessly big
 * (unbounded for slivers).
 *
 * Promise: *radius >= |v - *centre| for each vertex v in exact arithmetic: the
 * radius is the largest computed vertex distance rounded up by a few ulps, so
 * containment never depends on rounding. The radius is minimal up to that
 * rounding. */
void geom_triangle_enclosing_ball(const vec3d *a, const vec3d *b, const vec3d *c,
                                  vec3d *centre, double *radius);

/* ---- normals ------------------------------------------------------------- */

/* (b - a) x (c - a): the unnormalized normal, length = twice the area,
 * pointing to the side from which abc is seen counter-clockwise. */
vec3d geom_triangle_normal(const vec3d *a, const vec3d *b, const vec3d *c);

/* A triangle whose normal is shorter than this fraction of its squared longest
 * edge is degenerate: its normal direction is then not trustworthy (rounding
 * error of the cross product is ~1e-16 of the squared longest edge, so above
 * the threshold the direction is good to ~1e-5 radians). */
#define GEOM_DEGENERATE_NORMAL_RATIO 1e-10

/* Writes the unit normal of abc and returns 1, or writes (0, 0, 0) and
 * returns 0 when the triangle is degenerate in the sense above (this includes
 * zero-area triangles and non-finite input). */
int geom_triangle_unit_normal(const vec3d *a, const vec3d *b, const vec3d *c,
                              vec3d *unit_normal);

/* ---- boxes --------------------------------------------------------------- */

/* Rounds the double box [lo, hi] outward to float: on return lo_out[i] <=
 * lo[i] and hi_out[i] >= hi[i] hold exactly (as real numbers), with each float
 * the nearest one on the correct side, whatever the current rounding mode.
 * Values beyond the float range become -INFINITY / +INFINITY on the outer side
 * (or +-FLT_MAX on the inner side); a NaN bound becomes the infinite bound,
 * so the float box still contains whatever the NaN stood for. */
void geom_box_round_outward(const double lo[3], const double hi[3],
                            float lo_out[3], float hi_out[3]);

/* Largest of |x|, |y|, |z|. */
static inline double geom_max_abs_component(vec3d a)
{
    double m = fabs(a.x);
    if (fabs(a.y) > m) m = fabs(a.y);
    if (fabs(a.z) > m) m = fabs(a.z);
    return m;
}

#endif
