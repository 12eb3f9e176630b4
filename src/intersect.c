/* intersect.c - conservative triangle-triangle intersection (see intersect.h).
 *
 * Method. For closed triangles A, B and the hull H of their common corners,
 * A ∩ B is convex and contains H; if it contains a point outside H, one of
 * its extreme points is outside H, and every extreme point of A ∩ B lies on
 * an edge of A or of B. So it is enough to ask, for each of the six edges e
 * (of A against B and of B against A), whether e meets the other triangle
 * outside H:
 *
 *   - e has both ends in S: e lies in H, nothing to test;
 *   - e has one end p in S (p is then a corner of the other triangle T):
 *     e ∩ T is a segment starting at p, and it is longer than p exactly when
 *     e leaves p into T, i.e. e's far end lies in T's plane and inside T's
 *     corner wedge at p (edge_leaves_corner);
 *   - e has no end in S: the closed segment-triangle test
 *     (segment_meets_triangle).
 *
 * Each test returns 0 only on a sound certificate that the answer is "no":
 * boxes apart; the segment strictly on one side of T's plane; the line of the
 * segment passing strictly beside an edge of T (Plücker-style signs of
 * orient3d(p, q, t_i, t_j), valid for any T, degenerate ones included); or,
 * in the projection that drops one coordinate, a separating line through an
 * edge of one of the two (a linear projection maps a common point to a common
 * point, so disjoint projections prove disjoint originals). A sign is used
 * only when the computed determinant exceeds its error bound (orient2d,
 * orient3d below, after Shewchuk, "Adaptive Precision Floating-Point
 * Arithmetic and Fast Robust Geometric Predicates", 1997). Anything else is
 * answered 1, which makes the caller refuse the collapse: always safe.
 *
 * Two cheap whole-triangle rejections come first: disjoint boxes, and all
 * corners of one triangle that are not shared strictly on one side of the
 * other's plane (then the triangle meets that plane only inside H). */
#include "intersect.h"
#include "geom.h"

#include <math.h>

/* Shewchuk's first-stage error bounds for orient2d and orient3d are
 * (3 + 16 eps) eps and (7 + 56 eps) eps times the permanent, eps = 2^-53.
 * We use a little more than twice as much, and an absolute term that covers
 * the rounding of products that underflow. */
#define EPS (1.0 / 9007199254740992.0)
#define ORIENT2D_BOUND (8.0 * EPS)
#define ORIENT3D_BOUND (16.0 * EPS)
#define ABSOLUTE_BOUND 1e-300

/* +1 or -1 when the sign of det is certain, 0 when det is within the bound
 * of zero (NaN and infinities also give 0, every comparison failing). */
static int certain_sign(double det, double permanent, double relative_bound)
{
    double bound = relative_bound * permanent + ABSOLUTE_BOUND;
    if (det > bound) return 1;
    if (det < -bound) return -1;
    return 0;
}

/* Sign of the volume of tetrahedron abcd (Shewchuk's orient3d: positive when
 * d is below the plane through a, b, c seen counter-clockwise from above), or
 * 0 when uncertain. */
static inline int orient3d(const double *a, const double *b, const double *c, const double *d)
{
    double adx = a[0] - d[0], bdx = b[0] - d[0], cdx = c[0] - d[0];
    double ady = a[1] - d[1], bdy = b[1] - d[1], cdy = c[1] - d[1];
    double adz = a[2] - d[2], bdz = b[2] - d[2], cdz = c[2] - d[2];
    double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
    double cdxady = cdx * ady, adxcdy = adx * cdy;
    double adxbdy = adx * bdy, bdxady = bdx * ady;
    double det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
    double permanent = (fabs(bdxcdy) + fabs(cdxbdy)) * fabs(adz) +
                       (fabs(cdxady) + fabs(adxcdy)) * fabs(bdz) +
                       (fabs(adxbdy) + fabs(bdxady)) * fabs(cdz);
    return certain_sign(det, permanent, ORIENT3D_BOUND);
}

/* Sign of the signed area of abc in the coordinate plane (i, j), positive
 * when counter-clockwise, or 0 when uncertain. */
static int orient2d(const double *a, const double *b, const double *c, int i, int j)
{
    double left = (a[i] - c[i]) * (b[j] - c[j]);
    double right = (a[j] - c[j]) * (b[i] - c[i]);
    return certain_sign(left - right, fabs(left) + fabs(right), ORIENT2D_BOUND);
}

/* The coordinate to drop first when projecting onto a coordinate plane: the
 * largest component of t's (approximate) normal. Only a heuristic for which
 * projection to try first; soundness never depends on it. */
static int dominant_axis(const double t[3][3])
{
    double ux = t[1][0] - t[0][0], uy = t[1][1] - t[0][1], uz = t[1][2] - t[0][2];
    double vx = t[2][0] - t[0][0], vy = t[2][1] - t[0][1], vz = t[2][2] - t[0][2];
    double nx = fabs(uy * vz - uz * vy), ny = fabs(uz * vx - ux * vz), nz = fabs(ux * vy - uy * vx);
    if (nx >= ny && nx >= nz) return 0;
    return ny >= nz ? 1 : 2;
}

/* 1 when, in the projection dropping coordinate k, a line through an edge of
 * triangle t or through segment pq certainly separates the two (the one
 * strictly on one side, the other on the other closed side). */
static int separated_in_projection(const double *p, const double *q, const double t[3][3], int k)
{
    int i = (k + 1) % 3, j = (k + 2) % 3;

    /* boxes in the plane */
    for (int axis = 0; axis < 2; axis++) {
        int c = axis ? j : i;
        double slo = geom_fmin(p[c], q[c]), shi = geom_fmax(p[c], q[c]);
        double tlo = geom_fmin(t[0][c], geom_fmin(t[1][c], t[2][c]));
        double thi = geom_fmax(t[0][c], geom_fmax(t[1][c], t[2][c]));
        if (shi < tlo || thi < slo) return 1;
    }

    /* the segment's line: all of t strictly on one side */
    int s0 = orient2d(p, q, t[0], i, j);
    if (s0 != 0 && s0 == orient2d(p, q, t[1], i, j) && s0 == orient2d(p, q, t[2], i, j))
        return 1;

    /* an edge line of t: the opposite corner strictly on one side, p and q
     * strictly on the other */
    for (int e = 0; e < 3; e++) {
        const double *u = t[e], *w = t[(e + 1) % 3], *o = t[(e + 2) % 3];
        int so = orient2d(u, w, o, i, j);
        if (so == 0) continue;
        if (orient2d(u, w, p, i, j) == -so && orient2d(u, w, q, i, j) == -so) return 1;
    }
    return 0;
}

/* 0 when the closed segment pq certainly misses the closed triangle t, 1
 * otherwise. */
static int segment_meets_triangle(const double *p, const double *q, const double t[3][3])
{
    for (int c = 0; c < 3; c++) {
        double slo = geom_fmin(p[c], q[c]), shi = geom_fmax(p[c], q[c]);
        double tlo = geom_fmin(t[0][c], geom_fmin(t[1][c], t[2][c]));
        double thi = geom_fmax(t[0][c], geom_fmax(t[1][c], t[2][c]));
        if (shi < tlo || thi < slo) return 0;
    }

    /* both ends strictly on one side of t's plane */
    int sp = orient3d(t[0], t[1], t[2], p);
    if (sp != 0 && sp == orient3d(t[0], t[1], t[2], q)) return 0;

    /* the line pq passes strictly beside one edge of t and strictly on the
     * other side of another: it misses t (if the line met t, the three
     * signs would all be >= 0 or all <= 0) */
    int e01 = orient3d(p, q, t[0], t[1]);
    int e12 = orient3d(p, q, t[1], t[2]);
    int e20 = orient3d(p, q, t[2], t[0]);
    int positive = e01 > 0 || e12 > 0 || e20 > 0;
    int negative = e01 < 0 || e12 < 0 || e20 < 0;
    if (positive && negative) return 0;

    /* nearly coplanar (or t degenerate): separate in a projection */
    int k = dominant_axis(t);
    for (int n = 0; n < 3; n++)
        if (separated_in_projection(p, q, t, (k + n) % 3)) return 0;
    return 1;
}

/* p == t[m] is a corner of triangle t; q is not a corner of t. 0 when the
 * segment from p towards q certainly meets t at p only, 1 otherwise. */
static int edge_leaves_corner(const double *p, const double *q, const double t[3][3], int m)
{
    const double *u = t[(m + 1) % 3], *w = t[(m + 2) % 3];

    /* q strictly off t's plane: the segment crosses the plane at p only */
    if (orient3d(p, u, w, q) != 0) return 0;

    /* in a projection, q strictly outside t's corner wedge at p (the wedge
     * is convex, so one of its two bounding lines separates) */
    int k = dominant_axis(t);
    for (int n = 0; n < 3; n++) {
        int a = (k + n) % 3, i = (a + 1) % 3, j = (a + 2) % 3;
        int side_w = orient2d(p, u, w, i, j); /* w's side of line pu */
        if (side_w == 0) continue;             /* wedge degenerate in this plane */
        if (orient2d(p, u, q, i, j) == -side_w) return 0;
        if (orient2d(p, w, q, i, j) == side_w) return 0; /* u's side of pw is -side_w */
    }
    return 1;
}

static int same_point(const double *x, const double *y)
{
    return x[0] == y[0] && x[1] == y[1] && x[2] == y[2];
}

/* Bit j set when x is at t's corner j (most points differ in x, tested
 * first). */
static inline unsigned corner_matches(const double *x, const double t[3][3])
{
    return (unsigned)same_point(x, t[0]) | (unsigned)same_point(x, t[1]) << 1 | (unsigned)same_point(x, t[2]) << 2;
}

/* 1 when every corner of t not marked in the bit set `shared` is certainly
 * strictly on one and the same side of the plane of `plane`: t then meets
 * that plane only in the hull of its shared corners. */
static int off_plane_except_shared(const double t[3][3], unsigned shared, const double plane[3][3])
{
    int side = 0;
    for (int i = 0; i < 3; i++) {
        if (shared >> i & 1u) continue;
        int s = orient3d(plane[0], plane[1], plane[2], t[i]);
        if (s == 0 || (side != 0 && s != side)) return 0;
        side = s;
    }
    return side != 0;
}

/* Edge tests of the three edges of x, see the top of the file: 1 as soon as
 * one may meet y outside the hull of the shared corners. x_shared: bit i when
 * x[i] is a corner of y, which is then y[corner[i]] (the first such corner). */
static int edges_may_meet(const double x[3][3], unsigned x_shared, const int corner[3], const double y[3][3])
{
    for (int e = 0; e < 3; e++) {
        int i = e, j = (e + 1) % 3;
        int si = x_shared >> i & 1u, sj = x_shared >> j & 1u;
        if (si && sj) continue;
        if (si) {
            if (edge_leaves_corner(x[i], x[j], y, corner[i])) return 1;
        } else if (sj) {
            if (edge_leaves_corner(x[j], x[i], y, corner[j])) return 1;
        } else if (segment_meets_triangle(x[i], x[j], y)) {
            return 1;
        }
    }
    return 0;
}

int intersect_triangles_near(const double a[3][3], const double b[3][3])
{
    /* the common corners (positions compared with ==): bit 3 i + j when
     * a[i] == b[j]; most pairs differ in x, which is tested first */
    const unsigned same = corner_matches(a[0], b) | corner_matches(a[1], b) << 3 | corner_matches(a[2], b) << 6;
    if (!same) {
        if (off_plane_except_shared(b, 0, a) || off_plane_except_shared(a, 0, b)) return 0;
        const int none[3] = {-1, -1, -1};
        return edges_may_meet(a, 0, none, b) || edges_may_meet(b, 0, none, a);
    }
    /* a[i] is shared when row i of `same` is not empty, b[j] when column j */
    const unsigned a_shared = (same & 7u ? 1u : 0u) | (same & 070u ? 2u : 0u) | (same & 0700u ? 4u : 0u);
    const unsigned b_shared = (same & 0111u ? 1u : 0u) | (same & 0222u ? 2u : 0u) | (same & 0444u ? 4u : 0u);
    /* a triangle all of whose corners are shared lies in their hull */
    if (a_shared == 7u || b_shared == 7u) return 0;

    if (off_plane_except_shared(b, b_shared, a)) return 0;
    if (off_plane_except_shared(a, a_shared, b)) return 0;

    /* the corner each shared corner is of the other triangle: the first
     * match, as a scan of its corners finds it */
    int a_corner[3] = {-1, -1, -1}, b_corner[3] = {-1, -1, -1};
    for (int i = 2; i >= 0; i--)
        for (int j = 2; j >= 0; j--)
            if (same >> (3 * i + j) & 1u) a_corner[i] = j, b_corner[j] = i;
    if (edges_may_meet(a, a_shared, a_corner, b)) return 1;
    if (edges_may_meet(b, b_shared, b_corner, a)) return 1;
    return 0;
}

int intersect_triangles(const double a[3][3], const double b[3][3])
{
    if (!intersect_finite(a) || !intersect_finite(b)) return 1;

    for (int c = 0; c < 3; c++) {
        double alo = geom_fmin(a[0][c], geom_fmin(a[1][c], a[2][c]));
        double ahi = geom_fmax(a[0][c], geom_fmax(a[1][c], a[2][c]));
        double blo = geom_fmin(b[0][c], geom_fmin(b[1][c], b[2][c]));
        double bhi = geom_fmax(b[0][c], geom_fmax(b[1][c], b[2][c]));
        if (ahi < blo || bhi < alo) return 0;
    }
    return intersect_triangles_near(a, b);
}
