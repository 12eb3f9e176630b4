/* test_intersect.c - intersect_triangles on hand-made configurations (crossing,
 * touching, neighbours across an edge or a corner, coplanar, degenerate), on
 * every pair of small-integer triangles drawn at random against an exact
 * lattice-sampling reference, and on random double triangles placed within
 * rounding of touching against a long double reference. The property checked
 * everywhere: whenever the reference finds a common point outside the hull of
 * the shared corners, the function says 1 (it may say 1 more often). */
#include "check.h"
#include "intersect.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define RNG_SEED 0x696e746572736563ULL
#include "rng.h"

static int rng_below(int n)
{
    return (int)(rng_next() % (uint64_t)n);
}

/* ---- helpers -------------------------------------------------------------- */

typedef double tri[3][3];

static void set_tri(tri t, double x0, double y0, double z0, double x1, double y1, double z1,
                    double x2, double y2, double z2)
{
    t[0][0] = x0; t[0][1] = y0; t[0][2] = z0;
    t[1][0] = x1; t[1][1] = y1; t[1][2] = z1;
    t[2][0] = x2; t[2][1] = y2; t[2][2] = z2;
}

/* Permutation p (0..5) of t's corners into out. */
static void permute(const tri t, int p, tri out)
{
    static const int order[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
    for (int i = 0; i < 3; i++) memcpy(out[i], t[order[p][i]], sizeof out[i]);
}

/* The answer for (a, b), checked to be the same for (b, a) and every corner
 * order of both when `invariant` (exact configurations only). */
static int answer(const tri a, const tri b, int invariant)
{
    int r = intersect_triangles(a, b);
    if (invariant) {
        for (int pa = 0; pa < 6; pa++) {
            for (int pb = 0; pb < 6; pb++) {
                tri a2, b2;
                permute(a, pa, a2);
                permute(b, pb, b2);
                int r1 = intersect_triangles(a2, b2), r2 = intersect_triangles(b2, a2);
                CHECK(r1 == r && r2 == r, "order dependence: %d vs %d/%d (perm %d %d)", r, r1, r2,
                      pa, pb);
                if (r1 != r || r2 != r) return r;
            }
        }
    }
    return r;
}

/* ---- hand-made configurations --------------------------------------------- */

static tri A_unit; /* (0,0,0) (2,0,0) (0,2,0): the reference triangle in z = 0 */

static void setup_unit(void)
{
    set_tri(A_unit, 0, 0, 0, 2, 0, 0, 0, 2, 0);
}

static void test_crossing_and_separated(void)
{
    tri b;
    setup_unit();
    /* a vertical triangle crossing the interior */
    set_tri(b, 0.5, 0.5, -1, 0.5, 0.5, 1, 1.5, -1, 0);
    CHECK(answer(A_unit, b, 1) == 1, "crossing");
    /* the same lifted above the plane */
    set_tri(b, 0.5, 0.5, 0.25, 0.5, 0.5, 1, 1.5, -1, 0.5);
    CHECK(answer(A_unit, b, 1) == 0, "above");
    /* boxes apart */
    set_tri(b, 5, 5, 5, 6, 5, 5, 5, 6, 5);
    CHECK(answer(A_unit, b, 1) == 0, "far");
    /* crossing the plane outside the triangle */
    set_tri(b, 2, 2, -1, 2, 2, 1, 3, 1, 0);
    CHECK(answer(A_unit, b, 1) == 0, "crosses the plane beside");
    /* one edge piercing the interior, the rest far away */
    set_tri(b, 0.3, 0.3, -1, 0.3, 0.3, 1, 5, 5, 5);
    CHECK(answer(A_unit, b, 1) == 1, "edge piercing the interior");
    /* a corner of b on a's interior, b otherwise above */
    set_tri(b, 0.5, 0.5, 0, 0.5, 0.5, 1, 1, 0.5, 1);
    CHECK(answer(A_unit, b, 1) == 1, "corner on the face");
    /* a corner of b on the interior of a's edge, b otherwise beside */
    set_tri(b, 1, 0, 0, 1, -1, 1, 1, -1, -1);
    CHECK(answer(A_unit, b, 1) == 1, "corner on an edge");
    /* an edge of b crossing an edge of a at one point, b otherwise beside */
    set_tri(b, 1, -1, 1, 1, 1, -1, 1, -1, -5);
    CHECK(answer(A_unit, b, 1) == 1, "edge crossing edge");
    /* b's corner just beside a's edge */
    set_tri(b, 1, -0.001, 0, 1, -1, 1, 1, -1, -1);
    CHECK(answer(A_unit, b, 1) == 0, "corner just beside an edge");
}

static void test_shared_edge(void)
{
    tri a, b;
    set_tri(a, 0, 0, 0, 1, 0, 0, 0.5, 1, 0);
    /* flat neighbours on opposite sides of the edge */
    set_tri(b, 1, 0, 0, 0, 0, 0, 0.5, -1, 0);
    CHECK(answer(a, b, 1) == 0, "flat neighbours");
    /* folded 90 and ~170 degrees */
    set_tri(b, 1, 0, 0, 0, 0, 0, 0.5, 0, 1);
    CHECK(answer(a, b, 1) == 0, "folded 90");
    set_tri(b, 1, 0, 0, 0, 0, 0, 0.5, 1, 0.1);
    CHECK(answer(a, b, 1) == 0, "folded sharply, not coplanar");
    /* folded completely: coplanar and overlapping */
    set_tri(b, 1, 0, 0, 0, 0, 0, 0.5, 0.5, 0);
    CHECK(answer(a, b, 1) == 1, "folded onto each other");
    set_tri(b, 1, 0, 0, 0, 0, 0, 3, 7, 0);
    CHECK(answer(a, b, 1) == 1, "folded onto each other, wide");
    /* b's third corner exactly on the line of the shared edge, beyond it: a
     * degenerate triangle overlapping only the shared edge's line */
    set_tri(b, 1, 0, 0, 0, 0, 0, 2, 0, 0);
    /* exactly, 0 (they meet in the shared edge only); for a degenerate
     * triangle the promise allows a conservative 1, but not an answer that
     * depends on the corners' order or on which triangle comes first
     * (answer checks all 72 orders) */
    (void)answer(a, b, 1);
    /* b's third corner above a's interior with its edges passing through a */
    set_tri(b, 1, 0, 0, 0, 0, 0, 0.5, 2, -1);
    CHECK(answer(a, b, 1) == 0, "shared edge, other side of the plane below");
    /* a neighbour whose far corner dips through a's face: b = (0,0,0),(1,0,0),
     * far corner beyond a, below; edges pass under a: no intersection except
     * along the shared edge (planes meet only in the edge's line) */
    set_tri(b, 0, 0, 0, 1, 0, 0, 0.5, 2, -0.001);
    CHECK(answer(a, b, 1) == 0, "planes meet only along the shared edge");
}

static void test_shared_vertex(void)
{
    tri b;
    setup_unit();
    /* touches at the corner only */
    set_tri(b, 0, 0, 0, -1, 0, 1, 0, -1, 1);
    CHECK(answer(A_unit, b, 1) == 0, "corner only");
    /* its opposite edge crosses a's interior */
    set_tri(b, 0, 0, 0, 0.5, 0.5, -1, 0.5, 0.5, 1);
    CHECK(answer(A_unit, b, 1) == 1, "opposite edge crosses the interior");
    /* an edge from the shared corner runs into a's face (coplanar edge) */
    set_tri(b, 0, 0, 0, 0.5, 0.5, 0, 0.5, 0.5, 1);
    CHECK(answer(A_unit, b, 1) == 1, "edge from the shared corner along the face");
    /* an edge from the shared corner runs along a's edge */
    set_tri(b, 0, 0, 0, 1, 0, 0, 0, -1, 1);
    CHECK(answer(A_unit, b, 1) == 1, "edge along an edge");
    /* coplanar fan: disjoint wedges */
    set_tri(b, 0, 0, 0, -1, 0.1, 0, -1, -1, 0);
    CHECK(answer(A_unit, b, 1) == 0, "coplanar fan, disjoint");
    /* coplanar fan with collinear edges (grid): b to the left of a */
    set_tri(b, 0, 0, 0, 0, 2, 0, -2, 0, 0);
    CHECK(answer(A_unit, b, 1) == 0, "coplanar grid neighbours");
    /* wedges 170..200 degrees vs 0..10 degrees (only a's edge lines separate) */
    double c10 = cos(10 * M_PI / 180), s10 = sin(10 * M_PI / 180);
    double c170 = cos(170 * M_PI / 180), s170 = sin(170 * M_PI / 180);
    double c200 = cos(200 * M_PI / 180), s200 = sin(200 * M_PI / 180);
    tri a;
    set_tri(a, 0, 0, 0, 1, 0, 0, c10, s10, 0);
    set_tri(b, 0, 0, 0, c170, s170, 0, c200, s200, 0);
    CHECK(answer(a, b, 0) == 0, "coplanar fan, wide separation");
    /* coplanar fan: overlapping wedges */
    set_tri(b, 0, 0, 0, 1, 1, 0, 2, -1, 0);
    CHECK(answer(A_unit, b, 1) == 1, "coplanar fan, overlapping");
    /* shared corner, the other triangle entirely on one side */
    set_tri(b, 0, 0, 0, 1, 1, 1, 2, -1, 1);
    CHECK(answer(A_unit, b, 1) == 0, "shared corner, one side");
}

static void test_coplanar(void)
{
    tri b;
    setup_unit();
    set_tri(b, 3, 3, 0, 4, 3, 0, 3, 4, 0);
    CHECK(answer(A_unit, b, 1) == 0, "coplanar disjoint (boxes)");
    set_tri(b, 1.5, 1.5, 0, 3, 1, 0, 1, 3, 0);
    CHECK(answer(A_unit, b, 1) == 0, "coplanar disjoint, boxes overlap");
    set_tri(b, 1, 1, 0, 3, 1, 0, 1, 3, 0);
    CHECK(answer(A_unit, b, 1) == 1, "coplanar touching at a point of the hypotenuse");
    set_tri(b, 0.5, 0.5, 0, 3, 0.5, 0, 0.5, 3, 0);
    CHECK(answer(A_unit, b, 1) == 1, "coplanar overlapping");
    set_tri(b, 0.2, 0.2, 0, 0.6, 0.2, 0, 0.2, 0.6, 0);
    CHECK(answer(A_unit, b, 1) == 1, "coplanar contained");
    set_tri(b, -1, -1, 0, 5, -1, 0, -1, 5, 0);
    CHECK(answer(A_unit, b, 1) == 1, "coplanar containing");
    set_tri(b, 1, -1, 0, 1, 3, 0, 5, 1, 0);
    CHECK(answer(A_unit, b, 1) == 1, "coplanar star crossing");
    /* tilted plane, float coordinates rounded: nearly coplanar and clearly
     * disjoint in the plane */
    tri a, c;
    set_tri(a, 0.1f, 0.2f, 0.3f, 1.1f, 0.25f, 0.7f, 0.3f, 1.2f, 0.5f);
    set_tri(c, 2.1f, 2.2f, 1.3f, 3.1f, 2.25f, 1.7f, 2.3f, 3.2f, 1.5f);
    CHECK(answer(a, c, 0) == 0, "tilted plane, disjoint");
}

static void test_identical_and_all_shared(void)
{
    tri b;
    setup_unit();
    memcpy(b, A_unit, sizeof b);
    CHECK(answer(A_unit, b, 1) == 0, "identical");
    /* b's corners all on a's corners (b degenerate) */
    set_tri(b, 0, 0, 0, 2, 0, 0, 0, 0, 0);
    CHECK(answer(A_unit, b, 0) == 0, "b's corners all shared");
    /* -0.0 and +0.0 are the same position */
    set_tri(b, -0.0, -0.0, -0.0, -1, 0, 1, 0, -1, 1);
    CHECK(answer(A_unit, b, 0) == 0, "negative zero shares the corner");
}

static void test_degenerate(void)
{
    tri b;
    setup_unit();
    /* collinear triangle far away */
    set_tri(b, 5, 5, 5, 6, 6, 6, 7, 7, 7);
    CHECK(intersect_triangles(A_unit, b) == 0, "collinear far");
    CHECK(intersect_triangles(b, A_unit) == 0, "collinear far, swapped");
    /* collinear triangle beside, boxes overlapping */
    set_tri(b, 1.5, 1.5, -1, 1.5, 1.5, 0, 1.5, 1.5, 1);
    CHECK(intersect_triangles(A_unit, b) == 0, "collinear beside");
    /* collinear triangle piercing */
    set_tri(b, 0.5, 0.5, -1, 0.5, 0.5, 0, 0.5, 0.5, 1);
    CHECK(intersect_triangles(A_unit, b) == 1, "collinear piercing");
    CHECK(intersect_triangles(b, A_unit) == 1, "collinear piercing, swapped");
    set_tri(b, 0.5, 0.5, -1, 0.5, 0.5, 1, 0.5, 0.5, 3);
    CHECK(intersect_triangles(A_unit, b) == 1, "collinear piercing between corners");
    /* a point triangle on the face / off it */
    set_tri(b, 0.5, 0.5, 0, 0.5, 0.5, 0, 0.5, 0.5, 0);
    CHECK(intersect_triangles(A_unit, b) == 1, "point on the face");
    CHECK(intersect_triangles(b, A_unit) == 1, "point on the face, swapped");
    set_tri(b, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5);
    CHECK(intersect_triangles(A_unit, b) == 0, "point above the face");
    CHECK(intersect_triangles(b, A_unit) == 0, "point above the face, swapped");
    /* two degenerate triangles */
    tri c;
    set_tri(c, 0, 0, 0, 1, 1, 1, 2, 2, 2);
    set_tri(b, 0, 0, 1, 1, 1, 0, 0.5, 0.5, 0.5);
    CHECK(intersect_triangles(c, b) == 1, "two segments crossing");
    set_tri(b, 10, 0, 1, 11, 1, 0, 10.5, 0.5, 0.5);
    CHECK(intersect_triangles(c, b) == 0, "two segments apart");
    /* degenerate triangle sharing a corner, leaving away from the face */
    set_tri(b, 0, 0, 0, -1, -1, 1, -2, -2, 2);
    CHECK(intersect_triangles(A_unit, b) == 0, "degenerate neighbour at a corner, off the plane");
    /* non-finite input */
    set_tri(b, NAN, 0, 0, 1, 1, 1, 2, 2, 2);
    CHECK(intersect_triangles(A_unit, b) == 1, "NaN");
    set_tri(b, INFINITY, 0, 0, 1, 1, 1, 2, 2, 2);
    CHECK(intersect_triangles(b, A_unit) == 1, "infinity");
    /* huge and tiny coordinates do not crash */
    set_tri(b, 1e300, 1e300, 1e300, -1e300, 1e300, 0, 0, -1e300, -1e300);
    CHECK(intersect_triangles(A_unit, b) == 1, "huge crossing (within overflow: conservative)");
    tri t1, t2;
    set_tri(t1, 0, 0, 0, 2e-200, 0, 0, 0, 2e-200, 0);
    set_tri(t2, 0.5e-200, 0.5e-200, -1e-200, 0.5e-200, 0.5e-200, 1e-200, 1.5e-200, -1e-200, 0);
    CHECK(intersect_triangles(t1, t2) == 1, "tiny crossing");
}

/* ---- exact lattice reference on small integer triangles ------------------- */

typedef struct {
    int64_t v[3][3];
} itri;

static int64_t det3(const int64_t *a, const int64_t *b, const int64_t *c, const int64_t *d)
{
    int64_t ax = a[0] - d[0], ay = a[1] - d[1], az = a[2] - d[2];
    int64_t bx = b[0] - d[0], by = b[1] - d[1], bz = b[2] - d[2];
    int64_t cx = c[0] - d[0], cy = c[1] - d[1], cz = c[2] - d[2];
    return ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx);
}

static void normal3(const itri *t, int64_t n[3])
{
    int64_t u[3], w[3];
    for (int c = 0; c < 3; c++) {
        u[c] = t->v[1][c] - t->v[0][c];
        w[c] = t->v[2][c] - t->v[0][c];
    }
    n[0] = u[1] * w[2] - u[2] * w[1];
    n[1] = u[2] * w[0] - u[0] * w[2];
    n[2] = u[0] * w[1] - u[1] * w[0];
}

/* x (scaled by the same factor as t) in the closed non-degenerate triangle t. */
static int in_triangle(const itri *t, const int64_t *x)
{
    int64_t n[3];
    normal3(t, n);
    if (det3(t->v[0], t->v[1], t->v[2], x) != 0) return 0;
    int k = 0;
    if (llabs(n[1]) > llabs(n[k])) k = 1;
    if (llabs(n[2]) > llabs(n[k])) k = 2;
    int i = (k + 1) % 3, j = (k + 2) % 3;
    int pos = 0, neg = 0;
    for (int e = 0; e < 3; e++) {
        const int64_t *u = t->v[e], *w = t->v[(e + 1) % 3];
        int64_t d = (w[i] - u[i]) * (x[j] - u[j]) - (w[j] - u[j]) * (x[i] - u[i]);
        pos += d > 0;
        neg += d < 0;
    }
    return !(pos && neg);
}

/* x in the hull of the shared corners s[0..count-1] (all scaled). */
static int in_hull(const int64_t s[3][3], int count, const int64_t *x)
{
    if (count == 0) return 0;
    if (count == 1) return x[0] == s[0][0] && x[1] == s[0][1] && x[2] == s[0][2];
    int64_t d[3], e[3];
    for (int c = 0; c < 3; c++) {
        d[c] = s[1][c] - s[0][c];
        e[c] = x[c] - s[0][c];
    }
    if (d[1] * e[2] - d[2] * e[1] != 0 || d[2] * e[0] - d[0] * e[2] != 0 ||
        d[0] * e[1] - d[1] * e[0] != 0)
        return 0;
    int64_t t = d[0] * e[0] + d[1] * e[1] + d[2] * e[2];
    return t >= 0 && t <= d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
}

#define LATTICE 12

/* 1 when a lattice point of x (barycentrics k/LATTICE) lies in y (which must
 * be non-degenerate) outside the hull of the shared corners. */
static int lattice_hits(const itri *x, const itri *y, const int64_t s[3][3], int count)
{
    int64_t n[3];
    normal3(y, n);
    if (n[0] == 0 && n[1] == 0 && n[2] == 0) return 0;
    itri ys;
    int64_t ss[3][3];
    for (int i = 0; i < 3; i++)
        for (int c = 0; c < 3; c++) {
            ys.v[i][c] = y->v[i][c] * LATTICE;
            ss[i][c] = s[i][c] * LATTICE;
        }
    for (int i = 0; i <= LATTICE; i++)
        for (int j = 0; i + j <= LATTICE; j++) {
            int k = LATTICE - i - j;
            int64_t p[3];
            for (int c = 0; c < 3; c++) p[c] = i * x->v[0][c] + j * x->v[1][c] + k * x->v[2][c];
            if (in_triangle(&ys, p) && !in_hull(ss, count, p)) return 1;
        }
    return 0;
}

static int reference_integer(const itri *a, const itri *b)
{
    int64_t s[3][3];
    int count = 0, a_all = 1, b_all = 1;
    for (int i = 0; i < 3; i++) {
        int found = 0;
        for (int j = 0; j < 3; j++)
            found |= a->v[i][0] == b->v[j][0] && a->v[i][1] == b->v[j][1] && a->v[i][2] == b->v[j][2];
        a_all &= found;
        if (!found) continue;
        int dup = 0;
        for (int m = 0; m < count; m++)
            dup |= s[m][0] == a->v[i][0] && s[m][1] == a->v[i][1] && s[m][2] == a->v[i][2];
        if (!dup) {
            memcpy(s[count], a->v[i], sizeof s[count]);
            count++;
        }
    }
    for (int i = 0; i < 3; i++) {
        int found = 0;
        for (int j = 0; j < 3; j++)
            found |= b->v[i][0] == a->v[j][0] && b->v[i][1] == a->v[j][1] && b->v[i][2] == a->v[j][2];
        b_all &= found;
    }
    if (a_all || b_all) return 0;
    return lattice_hits(a, b, s, count) || lattice_hits(b, a, s, count);
}

static int is_degenerate(const itri *t)
{
    int64_t n[3];
    normal3(t, n);
    return n[0] == 0 && n[1] == 0 && n[2] == 0;
}

static void test_integer_grid_against_lattice_reference(void)
{
    int pairs = 0, hits = 0, extra = 0, misses = 0, degenerate = 0;
    for (int trial = 0; trial < 200000; trial++) {
        itri a, b;
        int range = 2 + rng_below(3); /* coordinates 0..range: many exact coincidences */
        for (int i = 0; i < 3; i++)
            for (int c = 0; c < 3; c++) {
                a.v[i][c] = rng_below(range + 1);
                b.v[i][c] = rng_below(range + 1);
            }
        /* share corners often */
        int share = rng_below(4);
        for (int m = 0; m < share && m < 3; m++) memcpy(b.v[m], a.v[(m + trial) % 3], sizeof b.v[m]);
        /* flatten both into z = 0 sometimes (coplanar cases) */
        if (rng_below(3) == 0)
            for (int i = 0; i < 3; i++) a.v[i][2] = b.v[i][2] = 0;
        tri da, db;
        for (int i = 0; i < 3; i++)
            for (int c = 0; c < 3; c++) {
                da[i][c] = (double)a.v[i][c];
                db[i][c] = (double)b.v[i][c];
            }
        int deg = is_degenerate(&a) || is_degenerate(&b);
        int got = deg ? intersect_triangles(da, db) : answer(da, db, trial < 20000);
        int want = reference_integer(&a, &b);
        pairs++;
        degenerate += deg;
        hits += want;
        if (want && !got) {
            misses++;
            if (misses < 10)
                CHECK(0, "false 0: a=(%lld %lld %lld)(%lld %lld %lld)(%lld %lld %lld) "
                         "b=(%lld %lld %lld)(%lld %lld %lld)(%lld %lld %lld)",
                      (long long)a.v[0][0], (long long)a.v[0][1], (long long)a.v[0][2],
                      (long long)a.v[1][0], (long long)a.v[1][1], (long long)a.v[1][2],
                      (long long)a.v[2][0], (long long)a.v[2][1], (long long)a.v[2][2],
                      (long long)b.v[0][0], (long long)b.v[0][1], (long long)b.v[0][2],
                      (long long)b.v[1][0], (long long)b.v[1][1], (long long)b.v[1][2],
                      (long long)b.v[2][0], (long long)b.v[2][1], (long long)b.v[2][2]);
        }
        extra += got && !want && !deg;
    }
    CHECK(misses == 0, "%d false zeros", misses);
    CHECK(hits > pairs / 10, "too few reference hits: %d of %d", hits, pairs);
    fprintf(stdout, "#   %d pairs (%d with a degenerate triangle), reference hits %d, "
                    "1 without a lattice hit (non-degenerate) %d\n",
            pairs, degenerate, hits, extra);
}

/* ---- long double reference near touching, random doubles ------------------ */

/* 1 when an edge of x without shared ends crosses y's plane at a parameter in
 * [margin, 1 - margin] at a point whose barycentrics in y are all >= margin
 * (a certain intersection outside the hull of shared corners, which lies on
 * y's boundary). Nearly parallel edges are skipped. */
static int reference_long_double(const tri x, const int *x_shared, const tri y, long double margin)
{
    long double u[3], w[3], n[3];
    for (int c = 0; c < 3; c++) {
        u[c] = (long double)y[1][c] - y[0][c];
        w[c] = (long double)y[2][c] - y[0][c];
    }
    n[0] = u[1] * w[2] - u[2] * w[1];
    n[1] = u[2] * w[0] - u[0] * w[2];
    n[2] = u[0] * w[1] - u[1] * w[0];
    long double nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    if (nn < 1e-12L) return 0;
    for (int e = 0; e < 3; e++) {
        int i = e, j = (e + 1) % 3;
        if (x_shared[i] || x_shared[j]) continue;
        long double d[3], r[3];
        for (int c = 0; c < 3; c++) {
            d[c] = (long double)x[j][c] - x[i][c];
            r[c] = (long double)y[0][c] - x[i][c];
        }
        long double den = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
        long double dd = sqrtl(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (fabsl(den) < 1e-6L * sqrtl(nn) * dd) continue;
        long double t = (n[0] * r[0] + n[1] * r[1] + n[2] * r[2]) / den;
        if (t < margin || t > 1 - margin) continue;
        long double p[3];
        for (int c = 0; c < 3; c++) p[c] = x[i][c] + t * d[c] - y[0][c];
        /* barycentrics via the normal: beta = ((p) x w) . n / nn, gamma = (u x p) . n / nn */
        long double pw[3] = {p[1] * w[2] - p[2] * w[1], p[2] * w[0] - p[0] * w[2], p[0] * w[1] - p[1] * w[0]};
        long double up[3] = {u[1] * p[2] - u[2] * p[1], u[2] * p[0] - u[0] * p[2], u[0] * p[1] - u[1] * p[0]};
        long double beta = (pw[0] * n[0] + pw[1] * n[1] + pw[2] * n[2]) / nn;
        long double gamma = (up[0] * n[0] + up[1] * n[1] + up[2] * n[2]) / nn;
        if (beta >= margin && gamma >= margin && 1 - beta - gamma >= margin) return 1;
    }
    return 0;
}

static void random_point_in(const tri t, double out[3])
{
    double s = rng_uniform(0, 1), r = rng_uniform(0, 1);
    if (s + r > 1) {
        s = 1 - s;
        r = 1 - r;
    }
    for (int c = 0; c < 3; c++) out[c] = t[0][c] + s * (t[1][c] - t[0][c]) + r * (t[2][c] - t[0][c]);
}

static void test_random_doubles_against_long_double_reference(void)
{
    int pairs = 0, hits = 0, misses = 0, ones = 0;
    for (int trial = 0; trial < 300000; trial++) {
        tri a, b;
        double scale = pow(10.0, rng_uniform(-3, 4));
        double offset = rng_below(2) ? rng_uniform(-1e4, 1e4) : 0;
        for (int i = 0; i < 3; i++)
            for (int c = 0; c < 3; c++) a[i][c] = offset + scale * rng_uniform(-1, 1);
        int kind = rng_below(5);
        for (int i = 0; i < 3; i++)
            for (int c = 0; c < 3; c++) b[i][c] = offset + scale * rng_uniform(-1, 1);
        if (kind == 1) { /* share a corner */
            memcpy(b[0], a[rng_below(3)], sizeof b[0]);
        } else if (kind == 2) { /* share an edge */
            int e = rng_below(3);
            memcpy(b[0], a[(e + 1) % 3], sizeof b[0]);
            memcpy(b[1], a[e], sizeof b[1]);
        } else if (kind >= 3) {
            /* b's corners (some) in a's plane up to a tiny offset */
            int m = 1 + rng_below(3);
            double n[3];
            double u[3], w[3];
            for (int c = 0; c < 3; c++) {
                u[c] = a[1][c] - a[0][c];
                w[c] = a[2][c] - a[0][c];
            }
            n[0] = u[1] * w[2] - u[2] * w[1];
            n[1] = u[2] * w[0] - u[0] * w[2];
            n[2] = u[0] * w[1] - u[1] * w[0];
            double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            if (len == 0) continue;
            for (int i = 0; i < m; i++) {
                double p[3];
                if (rng_below(2)) random_point_in(a, p);
                else { /* b's corner projected onto a's plane */
                    double dist = ((b[i][0] - a[0][0]) * n[0] + (b[i][1] - a[0][1]) * n[1] +
                                   (b[i][2] - a[0][2]) * n[2]) / len;
                    for (int c = 0; c < 3; c++) p[c] = b[i][c] - dist * n[c] / len;
                }
                double h = scale * pow(10.0, rng_uniform(-18, -6)) * (rng_below(2) ? 1 : -1);
                for (int c = 0; c < 3; c++) b[i][c] = p[c] + h * n[c] / len;
            }
            if (kind == 4) memcpy(b[2], a[rng_below(3)], sizeof b[2]);
        }
        int a_shared[3], b_shared[3];
        for (int i = 0; i < 3; i++) {
            a_shared[i] = b_shared[i] = 0;
            for (int j = 0; j < 3; j++) {
                a_shared[i] |= a[i][0] == b[j][0] && a[i][1] == b[j][1] && a[i][2] == b[j][2];
                b_shared[i] |= b[i][0] == a[j][0] && b[i][1] == a[j][1] && b[i][2] == a[j][2];
            }
        }
        int want = reference_long_double(a, a_shared, b, 1e-9L) ||
                   reference_long_double(b, b_shared, a, 1e-9L);
        int got = intersect_triangles(a, b);
        int got2 = intersect_triangles(b, a);
        pairs++;
        hits += want;
        ones += got;
        if (want && (!got || !got2)) {
            misses++;
            if (misses < 5) CHECK(0, "false 0 at trial %d (kind %d)", trial, kind);
        }
    }
    CHECK(misses == 0, "%d false zeros", misses);
    CHECK(hits > pairs / 20, "too few reference hits: %d of %d", hits, pairs);
    fprintf(stdout, "#   %d pairs, reference hits %d, function said 1 for %d\n", pairs, hits, ones);
}

/* ---- exact touching with coordinates full of bits ------------------------- */

/* A dyadic number m / 2^bits with m in [0, 2^bits]. */
static double rng_dyadic(int bits)
{
    return ldexp((double)(rng_next() % (((uint64_t)1 << bits) + 1)), -bits);
}

/* Configurations that touch exactly, built so that every coordinate is exact
 * in double but uses ~50 significant bits (so the naive determinants round):
 * a corner of b on an edge of a, a corner of b on a's face, a neighbour
 * across an edge folded exactly into a's plane on a's side, and in the plane
 * z = 0 (where the 2D tests decide), with a's edge a0a1 on a line of small
 * integer slope so that differences of coordinates round: a neighbour at a0
 * whose edge from a0 runs along a0a1, and a coplanar b with a corner on a0a1.
 * The answer must be 1 every time; a test whose signs have no error bound
 * fails here. */
static void test_exact_touching_with_rounding(void)
{
    int misses[5] = {0, 0, 0, 0, 0};
    for (int trial = 0; trial < 200000; trial++) {
        tri a, b;
        for (int i = 0; i < 3; i++)
            for (int c = 0; c < 3; c++) a[i][c] = (double)(int64_t)(rng_next() % (1u << 26)) - (1 << 25);
        int kind = trial % 5;
        double p[3];
        if (kind >= 3) {
            /* a0, a1 and p on the line s * (k2, k1, 0), p between */
            double k1 = 1 + rng_below(7), k2 = 1 + rng_below(7), sp[3];
            for (int i = 0; i < 3; i++) /* 50 bits, exponents apart: differences round */
                sp[i] = ldexp((double)(rng_next() >> 14), -60 + rng_below(40)) * (rng_below(2) ? 1 : -1);
            if (sp[0] > sp[1]) { double x = sp[0]; sp[0] = sp[1]; sp[1] = x; }
            if (!(sp[0] < sp[2] && sp[2] < sp[1])) continue;
            double *pt[3] = {a[0], a[1], p};
            for (int i = 0; i < 3; i++) {
                pt[i][0] = sp[i] * k2;
                pt[i][1] = sp[i] * k1;
                pt[i][2] = 0;
            }
            a[2][2] = 0;
        } else if (kind == 0) {
            double t = rng_dyadic(26);
            if (t == 0 || t == 1) continue;
            for (int c = 0; c < 3; c++) p[c] = a[0][c] + t * (a[1][c] - a[0][c]);
        } else {
            double s = rng_dyadic(13), t = rng_dyadic(13);
            if (s + t > 1) {
                s = 1 - s;
                t = 1 - t;
            }
            if (s == 0 || t == 0) continue;
            for (int c = 0; c < 3; c++)
                p[c] = a[0][c] + s * (a[1][c] - a[0][c]) + t * (a[2][c] - a[0][c]);
        }
        if (kind == 0 || kind == 1 || kind == 4) {
            /* b: corner p, the others anywhere (in z = 0 for kind 4) */
            memcpy(b[0], p, sizeof b[0]);
            for (int i = 1; i < 3; i++)
                for (int c = 0; c < 3; c++) b[i][c] = kind == 4 && c == 2 ? 0 : rng_uniform(-4e7, 4e7);
        } else if (kind == 3) {
            /* b = (a0, p, x): shares a0 only, its edge from a0 runs along a0a1 */
            memcpy(b[0], a[0], sizeof b[0]);
            memcpy(b[1], p, sizeof b[1]);
            b[2][0] = rng_uniform(-4e7, 4e7);
            b[2][1] = rng_uniform(-4e7, 4e7);
            b[2][2] = 0;
        } else {
            /* b = (a1, a0, p): a's neighbour across edge a0a1, apex inside a */
            memcpy(b[0], a[1], sizeof b[0]);
            memcpy(b[1], a[0], sizeof b[1]);
            memcpy(b[2], p, sizeof b[2]);
        }
        int shared = 0;
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                shared += b[i][0] == a[j][0] && b[i][1] == a[j][1] && b[i][2] == a[j][2];
        if ((kind == 0 || kind == 1 || kind == 4) && shared) continue;
        if (!intersect_triangles(a, b) || !intersect_triangles(b, a)) misses[kind]++;
    }
    CHECK(misses[0] == 0, "corner on an edge: %d false zeros", misses[0]);
    CHECK(misses[1] == 0, "corner on the face: %d false zeros", misses[1]);
    CHECK(misses[2] == 0, "neighbour folded into the plane: %d false zeros", misses[2]);
    CHECK(misses[3] == 0, "z = 0, neighbour at a corner along an edge: %d false zeros", misses[3]);
    CHECK(misses[4] == 0, "z = 0, corner on an edge: %d false zeros", misses[4]);
}

/* Nearly coplanar neighbours in a tilted, float-rounded plane: a regular
 * flat grid must not be reported as self-intersecting (or the simplifier
 * would refuse everything on flat regions). */
static void test_flat_tilted_grid_is_clean(void)
{
    enum { N = 6 };
    float grid[N + 1][N + 1][3];
    for (int i = 0; i <= N; i++)
        for (int j = 0; j <= N; j++) {
            double x = 0.37 * i + 0.11 * j + 100.0, y = 0.05 * i + 0.41 * j - 20.0;
            grid[i][j][0] = (float)x;
            grid[i][j][1] = (float)y;
            grid[i][j][2] = (float)(0.3 * x - 0.7 * y + 1.0);
        }
    tri faces[2 * N * N];
    int count = 0;
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++) {
            const float *p00 = grid[i][j], *p10 = grid[i + 1][j], *p01 = grid[i][j + 1],
                        *p11 = grid[i + 1][j + 1];
            for (int c = 0; c < 3; c++) {
                faces[count][0][c] = p00[c];
                faces[count][1][c] = p10[c];
                faces[count][2][c] = p11[c];
                faces[count + 1][0][c] = p00[c];
                faces[count + 1][1][c] = p11[c];
                faces[count + 1][2][c] = p01[c];
            }
            count += 2;
        }
    int reported = 0;
    for (int f = 0; f < count; f++)
        for (int g = f + 1; g < count; g++) reported += intersect_triangles(faces[f], faces[g]);
    CHECK(reported == 0, "%d of %d pairs of a flat grid reported", reported, count * (count - 1) / 2);
}

/* ---- the entry points for callers that tested boxes themselves ------------ */

/* intersect_triangles_near gives intersect_triangles' answer on finite
 * triangles whose boxes overlap: small-integer corners (many shared, coplanar
 * and degenerate pairs) and the same nudged by a few ulps. intersect_finite
 * finds every infinite and NaN coordinate. */
static void test_near_and_finite_agree(void)
{
    long compared = 0;
    for (int it = 0; it < 200000; it++) {
        tri a, b;
        for (int i = 0; i < 3; i++)
            for (int c = 0; c < 3; c++) {
                a[i][c] = rng_below(3);
                b[i][c] = rng_below(3);
            }
        for (int k = rng_below(4); k > 0; k--) memcpy(b[rng_below(3)], a[rng_below(3)], sizeof b[0]);
        if (it % 2) b[rng_below(3)][rng_below(3)] += (rng_below(5) - 2) * 1e-16;
        CHECK(intersect_finite(a) && intersect_finite(b), "finite corners");
        int overlap = 1;
        for (int c = 0; c < 3; c++) {
            double alo = fmin(a[0][c], fmin(a[1][c], a[2][c])), ahi = fmax(a[0][c], fmax(a[1][c], a[2][c]));
            double blo = fmin(b[0][c], fmin(b[1][c], b[2][c])), bhi = fmax(b[0][c], fmax(b[1][c], b[2][c]));
            overlap &= !(ahi < blo || bhi < alo);
        }
        if (!overlap) continue;
        compared++;
        int full = intersect_triangles(a, b), near = intersect_triangles_near(a, b);
        CHECK(full == near, "near %d vs %d (pair %d)", near, full, it);
        if (full != near) return;
    }
    CHECK(compared > 100000, "only %ld pairs compared", compared);

    const double bad[3] = {INFINITY, -INFINITY, NAN};
    for (int k = 0; k < 3; k++)
        for (int i = 0; i < 9; i++) {
            tri t;
            set_tri(t, 0, 0, 0, 1, 0, 0, 0, 1, 0);
            t[i / 3][i % 3] = bad[k];
            CHECK(!intersect_finite(t), "coordinate %d = %g found", i, bad[k]);
        }
}

int main(void)
{
    RUN(test_crossing_and_separated);
    RUN(test_shared_edge);
    RUN(test_shared_vertex);
    RUN(test_coplanar);
    RUN(test_identical_and_all_shared);
    RUN(test_degenerate);
    RUN(test_flat_tilted_grid_is_clean);
    RUN(test_exact_touching_with_rounding);
    RUN(test_integer_grid_against_lattice_reference);
    RUN(test_random_doubles_against_long_double_reference);
    RUN(test_near_and_finite_agree);
    return check_summary();
}
