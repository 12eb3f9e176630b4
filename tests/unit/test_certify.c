/* test_certify.c - the two-sided certificate (certify.h, DESIGN.md §4) on hand-made
 * adversarial cases, each checked against an independent measure computed here:
 * dense barycentric sampling of the triangle in question and the exact distance
 * of every sample to the other side by brute force over all its triangles
 * (geom_point_triangle_distance2). Sampling gives a LOWER bound of the true
 * distance, so it can only catch a false certificate: whenever a test says
 * "yes", sampled <= bound <= eps must hold.
 *
 * Cases: the obtuse triangle whose centroid + circumradius ball misses a vertex
 * (a naive Lipschitz test accepts a face that is NOT within eps); random obtuse
 * slivers floating over a curved surface (fuzz, both directions); thin sheets
 * with opposite normals (never certified through); materials; degenerate and
 * NaN faces; a face equal to an original triangle; the same case translated by
 * 1e5 units. */
#include "certify.h"
#include "check.h"
#include "geom.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RNG_SEED 0x6365727469667921ULL
#include "rng.h"

/* ---- an original mesh built by hand --------------------------------------- */

typedef struct {
    uint32_t nv, nt, cap_v, cap_t;
    float *pos;
    uint32_t *tri;
    int32_t *mat;
    uint32_t *off, *vt;
    cert_original o;
    int built;
} orig_mesh;

static void om_init(orig_mesh *m, uint32_t cap_v, uint32_t cap_t)
{
    memset(m, 0, sizeof *m);
    m->cap_v = cap_v;
    m->cap_t = cap_t;
    m->pos = calloc(3 * (size_t)cap_v + 1, sizeof *m->pos);
    m->tri = calloc(3 * (size_t)cap_t + 1, sizeof *m->tri);
    m->mat = calloc((size_t)cap_t + 1, sizeof *m->mat);
    if (!m->pos || !m->tri || !m->mat) abort();
}

static uint32_t om_vertex(orig_mesh *m, double x, double y, double z)
{
    if (m->nv >= m->cap_v) abort();
    m->pos[3 * m->nv] = (float)x;
    m->pos[3 * m->nv + 1] = (float)y;
    m->pos[3 * m->nv + 2] = (float)z;
    return m->nv++;
}

static void om_tri(orig_mesh *m, uint32_t a, uint32_t b, uint32_t c, int32_t material)
{
    if (m->nt >= m->cap_t) abort();
    m->tri[3 * m->nt] = a;
    m->tri[3 * m->nt + 1] = b;
    m->tri[3 * m->nt + 2] = c;
    m->mat[m->nt++] = material;
}

/* Builds the vertex -> triangle CSR (ascending) and the cert_original. */
static int om_build(orig_mesh *m)
{
    m->off = calloc((size_t)m->nv + 2, sizeof *m->off);
    m->vt = calloc(3 * (size_t)m->nt + 1, sizeof *m->vt);
    if (!m->off || !m->vt) abort();
    for (uint32_t i = 0; i < 3 * m->nt; ++i) m->off[m->tri[i] + 1]++;
    for (uint32_t v = 0; v < m->nv; ++v) m->off[v + 1] += m->off[v];
    uint32_t *fill = calloc((size_t)m->nv + 1, sizeof *fill);
    if (!fill) abort();
    for (uint32_t t = 0; t < m->nt; ++t)
        for (int k = 0; k < 3; ++k) {
            uint32_t v = m->tri[3 * t + (uint32_t)k];
            int dup = 0;
            for (int j = 0; j < k; ++j) dup |= m->tri[3 * t + (uint32_t)j] == v;
            if (!dup) m->vt[m->off[v] + fill[v]++] = t;
        }
    /* a triangle with a repeated vertex would leave holes: not used here */
    free(fill);
    int rc = cert_original_init(&m->o, m->pos, m->nv, m->tri, m->nt, m->mat, m->off, m->vt, 1);
    m->built = rc == 0;
    return rc;
}

static void om_free(orig_mesh *m)
{
    if (m->built) cert_original_free(&m->o);
    free(m->pos);
    free(m->tri);
    free(m->mat);
    free(m->off);
    free(m->vt);
    memset(m, 0, sizeof *m);
}

static vec3d om_point(const orig_mesh *m, uint32_t v)
{
    return geom_vec3d_from_floats(m->pos + 3 * (size_t)v);
}

static void om_triangle(const orig_mesh *m, uint32_t t, vec3d out[3])
{
    for (int k = 0; k < 3; ++k) out[k] = om_point(m, m->tri[3 * (size_t)t + (uint32_t)k]);
}

/* Height field z = f(x, y) on [0, 1]^2, n x n cells, material 0, normals up. */
static double bumpy(double x, double y)
{
    return 0.08 * sin(5.0 * x) * cos(4.0 * y) + 0.03 * sin(11.0 * x + 3.0 * y);
}

static void om_height_field(orig_mesh *m, uint32_t n)
{
    om_init(m, (n + 1) * (n + 1), 2 * n * n);
    for (uint32_t j = 0; j <= n; ++j)
        for (uint32_t i = 0; i <= n; ++i) {
            double x = (double)i / n, y = (double)j / n;
            om_vertex(m, x, y, bumpy(x, y));
        }
    for (uint32_t j = 0; j < n; ++j)
        for (uint32_t i = 0; i < n; ++i) {
            uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
            om_tri(m, a, b, d, 0);
            om_tri(m, a, d, c, 0);
        }
}

/* Builds m; 0 (after reporting it, m freed) when that fails. */
static int om_ready(orig_mesh *m)
{
    CHECK(om_build(m) == 0, "cert_original_init");
    if (m->built) return 1;
    om_free(m);
    return 0;
}

/* A built height field of n x n squares, as om_ready. */
static int height_field_built(orig_mesh *m, uint32_t n)
{
    om_height_field(m, n);
    return om_ready(m);
}

/* ---- the independent measure ------------------------------------------------ */

static vec3d bary(const vec3d p[3], double u, double v)
{
    double w = 1.0 - u - v;
    return geom_vec3d(w * p[0].x + u * p[1].x + v * p[2].x, w * p[0].y + u * p[1].y + v * p[2].y,
                      w * p[0].z + u * p[1].z + v * p[2].z);
}

/* Exact distance from p to the union of the original triangles accepted by
 * `material` (< -1: any) and `normal` (NULL: any; else n_t . normal > 0). */
static double dist_to_original(const orig_mesh *m, vec3d p, int32_t material, const double *normal)
{
    double best2 = INFINITY;
    for (uint32_t t = 0; t < m->nt; ++t) {
        if (material >= -1 && m->mat[t] != material) continue;
        vec3d tri[3];
        om_triangle(m, t, tri);
        if (normal) {
            vec3d n = geom_triangle_normal(&tri[0], &tri[1], &tri[2]);
            if (!(n.x * normal[0] + n.y * normal[1] + n.z * normal[2] > 0.0)) continue;
        }
        double d2 = geom_point_triangle_distance2(&p, &tri[0], &tri[1], &tri[2], NULL);
        if (d2 < best2) best2 = d2;
    }
    return sqrt(best2);
}

/* Largest sampled distance from triangle p (n x n barycentric grid, corners
 * and edge points included) to the original. */
static double sampled_face_to_original(const orig_mesh *m, const vec3d p[3], int n, int32_t material,
                                       const double *normal)
{
    double worst = 0.0;
    for (int i = 0; i <= n; ++i)
        for (int j = 0; i + j <= n; ++j) {
            double d = dist_to_original(m, bary(p, (double)i / n, (double)j / n), material, normal);
            if (!(d <= worst)) worst = d;
        }
    return worst;
}

/* Largest sampled distance from original triangle t to the union of faces. */
static double sampled_original_to_faces(const orig_mesh *m, uint32_t t, const cert_tri *faces, uint32_t count,
                                        int n)
{
    vec3d p[3];
    om_triangle(m, t, p);
    double worst = 0.0;
    for (int i = 0; i <= n; ++i)
        for (int j = 0; i + j <= n; ++j) {
            vec3d q = bary(p, (double)i / n, (double)j / n);
            double best2 = INFINITY;
            for (uint32_t k = 0; k < count; ++k) {
                vec3d a = geom_vec3d_from_doubles(faces[k].p[0]), b = geom_vec3d_from_doubles(faces[k].p[1]),
                      c = geom_vec3d_from_doubles(faces[k].p[2]);
                double d2 = geom_point_triangle_distance2(&q, &a, &b, &c, NULL);
                if (d2 < best2) best2 = d2;
            }
            double d = sqrt(best2);
            if (!(d <= worst)) worst = d;
        }
    return worst;
}

static cert_tri make_face(vec3d a, vec3d b, vec3d c, int32_t material, uint32_t id)
{
    cert_tri f;
    memset(&f, 0, sizeof f);
    const vec3d p[3] = {a, b, c};
    for (int k = 0; k < 3; ++k) {
        f.p[k][0] = p[k].x;
        f.p[k][1] = p[k].y;
        f.p[k][2] = p[k].z;
    }
    f.material = material;
    f.id = id;
    cert_face_normal(&f);
    return f;
}

static void face_points(const cert_tri *f, vec3d p[3])
{
    for (int k = 0; k < 3; ++k) p[k] = geom_vec3d_from_doubles(f->p[k]);
}

/* cert_tri.vertex: the original vertex nearest to each corner (a level's
 * corners are original vertices; for a free-floating test face this is only
 * the hint cert_face starts its search from, never part of what it proves). */
static void hint(const orig_mesh *m, cert_tri *f)
{
    for (int k = 0; k < 3; ++k) {
        vec3d q = geom_vec3d_from_doubles(f->p[k]);
        double best = INFINITY;
        for (uint32_t v = 0; v < m->nv; ++v) {
            double d2 = geom_distance2(q, om_point(m, v));
            if (d2 < best) {
                best = d2;
                f->vertex[k] = v;
            }
        }
    }
}

/* Tolerance for comparing a sampled distance with a certified bound: the
 * sample points are rounded barycentric combinations (a few ulps off the
 * face), nothing more. */
static double slack(double scale)
{
    return 1e-12 * (scale > 1.0 ? scale : 1.0);
}

/* ---- the obtuse triangle ----------------------------------------------------- */

/* Circumradius of abc (abc / 4K). */
static double circumradius(vec3d a, vec3d b, vec3d c)
{
    double la = geom_distance(b, c), lb = geom_distance(c, a), lc = geom_distance(a, b);
    double area = 0.5 * geom_length(geom_triangle_normal(&a, &b, &c));
    return la * lb * lc / (4.0 * area);
}

/* F = (0,0,0) (10,0,0) (0.1,0.2,0): obtuse at the third corner. Its centroid G
 * is 6.63 from the far corner B but the circumradius is only 5.54, so the
 * "centroid + circumradius" ball misses B. The original is a small triangle
 * around G in F's plane: d(G) = 0, so the naive test d(G) + R <= eps accepts F
 * for eps = 6, while B is 6.3 away from the original: F is NOT within eps.
 * cert_face must reject it; with eps = 7 it may accept, but then its bound
 * must be at least the sampled distance. Then the same with the whole setup
 * translated by (1e5, -1e5, 1e5) and rotated out of the coordinate planes. */
static void obtuse_case(vec3d shift, int rotate)
{
    vec3d a = geom_vec3d(0, 0, 0), b = geom_vec3d(10, 0, 0), c = geom_vec3d(0.1, 0.2, 0);
    vec3d g = geom_scale(geom_add(geom_add(a, b), c), 1.0 / 3.0);
    const vec3d around[3] = {geom_vec3d(g.x - 0.3, g.y - 0.3, 0), geom_vec3d(g.x + 0.3, g.y - 0.3, 0),
                             geom_vec3d(g.x, g.y + 0.3, 0)};
    /* a rotation about (1, 1, 1) / sqrt 3 by 40 degrees, then the shift; every
     * point goes through float (as the original's positions do) */
    const double ang = rotate ? 40.0 * M_PI / 180.0 : 0.0, cs = cos(ang), sn = sin(ang), k = 1.0 / sqrt(3.0);
    const double kx = k, ky = k, kz = k;
    double rot[3][3] = {
        {cs + kx * kx * (1 - cs), kx * ky * (1 - cs) - kz * sn, kx * kz * (1 - cs) + ky * sn},
        {ky * kx * (1 - cs) + kz * sn, cs + ky * ky * (1 - cs), ky * kz * (1 - cs) - kx * sn},
        {kz * kx * (1 - cs) - ky * sn, kz * ky * (1 - cs) + kx * sn, cs + kz * kz * (1 - cs)}};
#define XF(v)                                                                                               \
    geom_vec3d((double)(float)(rot[0][0] * (v).x + rot[0][1] * (v).y + rot[0][2] * (v).z + shift.x),          \
               (double)(float)(rot[1][0] * (v).x + rot[1][1] * (v).y + rot[1][2] * (v).z + shift.y),          \
               (double)(float)(rot[2][0] * (v).x + rot[2][1] * (v).y + rot[2][2] * (v).z + shift.z))
    vec3d fa = XF(a), fb = XF(b), fc = XF(c), o0 = XF(around[0]), o1 = XF(around[1]), o2 = XF(around[2]);
#undef XF
    orig_mesh m;
    om_init(&m, 3, 1);
    om_vertex(&m, o0.x, o0.y, o0.z);
    om_vertex(&m, o1.x, o1.y, o1.z);
    om_vertex(&m, o2.x, o2.y, o2.z);
    om_tri(&m, 0, 1, 2, 0);
    if (!om_ready(&m)) return;
    cert_tri f = make_face(fa, fb, fc, 0, 0);
    hint(&m, &f);
    CHECK(!f.degenerate, "face not degenerate");
    CHECK(geom_dot(geom_sub(fa, fc), geom_sub(fb, fc)) < 0, "the face is obtuse at its third corner");

    /* the naive ball is wrong: it does not contain B, and its test accepts */
    vec3d fg = geom_scale(geom_add(geom_add(fa, fb), fc), 1.0 / 3.0);
    double naive_r = circumradius(fa, fb, fc);
    CHECK(geom_distance(fg, fb) > naive_r + 1.0, "centroid ball misses B: |B-G| = %g, R = %g",
          geom_distance(fg, fb), naive_r);
    const double eps = 6.0;
    double d_g = dist_to_original(&m, fg, 0, NULL);
    CHECK(d_g + naive_r <= eps, "the naive test would accept: d(G) + R = %g <= %g", d_g + naive_r, eps);

    /* the independent measure: F is not within eps */
    double sampled = sampled_face_to_original(&m, (const vec3d[3]){fa, fb, fc}, 64, 0, NULL);
    CHECK(sampled > eps + 0.2, "F really is farther than eps: sampled %g", sampled);

    /* the minimal enclosing ball does contain the face */
    vec3d centre;
    double r;
    geom_triangle_enclosing_ball(&fa, &fb, &fc, &centre, &r);
    CHECK(geom_distance(centre, fa) <= r && geom_distance(centre, fb) <= r && geom_distance(centre, fc) <= r,
          "the minimal enclosing ball contains F");
    CHECK(fabs(r - 5.0) < 0.02, "it is the longest-edge ball: r = %g", r);

    double bound = -1.0;
    int ok = cert_face(&m.o, &f, eps, &bound);
    CHECK(!ok, "cert_face must reject a face 6.3 > eps = 6 from the original (bound %g)", bound);
    if (ok) CHECK(bound >= sampled, "a false certificate: bound %.17g < sampled %.17g", bound, sampled);

    /* with room to spare it may accept, but never below the measure */
    const double eps2 = 7.0;
    ok = cert_face(&m.o, &f, eps2, &bound);
    CHECK(ok, "within eps = 7 (sampled %g): should be certified", sampled);
    if (ok) CHECK(sampled <= bound + slack(1e5) && bound <= eps2, "sampled %.17g <= bound %.17g <= eps %g", sampled,
                  bound, eps2);

    /* the same face turned over has no witness at all */
    cert_tri flipped = make_face(fa, fc, fb, 0, 0);
    hint(&m, &flipped);
    CHECK(!cert_face(&m.o, &flipped, eps2, &bound), "a flipped face has no front-facing witness");
    om_free(&m);
}

static void test_obtuse_centroid_ball(void)
{
    obtuse_case(geom_vec3d(0, 0, 0), 0);
}

static void test_obtuse_translated_rotated(void)
{
    obtuse_case(geom_vec3d(1e5, -1e5, 1e5), 1);
    obtuse_case(geom_vec3d(0, 0, 0), 1);
}

/* A family of obtuse triangles (one corner pulled towards the long edge) whose
 * centroid ball misses a vertex, over a flat original that stops short of the
 * far corner by more than eps - R. */
static void test_obtuse_family(void)
{
    int cases = 0, naive_wrong = 0;
    for (int i = 1; i <= 20; ++i) {
        double h = 0.1 * i, x = 0.05 * i; /* third corner (x, h): obtuse, x / h = 0.5 */
        vec3d a = geom_vec3d(0, 0, 0), b = geom_vec3d(10, 0, 0), c = geom_vec3d(x, h, 0);
        if (geom_dot(geom_sub(a, c), geom_sub(b, c)) >= 0) continue;
        cases++;
        vec3d g = geom_scale(geom_add(geom_add(a, b), c), 1.0 / 3.0);
        double naive_r = circumradius(a, b, c);
        /* original: the part of F with x <= cut, as one triangle fan in F's plane */
        double cut = g.x + 0.5;
        orig_mesh m;
        om_init(&m, 4, 2);
        double yc = h * (cut - 10.0) / (x - 10.0); /* on edge c-b at x = cut */
        om_vertex(&m, 0, 0, 0);
        om_vertex(&m, cut, 0, 0);
        om_vertex(&m, cut, yc, 0);
        om_vertex(&m, x, h, 0);
        om_tri(&m, 0, 1, 2, 0);
        om_tri(&m, 0, 2, 3, 0);
        if (om_build(&m) != 0) {
            CHECK(0, "cert_original_init");
            om_free(&m);
            continue;
        }
        cert_tri f = make_face(a, b, c, 0, 0);
        hint(&m, &f);
        double sampled = sampled_face_to_original(&m, (const vec3d[3]){a, b, c}, 48, 0, NULL);
        double d_g = dist_to_original(&m, g, 0, NULL);
        /* the eps that makes the naive test accept */
        double eps = d_g + naive_r + 1e-6;
        if (sampled > eps) naive_wrong++;
        double bound = -1;
        int ok = cert_face(&m.o, &f, eps, &bound);
        if (sampled > eps) CHECK(!ok, "case %d: face %g beyond eps %g certified (bound %g)", i, sampled, eps, bound);
        if (ok) CHECK(sampled <= bound + slack(10) && bound <= eps, "case %d: sampled %.17g <= bound %.17g <= %g", i,
                      sampled, bound, eps);
        /* and at a comfortable eps it is accepted with an honest bound */
        double eps2 = sampled * 1.25 + 0.01;
        ok = cert_face(&m.o, &f, eps2, &bound);
        CHECK(ok, "case %d: not certified at eps %g (sampled %g)", i, eps2, sampled);
        if (ok) CHECK(sampled <= bound + slack(10) && bound <= eps2, "case %d: sampled %.17g <= bound %.17g <= %g", i,
                      sampled, bound, eps2);
        om_free(&m);
    }
    CHECK(cases >= 10, "obtuse cases %d", cases);
    CHECK(naive_wrong >= 5, "cases where the naive ball is wrong: %d", naive_wrong);
}

/* ---- fuzz: slivers over a curved surface -------------------------------------- */

/* A random triangle near the surface: with probability 1/2 an obtuse sliver
 * (third corner near the long edge's middle), with the corners lifted off the
 * surface by up to `lift`. Counter-clockwise seen from above. */
static cert_tri random_face(double size, double lift, uint32_t id)
{
    vec3d p[3];
    double cx = rng_uniform(0.15, 0.85), cy = rng_uniform(0.15, 0.85);
    double ang = rng_uniform(0, 2 * M_PI);
    if (rng_next() & 1) {
        double len = size * rng_uniform(0.5, 1.0);
        double ux = cos(ang), uy = sin(ang);
        double t = rng_uniform(-0.3, 0.3), off = len * rng_uniform(0.02, 0.2);
        p[0] = geom_vec3d(cx - ux * len, cy - uy * len, 0);
        p[1] = geom_vec3d(cx + ux * len, cy + uy * len, 0);
        p[2] = geom_vec3d(cx + ux * len * t - uy * off, cy + uy * len * t + ux * off, 0);
    } else {
        for (int k = 0; k < 3; ++k)
            p[k] = geom_vec3d(cx + size * rng_uniform(-1, 1), cy + size * rng_uniform(-1, 1), 0);
    }
    for (int k = 0; k < 3; ++k) p[k].z = bumpy(p[k].x, p[k].y) + rng_uniform(-lift, lift);
    vec3d n = geom_triangle_normal(&p[0], &p[1], &p[2]);
    if (n.z < 0) {
        vec3d t = p[1];
        p[1] = p[2];
        p[2] = t;
    }
    return make_face(p[0], p[1], p[2], 0, id);
}

static void test_face_fuzz(void)
{
    orig_mesh m;
    if (!height_field_built(&m, 16)) return;
    int accepted = 0, rejected = 0;
    for (int trial = 0; trial < 400; ++trial) {
        double eps = rng_uniform(0.004, 0.06);
        cert_tri f = random_face(rng_uniform(0.02, 0.3), eps * rng_uniform(0, 1.2), 0);
        if (f.degenerate) continue;
        if (trial % 4) hint(&m, &f); /* else all corners hint vertex 0 */
        double bound = -1;
        if (!cert_face(&m.o, &f, eps, &bound)) {
            rejected++;
            continue;
        }
        accepted++;
        vec3d p[3];
        face_points(&f, p);
        double sampled = sampled_face_to_original(&m, p, 20, 0, NULL);
        CHECK(sampled <= bound + slack(1) && bound <= eps,
              "trial %d: sampled %.17g <= bound %.17g <= eps %.17g (face %g %g %g / %g %g %g / %g %g %g)", trial,
              sampled, bound, eps, p[0].x, p[0].y, p[0].z, p[1].x, p[1].y, p[1].z, p[2].x, p[2].y, p[2].z);
    }
    printf("#   cert_face fuzz: %d accepted (each sampled), %d rejected\n", accepted, rejected);
    CHECK(accepted >= 40 && rejected >= 40, "not vacuous: %d accepted, %d rejected", accepted, rejected);
    om_free(&m);
}

/* A polar grid over the height field: a hub with `sectors` thin sectors
 * around it (its valence), `rings` rings of quads outside them. */
static int hub_fan_built(orig_mesh *m, uint32_t sectors, uint32_t rings)
{
    om_init(m, 1 + sectors * rings, sectors * (2 * rings - 1));
    const double cx = 0.5, cy = 0.5, radius = 0.45;
    const uint32_t hub = om_vertex(m, cx, cy, bumpy(cx, cy));
    for (uint32_t j = 1; j <= rings; ++j)
        for (uint32_t i = 0; i < sectors; ++i) {
            const double a = 2.0 * M_PI * i / sectors, rr = radius * j / rings;
            const double x = cx + rr * cos(a), y = cy + rr * sin(a);
            om_vertex(m, x, y, bumpy(x, y));
        }
    for (uint32_t i = 0; i < sectors; ++i) {
        const uint32_t next = (i + 1) % sectors;
        om_tri(m, hub, 1 + i, 1 + next, 0);
        for (uint32_t j = 1; j < rings; ++j) {
            const uint32_t a = 1 + (j - 1) * sectors + i, b = 1 + (j - 1) * sectors + next;
            om_tri(m, a, a + sectors, b + sectors, 0);
            om_tri(m, a, b + sectors, b, 0);
        }
    }
    return om_ready(m);
}

/* A piece's search for one original holding it walks the rings of its
 * closest original's corners, or (around a vertex of high valence) asks the
 * tree for the originals near the piece. Both must give the same answer to
 * the bit: every face, certified both ways on a fan of 600 sectors around a
 * hub (sector faces from the hub, faces near it, some lifted off it), gets
 * the same verdict and bound, and an accepted one is sampled within it. */
static void test_hub_fan_tree_search(void)
{
    orig_mesh m;
    if (!hub_fan_built(&m, 600, 3)) return;
    int accepted = 0, rejected = 0, differ = 0;
    for (int trial = 0; trial < 240; ++trial) {
        const double eps = rng_uniform(0.002, 0.03);
        vec3d p[3];
        const double a = rng_uniform(0, 2 * M_PI), span = rng_uniform(0.01, 0.4), reach = rng_uniform(0.05, 0.45);
        if (trial % 2) { /* a sector face from the hub */
            p[0] = geom_vec3d(0.5, 0.5, bumpy(0.5, 0.5));
            p[1] = geom_vec3d(0.5 + reach * cos(a), 0.5 + reach * sin(a), 0);
            p[2] = geom_vec3d(0.5 + reach * cos(a + span), 0.5 + reach * sin(a + span), 0);
        } else { /* a small face near the hub */
            const double size = rng_uniform(0.01, 0.1), cx = 0.5 + rng_uniform(-0.05, 0.05),
                         cy = 0.5 + rng_uniform(-0.05, 0.05);
            for (int k = 0; k < 3; ++k) {
                const double b = a + 2.0 * M_PI * k / 3 + rng_uniform(-0.5, 0.5);
                p[k] = geom_vec3d(cx + size * cos(b), cy + size * sin(b), 0);
            }
        }
        const double lift = trial % 3 == 0 ? eps * rng_uniform(0, 1.5) : 0.0;
        for (int k = (trial % 2); k < 3; ++k) p[k].z = bumpy(p[k].x, p[k].y) + rng_uniform(-lift, lift);
        cert_tri f = make_face(p[0], p[1], p[2], 0, 0);
        if (f.degenerate) continue;
        hint(&m, &f);
        double bound_rings = -1, bound_tree = -1, bound_default = -1;
        m.o.ring_scan_max = UINT32_MAX;
        const int ok_rings = cert_face(&m.o, &f, eps, &bound_rings);
        m.o.ring_scan_max = 0;
        const int ok_tree = cert_face(&m.o, &f, eps, &bound_tree);
        m.o.ring_scan_max = CERT_RING_SCAN_MAX;
        const int ok_default = cert_face(&m.o, &f, eps, &bound_default);
        if (ok_rings != ok_tree || ok_rings != ok_default ||
            (ok_rings && (bound_rings != bound_tree || bound_rings != bound_default))) {
            differ++;
            printf("#   trial %d: rings %d %.17g, tree %d %.17g, default %d %.17g\n", trial, ok_rings, bound_rings,
                   ok_tree, bound_tree, ok_default, bound_default);
        }
        if (!ok_rings) {
            rejected++;
            continue;
        }
        accepted++;
        face_points(&f, p);
        const double sampled = sampled_face_to_original(&m, p, 12, 0, NULL);
        CHECK(sampled <= bound_rings + slack(1) && bound_rings <= eps, "trial %d: sampled %.17g <= bound %.17g <= eps %.17g",
              trial, sampled, bound_rings, eps);
    }
    printf("#   hub fan: %d accepted, %d rejected, %d differ\n", accepted, rejected, differ);
    CHECK(differ == 0, "%d faces certified differently by the ring walk and the tree", differ);
    CHECK(accepted >= 40 && rejected >= 20, "not vacuous: %d accepted, %d rejected", accepted, rejected);
    om_free(&m);
}

/* (b): an original triangle against a handful of random faces around it; when
 * covered, the faces it names are enough: sampled distance from t to the union
 * of the USED faces <= bound <= eps. */
static void test_cover_fuzz(void)
{
    orig_mesh m;
    if (!height_field_built(&m, 16)) return;
    int accepted = 0, rejected = 0;
    for (int trial = 0; trial < 400; ++trial) {
        uint32_t t = (uint32_t)(rng_next() % m.nt);
        vec3d tp[3];
        om_triangle(&m, t, tp);
        double eps = rng_uniform(0.002, 0.04);
        /* faces: a coarse fan around t's centroid, corners lifted randomly */
        vec3d g = geom_scale(geom_add(geom_add(tp[0], tp[1]), tp[2]), 1.0 / 3.0);
        cert_tri faces[12];
        uint32_t count = 0;
        const int sides = 3 + (int)(rng_next() % 6);
        double radius = rng_uniform(0.05, 0.2), lift = eps * rng_uniform(0, 1.5);
        vec3d centre = geom_vec3d(g.x, g.y, bumpy(g.x, g.y) + rng_uniform(-lift, lift));
        for (int s = 0; s < sides; ++s) {
            double a0 = 2 * M_PI * s / sides, a1 = 2 * M_PI * (s + 1) / sides;
            vec3d p0 = geom_vec3d(g.x + radius * cos(a0), g.y + radius * sin(a0), 0),
                  p1 = geom_vec3d(g.x + radius * cos(a1), g.y + radius * sin(a1), 0);
            p0.z = bumpy(p0.x, p0.y) + rng_uniform(-lift, lift);
            p1.z = bumpy(p1.x, p1.y) + rng_uniform(-lift, lift);
            faces[count] = make_face(centre, p0, p1, 0, 100 + (uint32_t)s);
            /* ids as in a level: the centre and the rim vertices are shared,
             * so the overlay's closing-up test can find neighbours */
            faces[count].vertex[0] = 5000;
            faces[count].vertex[1] = 5001 + (uint32_t)s;
            faces[count].vertex[2] = 5001 + (uint32_t)((s + 1) % sides);
            count++;
        }
        uint32_t used[CERT_MAX_WITNESSES], used_count = 99;
        double bound = -1;
        /* sometimes with "previous witnesses" to try first */
        uint32_t first[2] = {(uint32_t)(rng_next() % count), (uint32_t)(rng_next() % count)};
        uint32_t first_count = (uint32_t)(trial % 3);
        if (!cert_cover(&m.o, t, faces, count, eps, first, first_count, used, &used_count, &bound)) {
            rejected++;
            continue;
        }
        accepted++;
        CHECK(used_count >= 1 && used_count <= CERT_MAX_WITNESSES, "used %u", used_count);
        cert_tri chosen[CERT_MAX_WITNESSES];
        uint32_t n = 0;
        for (uint32_t i = 0; i < used_count && i < CERT_MAX_WITNESSES; ++i)
            for (uint32_t k = 0; k < count; ++k)
                if (faces[k].id == used[i]) chosen[n++] = faces[k];
        CHECK(n == used_count, "used ids name given faces");
        for (uint32_t i = 0; i < n; ++i)
            for (uint32_t j = 0; j < i; ++j) CHECK(chosen[i].id != chosen[j].id, "used ids distinct");
        double sampled = sampled_original_to_faces(&m, t, chosen, n, 24);
        CHECK(sampled <= bound + slack(1) && bound <= eps, "trial %d: t %u sampled %.17g <= bound %.17g <= eps %.17g",
              trial, t, sampled, bound, eps);
    }
    printf("#   cert_cover fuzz: %d accepted (each sampled), %d rejected\n", accepted, rejected);
    CHECK(accepted >= 40 && rejected >= 40, "not vacuous: %d accepted, %d rejected", accepted, rejected);
    om_free(&m);
}

/* ---- thin sheets: never certified through -------------------------------------- */

/* Two parallel unit squares 0.01 apart: the top one (z = 0.01) faces up, the
 * bottom one (z = 0) faces down. eps = 0.05 is five times the gap. */
static void build_thin_plate(orig_mesh *m)
{
    om_init(m, 8, 4);
    const double t = 0.01;
    om_vertex(m, 0, 0, t);
    om_vertex(m, 1, 0, t);
    om_vertex(m, 1, 1, t);
    om_vertex(m, 0, 1, t);
    om_vertex(m, 0, 0, 0);
    om_vertex(m, 1, 0, 0);
    om_vertex(m, 1, 1, 0);
    om_vertex(m, 0, 1, 0);
    om_tri(m, 0, 1, 2, 0); /* up */
    om_tri(m, 0, 2, 3, 0);
    om_tri(m, 4, 6, 5, 0); /* down */
    om_tri(m, 4, 7, 6, 0);
}

static void test_thin_plate_face(void)
{
    orig_mesh m;
    build_thin_plate(&m);
    if (!om_ready(&m)) return;
    const double eps = 0.05;
    double bound;
    /* an up-facing face 0.02 below the bottom sheet: 0.02 from the bottom
     * (wrong side), 0.03 from the top (right side): certified, bound >= 0.03 */
    cert_tri f = make_face(geom_vec3d(0.2, 0.2, -0.02), geom_vec3d(0.8, 0.2, -0.02), geom_vec3d(0.5, 0.8, -0.02), 0, 0);
    hint(&m, &f); /* the nearest vertices: the bottom sheet's, on purpose */
    int ok = cert_face(&m.o, &f, eps, &bound);
    CHECK(ok, "up face 0.03 below the top sheet is within eps of it");
    if (ok) CHECK(bound >= 0.03 - 1e-7 && bound <= eps, "bound %.17g measured against the top sheet only", bound);
    /* 0.045 below the bottom: 0.045 from the bottom sheet (wrong side), 0.055
     * from the top one: must be rejected */
    f = make_face(geom_vec3d(0.2, 0.2, -0.045), geom_vec3d(0.8, 0.2, -0.045), geom_vec3d(0.5, 0.8, -0.045), 0, 0);
    hint(&m, &f); /* the nearest vertices: the bottom sheet's, on purpose */
    CHECK(!cert_face(&m.o, &f, eps, &bound), "up face certified through the plate against the bottom sheet");
    /* the same face facing down is fine (0.045 from the bottom sheet) */
    f = make_face(geom_vec3d(0.2, 0.2, -0.045), geom_vec3d(0.5, 0.8, -0.045), geom_vec3d(0.8, 0.2, -0.045), 0, 0);
    hint(&m, &f); /* the nearest vertices: the bottom sheet's, on purpose */
    ok = cert_face(&m.o, &f, eps, &bound);
    CHECK(ok, "down face 0.045 below the bottom sheet");
    if (ok) CHECK(bound >= 0.045 - 1e-7 && bound <= eps, "bound %.17g", bound);
    /* a down face above the top sheet by 0.045: 0.055 from the bottom sheet */
    f = make_face(geom_vec3d(0.2, 0.2, 0.055), geom_vec3d(0.5, 0.8, 0.055), geom_vec3d(0.8, 0.2, 0.055), 0, 0);
    hint(&m, &f);
    CHECK(!cert_face(&m.o, &f, eps, &bound), "down face certified against the top sheet");
    om_free(&m);
}

static void test_thin_plate_cover(void)
{
    orig_mesh m;
    build_thin_plate(&m);
    if (!om_ready(&m)) return;
    const double eps = 0.05;
    uint32_t used[CERT_MAX_WITNESSES], n;
    double bound;
    /* level = only the bottom sheet (down faces): the top originals (up) must
     * not be covered by it although it is 0.01 away */
    cert_tri bottom[2] = {make_face(geom_vec3d(0, 0, 0), geom_vec3d(1, 1, 0), geom_vec3d(1, 0, 0), 0, 10),
                          make_face(geom_vec3d(0, 0, 0), geom_vec3d(0, 1, 0), geom_vec3d(1, 1, 0), 0, 11)};
    CHECK(!cert_cover(&m.o, 0, bottom, 2, eps, NULL, 0, used, &n, &bound), "top original covered by the bottom sheet");
    CHECK(!cert_cover(&m.o, 1, bottom, 2, eps, NULL, 0, used, &n, &bound), "top original covered by the bottom sheet");
    int ok = cert_cover(&m.o, 2, bottom, 2, eps, NULL, 0, used, &n, &bound);
    CHECK(ok, "bottom original covered by the bottom sheet");
    if (ok) CHECK(bound <= 1e-9 && n >= 1 && n <= 2, "bound %g n %u", bound, n);
    /* faces of the top orientation lying on the bottom sheet do cover the top */
    cert_tri top_low[2] = {make_face(geom_vec3d(0, 0, 0), geom_vec3d(1, 0, 0), geom_vec3d(1, 1, 0), 0, 20),
                           make_face(geom_vec3d(0, 0, 0), geom_vec3d(1, 1, 0), geom_vec3d(0, 1, 0), 0, 21)};
    ok = cert_cover(&m.o, 0, top_low, 2, eps, NULL, 0, used, &n, &bound);
    CHECK(ok, "top original covered by up faces 0.01 below");
    if (ok) CHECK(fabs(bound - 0.01) < 1e-6, "bound %.17g should be the gap", bound);
    om_free(&m);
}

/* cert_face's first test: a face whose corners are original vertices, at
 * their place, is within its enclosing ball's radius of them; only when a
 * witness (same material, normal the face's way) lies at every corner. */
static void test_corner_ball(void)
{
    /* a small down-facing square (0.1 wide) under an up-facing sheet 0.2 above */
    orig_mesh m;
    om_init(&m, 8, 4);
    om_vertex(&m, 0, 0, 0);
    om_vertex(&m, 0.1, 0, 0);
    om_vertex(&m, 0.1, 0.1, 0);
    om_vertex(&m, 0, 0.1, 0);
    om_vertex(&m, -1, -1, 0.2);
    om_vertex(&m, 1, -1, 0.2);
    om_vertex(&m, 1, 1, 0.2);
    om_vertex(&m, -1, 1, 0.2);
    om_tri(&m, 0, 2, 1, 0); /* down */
    om_tri(&m, 0, 3, 2, 0);
    om_tri(&m, 4, 5, 6, 0); /* up */
    om_tri(&m, 4, 6, 7, 0);
    if (!om_ready(&m)) return;
    double bound;
    /* an up face on corners 0, 1, 2: its ball's radius (0.0707) is within eps
     * (0.1), but every original at those corners faces down, and the nearest
     * up-facing original is 0.2 away: refused */
    cert_tri f = make_face(om_point(&m, 0), om_point(&m, 1), om_point(&m, 2), 0, 0);
    f.vertex[0] = 0, f.vertex[1] = 1, f.vertex[2] = 2;
    CHECK(!cert_face(&m.o, &f, 0.1, &bound), "up face on down corners certified with bound %.17g", bound);
    /* the same corners facing down vouch for the face: bound = the radius */
    f = make_face(om_point(&m, 0), om_point(&m, 2), om_point(&m, 1), 0, 0);
    f.vertex[0] = 0, f.vertex[1] = 2, f.vertex[2] = 1;
    vec3d c, p[3];
    double r;
    face_points(&f, p);
    geom_triangle_enclosing_ball(&p[0], &p[1], &p[2], &c, &r);
    int ok = cert_face(&m.o, &f, 0.1, &bound);
    CHECK(ok && bound == r, "down face on down corners: certified %d, bound %.17g, radius %.17g", ok, bound, r);
    if (ok) {
        const double sampled = sampled_face_to_original(&m, p, 24, 0, f.n);
        CHECK(sampled <= bound + slack(1.0), "sampled %.17g > bound %.17g", sampled, bound);
    }
    /* a radius beyond eps: the other tests decide (the face lies on the square) */
    ok = cert_face(&m.o, &f, 0.05, &bound);
    CHECK(ok && bound < 1e-6, "radius 0.0707 > eps 0.05: certified %d against the square itself, bound %.17g", ok, bound);
    /* a corner moved off its vertex (as placement moves one) is no point of the
     * original: the radius is not used */
    f = make_face(om_point(&m, 0), om_point(&m, 2), geom_vec3d(0.1, 1e-3, 0.0), 0, 0);
    f.vertex[0] = 0, f.vertex[1] = 2, f.vertex[2] = 1;
    face_points(&f, p);
    geom_triangle_enclosing_ball(&p[0], &p[1], &p[2], &c, &r);
    ok = cert_face(&m.o, &f, 0.1, &bound);
    CHECK(ok && bound < 1e-6, "moved corner: certified %d, bound %.17g (radius %.17g)", ok, bound, r);
    om_free(&m);
}

/* ---- materials, degenerate and odd input ---------------------------------------- */

static void test_material_and_degenerate(void)
{
    orig_mesh m;
    om_height_field(&m, 8);
    for (uint32_t t = 0; t < m.nt; ++t) m.mat[t] = (t % 16) < 8 ? 1 : 2; /* stripes */
    if (!om_ready(&m)) return;
    double bound;
    uint32_t used[CERT_MAX_WITNESSES], n;
    /* a face equal to original triangle 0 (material 1) */
    vec3d p[3];
    om_triangle(&m, 0, p);
    cert_tri same = make_face(p[0], p[1], p[2], 1, 0);
    hint(&m, &same);
    int ok = cert_face(&m.o, &same, 1e-6, &bound);
    CHECK(ok && bound <= 1e-12, "a face equal to an original is certified at bound ~0: %d %g", ok, bound);
    cert_tri other = make_face(p[0], p[1], p[2], 2, 0);
    hint(&m, &other);
    /* material 2 is elsewhere on the same surface: 1e-6 is far too small */
    CHECK(!cert_face(&m.o, &other, 1e-6, &bound), "certified against another material");
    ok = cert_cover(&m.o, 0, &same, 1, 1e-6, NULL, 0, used, &n, &bound);
    CHECK(ok && n == 1 && used[0] == 0 && bound <= 1e-12, "cover by its own copy: %d %u %g", ok, n, bound);
    CHECK(!cert_cover(&m.o, 0, &other, 1, 1e-6, NULL, 0, used, &n, &bound), "covered by a face of another material");
    CHECK(!cert_cover(&m.o, 0, &other, 1, 10.0, NULL, 0, used, &n, &bound), "another material never covers, whatever eps");

    /* degenerate faces: collinear, repeated corner */
    cert_tri line = make_face(geom_vec3d(0.1, 0.1, bumpy(0.1, 0.1)), geom_vec3d(0.2, 0.2, bumpy(0.2, 0.2)),
                              geom_vec3d(0.3, 0.3, bumpy(0.3, 0.3)), 1, 0);
    line.p[2][0] = 2 * line.p[1][0] - line.p[0][0];
    line.p[2][1] = 2 * line.p[1][1] - line.p[0][1];
    line.p[2][2] = 2 * line.p[1][2] - line.p[0][2];
    cert_face_normal(&line);
    CHECK(line.degenerate, "collinear face is degenerate");
    CHECK(!cert_face(&m.o, &line, 1.0, &bound), "a degenerate face is never certified");
    CHECK(!cert_cover(&m.o, 0, &line, 1, 10.0, NULL, 0, used, &n, &bound), "a degenerate face never covers");
    cert_tri point = make_face(p[0], p[0], p[1], 1, 0);
    CHECK(point.degenerate && !cert_face(&m.o, &point, 1.0, &bound), "repeated corner");

    /* NaN and infinity: rejected, no crash */
    cert_tri bad = same;
    bad.p[1][2] = NAN;
    cert_face_normal(&bad);
    CHECK(!cert_face(&m.o, &bad, 1.0, &bound), "NaN face rejected");
    CHECK(bad.degenerate, "a NaN corner makes the face degenerate");
    CHECK(!cert_cover(&m.o, 0, &bad, 1, 1.0, NULL, 0, used, &n, &bound), "NaN face never covers");
    bad = same;
    bad.p[0][0] = INFINITY;
    cert_face_normal(&bad);
    CHECK(!cert_face(&m.o, &bad, 1.0, &bound), "infinite face rejected");
    /* NaN eps */
    CHECK(!cert_face(&m.o, &same, NAN, &bound), "NaN eps rejects");
    CHECK(!cert_cover(&m.o, 0, &same, 1, NAN, NULL, 0, used, &n, &bound), "NaN eps rejects (cover)");
    om_free(&m);
}

/* Far from the origin: a whole height field at (1e5, 1e5, 1e5) and a face
 * floating 0.01 above it: the bound must still hold against the measure. */
static void test_translated_far(void)
{
    orig_mesh m;
    om_height_field(&m, 12);
    for (uint32_t i = 0; i < 3 * m.nv; ++i) m.pos[i] = (float)((double)m.pos[i] * 64.0 + 1e5);
    if (!om_ready(&m)) return;
    int accepted = 0;
    for (int trial = 0; trial < 60; ++trial) {
        cert_tri f = random_face(rng_uniform(0.02, 0.2), 0.002, 0);
        for (int k = 0; k < 3; ++k)
            for (int a = 0; a < 3; ++a) f.p[k][a] = (double)(float)(f.p[k][a] * 64.0 + 1e5);
        cert_face_normal(&f);
        if (f.degenerate) continue;
        hint(&m, &f);
        const double eps = 64.0 * 0.01;
        double bound;
        if (!cert_face(&m.o, &f, eps, &bound)) continue;
        accepted++;
        vec3d p[3];
        face_points(&f, p);
        double sampled = sampled_face_to_original(&m, p, 16, 0, NULL);
        CHECK(sampled <= bound + slack(1e5) && bound <= eps, "trial %d: sampled %.17g <= bound %.17g <= %g", trial,
              sampled, bound, eps);
    }
    CHECK(accepted >= 20, "accepted %d", accepted);
    om_free(&m);
}

/* ---- the overlay partition test (DESIGN.md §4 (a)2, (b)2) ------------------------ */

/* A level "tent" of four faces over the plane z = 0: centre c (id 900) and
 * four rim corners (ids 901..904) far out, every corner at height h (so each
 * face is parallel to the plane and h above it). skip < 4 leaves that face
 * out; raise lifts the centre by that much more; flip winds every face the
 * other way. */
static uint32_t tent(cert_tri faces[4], vec3d c, double h, int skip, double raise, int flip, vec3d shift)
{
    const vec3d rim[4] = {geom_vec3d(c.x + 5, c.y, h), geom_vec3d(c.x, c.y + 5, h), geom_vec3d(c.x - 5, c.y, h),
                          geom_vec3d(c.x, c.y - 5, h)};
    const vec3d centre = geom_vec3d(c.x, c.y, h + raise);
    uint32_t n = 0;
    for (int s = 0; s < 4; ++s) {
        if (s == skip) continue;
        vec3d a = geom_add(centre, shift), b = geom_add(rim[s], shift), d = geom_add(rim[(s + 1) % 4], shift);
        uint32_t ia = 900, ib = 901 + (uint32_t)s, id = 901 + (uint32_t)((s + 1) % 4);
        faces[n] = flip ? make_face(a, d, b, 0, 40 + (uint32_t)s) : make_face(a, b, d, 0, 40 + (uint32_t)s);
        faces[n].vertex[0] = ia;
        faces[n].vertex[1] = flip ? id : ib;
        faces[n].vertex[2] = flip ? ib : id;
        n++;
    }
    return n;
}

/* (b) by overlay. One big original triangle in z = 0; the level is the tent
 * h = 0.4 eps above it, whose four fold lines cross the triangle. Every
 * point of t is 0.4 eps from the tent, but a piece straddling a fold line is
 * within eps of no SINGLE face unless it is smaller than ~eps, which
 * subdivision to CERT_MAX_DEPTH = 6 (pieces of 1/64 of a unit triangle,
 * eps = 1e-3) never reaches:
 * only the overlay (pieces cut along the projected fold lines) proves it.
 * Then the ways it must fail: a face missing (a real hole: sampled > eps),
 * the tent's top lifted beyond eps, the tent turned over; all of it also at
 * 1e5. */
static void overlay_cover_case(vec3d shift)
{
    orig_mesh m;
    om_init(&m, 3, 1);
    om_vertex(&m, shift.x, shift.y, shift.z);
    om_vertex(&m, 1 + shift.x, shift.y, shift.z);
    om_vertex(&m, shift.x, 1 + shift.y, shift.z);
    om_tri(&m, 0, 1, 2, 0);
    if (!om_ready(&m)) return;
    const double eps = 1e-3, h = 0.4 * eps;
    const vec3d c = geom_vec3d(0.3, 0.3, 0);
    /* shift the float-rounded original's corners back: the faces are built
     * in double around the same place */
    cert_tri faces[4];
    uint32_t used[CERT_MAX_WITNESSES], n = 0;
    double bound = -1;
    uint32_t count = tent(faces, c, h, -1, 0, 0, shift);
    int ok = cert_cover(&m.o, 0, faces, count, eps, NULL, 0, used, &n, &bound);
    CHECK(ok, "the tent covers t (only the overlay can prove it)");
    if (ok) {
        cert_tri chosen[CERT_MAX_WITNESSES];
        uint32_t k = 0;
        for (uint32_t i = 0; i < n; ++i)
            for (uint32_t j = 0; j < count; ++j)
                if (faces[j].id == used[i]) chosen[k++] = faces[j];
        double sampled = sampled_original_to_faces(&m, 0, chosen, k, 64);
        CHECK(k == n && n == 4, "all four faces reach into t and are registered: %u", n);
        CHECK(sampled <= bound + slack(geom_length(shift)) && bound <= eps && bound >= h - 1e-9,
              "sampled %.17g <= bound %.17g <= eps (h %g)", sampled, bound, h);
    }
    /* the verifier's re-run accepts it with the registered faces */
    cert_tri reg[CERT_MAX_WITNESSES];
    for (uint32_t i = 0; i < n && i < CERT_MAX_WITNESSES; ++i)
        for (uint32_t j = 0; j < count; ++j)
            if (faces[j].id == used[i]) reg[i] = faces[j];
    double vbound = -1;
    if (ok) CHECK(cert_cover_within(&m.o, 0, reg, n, bound, &vbound), "cert_cover_within accepts at the bound");

    for (int skip = 0; skip < 4; ++skip) {
        count = tent(faces, c, h, skip, 0, 0, shift);
        double sampled = sampled_original_to_faces(&m, 0, faces, count, 64);
        CHECK(sampled > eps, "a missing face leaves points of t farther than eps: %g", sampled);
        CHECK(!cert_cover(&m.o, 0, faces, count, eps, NULL, 0, used, &n, &bound),
              "covered with face %d missing (sampled %g > eps)", skip, sampled);
    }
    count = tent(faces, c, h, -1, 2 * eps, 0, shift);
    CHECK(sampled_original_to_faces(&m, 0, faces, count, 64) > eps, "the lifted tent is farther than eps");
    CHECK(!cert_cover(&m.o, 0, faces, count, eps, NULL, 0, used, &n, &bound), "covered by a tent lifted beyond eps");
    count = tent(faces, c, h, -1, 0, 1, shift);
    CHECK(!cert_cover(&m.o, 0, faces, count, eps, NULL, 0, used, &n, &bound), "covered by back-facing faces");
    om_free(&m);
}

static void test_overlay_cover(void)
{
    overlay_cover_case(geom_vec3d(0, 0, 0));
    overlay_cover_case(geom_vec3d(1e5, -1e5, 1e5));
}

/* (a) by overlay. The original is a flat n x n grid of [0, 1]^2 in z = 0
 * (optionally with one triangle missing); the face F spans three grid
 * vertices and floats 0.4 eps above. Its pieces straddle many original edges,
 * so subdivision cannot prove it at eps = 1e-3; the flood-filled overlay can.
 * A hole under F, F overhanging the grid's border, F raised beyond eps, or
 * an original of another material under F must be refused. */
static void overlay_face_case(int hole, double raise, int overhang, int decal)
{
    orig_mesh m;
    const uint32_t n = 8;
    om_init(&m, (n + 1) * (n + 1), 2 * n * n);
    for (uint32_t j = 0; j <= n; ++j)
        for (uint32_t i = 0; i <= n; ++i) om_vertex(&m, (double)i / n, (double)j / n, 0);
    for (uint32_t j = 0; j < n; ++j)
        for (uint32_t i = 0; i < n; ++i) {
            uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
            if (hole && i == 3 && j == 2) {
                om_tri(&m, a, d, c, 0);
                continue;
            }
            if (decal && i == 1 && j == 1) { /* under F's first corner, of another material */
                om_tri(&m, a, b, d, 1);
                om_tri(&m, a, d, c, 0);
                continue;
            }
            om_tri(&m, a, b, d, 0);
            om_tri(&m, a, d, c, 0);
        }
    if (!om_ready(&m)) return;
    const double eps = 1e-3, h = 0.4 * eps;
    /* corners at grid vertices (1,1), (7,1), (4,7) */
    const uint32_t ids[3] = {1 * (n + 1) + 1, 1 * (n + 1) + 7, 7 * (n + 1) + 4};
    vec3d p[3];
    for (int k = 0; k < 3; ++k) {
        p[k] = om_point(&m, ids[k]);
        p[k].z = h + raise;
    }
    if (overhang) p[1].x = 1.3;
    cert_tri f = make_face(p[0], p[1], p[2], 0, 0);
    for (int k = 0; k < 3; ++k) f.vertex[k] = ids[k];
    double bound = -1;
    int ok = cert_face(&m.o, &f, eps, &bound);
    /* the measure of (a): distance to the originals that face F's way */
    double sampled = sampled_face_to_original(&m, p, 64, 0, f.n);
    /* the overlay alone (what the simplifier uses to tighten a level's
     * bound) decides the same, with the same bound here */
    double overlay_bound = -1;
    const int overlay_ok = cert_face_overlay(&m.o, &f, eps, &overlay_bound);
    if (!hole && raise == 0 && !overhang && !decal) {
        CHECK(ok, "F 0.4 eps above a grid is certified (only the overlay can prove it)");
        if (ok)
            CHECK(sampled <= bound + slack(1) && bound <= eps && bound >= h - 1e-9, "sampled %.17g <= bound %.17g <= eps",
                  sampled, bound);
        CHECK(overlay_ok && overlay_bound == bound, "the overlay alone: %d, bound %.17g (cert_face %.17g)", overlay_ok,
              overlay_bound, bound);
    } else {
        CHECK(sampled > eps, "the bad case really is farther than eps: %g", sampled);
        CHECK(!ok, "certified F with hole %d raise %g overhang %d decal %d (sampled %g > eps)", hole, raise, overhang,
              decal, sampled);
        CHECK(!overlay_ok, "the overlay alone certified F with hole %d raise %g overhang %d decal %d", hole, raise,
              overhang, decal);
    }
    om_free(&m);
}

static void test_overlay_face(void)
{
    overlay_face_case(0, 0, 0, 0);
    overlay_face_case(1, 0, 0, 0);
    overlay_face_case(0, 2e-3, 0, 0);
    overlay_face_case(0, 0, 1, 0);
    /* an original of another material around F's first corner: the flood
     * first meets it as an optional corner triangle and passes over it; when
     * an accepted neighbour's edge then needs it, the flood must fail */
    overlay_face_case(0, 0, 0, 1);
}

/* ---- clusters (b) whole: one face for a run of originals -------------------- */

/* The clusters partition the originals into runs of the BVH order of at most
 * CERT_CLUSTER_MAX; each ball holds its triangles' vertices; each cone holds
 * its triangles' real normals (checked with random face normals: whenever
 * the cone test passes, every real normal agrees). */
static void test_cluster_layout(void)
{
    orig_mesh m;
    if (!height_field_built(&m, 24)) return;
    const cert_original *o = &m.o;
    CHECK(o->cluster_count > 1 && o->cluster_count < m.nt, "%u clusters of %u triangles", o->cluster_count, m.nt);
    uint32_t next = 0, agreeing = 0;
    for (uint32_t c = 0; c < o->cluster_count; ++c) {
        const cert_cluster_info *ci = &o->clusters[c];
        CHECK(ci->first == next && ci->count >= 1 && ci->count <= CERT_CLUSTER_MAX, "cluster %u: run %u + %u", c,
              ci->first, ci->count);
        next = ci->first + ci->count;
        /* its vertex list: each corner of its triangles once, nothing else */
        const uint32_t *vl = o->cluster_vertices + o->cluster_vertex_start[c];
        const uint32_t vn = o->cluster_vertex_start[c + 1] - o->cluster_vertex_start[c];
        for (uint32_t i = 0; i < vn; ++i) {
            int corner = 0;
            for (uint32_t j = 0; j < ci->count && !corner; ++j)
                for (int k = 0; k < 3; ++k) corner |= m.tri[3 * (size_t)o->tree.triangle_order[ci->first + j] + k] == vl[i];
            CHECK(corner, "cluster %u lists vertex %u, no corner of its triangles", c, vl[i]);
            for (uint32_t j = 0; j < i; ++j) CHECK(vl[j] != vl[i], "cluster %u lists vertex %u twice", c, vl[i]);
        }
        for (uint32_t i = 0; i < ci->count; ++i) {
            uint32_t t = o->tree.triangle_order[ci->first + i];
            CHECK(o->cluster_of[t] == c, "triangle %u in cluster %u says %u", t, c, o->cluster_of[t]);
            for (int k = 0; k < 3; ++k) {
                int listed = 0;
                for (uint32_t j = 0; j < vn; ++j) listed |= vl[j] == m.tri[3 * (size_t)t + k];
                CHECK(listed, "cluster %u: a corner of triangle %u is not in its vertex list", c, t);
            }
            vec3d p[3];
            om_triangle(&m, t, p);
            for (int k = 0; k < 3; ++k)
                CHECK(geom_distance(p[k], geom_vec3d(ci->centre[0], ci->centre[1], ci->centre[2])) <= ci->radius,
                      "cluster %u: a vertex outside its ball", c);
        }
        for (int trial = 0; trial < 200; ++trial) {
            vec3d g = geom_vec3d(rng_uniform(-1, 1), rng_uniform(-1, 1), rng_uniform(-1, 1));
            if (geom_length(g) < 0.1) continue;
            g = geom_scale(g, 1.0 / geom_length(g));
            if (!(ci->axis[0] * g.x + ci->axis[1] * g.y + ci->axis[2] * g.z > ci->cone_sin)) continue;
            agreeing++;
            for (uint32_t i = 0; i < ci->count; ++i) {
                const double *n = o->normals + 3 * (size_t)o->tree.triangle_order[ci->first + i];
                CHECK(n[0] * g.x + n[1] * g.y + n[2] * g.z > 0.0, "cluster %u: a normal outside its cone", c);
            }
        }
    }
    CHECK(next == m.nt, "the runs cover the order: %u of %u", next, m.nt);
    CHECK(agreeing > 1000, "not vacuous: %u agreeing normals drawn", agreeing);
    om_free(&m);
}

/* Random faces near a height field against every cluster: what is accepted
 * holds each of the cluster's triangles within the bound (sampled), and
 * never by the face turned the other way. */
static void test_cluster_fuzz(void)
{
    orig_mesh m;
    if (!height_field_built(&m, 16)) return;
    int accepted = 0, rejected = 0;
    for (int trial = 0; trial < 300; ++trial) {
        uint32_t c = (uint32_t)(rng_next() % m.o.cluster_count);
        const cert_cluster_info *ci = &m.o.clusters[c];
        double eps = rng_uniform(0.01, 0.15), lift = eps * rng_uniform(0, 1.2), size = rng_uniform(0.1, 0.6);
        vec3d q[3];
        for (int k = 0; k < 3; ++k) {
            double a = 2 * M_PI * k / 3 + rng_uniform(-0.3, 0.3);
            q[k] = geom_vec3d(ci->centre[0] + size * cos(a), ci->centre[1] + size * sin(a), 0);
            q[k].z = bumpy(q[k].x, q[k].y) + rng_uniform(-lift, lift);
        }
        cert_tri faces[2] = {make_face(q[0], q[1], q[2], 0, 7), make_face(q[0], q[2], q[1], 0, 8)};
        uint32_t face = 99;
        double bound = -1;
        /* the same face both ways round: only the up-facing one may hold it */
        if (!cert_cluster(&m.o, c, faces, 2, eps, NULL, 0, &face, &bound)) {
            rejected++;
            continue;
        }
        accepted++;
        CHECK(face == 7, "trial %d: the down-facing copy was used", trial);
        CHECK(cert_cluster_within(&m.o, c, &faces[0], bound * (1 + 1e-12)), "the checker's re-run agrees");
        double worst = 0.0;
        for (uint32_t i = 0; i < ci->count; ++i) {
            double d = sampled_original_to_faces(&m, m.o.tree.triangle_order[ci->first + i], &faces[0], 1, 12);
            if (d > worst) worst = d;
        }
        CHECK(worst <= bound + slack(1) && bound <= eps, "trial %d: sampled %.17g <= bound %.17g <= eps %.17g", trial,
              worst, bound, eps);
    }
    printf("#   cert_cluster fuzz: %d accepted (each sampled), %d rejected\n", accepted, rejected);
    CHECK(accepted >= 40 && rejected >= 40, "not vacuous: %d accepted, %d rejected", accepted, rejected);
    om_free(&m);
}

/* A thin plate's two sheets in one cluster have no normal cone: no face
 * holds it whole (each sheet alone is the overlay's business); a cluster of
 * two materials neither. */
static void test_cluster_plate_and_materials(void)
{
    orig_mesh m;
    build_thin_plate(&m);
    if (!om_ready(&m)) return;
    CHECK(m.o.cluster_count == 1 && m.o.clusters[0].cone_sin > 1.0, "one cluster, no cone");
    uint32_t face;
    double bound;
    cert_tri up = make_face(geom_vec3d(-1, -1, 0.005), geom_vec3d(3, -1, 0.005), geom_vec3d(-1, 3, 0.005), 0, 1);
    cert_tri down = make_face(geom_vec3d(-1, -1, 0.005), geom_vec3d(-1, 3, 0.005), geom_vec3d(3, -1, 0.005), 0, 2);
    const cert_tri both[2] = {up, down};
    CHECK(!cert_cluster(&m.o, 0, both, 2, 0.05, NULL, 0, &face, &bound), "a plate certified whole by one face");
    om_free(&m);

    om_height_field(&m, 4);
    m.mat[5] = 3;
    if (!om_ready(&m)) return;
    uint32_t c = m.o.cluster_of[5];
    CHECK(m.o.clusters[c].material == CERT_MIXED, "a cluster of two materials is mixed");
    cert_tri big = make_face(geom_vec3d(-2, -2, 0), geom_vec3d(4, -2, 0), geom_vec3d(-2, 4, 0), 0, 1);
    CHECK(!cert_cluster(&m.o, c, &big, 1, 10.0, NULL, 0, &face, &bound), "a mixed cluster certified whole");
    om_free(&m);
}

int main(void)
{
    RUN(test_obtuse_centroid_ball);
    RUN(test_obtuse_translated_rotated);
    RUN(test_obtuse_family);
    RUN(test_face_fuzz);
    RUN(test_hub_fan_tree_search);
    RUN(test_cover_fuzz);
    RUN(test_thin_plate_face);
    RUN(test_thin_plate_cover);
    RUN(test_corner_ball);
    RUN(test_material_and_degenerate);
    RUN(test_translated_far);
    RUN(test_overlay_cover);
    RUN(test_overlay_face);
    RUN(test_cluster_layout);
    RUN(test_cluster_fuzz);
    RUN(test_cluster_plate_and_materials);
    return check_summary();
}
