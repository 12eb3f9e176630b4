/* test_simplify.c - the certified simplifier (simplify.h, DESIGN.md §4-§6) on
 * the adversarial cases of the design, each level checked against an
 * INDEPENDENT measure computed here: dense barycentric samples on every level
 * face, their exact distance to the original by brute force over the original
 * triangles (geom_point_triangle_distance2, accelerated only by a uniform grid
 * written here, not by the BVH), and the other way round. Sampling gives a
 * lower bound of the true two-sided Hausdorff distance, so it can only catch a
 * false certificate: sampled <= bound <= eps must hold at every level. The same
 * measure is also taken orientation-aware (a point of a face may only be
 * matched by triangles whose normal agrees, n . n' > 0, as the certificate
 * promises), which is what "a thin sheet is never certified through" means.
 *
 * Cases: a spike and a pit one grid cell wide and taller than eps (their tips
 * must survive); a V-groove narrower than eps but deeper (must not be bridged),
 * on a flat and on a curved base; a closed thin box thinner than eps (both
 * orientations kept, each sheet measured against its own originals, no face
 * pair intersecting: DESIGN.md §5 tests self-intersections where the original
 * is thin); a sawtooth border with teeth taller than eps (tips survive); a
 * decal of a second material (each material within the bound of its own
 * originals); the invariant checker switched on during real runs; a model and
 * the same model moved by 1e5 units; the same result for 1, 2 and 8 threads;
 * and the Euler characteristic, border loops and manifoldness of closed and
 * open meshes at every level. */
#include "check.h"
#include "geom.h"
#include "simplify.h"
#include "weld.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* ---- meshes built by hand ------------------------------------------------- */

typedef struct {
    float *pos;
    uint32_t *tri;
    uint8_t *mat;     /* per triangle: material 0 or 1 */
    uint8_t cur_mat;  /* material of the triangles added next */
    uint32_t nv, nt, cap_v, cap_t;
} mesh;

static void mesh_init(mesh *m)
{
    memset(m, 0, sizeof *m);
}

static void mesh_free(mesh *m)
{
    free(m->pos);
    free(m->tri);
    free(m->mat);
    memset(m, 0, sizeof *m);
}

static uint32_t mesh_vertex(mesh *m, double x, double y, double z)
{
    if (m->nv == m->cap_v) {
        m->cap_v = m->cap_v ? 2 * m->cap_v : 256;
        m->pos = realloc(m->pos, 3 * (size_t)m->cap_v * sizeof *m->pos);
        if (!m->pos) abort();
    }
    m->pos[3 * m->nv] = (float)x;
    m->pos[3 * m->nv + 1] = (float)y;
    m->pos[3 * m->nv + 2] = (float)z;
    return m->nv++;
}

static void mesh_tri(mesh *m, uint32_t a, uint32_t b, uint32_t c)
{
    if (m->nt == m->cap_t) {
        m->cap_t = m->cap_t ? 2 * m->cap_t : 256;
        m->tri = realloc(m->tri, 3 * (size_t)m->cap_t * sizeof *m->tri);
        m->mat = realloc(m->mat, m->cap_t);
        if (!m->tri || !m->mat) abort();
    }
    m->mat[m->nt] = m->cur_mat;
    m->tri[3 * m->nt] = a;
    m->tri[3 * m->nt + 1] = b;
    m->tri[3 * m->nt + 2] = c;
    m->nt++;
}

static void mesh_quad(mesh *m, uint32_t a, uint32_t b, uint32_t c, uint32_t d)
{
    mesh_tri(m, a, b, c);
    mesh_tri(m, a, c, d);
}

typedef double (*height_fn)(uint32_t i, uint32_t j, double x, double y, void *ctx);

/* A grid of nx x ny cells over [x0, x1] x [y0, y1], facing +z, vertex (i, j)
 * = first + j * (nx + 1) + i; the diagonals alternate (no preferred
 * direction). Returns the first vertex. */
static uint32_t mesh_grid(mesh *m, uint32_t nx, uint32_t ny, double x0, double x1, double y0, double y1,
                          height_fn h, void *ctx)
{
    uint32_t first = m->nv;
    for (uint32_t j = 0; j <= ny; ++j)
        for (uint32_t i = 0; i <= nx; ++i) {
            double x = x0 + (x1 - x0) * i / nx, y = y0 + (y1 - y0) * j / ny;
            mesh_vertex(m, x, y, h ? h(i, j, x, y, ctx) : 0.0);
        }
    for (uint32_t j = 0; j < ny; ++j)
        for (uint32_t i = 0; i < nx; ++i) {
            uint32_t a = first + j * (nx + 1) + i, b = a + 1, c = a + nx + 2, d = a + nx + 1;
            if ((i + j) % 2) {
                mesh_tri(m, a, b, c);
                mesh_tri(m, a, c, d);
            } else {
                mesh_tri(m, a, b, d);
                mesh_tri(m, b, c, d);
            }
        }
    return first;
}

/* ---- welding and simplifying ------------------------------------------------ */

typedef struct {
    scene_mesh sm;
    scene_primitive prim[2];
    scene_stream stream[2];
    uint32_t *indices[2];
    weld_result w;
    simplify_result r;
    int welded, simplified;
    double seconds;
} run;

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

/* simplify_options.full_edge_levels for the next run_simplify calls */
static uint32_t g_full_edge_levels;
/* simplify_options.hub_faces likewise (0: the default) */
static uint32_t g_hub_faces;
/* simplify_options.patient_faces likewise (0: the default) */
static uint32_t g_patient_faces;
/* simplify_options.region_vertices likewise: 0 leaves these small meshes
 * to the global passes; a small size sends them through region rounds */
static uint32_t g_region_vertices;

/* Welds m (one primitive, material 0, positions only) and simplifies it
 * through fractions[0..count-1]. Returns the simplify_mesh result code. */
static int run_simplify(run *rn, const mesh *m, const double *fractions, uint32_t count, uint32_t threads, int verify)
{
    memset(rn, 0, sizeof *rn);
    rn->sm.name = "test";
    rn->sm.primitives = rn->prim;
    rn->sm.triangle_count = m->nt;
    /* one primitive per material (0, then 1 if used), sharing the vertices */
    for (uint8_t mat = 0; mat < 2; ++mat) {
        uint32_t n = 0;
        rn->indices[mat] = malloc(3 * (size_t)m->nt * sizeof(uint32_t) + 1);
        if (!rn->indices[mat]) abort();
        for (uint32_t t = 0; t < m->nt; ++t)
            if (m->mat[t] == mat) memcpy(rn->indices[mat] + 3 * (size_t)n++, m->tri + 3 * (size_t)t, 3 * sizeof(uint32_t));
        if (!n) continue;
        uint32_t p = rn->sm.primitive_count++;
        scene_primitive *pr = &rn->prim[p];
        pr->index = p;
        pr->mode = 4;
        pr->material = mat;
        pr->indices = -1;
        pr->vertex_count = m->nv;
        pr->positions = m->pos;
        pr->stream_count = 1;
        pr->streams = &rn->stream[p];
        pr->triangle_count = n;
        pr->triangles = rn->indices[mat];
        rn->stream[p].name = "POSITION";
        rn->stream[p].components = 3;
        rn->stream[p].values = m->pos;
    }
    lp_error err;
    memset(&err, 0, sizeof err);
    int rc = weld_build(&rn->sm, 1, &rn->w, &err);
    CHECK(rc == LP_OK, "weld_build: %s", err.msg);
    if (rc != LP_OK) return rc;
    rn->welded = 1;
    CHECK(rn->w.triangle_count + rn->w.back_count == m->nt, "weld kept every triangle: %u (and %u backs) of %u",
          rn->w.triangle_count, rn->w.back_count, m->nt);
    simplify_options o;
    memset(&o, 0, sizeof o);
    o.fractions = fractions;
    o.level_count = count;
    o.threads = threads;
    o.flip_cos = 0.25;
    o.verify = verify;
    o.full_edge_levels = g_full_edge_levels;
    o.region_vertices = g_region_vertices;
    o.hub_faces = g_hub_faces;
    o.patient_faces = g_patient_faces;
    int64_t material[2] = {rn->prim[0].material, rn->prim[1].material};
    double t0 = now();
    rc = simplify_mesh(&rn->w, material, &o, &rn->r, &err);
    rn->seconds = now() - t0;
    CHECK(rc == LP_OK, "simplify_mesh: rc %d: %s", rc, err.msg);
    if (rc == LP_OK) rn->simplified = 1;
    uint64_t region_commits = 0;
    for (uint32_t k = 0; rc == LP_OK && k < rn->r.level_count; ++k) region_commits += rn->r.levels[k].stats.region_commits;
    printf("#   simplify_mesh: %u triangles, %u levels, %u threads, verify %d, full-edge levels 0x%x, regions of %u "
           "(%llu commits in them): %.2f s\n", m->nt, count, threads, verify, g_full_edge_levels, g_region_vertices,
           (unsigned long long)region_commits, rn->seconds);
    /* with small regions every mesh of these tests goes through them */
    if (rc == LP_OK && g_region_vertices && rn->w.vertex_count >= 8 * g_region_vertices)
        CHECK(rn->r.levels[0].stats.rounds > 0 && region_commits > 0,
              "%u vertices, regions of %u: %u rounds, %llu commits in them", rn->w.vertex_count, g_region_vertices,
              rn->r.levels[0].stats.rounds, (unsigned long long)region_commits);
    fflush(stdout);
    return rc;
}

static void run_free(run *rn)
{
    if (rn->simplified) simplify_result_free(&rn->r);
    if (rn->welded) weld_free(&rn->w);
    free(rn->indices[0]);
    free(rn->indices[1]);
    memset(rn, 0, sizeof *rn);
}

/* Position vertex of corner c of level face f. */
static uint32_t level_vertex(const run *rn, uint32_t k, uint32_t f, int c)
{
    return rn->w.wedge_vertex[rn->r.levels[k].wedges[3 * (size_t)f + (uint32_t)c]];
}

static vec3d weld_point(const weld_result *w, uint32_t v)
{
    return geom_vec3d_from_floats(w->positions + 3 * (size_t)v);
}

/* 1 when position vertex v is a corner of some face of level k. */
static int level_has_vertex(const run *rn, uint32_t k, uint32_t v)
{
    const simplify_level *L = &rn->r.levels[k];
    for (uint32_t i = 0; i < 3 * L->triangle_count; ++i)
        if (rn->w.wedge_vertex[L->wedges[i]] == v) return 1;
    return 0;
}

/* The weld vertex at exactly the float position of (x, y, z), or UINT32_MAX. */
static uint32_t find_vertex(const weld_result *w, double x, double y, double z)
{
    const float fx = (float)x, fy = (float)y, fz = (float)z;
    for (uint32_t v = 0; v < w->vertex_count; ++v)
        if (w->positions[3 * v] == fx && w->positions[3 * v + 1] == fy && w->positions[3 * v + 2] == fz) return v;
    return UINT32_MAX;
}

/* ---- the independent measure: a uniform grid over a triangle set ---------- */

typedef struct {
    size_t n;
    vec3d (*t)[3];
    vec3d *normal;   /* unit, or 0 when degenerate */
    double lo[3], cell;
    int dim[3];
    uint32_t *start, *items;
    uint32_t *stamp, cur;
} tset;

static int cell_index(const tset *s, int axis, double x)
{
    double f = floor((x - s->lo[axis]) / s->cell);
    if (!(f >= 0)) return 0;
    if (f >= s->dim[axis]) return s->dim[axis] - 1;
    return (int)f;
}

static void tset_build(tset *s, vec3d (*tris)[3], size_t n)
{
    memset(s, 0, sizeof *s);
    s->n = n;
    s->t = tris;
    s->normal = calloc(n + 1, sizeof *s->normal);
    s->stamp = calloc(n + 1, sizeof *s->stamp);
    if (!s->normal || !s->stamp) abort();
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n; ++i) {
        geom_triangle_unit_normal(&tris[i][0], &tris[i][1], &tris[i][2], &s->normal[i]);
        for (int k = 0; k < 3; ++k) {
            const double c[3] = {tris[i][k].x, tris[i][k].y, tris[i][k].z};
            for (int a = 0; a < 3; ++a) {
                if (c[a] < lo[a]) lo[a] = c[a];
                if (c[a] > hi[a]) hi[a] = c[a];
            }
        }
    }
    double ext = 0;
    for (int a = 0; a < 3; ++a)
        if (hi[a] - lo[a] > ext) ext = hi[a] - lo[a];
    if (!(ext > 0)) ext = 1;
    s->cell = ext / 48.0;
    size_t cells = 1;
    for (int a = 0; a < 3; ++a) {
        s->lo[a] = n ? lo[a] : 0;
        s->dim[a] = n ? 1 + (int)((hi[a] - lo[a]) / s->cell) : 1;
        cells *= (size_t)s->dim[a];
    }
    s->start = calloc(cells + 1, sizeof *s->start);
    if (!s->start) abort();
    for (int pass = 0; pass < 2; ++pass) {
        for (size_t i = 0; i < n; ++i) {
            int l[3], h[3];
            for (int a = 0; a < 3; ++a) {
                double mn = INFINITY, mx = -INFINITY;
                for (int k = 0; k < 3; ++k) {
                    const double c = a == 0 ? tris[i][k].x : a == 1 ? tris[i][k].y : tris[i][k].z;
                    if (c < mn) mn = c;
                    if (c > mx) mx = c;
                }
                l[a] = cell_index(s, a, mn);
                h[a] = cell_index(s, a, mx);
            }
            for (int z = l[2]; z <= h[2]; ++z)
                for (int y = l[1]; y <= h[1]; ++y)
                    for (int x = l[0]; x <= h[0]; ++x) {
                        size_t c = ((size_t)z * (size_t)s->dim[1] + (size_t)y) * (size_t)s->dim[0] + (size_t)x;
                        if (pass == 0) s->start[c + 1]++;
                        else s->items[s->start[c]++] = (uint32_t)i;
                    }
        }
        if (pass == 0) {
            for (size_t c = 0; c < cells; ++c) s->start[c + 1] += s->start[c];
            s->items = malloc(((size_t)s->start[cells] + 1) * sizeof *s->items);
            if (!s->items) abort();
        } else {
            for (size_t c = cells; c > 0; --c) s->start[c] = s->start[c - 1];
            s->start[0] = 0;
        }
    }
}

static void tset_free(tset *s)
{
    free(s->normal);
    free(s->stamp);
    free(s->start);
    free(s->items);
    memset(s, 0, sizeof *s);
}

/* Exact distance from p to the nearest triangle of s; with `facing` (a unit
 * normal, or NULL) only triangles whose normal agrees with it count (n . facing
 * > -1e-9, a little generous so that rounding can only lower the measure), and
 * degenerate ones always count. Returns INFINITY when nothing qualifies. */
static double tset_distance(tset *s, vec3d p, const vec3d *facing, uint32_t *which)
{
    if (++s->cur == 0) {
        memset(s->stamp, 0, (s->n + 1) * sizeof *s->stamp);
        s->cur = 1;
    }
    const int c0[3] = {cell_index(s, 0, p.x), cell_index(s, 1, p.y), cell_index(s, 2, p.z)};
    int maxr = 0;
    for (int a = 0; a < 3; ++a) {
        if (c0[a] > maxr) maxr = c0[a];
        if (s->dim[a] - 1 - c0[a] > maxr) maxr = s->dim[a] - 1 - c0[a];
    }
    double best2 = INFINITY;
    uint32_t best_t = UINT32_MAX;
    for (int r = 0; r <= maxr; ++r) {
        for (int z = c0[2] - r; z <= c0[2] + r; ++z) {
            if (z < 0 || z >= s->dim[2]) continue;
            for (int y = c0[1] - r; y <= c0[1] + r; ++y) {
                if (y < 0 || y >= s->dim[1]) continue;
                for (int x = c0[0] - r; x <= c0[0] + r; ++x) {
                    if (x < 0 || x >= s->dim[0]) continue;
                    if (abs(x - c0[0]) != r && abs(y - c0[1]) != r && abs(z - c0[2]) != r) continue;
                    size_t c = ((size_t)z * (size_t)s->dim[1] + (size_t)y) * (size_t)s->dim[0] + (size_t)x;
                    for (uint32_t i = s->start[c]; i < s->start[c + 1]; ++i) {
                        uint32_t t = s->items[i];
                        if (s->stamp[t] == s->cur) continue;
                        s->stamp[t] = s->cur;
                        if (facing) {
                            const vec3d n = s->normal[t];
                            int degenerate = n.x == 0 && n.y == 0 && n.z == 0;
                            if (!degenerate && !(geom_dot(n, *facing) > -1e-9)) continue;
                        }
                        double d2 = geom_point_triangle_distance2(&p, &s->t[t][0], &s->t[t][1], &s->t[t][2], NULL);
                        if (d2 < best2) {
                            best2 = d2;
                            best_t = t;
                        }
                    }
                }
            }
        }
        /* every triangle not seen yet is at least r cells away */
        const double reach = r * s->cell;
        if (best2 <= reach * reach) break;
    }
    if (which) *which = best_t;
    return sqrt(best2);
}

/* Largest distance from the samples of triangles a[0..na-1] to the set b.
 * Samples: barycentric grid of each triangle with its longest edge cut into
 * pieces no longer than `spacing` (at most max_div), corners and edges
 * included. With `oriented`, each sample only sees triangles of b agreeing
 * with its own triangle's normal. */
typedef struct {
    double worst;
    size_t triangle; /* where (index into a) */
    vec3d point;
} measure;

static measure sample_max(vec3d (*a)[3], size_t na, tset *b, double spacing, int max_div, int oriented)
{
    measure m = {0.0, SIZE_MAX, {0, 0, 0}};
    for (size_t i = 0; i < na; ++i) {
        const vec3d *p = a[i];
        double longest = fmax(geom_distance(p[0], p[1]), fmax(geom_distance(p[1], p[2]), geom_distance(p[2], p[0])));
        int n = (int)ceil(longest / spacing);
        if (n < 1) n = 1;
        if (n > max_div) n = max_div;
        vec3d normal;
        int has_normal = geom_triangle_unit_normal(&p[0], &p[1], &p[2], &normal);
        for (int u = 0; u <= n; ++u)
            for (int v = 0; u + v <= n; ++v) {
                double bu = (double)u / n, bv = (double)v / n, bw = 1.0 - bu - bv;
                vec3d q = geom_vec3d(bw * p[0].x + bu * p[1].x + bv * p[2].x, bw * p[0].y + bu * p[1].y + bv * p[2].y,
                                     bw * p[0].z + bu * p[1].z + bv * p[2].z);
                double d = tset_distance(b, q, oriented && has_normal ? &normal : NULL, NULL);
                if (!(d <= m.worst)) {
                    m.worst = d;
                    m.triangle = i;
                    m.point = q;
                }
            }
    }
    return m;
}

/* Triangles of the original (welded) and of level k, as coordinates. */
/* The original's triangles: the weld's, then their backs (weld.h). */
static uint32_t original_count(const run *rn)
{
    return rn->w.triangle_count + rn->w.back_count;
}

static uint32_t original_primitive(const run *rn, uint32_t f)
{
    return f < rn->w.triangle_count ? rn->w.triangle_primitive[f] : rn->w.back_primitive[f - rn->w.triangle_count];
}

static vec3d (*original_tris(const run *rn))[3]
{
    vec3d (*t)[3] = malloc(((size_t)original_count(rn) + 1) * sizeof *t);
    if (!t) abort();
    for (uint32_t f = 0; f < rn->w.triangle_count; ++f)
        for (int c = 0; c < 3; ++c) t[f][c] = weld_point(&rn->w, rn->w.triangle_vertices[3 * f + (uint32_t)c]);
    for (uint32_t b = 0; b < rn->w.back_count; ++b)
        for (int c = 0; c < 3; ++c)
            t[rn->w.triangle_count + b][c] = weld_point(&rn->w, rn->w.wedge_vertex[rn->w.back_wedges[3 * b + (uint32_t)c]]);
    return t;
}

/* Where level k has position vertex v: its own positions when it placed
 * vertices (full-edge placement), else the weld's. */
static vec3d level_point(const run *rn, uint32_t k, uint32_t v)
{
    const float *p = rn->r.levels[k].positions;
    return p ? geom_vec3d_from_floats(p + 3 * (size_t)v) : weld_point(&rn->w, v);
}

static vec3d (*level_tris(const run *rn, uint32_t k))[3]
{
    const simplify_level *L = &rn->r.levels[k];
    vec3d (*t)[3] = malloc(((size_t)L->triangle_count + 1) * sizeof *t);
    if (!t) abort();
    for (uint32_t f = 0; f < L->triangle_count; ++f)
        for (int c = 0; c < 3; ++c) t[f][c] = level_point(rn, k, level_vertex(rn, k, f, c));
    return t;
}

/* ---- self-intersections ------------------------------------------------------- */

static double orient3(vec3d a, vec3d b, vec3d c, vec3d d)
{
    return geom_dot(geom_cross(geom_sub(b, a), geom_sub(c, a)), geom_sub(d, a));
}

/* Does segment pq cross the (non-degenerate) triangle abc, p and q strictly on
 * opposite sides of its plane? */
static int segment_crosses(vec3d p, vec3d q, const vec3d t[3])
{
    double dp = orient3(t[0], t[1], t[2], p), dq = orient3(t[0], t[1], t[2], q);
    if (!((dp > 0 && dq < 0) || (dp < 0 && dq > 0))) return 0;
    vec3d x = geom_lerp(p, q, dp / (dp - dq));
    vec3d n = geom_triangle_normal(&t[0], &t[1], &t[2]);
    for (int k = 0; k < 3; ++k) {
        vec3d e = geom_sub(t[(k + 1) % 3], t[k]);
        if (geom_dot(n, geom_cross(e, geom_sub(x, t[k]))) < 0) return 0;
    }
    return 1;
}

/* 2-D test for coplanar triangles: an edge pair properly crossing, or a
 * vertex strictly inside the other. */
static int coplanar_overlap(const vec3d a[3], const vec3d b[3], vec3d n)
{
    int drop = fabs(n.x) > fabs(n.y) ? (fabs(n.x) > fabs(n.z) ? 0 : 2) : (fabs(n.y) > fabs(n.z) ? 1 : 2);
    double pa[3][2], pb[3][2];
    for (int k = 0; k < 3; ++k) {
        const double ca[3] = {a[k].x, a[k].y, a[k].z}, cb[3] = {b[k].x, b[k].y, b[k].z};
        pa[k][0] = ca[(drop + 1) % 3];
        pa[k][1] = ca[(drop + 2) % 3];
        pb[k][0] = cb[(drop + 1) % 3];
        pb[k][1] = cb[(drop + 2) % 3];
    }
#define O2(p, q, r) (((q)[0] - (p)[0]) * ((r)[1] - (p)[1]) - ((q)[1] - (p)[1]) * ((r)[0] - (p)[0]))
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            const double *p = pa[i], *q = pa[(i + 1) % 3], *r = pb[j], *s = pb[(j + 1) % 3];
            double d1 = O2(p, q, r), d2 = O2(p, q, s), d3 = O2(r, s, p), d4 = O2(r, s, q);
            if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) return 1;
        }
    for (int pass = 0; pass < 2; ++pass) {
        double (*x)[2] = pass ? pb : pa, (*y)[2] = pass ? pa : pb;
        double area = O2(y[0], y[1], y[2]);
        for (int i = 0; i < 3; ++i) {
            double s0 = O2(y[0], y[1], x[i]), s1 = O2(y[1], y[2], x[i]), s2 = O2(y[2], y[0], x[i]);
            if (area > 0 ? (s0 > 0 && s1 > 0 && s2 > 0) : (s0 < 0 && s1 < 0 && s2 < 0)) return 1;
        }
    }
#undef O2
    return 0;
}

/* Pairs of faces of level k that intersect other than along what they share:
 * each triangle is first shrunk towards its centroid by 1e-6 of its size, so
 * faces that only touch at a shared vertex or edge come apart, while faces
 * that cross (or fold onto each other) still meet. O(F^2): small levels only. */
static uint32_t count_intersections(vec3d (*t)[3], uint32_t n, uint32_t example[2])
{
    for (uint32_t f = 0; f < n; ++f) {
        vec3d g = geom_scale(geom_add(geom_add(t[f][0], t[f][1]), t[f][2]), 1.0 / 3.0);
        for (int c = 0; c < 3; ++c) t[f][c] = geom_lerp(g, t[f][c], 1.0 - 1e-6);
    }
    uint32_t count = 0;
    example[0] = example[1] = UINT32_MAX;
    for (uint32_t a = 0; a < n; ++a)
        for (uint32_t b = a + 1; b < n; ++b) {
            const vec3d *x = t[a], *y = t[b];
            int hit = 0;
            for (int e = 0; e < 3 && !hit; ++e)
                hit = segment_crosses(x[e], x[(e + 1) % 3], y) || segment_crosses(y[e], y[(e + 1) % 3], x);
            if (!hit) {
                vec3d n = geom_triangle_normal(&x[0], &x[1], &x[2]);
                double len = geom_length(n), scale = 0;
                for (int c = 0; c < 3; ++c) scale = fmax(scale, geom_distance(x[c], x[(c + 1) % 3]));
                int coplanar = 1;
                for (int c = 0; c < 3; ++c)
                    coplanar &= fabs(orient3(x[0], x[1], x[2], y[c])) <= 1e-12 * len * scale;
                if (coplanar) hit = coplanar_overlap(x, y, n);
            }
            if (hit) {
                if (!count) {
                    example[0] = a;
                    example[1] = b;
                }
                count++;
            }
        }
    return count;
}

static uint32_t self_intersections(const run *rn, uint32_t k, uint32_t example[2])
{
    vec3d(*t)[3] = level_tris(rn, k);
    uint32_t count = count_intersections(t, rn->r.levels[k].triangle_count, example);
    free(t);
    return count;
}

/* The detector itself, on hand-made pairs. */
static void check_intersection_detector(void)
{
    uint32_t ex[2];
    const vec3d P = geom_vec3d(0, 0, 0), X = geom_vec3d(1, 0, 0), Y = geom_vec3d(0, 1, 0), Z = geom_vec3d(0, 0, 1);
    vec3d t[2][3] = {{P, X, Y}, {geom_vec3d(0.2, 0.2, -1), geom_vec3d(0.3, 0.2, 1), geom_vec3d(0.2, 0.3, 1)}};
    CHECK(count_intersections(t, 2, ex) == 1, "crossing pair");
    vec3d u[2][3] = {{P, X, Y}, {P, Z, geom_vec3d(-1, -1, 0)}};
    CHECK(count_intersections(u, 2, ex) == 0, "pair touching at a vertex");
    vec3d v[2][3] = {{P, X, Y}, {X, P, geom_vec3d(0.5, -1, 0.2)}};
    CHECK(count_intersections(v, 2, ex) == 0, "pair sharing an edge");
    vec3d w[2][3] = {{P, X, Y}, {X, P, geom_vec3d(0.3, 0.4, 0)}};
    CHECK(count_intersections(w, 2, ex) == 1, "pair folded onto each other");
    vec3d x[2][3] = {{P, X, Y}, {P, geom_vec3d(1, 1, 0.01), geom_vec3d(0.2, 1, -0.01)}};
    CHECK(count_intersections(x, 2, ex) == 1, "pair sharing a vertex, overlapping beyond it");
}

/* Slack for comparing a sampled distance with the certified bound: sample
 * points are rounded barycentric combinations, a few ulps of the coordinates
 * off their face. */
static double slack_of(const run *rn)
{
    double m = 0;
    for (uint32_t i = 0; i < 3 * rn->w.vertex_count; ++i)
        if (fabs(rn->w.positions[i]) > m) m = fabs(rn->w.positions[i]);
    return 1e-12 * (m > 1 ? m : 1) + 1e-12 * rn->r.diagonal;
}

typedef struct {
    double level_to_original, original_to_level;
} two_sided;

/* The independent two-sided check of every level: sampled <= bound <= eps,
 * plain and orientation-aware. Returns the plain measures of the last level
 * checked (for the caller's own assertions). */
static two_sided check_levels(const char *name, const run *rn, int max_div)
{
    two_sided last = {0, 0};
    vec3d(*orig)[3] = original_tris(rn);
    tset so;
    tset_build(&so, orig, original_count(rn));
    const double slack = slack_of(rn);
    for (uint32_t k = 0; k < rn->r.level_count; ++k) {
        const simplify_level *L = &rn->r.levels[k];
        CHECK(L->bound <= L->eps && L->bound >= 0, "%s level %u: bound %.17g <= eps %.17g", name, k, L->bound, L->eps);
        vec3d(*lev)[3] = level_tris(rn, k);
        tset sl;
        tset_build(&sl, lev, L->triangle_count);
        const double spacing = L->eps / 3.0;
        for (int oriented = 0; oriented <= 1; ++oriented) {
            measure a = sample_max(lev, L->triangle_count, &so, spacing, max_div, oriented);
            measure b = sample_max(orig, original_count(rn), &sl, spacing, max_div, oriented);
            CHECK(a.worst <= L->bound + slack,
                  "%s level %u%s: level -> original sampled %.17g > certified bound %.17g (eps %g) at level face %zu, "
                  "point (%.9g, %.9g, %.9g)",
                  name, k, oriented ? " (oriented)" : "", a.worst, L->bound, L->eps, a.triangle, a.point.x, a.point.y,
                  a.point.z);
            CHECK(b.worst <= L->bound + slack,
                  "%s level %u%s: original -> level sampled %.17g > certified bound %.17g (eps %g) at original "
                  "triangle %zu, point (%.9g, %.9g, %.9g)",
                  name, k, oriented ? " (oriented)" : "", b.worst, L->bound, L->eps, b.triangle, b.point.x, b.point.y,
                  b.point.z);
            if (!oriented) {
                last.level_to_original = a.worst;
                last.original_to_level = b.worst;
            }
        }
        /* per material: faces are certified only against originals of
         * their own material, and each original only by faces of its own */
        for (uint32_t prim = 0; rn->sm.primitive_count > 1 && prim < rn->sm.primitive_count; ++prim) {
            size_t no = 0, nl = 0;
            vec3d(*om)[3] = malloc(((size_t)original_count(rn) + 1) * sizeof *om);
            vec3d(*lm)[3] = malloc(((size_t)L->triangle_count + 1) * sizeof *lm);
            if (!om || !lm) abort();
            for (uint32_t f = 0; f < original_count(rn); ++f)
                if (original_primitive(rn, f) == prim) memcpy(om[no++], orig[f], sizeof orig[f]);
            for (uint32_t f = 0; f < L->triangle_count; ++f)
                if (L->primitive[f] == prim) memcpy(lm[nl++], lev[f], sizeof lev[f]);
            tset a_set, b_set;
            tset_build(&a_set, om, no);
            tset_build(&b_set, lm, nl);
            measure a = sample_max(lm, nl, &a_set, spacing, max_div, 1);
            measure b = sample_max(om, no, &b_set, spacing, max_div, 1);
            CHECK(nl > 0, "%s level %u: material of primitive %u vanished", name, k, prim);
            CHECK(a.worst <= L->bound + slack, "%s level %u primitive %u: its faces are %.17g from its originals > bound "
                  "%.17g, at (%.9g, %.9g, %.9g)", name, k, prim, a.worst, L->bound, a.point.x, a.point.y, a.point.z);
            CHECK(b.worst <= L->bound + slack, "%s level %u primitive %u: its originals are %.17g from its faces > bound "
                  "%.17g, at (%.9g, %.9g, %.9g)", name, k, prim, b.worst, L->bound, b.point.x, b.point.y, b.point.z);
            tset_free(&a_set);
            tset_free(&b_set);
            free(om);
            free(lm);
        }
        uint32_t ex[2];
        printf("#   %s level %u: eps %.4g, %u -> %u triangles, bound %.4g, sampled %.4g / %.4g, self-intersecting "
               "pairs %u, rejected by (b) %llu, by (a) %llu\n",
               name, k, L->eps, rn->w.triangle_count, L->triangle_count, L->bound, last.level_to_original,
               last.original_to_level, self_intersections(rn, k, ex),
               (unsigned long long)L->stats.rejected[SIMPLIFY_REJECT_COVER],
               (unsigned long long)L->stats.rejected[SIMPLIFY_REJECT_FACE]);
        tset_free(&sl);
        free(lev);
    }
    tset_free(&so);
    free(orig);
    return last;
}

/* Structure of every level: counts do not grow, the vertex sets and the
 * wedge sets nest (lodchain's vertex order relies on the wedges'), every face
 * has three distinct vertices and is not degenerate by index. */
static void check_structure(const char *name, const run *rn)
{
    const uint32_t nv = rn->w.vertex_count, nw = rn->w.wedge_count;
    uint8_t *prev = malloc(nv + 1), *cur = malloc(nv + 1), *prev_wedge = malloc(nw + 1), *cur_wedge = malloc(nw + 1);
    if (!prev || !cur || !prev_wedge || !cur_wedge) abort();
    memset(prev, 1, nv);
    memset(prev_wedge, 1, nw);
    uint32_t prev_count = rn->w.triangle_count;
    for (uint32_t k = 0; k < rn->r.level_count; ++k) {
        const simplify_level *L = &rn->r.levels[k];
        CHECK(L->triangle_count <= prev_count, "%s level %u: %u triangles after %u", name, k, L->triangle_count,
              prev_count);
        prev_count = L->triangle_count;
        memset(cur, 0, nv);
        memset(cur_wedge, 0, nw);
        int ok_face = 1, ok_wedge = 1;
        for (uint32_t f = 0; f < L->triangle_count; ++f) {
            uint32_t v[3];
            for (int c = 0; c < 3; ++c) {
                uint32_t wd = L->wedges[3 * f + (uint32_t)c];
                if (wd >= rn->w.wedge_count) {
                    ok_wedge = 0;
                    v[c] = 0;
                    continue;
                }
                v[c] = rn->w.wedge_vertex[wd];
                cur[v[c]] = 1;
                cur_wedge[wd] = 1;
            }
            if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) ok_face = 0;
        }
        CHECK(ok_wedge, "%s level %u: wedge out of range", name, k);
        CHECK(ok_face, "%s level %u: a face with a repeated vertex", name, k);
        int nested = 1, wedges_nested = 1;
        for (uint32_t v = 0; v < nv; ++v)
            if (cur[v] && !prev[v]) nested = 0;
        for (uint32_t x = 0; x < nw; ++x)
            if (cur_wedge[x] && !prev_wedge[x]) wedges_nested = 0;
        CHECK(nested, "%s level %u: a vertex came back", name, k);
        CHECK(wedges_nested, "%s level %u: a wedge came back", name, k);
        memcpy(prev, cur, nv);
        memcpy(prev_wedge, cur_wedge, nw);
    }
    free(prev);
    free(cur);
    free(prev_wedge);
    free(cur_wedge);
}

/* Topology of a level from its faces: V, E, F, border edges, border loops,
 * and whether it is an (oriented) 2-manifold: every edge used once (border)
 * or twice in opposite directions, every vertex's faces one fan. */
typedef struct {
    long v, e, f, border_edges, border_loops;
    int manifold;
} topo;

typedef struct {
    uint32_t a, b; /* directed a -> b */
    uint32_t face;
} dedge;

static int cmp_dedge(const void *x, const void *y)
{
    const dedge *p = x, *q = y;
    uint32_t pa = p->a < p->b ? p->a : p->b, pb = p->a < p->b ? p->b : p->a;
    uint32_t qa = q->a < q->b ? q->a : q->b, qb = q->a < q->b ? q->b : q->a;
    if (pa != qa) return pa < qa ? -1 : 1;
    if (pb != qb) return pb < qb ? -1 : 1;
    return p->a < q->a ? -1 : p->a > q->a;
}

static topo level_topology(const run *rn, uint32_t k)
{
    topo t = {0, 0, 0, 0, 0, 1};
    const simplify_level *L = &rn->r.levels[k];
    const uint32_t nv = rn->w.vertex_count, nf = L->triangle_count;
    t.f = nf;
    uint8_t *used = calloc(nv + 1, 1);
    dedge *e = malloc((3 * (size_t)nf + 1) * sizeof *e);
    if (!used || !e) abort();
    for (uint32_t f = 0; f < nf; ++f)
        for (int c = 0; c < 3; ++c) {
            e[3 * f + (uint32_t)c].a = level_vertex(rn, k, f, c);
            e[3 * f + (uint32_t)c].b = level_vertex(rn, k, f, (c + 1) % 3);
            e[3 * f + (uint32_t)c].face = f;
            used[level_vertex(rn, k, f, c)] = 1;
        }
    for (uint32_t v = 0; v < nv; ++v) t.v += used[v];
    qsort(e, 3 * (size_t)nf, sizeof *e, cmp_dedge);
    /* border edges: for loops, each border vertex must have exactly one
     * outgoing and one incoming border edge */
    uint32_t *border_next = malloc((nv + 1) * sizeof *border_next);
    uint32_t *border_out = calloc(nv + 1, sizeof *border_out);
    if (!border_next || !border_out) abort();
    for (size_t i = 0; i < 3 * (size_t)nf;) {
        /* group by undirected edge */
        size_t j = i + 1;
        uint32_t ua = e[i].a < e[i].b ? e[i].a : e[i].b, ub = e[i].a < e[i].b ? e[i].b : e[i].a;
        while (j < 3 * (size_t)nf) {
            uint32_t va = e[j].a < e[j].b ? e[j].a : e[j].b, vb = e[j].a < e[j].b ? e[j].b : e[j].a;
            if (va != ua || vb != ub) break;
            j++;
        }
        t.e++;
        if (j - i == 1) {
            t.border_edges++;
            /* the border runs opposite to the face's edge: b -> a */
            border_out[e[i].b]++;
            border_next[e[i].b] = e[i].a;
        } else if (j - i == 2) {
            if (e[i].a == e[i + 1].a) t.manifold = 0; /* same direction twice */
        } else {
            t.manifold = 0;
        }
        i = j;
    }
    /* border loops; a vertex with two outgoing border edges is not manifold */
    uint8_t *seen = calloc(nv + 1, 1);
    if (!seen) abort();
    for (uint32_t v = 0; v < nv; ++v) {
        if (border_out[v] > 1) t.manifold = 0;
        if (border_out[v] != 1 || seen[v]) continue;
        t.border_loops++;
        uint32_t x = v;
        size_t steps = 0;
        while (!seen[x] && steps++ <= nv) {
            seen[x] = 1;
            if (border_out[x] != 1) {
                t.manifold = 0;
                break;
            }
            x = border_next[x];
        }
    }
    /* one fan per vertex: the faces around v, linked across manifold edges,
     * must form one connected group */
    if (t.manifold) {
        uint32_t *count = calloc(nv + 1, sizeof *count);
        if (!count) abort();
        for (uint32_t f = 0; f < nf; ++f)
            for (int c = 0; c < 3; ++c) count[level_vertex(rn, k, f, c)]++;
        /* edges at v: (number of faces) - (number of interior edges at v) =
         * number of fans (open fans) or 0 for one closed fan */
        long *interior = calloc(nv + 1, sizeof *interior);
        if (!interior) abort();
        for (size_t i = 0; i + 1 < 3 * (size_t)nf; ++i) {
            uint32_t ua = e[i].a < e[i].b ? e[i].a : e[i].b, ub = e[i].a < e[i].b ? e[i].b : e[i].a;
            uint32_t va = e[i + 1].a < e[i + 1].b ? e[i + 1].a : e[i + 1].b,
                     vb = e[i + 1].a < e[i + 1].b ? e[i + 1].b : e[i + 1].a;
            if (ua == va && ub == vb) {
                interior[ua]++;
                interior[ub]++;
            }
        }
        for (uint32_t v = 0; v < nv; ++v) {
            if (!used[v]) continue;
            long fans_open = (long)count[v] - interior[v]; /* a closed fan: faces == interior edges */
            if (!(fans_open == 0 || fans_open == 1)) t.manifold = 0;
            if ((fans_open == 1) != (border_out[v] == 1)) t.manifold = 0;
        }
        free(count);
        free(interior);
    }
    free(seen);
    free(border_next);
    free(border_out);
    free(used);
    free(e);
    return t;
}

static void check_topology(const char *name, const run *rn, long euler, long loops)
{
    for (uint32_t k = 0; k < rn->r.level_count; ++k) {
        topo t = level_topology(rn, k);
        CHECK(t.v - t.e + t.f == euler, "%s level %u: Euler characteristic %ld (V %ld E %ld F %ld), expected %ld", name,
              k, t.v - t.e + t.f, t.v, t.e, t.f, euler);
        CHECK(t.border_loops == loops, "%s level %u: %ld border loops, expected %ld", name, k, t.border_loops, loops);
        CHECK(t.manifold, "%s level %u: not an oriented 2-manifold", name, k);
    }
}

/* ---- spike and pit ---------------------------------------------------------- */

typedef struct {
    uint32_t si, sj, pi, pj;
    double h;
} spike_ctx;

static double spike_height(uint32_t i, uint32_t j, double x, double y, void *ctx)
{
    const spike_ctx *s = ctx;
    (void)x;
    (void)y;
    if (i == s->si && j == s->sj) return s->h;
    if (i == s->pi && j == s->pj) return -s->h;
    return 0.0;
}

/* A flat 40 x 40 grid over [0, 1]^2 with one vertex raised by h = 0.15 and one
 * lowered by h, each one cell (0.025) wide. Any level without the tip vertex
 * lies in z <= 0 (all other vertices do), so the tip would be >= h from it:
 * for every eps < h the tip and the pit bottom must survive, even where the
 * spike is narrower than eps (levels 2, 3: eps 0.029, 0.072 > 0.025). */
static void test_spike_and_pit(void)
{
    mesh m;
    mesh_init(&m);
    spike_ctx s = {10, 10, 29, 27, 0.15};
    mesh_grid(&m, 40, 40, 0, 1, 0, 1, spike_height, &s);
    const double fractions[5] = {0.005, 0.01, 0.02, 0.05, 0.12};
    run rn;
    if (run_simplify(&rn, &m, fractions, 5, 0, 0) == LP_OK) {
        uint32_t tip = find_vertex(&rn.w, 0.25, 0.25, 0.15), pit = find_vertex(&rn.w, 29 / 40.0, 27 / 40.0, -0.15);
        CHECK(tip != UINT32_MAX && pit != UINT32_MAX, "tip and pit found");
        for (uint32_t k = 0; k < 5 && tip != UINT32_MAX && pit != UINT32_MAX; ++k) {
            const simplify_level *L = &rn.r.levels[k];
            if (L->eps < s.h) {
                CHECK(level_has_vertex(&rn, k, tip), "level %u (eps %g < spike %g): the spike tip is gone", k, L->eps,
                      s.h);
                CHECK(level_has_vertex(&rn, k, pit), "level %u (eps %g < pit %g): the pit bottom is gone", k, L->eps,
                      s.h);
            }
        }
        CHECK(rn.r.levels[0].triangle_count < rn.w.triangle_count / 4, "the flat part simplifies: %u of %u",
              rn.r.levels[0].triangle_count, rn.w.triangle_count);
        check_structure("spike", &rn);
        check_levels("spike", &rn, 8);
        check_topology("spike", &rn, 1, 1);
    }
    run_free(&rn);
    mesh_free(&m);
}

/* ---- V-groove --------------------------------------------------------------- */

typedef struct {
    double d;   /* depth */
    int curved; /* 0: flat base; 1: a gently curved base, the groove following it */
} groove_ctx;

static double groove_base(double x, double y, int curved)
{
    return curved ? 0.04 * sin(3.0 * x + 2.0 * y) + 0.02 * cos(5.0 * y) : 0.0;
}

static double groove_height(uint32_t i, uint32_t j, double x, double y, void *ctx)
{
    const groove_ctx *g = ctx;
    (void)j;
    return groove_base(x, y, g->curved) - (i == 20 ? g->d : 0.0);
}

/* A flat 40 x 40 grid over [0, 1]^2 with a V-groove along x = 0.5: the middle
 * column of vertices lowered by d = 0.1, so the groove is two cells (0.05)
 * wide and d deep. A flat face bridging it stays within 0.025 of the walls -
 * direction (a) alone would accept it at eps 0.042 and 0.071 - but the groove
 * bottom would then be d away: direction (b) must refuse. */
static void groove_case(int curved)
{
    mesh m;
    mesh_init(&m);
    const double d = 0.1;
    groove_ctx g = {d, curved};
    const char *name = curved ? "curved groove" : "groove";
    mesh_grid(&m, 40, 40, 0, 1, 0, 1, groove_height, &g);
    const double fractions[4] = {0.01, 0.03, 0.05, 0.1};
    run rn;
    if (run_simplify(&rn, &m, fractions, 4, 0, 0) == LP_OK) {
        check_structure(name, &rn);
        check_levels(name, &rn, 8);
        check_topology(name, &rn, 1, 1);
        /* explicitly: the groove bottom line, densely, against every level
         * whose eps is below the depth */
        for (uint32_t k = 0; k < rn.r.level_count; ++k) {
            const simplify_level *L = &rn.r.levels[k];
            if (!(L->eps < d)) continue;
            vec3d(*lev)[3] = level_tris(&rn, k);
            tset sl;
            tset_build(&sl, lev, L->triangle_count);
            double worst = 0, at = 0;
            for (int i = 0; i <= 400; ++i) {
                vec3d p = geom_vec3d(0.5, i / 400.0, groove_base(0.5, i / 400.0, curved) - d);
                double dist = tset_distance(&sl, p, NULL, NULL);
                if (dist > worst) {
                    worst = dist;
                    at = p.y;
                }
            }
            /* the bottom line is sampled between its vertices, where a float
             * rounding of the line itself is ~1e-8 off */
            CHECK(worst <= L->bound + 1e-7, "%s level %u: groove bottom (0.5, %g) is %g from the level: bridged "
                  "(bound %g)", name, k, at, worst, L->bound);
            /* and level vertices on the groove bottom line survive */
            uint32_t bottom = 0;
            for (uint32_t f = 0; f < L->triangle_count; ++f)
                for (int c = 0; c < 3; ++c) bottom += rn.w.positions[3 * level_vertex(&rn, k, f, c)] == 0.5f;
            CHECK(bottom > 0, "%s level %u: no vertex at the groove bottom", name, k);
            tset_free(&sl);
            free(lev);
        }
        CHECK(rn.r.levels[1].triangle_count < rn.w.triangle_count / 4, "%s: the sides simplify: %u", name,
              rn.r.levels[1].triangle_count);
    }
    run_free(&rn);
    mesh_free(&m);
}

static void test_v_groove(void)
{
    groove_case(0);
    groove_case(1);
}

/* ---- thin plate --------------------------------------------------------------- */

/* A closed box 10 x 10 x t: a 20 x 20 grid on top (z = t, facing up), one at
 * the bottom (z = 0, facing down), and the rim walls as one strip of quads.
 * Vertices are shared along the rim (closed, genus 0). */
static void build_box(mesh *m, uint32_t n, double size, double t)
{
    uint32_t top = mesh_grid(m, n, n, 0, size, 0, size, NULL, NULL);
    for (uint32_t i = 0; i < (n + 1) * (n + 1); ++i) m->pos[3 * (top + i) + 2] = (float)t;
    uint32_t bottom = m->nv;
    for (uint32_t j = 0; j <= n; ++j)
        for (uint32_t i = 0; i <= n; ++i) mesh_vertex(m, size * i / n, size * j / n, 0.0);
    for (uint32_t j = 0; j < n; ++j)
        for (uint32_t i = 0; i < n; ++i) {
            uint32_t a = bottom + j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
            /* clockwise seen from above: facing down */
            if ((i + j) % 2) {
                mesh_tri(m, a, c, b);
                mesh_tri(m, a, d, c);
            } else {
                mesh_tri(m, a, d, b);
                mesh_tri(m, b, d, c);
            }
        }
    /* rim, counter-clockwise seen from above: (0,0) -> (n,0) -> (n,n) -> (0,n) */
    uint32_t ring = 4 * n;
    for (uint32_t s = 0; s < ring; ++s) {
        uint32_t ij[2][2];
        for (int pass = 0; pass < 2; ++pass) {
            uint32_t q = (s + (uint32_t)pass) % ring, i, j;
            if (q < n) i = q, j = 0;
            else if (q < 2 * n) i = n, j = q - n;
            else if (q < 3 * n) i = 3 * n - q, j = n;
            else i = 0, j = 4 * n - q;
            ij[pass][0] = i;
            ij[pass][1] = j;
        }
        const uint32_t i0 = ij[0][0], j0 = ij[0][1], i1 = ij[1][0], j1 = ij[1][1];
        uint32_t t0 = top + j0 * (n + 1) + i0, t1 = top + j1 * (n + 1) + i1;
        uint32_t b0 = bottom + j0 * (n + 1) + i0, b1 = bottom + j1 * (n + 1) + i1;
        /* outward: the wall seen from outside runs b0 -> b1 -> t1 -> t0 */
        mesh_quad(m, b0, b1, t1, t0);
    }
}

static void test_thin_plate(void)
{
    mesh m;
    check_intersection_detector();
    mesh_init(&m);
    const double t = 0.025, size = 10.0;
    build_box(&m, 20, size, t);
    const double fractions[3] = {0.007, 0.02, 0.05}; /* eps 0.099, 0.28, 0.71: 4x to 28x the thickness */
    run rn;
    if (run_simplify(&rn, &m, fractions, 3, 0, 0) == LP_OK) {
        CHECK(rn.w.stats.vertices_by_kind[WELD_MANIFOLD] == rn.w.vertex_count, "the box is closed and manifold");
        CHECK(t < rn.r.levels[0].eps / 3.9, "thinner than eps / 4: t %g eps %g", t, rn.r.levels[0].eps);
        check_structure("plate", &rn);
        check_levels("plate", &rn, 8);
        check_topology("plate", &rn, 2, 0);
        for (uint32_t k = 0; k < rn.r.level_count; ++k) {
            const simplify_level *L = &rn.r.levels[k];
            double up_area = 0, down_area = 0;
            uint32_t on_top = 0, on_bottom = 0, wrong = 0, facing_up = 0, facing_down = 0;
            for (uint32_t f = 0; f < L->triangle_count; ++f) {
                vec3d p[3];
                int tops = 0, bottoms = 0;
                for (int c = 0; c < 3; ++c) {
                    p[c] = weld_point(&rn.w, level_vertex(&rn, k, f, c));
                    tops += p[c].z == (double)(float)t;
                    bottoms += p[c].z == 0.0;
                }
                vec3d n = geom_triangle_normal(&p[0], &p[1], &p[2]); /* length = 2 area */
                if (n.z > 0) up_area += 0.5 * n.z;
                else down_area -= 0.5 * n.z;
                facing_up += n.z > 0.7 * geom_length(n);
                facing_down += n.z < -0.7 * geom_length(n);
                if (tops == 3) {
                    on_top++;
                    wrong += !(n.z > 0);
                }
                if (bottoms == 3) {
                    on_bottom++;
                    wrong += !(n.z < 0);
                }
            }
            /* a coarse level may be a thin closed "pillow" whose faces each
             * span both sheets (corners at z = 0 and z = t): what matters is
             * that both orientations are there, each covering its sheet */
            CHECK(facing_up > 0 && facing_down > 0, "level %u: faces facing up %u, down %u", k, facing_up, facing_down);
            CHECK(wrong == 0, "level %u: %u sheet triangles (%u on top, %u on the bottom) facing the wrong way", k, wrong,
                  on_top, on_bottom);
            uint32_t crossing[2];
            CHECK(self_intersections(&rn, k, crossing) == 0,
                  "level %u: %u pairs of faces intersect (e.g. level faces %u and %u): the plate was cut through", k,
                  self_intersections(&rn, k, crossing), crossing[0], crossing[1]);
            CHECK(fabs(up_area - size * size) < 0.02 * size * size && fabs(down_area - size * size) < 0.02 * size * size,
                  "level %u: projected area facing up %g, down %g (each should be %g)", k, up_area, down_area,
                  size * size);
        }
        /* per sheet: up-facing level faces against the top sheet's originals
         * only, and the top originals against up-facing level faces only
         * (likewise down / bottom); a face certified through the plate would
         * be t away from its own sheet. Points of the level lie in the box, so
         * this measure is at most t + bound in any case: check it against the
         * bound, allowing t only for faces touching the rim. */
        for (uint32_t k = 0; k < rn.r.level_count; ++k) {
            const simplify_level *L = &rn.r.levels[k];
            for (int sheet = 0; sheet < 2; ++sheet) {
                const double z = sheet ? 0.0 : (double)(float)t;
                const double sign = sheet ? -1.0 : 1.0;
                vec3d(*orig)[3] = malloc((size_t)rn.w.triangle_count * sizeof *orig);
                vec3d(*lev)[3] = malloc(((size_t)L->triangle_count + 1) * sizeof *lev);
                vec3d(*facing)[3] = malloc(((size_t)L->triangle_count + 1) * sizeof *facing);
                if (!orig || !lev || !facing) abort();
                size_t no = 0, nl = 0, nfacing = 0;
                for (uint32_t f = 0; f < rn.w.triangle_count; ++f) {
                    vec3d p[3];
                    int on = 1;
                    for (int c = 0; c < 3; ++c) {
                        p[c] = weld_point(&rn.w, rn.w.triangle_vertices[3 * f + (uint32_t)c]);
                        on &= p[c].z == z;
                    }
                    if (on) memcpy(orig[no++], p, sizeof p);
                }
                for (uint32_t f = 0; f < L->triangle_count; ++f) {
                    vec3d p[3];
                    for (int c = 0; c < 3; ++c) p[c] = weld_point(&rn.w, level_vertex(&rn, k, f, c));
                    vec3d n = geom_triangle_normal(&p[0], &p[1], &p[2]);
                    double len = geom_length(n);
                    if (len > 0 && sign * n.z > 0.7 * len) memcpy(lev[nl++], p, sizeof p);
                    if (sign * n.z > 0) memcpy(facing[nfacing++], p, sizeof p);
                }
                CHECK(no == 800, "sheet %d: %zu original triangles", sheet, no);
                tset so, sl;
                tset_build(&so, orig, no);
                tset_build(&sl, facing, nfacing);
                measure a = sample_max(lev, nl, &so, L->eps / 3, 12, 0);
                measure b = sample_max(orig, no, &sl, L->eps / 3, 12, 0);
                /* a level face of this sheet whose corners all lie on it */
                int rim = 0;
                if (a.triangle != SIZE_MAX)
                    for (int c = 0; c < 3; ++c) rim |= lev[a.triangle][c].z != z;
                CHECK(a.worst <= L->bound + 1e-9 || (rim && a.worst <= t + 1e-9),
                      "level %u sheet %d: its faces are %g from its own sheet (bound %g)", k, sheet, a.worst, L->bound);
                CHECK(b.worst <= L->bound + 1e-9, "level %u sheet %d: the sheet is %g from the level's faces of its "
                      "orientation (bound %g)", k, sheet, b.worst, L->bound);
                tset_free(&so);
                tset_free(&sl);
                free(orig);
                free(lev);
                free(facing);
            }
        }
    }
    run_free(&rn);
    mesh_free(&m);
}

/* The run simplified, not by refusing everything: its coarsest level keeps
 * at most a quarter of the input's triangles. */
static void check_simplified(const char *name, const run *rn, uint32_t input_triangles)
{
    const uint32_t last = rn->r.levels[rn->r.level_count - 1].triangle_count;
    CHECK(last <= input_triangles / 4, "%s: the coarsest level kept %u of %u triangles", name, last, input_triangles);
    printf("#   %s: %u -> %u triangles\n", name, input_triangles, last);
}

/* DESIGN.md §5: "new faces are tested against nearby faces of A where the
 * original is thin (another sheet within 2 * eps_max)". A closed box whose
 * thickness is far below 2 * eps_max is thin everywhere: no level may have
 * its top surface pass through its bottom one, although such a level can be
 * within the two-sided bound (every point is within t of both sheets). */
static void test_thin_plate_no_self_intersection(void)
{
    static const struct {
        uint32_t n;
        double t, f0;
    } cases[2] = {{8, 0.1, 0.007}, {12, 0.025, 0.007}};
    for (int c = 0; c < 2; ++c) {
        mesh m;
        mesh_init(&m);
        build_box(&m, cases[c].n, 10.0, cases[c].t);
        const double f0 = cases[c].f0, fractions[4] = {f0, 3 * f0, 7 * f0, 15 * f0};
        run rn;
        if (run_simplify(&rn, &m, fractions, 4, 1, 0) == LP_OK) {
            check_topology("box", &rn, 2, 0);
            char label[64];
            snprintf(label, sizeof label, "thin box %u x %u cells, t %g", cases[c].n, cases[c].n, cases[c].t);
            check_simplified(label, &rn, m.nt); /* the six flat sides simplify */
            for (uint32_t k = 0; k < rn.r.level_count; ++k) {
                uint32_t ex[2], n = self_intersections(&rn, k, ex);
                CHECK(n == 0,
                      "box 10 x 10 x %g, %u x %u cells, fractions %g x {1,3,7,15}, 1 thread: level %u (%u triangles) has "
                      "%u intersecting face pairs, e.g. level faces %u and %u",
                      cases[c].t, cases[c].n, cases[c].n, f0, k, rn.r.levels[k].triangle_count, n, ex[0], ex[1]);
            }
        }
        run_free(&rn);
        mesh_free(&m);
    }
}

/* Runs m through region rounds of each size (0: the default size, too
 * large for these meshes: the passes alone) and checks that no level cuts
 * through itself and every level keeps the topology. */
static void check_regions_never_cross(const char *name, const mesh *m, const double *fractions, uint32_t count,
                                      const uint32_t *sizes, size_t size_count, long euler, long loops)
{
    const uint32_t saved = g_region_vertices;
    for (size_t c = 0; c < size_count; ++c) {
        g_region_vertices = sizes[c];
        run rn;
        if (run_simplify(&rn, m, fractions, count, 2, 0) == LP_OK) {
            check_topology(name, &rn, euler, loops);
            char label[96];
            snprintf(label, sizeof label, "%s, regions of %u", name, sizes[c]);
            check_simplified(label, &rn, m->nt);
            for (uint32_t k = 0; k < rn.r.level_count; ++k) {
                uint32_t ex[2], bad = self_intersections(&rn, k, ex);
                CHECK(bad == 0, "%s, regions of %u: level %u (%u triangles) has %u intersecting face pairs, e.g. %u and %u",
                      name, sizes[c], k, rn.r.levels[k].triangle_count, bad, ex[0], ex[1]);
            }
        }
        run_free(&rn);
    }
    g_region_vertices = saved;
}

/* A closed shell of two wavy sheets t apart (the box above with both
 * sheets lifted by the same bumps), thin everywhere against eps: through
 * region rounds of many sizes, so that region boundaries cross it in many
 * places, no level may have its top sheet cut through its bottom one. A
 * region skips other regions' faces in its crossing test (their cells are
 * apart) but must test the faces shared across its boundary. */
static void test_wavy_shell_regions(void)
{
    static const uint32_t sizes[] = {32, 48, 64, 96, 128, 160};
    mesh m;
    mesh_init(&m);
    const uint32_t n = 24;
    const double size = 10.0, t = 0.05;
    build_box(&m, n, size, t);
    for (uint32_t v = 0; v < m.nv; ++v) {
        const double x = m.pos[3 * v], y = m.pos[3 * v + 1];
        m.pos[3 * v + 2] += (float)(0.6 * sin(x * 1.3) * sin(y * 1.1 + 0.4));
    }
    const double fractions[4] = {0.004, 0.012, 0.028, 0.06};
    check_regions_never_cross("wavy shell", &m, fractions, 4, sizes, sizeof sizes / sizeof *sizes, 2, 0);
    mesh_free(&m);
}

/* A fine hill over a coarse copy of it whose vertices lie t below the
 * hill: 32 large faces, each reaching across many region cells, so every
 * one of them is shared in every round. A collapse on the hill cuts below
 * it (a chord of length L sags by c L^2 / 4 > t for L > 2 sqrt(t / c)), and
 * over a vertex of the coarse copy that goes right through it: only the
 * region's query of the shared faces can see that (its own grid holds
 * none of them): with that query left out, every size below gives levels
 * with 8 to 44 crossing face pairs. */
#define HILL_C 0.1
static double hill_height(uint32_t i, uint32_t j, double x, double y, void *ctx)
{
    (void)i, (void)j, (void)ctx;
    return 5.0 - HILL_C * ((x - 5.0) * (x - 5.0) + (y - 5.0) * (y - 5.0));
}

static void test_hill_over_coarse_hill_regions(void)
{
    static const uint32_t sizes[] = {0, 32, 64, 128};
    const double t = 0.01;
    mesh m;
    mesh_init(&m);
    mesh_grid(&m, 40, 40, 0, 10, 0, 10, hill_height, NULL);
    const uint32_t under = mesh_grid(&m, 4, 4, 0, 10, 0, 10, hill_height, NULL);
    for (uint32_t v = under; v < m.nv; ++v) m.pos[3 * v + 2] -= (float)t;
    const double fractions[4] = {0.002, 0.005, 0.01, 0.03};
    check_regions_never_cross("hill over a coarse hill", &m, fractions, 4, sizes, sizeof sizes / sizeof *sizes, 2, 2);
    mesh_free(&m);
}

/* ---- a double-sided sheet (weld.h "back faces") -------------------------------- */

/* Face (a, b, c) rotated to start at its lowest vertex, packed; `reverse`
 * reads it as (a, c, b). */
static uint64_t face_key(uint32_t a, uint32_t b, uint32_t c, int reverse)
{
    uint32_t v[3] = {a, reverse ? c : b, reverse ? b : c};
    int low = v[0] < v[1] ? (v[0] < v[2] ? 0 : 2) : (v[1] < v[2] ? 1 : 2);
    return (uint64_t)v[low] << 42 | (uint64_t)v[(low + 1) % 3] << 21 | v[(low + 2) % 3];
}

static int compare_keys(const void *x, const void *y)
{
    const uint64_t a = *(const uint64_t *)x, b = *(const uint64_t *)y;
    return (a > b) - (a < b);
}

/* A hill modelled as two coincident layers, the back in a primitive (and
 * material) of its own: the back is no obstacle (nothing is locked), every
 * level's back faces are exactly its front faces reversed, and the sampled
 * measure holds per primitive and facing, against the original's front and
 * back. */
static void test_double_sided_sheet(void)
{
    mesh m;
    mesh_init(&m);
    mesh_grid(&m, 40, 40, 0, 10, 0, 10, hill_height, NULL);
    const uint32_t front = m.nt;
    m.cur_mat = 1;
    for (uint32_t t = 0; t < front; ++t) {
        const uint32_t a = m.tri[3 * t], b = m.tri[3 * t + 1], c = m.tri[3 * t + 2];
        mesh_tri(&m, a, c, b);
    }
    const double fractions[2] = {0.01, 0.03};
    /* the single sheet, for its levels */
    mesh single = m;
    single.nt = front;
    run one;
    uint64_t *single_keys[2] = {NULL, NULL};
    uint32_t single_count[2] = {0, 0};
    if (run_simplify(&one, &single, fractions, 2, 1, 0) == LP_OK)
        for (uint32_t k = 0; k < 2; ++k) {
            const simplify_level *L = &one.r.levels[k];
            single_keys[k] = malloc(((size_t)L->triangle_count + 1) * sizeof *single_keys[k]);
            if (!single_keys[k]) abort();
            for (uint32_t f = 0; f < L->triangle_count; ++f)
                single_keys[k][single_count[k]++] = face_key(level_vertex(&one, k, f, 0), level_vertex(&one, k, f, 1),
                                                             level_vertex(&one, k, f, 2), 0);
            qsort(single_keys[k], single_count[k], sizeof *single_keys[k], compare_keys);
        }
    run_free(&one);
    for (uint32_t threads = 1; threads <= 2; ++threads) {
        run rn;
        if (run_simplify(&rn, &m, fractions, 2, threads, 1) == LP_OK) {
            CHECK(rn.w.back_count == front && rn.w.stats.vertices_by_kind[WELD_LOCKED] == 0, "backs %u, locked %u",
                  rn.w.back_count, rn.w.stats.vertices_by_kind[WELD_LOCKED]);
            for (uint32_t k = 0; k < rn.r.level_count; ++k) {
                const simplify_level *L = &rn.r.levels[k];
                uint64_t *keys[2];
                uint32_t n[2] = {0, 0};
                for (int side = 0; side < 2; ++side) {
                    keys[side] = malloc(((size_t)L->triangle_count + 1) * sizeof *keys[side]);
                    if (!keys[side]) abort();
                }
                for (uint32_t f = 0; f < L->triangle_count; ++f) {
                    const uint32_t side = L->primitive[f] == 1;
                    keys[side][n[side]++] = face_key(level_vertex(&rn, k, f, 0), level_vertex(&rn, k, f, 1),
                                                     level_vertex(&rn, k, f, 2), (int)side);
                }
                qsort(keys[0], n[0], sizeof *keys[0], compare_keys);
                qsort(keys[1], n[1], sizeof *keys[1], compare_keys);
                CHECK(n[0] == n[1] && n[0] > 0 && n[0] < front / 10 &&
                          memcmp(keys[0], keys[1], n[0] * sizeof *keys[0]) == 0,
                      "level %u: %u front and %u back faces (of %u), the backs the fronts reversed", k, n[0], n[1], front);
                /* the back changes nothing for the front: the same decisions, the same faces */
                CHECK(k < 2 && n[0] == single_count[k] && single_keys[k] &&
                          memcmp(keys[0], single_keys[k], n[0] * sizeof *keys[0]) == 0,
                      "level %u: the front layer is the single sheet's level (%u and %u faces)", k, n[0],
                      k < 2 ? single_count[k] : 0);
                free(keys[0]);
                free(keys[1]);
            }
            check_levels("double-sided sheet", &rn, 4);
        }
        run_free(&rn);
    }
    free(single_keys[0]);
    free(single_keys[1]);
    mesh_free(&m);
}

/* ---- sawtooth border ---------------------------------------------------------- */

static double saw_y(uint32_t i, double h)
{
    static const double wave[4] = {0.0, 0.5, 1.0, 0.5};
    return -h * wave[i % 4];
}

/* An open 40 x 20 grid over [0, 1] x [0, 0.5] whose bottom border row is a
 * sawtooth: teeth 0.1 wide and h = 0.1 tall (tips at x = 0.05, 0.15, ...,
 * 0.95, y = -h). A level without a tip vertex reaches it only with a face
 * spanning a notch, whose deepest point is 0.045 from the original, or with
 * a point at most y = -h/2 high: for eps < h/4 every tip must survive. */
static void test_sawtooth_border(void)
{
    mesh m;
    mesh_init(&m);
    const double h = 0.1;
    uint32_t first = mesh_grid(&m, 40, 20, 0, 1, 0, 0.5, NULL, NULL);
    for (uint32_t i = 0; i <= 40; ++i) m.pos[3 * (first + i) + 1] = (float)saw_y(i, h);
    const double fractions[5] = {0.004, 0.008, 0.016, 0.05, 0.2};
    run rn;
    if (run_simplify(&rn, &m, fractions, 5, 0, 0) == LP_OK) {
        check_structure("sawtooth", &rn);
        check_levels("sawtooth", &rn, 8);
        check_topology("sawtooth", &rn, 1, 1);
        for (uint32_t k = 0; k < rn.r.level_count; ++k) {
            const simplify_level *L = &rn.r.levels[k];
            if (!(L->eps < h / 4)) continue;
            int tips = 0, kept = 0;
            for (uint32_t i = 2; i <= 38; i += 4) {
                uint32_t v = find_vertex(&rn.w, i / 40.0, -h, 0.0);
                tips++;
                if (v != UINT32_MAX && level_has_vertex(&rn, k, v)) kept++;
                else CHECK(0, "level %u (eps %g < h/4): tooth tip at x = %g is gone", k, L->eps, i / 40.0);
            }
            CHECK(tips == 10 && kept == 10, "level %u: %d of %d tips kept", k, kept, tips);
        }
        CHECK(rn.r.levels[1].triangle_count < rn.w.triangle_count / 3, "the flat part simplifies: %u",
              rn.r.levels[1].triangle_count);
    }
    run_free(&rn);
    mesh_free(&m);
}

/* ---- materials ------------------------------------------------------------------ */

/* A gently curved 30 x 30 grid whose middle square (cells 10..19 both ways) is
 * a second material - a decal, its own primitive sharing the positions along
 * the seam. Each material must stay within the bound of ITS OWN originals both
 * ways: the decal may not spread over the base or shrink into it. */
static double decal_height(uint32_t i, uint32_t j, double x, double y, void *ctx)
{
    (void)i;
    (void)j;
    (void)ctx;
    return 0.03 * sin(4.0 * x) * cos(3.0 * y);
}

/* The 30 x 30 grid with its decal (material 1). */
static void decal_mesh(mesh *m)
{
    mesh_init(m);
    mesh_grid(m, 30, 30, 0, 1, 0, 1, decal_height, NULL);
    for (uint32_t t = 0; t < m->nt; ++t) {
        uint32_t cell = t / 2, i = cell % 30, j = cell / 30;
        m->mat[t] = i >= 10 && i < 20 && j >= 10 && j < 20;
    }
}

static void test_materials(void)
{
    mesh m;
    decal_mesh(&m);
    const double fractions[3] = {0.01, 0.03, 0.07};
    run rn;
    if (run_simplify(&rn, &m, fractions, 3, 0, 0) == LP_OK) {
        CHECK(rn.sm.primitive_count == 2 && rn.w.stats.seam_edges == 40, "two primitives, a 40-edge seam: %u",
              rn.w.stats.seam_edges);
        check_structure("decal", &rn);
        check_levels("decal", &rn, 8);
        check_topology("decal", &rn, 1, 1);
        /* and the decal corners: moving one along the seam cuts a corner of
         * the decal by >= 0.0236 (half a cell diagonal), more than eps 0.014 */
        const double c[4][2] = {{10, 10}, {20, 10}, {20, 20}, {10, 20}};
        for (int q = 0; q < 4; ++q) {
            double x = c[q][0] / 30.0, y = c[q][1] / 30.0;
            uint32_t v = find_vertex(&rn.w, x, y, decal_height(0, 0, x, y, NULL));
            CHECK(v != UINT32_MAX && level_has_vertex(&rn, 0, v), "level 0: decal corner (%g, %g) is gone", x, y);
        }
        CHECK(rn.r.levels[1].triangle_count < rn.w.triangle_count / 4, "decal mesh simplifies: %u",
              rn.r.levels[1].triangle_count);
    }
    run_free(&rn);
    mesh_free(&m);
}


/* The double-sided hill with both sides in ONE primitive, shuffled together
 * as an index optimizer leaves them (every third pair lists its reversed
 * triangle first): the weld chooses the fronts so that they agree (weld.h),
 * and every level is one layer and its reversal, a few faces, certified. */
static void test_double_sided_shuffled(void)
{
    mesh g;
    mesh_init(&g);
    mesh_grid(&g, 40, 40, 0, 10, 0, 10, hill_height, NULL);
    mesh m = g;
    m.tri = malloc(6 * (size_t)g.nt * sizeof *m.tri);
    m.mat = calloc(2 * (size_t)g.nt, sizeof *m.mat);
    if (!m.tri || !m.mat) abort();
    m.nt = 0;
    for (uint32_t t = 0; t < g.nt; ++t) {
        const uint32_t a = g.tri[3 * t], b = g.tri[3 * t + 1], c = g.tri[3 * t + 2];
        const uint32_t first[3] = {a, t % 3 == 1 ? c : b, t % 3 == 1 ? b : c};
        const uint32_t second[3] = {a, first[2], first[1]};
        memcpy(m.tri + 3 * (size_t)m.nt++, first, sizeof first);
        memcpy(m.tri + 3 * (size_t)m.nt++, second, sizeof second);
    }
    const double fractions[2] = {0.01, 0.03};
    run rn;
    if (run_simplify(&rn, &m, fractions, 2, 2, 1) == LP_OK) {
        CHECK(rn.w.back_count == g.nt && rn.w.stats.vertices_by_kind[WELD_LOCKED] == 0 && rn.w.stats.nonmanifold_edges == 0,
              "backs %u of %u, locked %u, non-manifold edges %u", rn.w.back_count, g.nt,
              rn.w.stats.vertices_by_kind[WELD_LOCKED], rn.w.stats.nonmanifold_edges);
        for (uint32_t k = 0; k < rn.r.level_count; ++k) {
            const simplify_level *L = &rn.r.levels[k];
            uint64_t *keys[2];
            for (int side = 0; side < 2; ++side) {
                keys[side] = malloc(((size_t)L->triangle_count + 1) * sizeof *keys[side]);
                if (!keys[side]) abort();
                for (uint32_t f = 0; f < L->triangle_count; ++f)
                    keys[side][f] = face_key(level_vertex(&rn, k, f, 0), level_vertex(&rn, k, f, 1),
                                             level_vertex(&rn, k, f, 2), side);
                qsort(keys[side], L->triangle_count, sizeof *keys[side], compare_keys);
            }
            CHECK(L->triangle_count > 0 && L->triangle_count < g.nt / 5 &&
                      memcmp(keys[0], keys[1], L->triangle_count * sizeof *keys[0]) == 0,
                  "level %u: %u faces (of %u), each with its reversal", k, L->triangle_count, 2 * g.nt);
            free(keys[0]);
            free(keys[1]);
        }
        check_levels("shuffled double-sided hill", &rn, 4);
    }
    run_free(&rn);
    free(m.tri);
    free(m.mat);
    mesh_free(&g);
}

/* The decal of test_materials with every triangle again reversed in its own
 * material (each primitive double-sided, as exporters write it): the material
 * seam is no back border (weld.h), so each level is exactly the single decal's
 * level plus its faces reversed - the backs take nothing from the front. */
static void test_double_sided_decal(void)
{
    mesh m;
    decal_mesh(&m);
    const uint32_t front = m.nt;
    for (uint32_t t = 0; t < front; ++t) {
        m.cur_mat = m.mat[t];
        mesh_tri(&m, m.tri[3 * t], m.tri[3 * t + 2], m.tri[3 * t + 1]);
    }
    const double fractions[3] = {0.01, 0.03, 0.07};
    mesh single = m;
    single.nt = front;
    run one, two;
    if (run_simplify(&one, &single, fractions, 3, 1, 0) == LP_OK && run_simplify(&two, &m, fractions, 3, 2, 1) == LP_OK) {
        CHECK(two.w.back_count == front && two.w.stats.vertices_by_kind[WELD_LOCKED] == one.w.stats.vertices_by_kind[WELD_LOCKED],
              "backs %u, locked %u (single: %u)", two.w.back_count, two.w.stats.vertices_by_kind[WELD_LOCKED],
              one.w.stats.vertices_by_kind[WELD_LOCKED]);
        for (uint32_t k = 0; k < 3; ++k) {
            const simplify_level *L1 = &one.r.levels[k], *L2 = &two.r.levels[k];
            uint64_t *expect = malloc((2 * (size_t)L1->triangle_count + 1) * sizeof *expect);
            uint64_t *got = malloc(((size_t)L2->triangle_count + 1) * sizeof *got);
            if (!expect || !got) abort();
            for (uint32_t f = 0; f < L1->triangle_count; ++f)
                for (int side = 0; side < 2; ++side)
                    expect[2 * f + (uint32_t)side] = face_key(level_vertex(&one, k, f, 0), level_vertex(&one, k, f, 1),
                                                              level_vertex(&one, k, f, 2), side) << 1 |
                                                     (uint64_t)L1->primitive[f] << 63;
            for (uint32_t f = 0; f < L2->triangle_count; ++f)
                got[f] = face_key(level_vertex(&two, k, f, 0), level_vertex(&two, k, f, 1), level_vertex(&two, k, f, 2), 0)
                             << 1 |
                         (uint64_t)L2->primitive[f] << 63;
            qsort(expect, 2 * (size_t)L1->triangle_count, sizeof *expect, compare_keys);
            qsort(got, L2->triangle_count, sizeof *got, compare_keys);
            CHECK(L2->triangle_count == 2 * L1->triangle_count && L1->triangle_count < front / 4 &&
                      memcmp(expect, got, L2->triangle_count * sizeof *got) == 0,
                  "level %u: %u faces, the single decal's %u and their reversals, in their primitives", k,
                  L2->triangle_count, L1->triangle_count);
            free(expect);
            free(got);
        }
        check_levels("double-sided decal", &two, 4);
    }
    run_free(&one);
    run_free(&two);
    mesh_free(&m);
}

/* ---- closed meshes: a bumpy sphere and a torus ---------------------------------- */

/* An icosphere with `subdiv` subdivisions (20 * 4^subdiv triangles), radius
 * 10 with bumps, every coordinate rounded to a multiple of 1/128 (so that the
 * mesh moved by 1e5 is exactly the same shape in float). */
static double bump_radius(vec3d n)
{
    return 10.0 * (1.0 + 0.08 * sin(3.0 * n.x + 1.0) * sin(2.0 * n.y) + 0.05 * cos(5.0 * n.z));
}

typedef struct {
    uint64_t *key;
    uint32_t *val;
    size_t cap;
} edge_map;

static uint32_t midpoint(mesh *m, edge_map *em, uint32_t a, uint32_t b, vec3d *dirs, uint32_t *ndirs)
{
    uint64_t key = a < b ? ((uint64_t)a << 32) | b : ((uint64_t)b << 32) | a;
    size_t h = (size_t)(key * 0x9e3779b97f4a7c15ULL) & (em->cap - 1);
    while (em->key[h] != UINT64_MAX) {
        if (em->key[h] == key) return em->val[h];
        h = (h + 1) & (em->cap - 1);
    }
    vec3d d = geom_add(dirs[a], dirs[b]);
    d = geom_scale(d, 1.0 / geom_length(d));
    uint32_t v = (*ndirs)++;
    dirs[v] = d;
    (void)m;
    em->key[h] = key;
    em->val[h] = v;
    return v;
}

static void build_icosphere(mesh *m, int subdiv, vec3d shift)
{
    const double g = (1.0 + sqrt(5.0)) / 2.0;
    static const int tri0[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                    {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                    {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                    {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    const double v0[12][3] = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0}, {0, -1, g}, {0, 1, g},
                              {0, -1, -g}, {0, 1, -g}, {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
    uint32_t maxv = 12, nt = 20;
    for (int s = 0; s < subdiv; ++s) {
        maxv += 3 * nt / 2;
        nt *= 4;
    }
    vec3d *dirs = malloc(maxv * sizeof *dirs);
    uint32_t *tris = malloc(3 * (size_t)nt * sizeof *tris), *next = malloc(3 * (size_t)nt * sizeof *next);
    if (!dirs || !tris || !next) abort();
    uint32_t ndirs = 12, ntris = 20;
    for (int i = 0; i < 12; ++i) {
        vec3d d = geom_vec3d(v0[i][0], v0[i][1], v0[i][2]);
        dirs[i] = geom_scale(d, 1.0 / geom_length(d));
    }
    for (int i = 0; i < 20; ++i)
        for (int c = 0; c < 3; ++c) tris[3 * i + c] = (uint32_t)tri0[i][c];
    for (int s = 0; s < subdiv; ++s) {
        edge_map em;
        em.cap = 1;
        while (em.cap < 4 * (size_t)ntris) em.cap *= 2;
        em.key = malloc(em.cap * sizeof *em.key);
        em.val = malloc(em.cap * sizeof *em.val);
        if (!em.key || !em.val) abort();
        memset(em.key, 0xff, em.cap * sizeof *em.key);
        uint32_t n2 = 0;
        for (uint32_t t = 0; t < ntris; ++t) {
            uint32_t a = tris[3 * t], b = tris[3 * t + 1], c = tris[3 * t + 2];
            uint32_t ab = midpoint(m, &em, a, b, dirs, &ndirs), bc = midpoint(m, &em, b, c, dirs, &ndirs),
                     ca = midpoint(m, &em, c, a, dirs, &ndirs);
            const uint32_t q[4][3] = {{a, ab, ca}, {ab, b, bc}, {ca, bc, c}, {ab, bc, ca}};
            for (int i = 0; i < 4; ++i)
                for (int k = 0; k < 3; ++k) next[3 * (n2 + (uint32_t)i) + (uint32_t)k] = q[i][k];
            n2 += 4;
        }
        ntris = n2;
        memcpy(tris, next, 3 * (size_t)ntris * sizeof *tris);
        free(em.key);
        free(em.val);
    }
    uint32_t base = m->nv;
    for (uint32_t v = 0; v < ndirs; ++v) {
        vec3d p = geom_scale(dirs[v], bump_radius(dirs[v]));
        mesh_vertex(m, round(p.x * 128.0) / 128.0 + shift.x, round(p.y * 128.0) / 128.0 + shift.y,
                    round(p.z * 128.0) / 128.0 + shift.z);
    }
    for (uint32_t t = 0; t < ntris; ++t) mesh_tri(m, base + tris[3 * t], base + tris[3 * t + 1], base + tris[3 * t + 2]);
    free(dirs);
    free(tris);
    free(next);
}

/* A torus (major radius 3, minor 1, with ripples), nu x nv quads. */
static void build_torus(mesh *m, uint32_t nu, uint32_t nv)
{
    uint32_t base = m->nv;
    for (uint32_t j = 0; j < nv; ++j)
        for (uint32_t i = 0; i < nu; ++i) {
            double u = 2 * M_PI * i / nu, v = 2 * M_PI * j / nv;
            double r = 1.0 + 0.1 * sin(3 * u) * cos(2 * v);
            mesh_vertex(m, (3 + r * cos(v)) * cos(u), (3 + r * cos(v)) * sin(u), r * sin(v));
        }
    for (uint32_t j = 0; j < nv; ++j)
        for (uint32_t i = 0; i < nu; ++i) {
            uint32_t a = base + j * nu + i, b = base + j * nu + (i + 1) % nu, c = base + ((j + 1) % nv) * nu + (i + 1) % nu,
                     d = base + ((j + 1) % nv) * nu + i;
            mesh_quad(m, a, b, c, d);
        }
}

static const double default_ladder[4] = {0.01, 0.03, 0.07, 0.15};

static void test_euler_closed(void)
{
    mesh m;
    mesh_init(&m);
    build_icosphere(&m, 3, geom_vec3d(0, 0, 0));
    run rn;
    if (run_simplify(&rn, &m, default_ladder, 4, 0, 0) == LP_OK) {
        CHECK(rn.w.stats.vertices_by_kind[WELD_MANIFOLD] == rn.w.vertex_count, "sphere closed and manifold");
        check_structure("sphere", &rn);
        check_topology("sphere", &rn, 2, 0);
        check_levels("sphere", &rn, 8);
        CHECK(rn.r.levels[3].triangle_count < rn.w.triangle_count / 4, "sphere simplifies: %u",
              rn.r.levels[3].triangle_count);
    }
    run_free(&rn);
    mesh_free(&m);

    mesh_init(&m);
    build_torus(&m, 48, 24);
    if (run_simplify(&rn, &m, default_ladder, 4, 0, 0) == LP_OK) {
        check_structure("torus", &rn);
        check_topology("torus", &rn, 0, 0);
        check_levels("torus", &rn, 8);
        CHECK(rn.r.levels[3].triangle_count < rn.w.triangle_count / 4, "torus simplifies: %u",
              rn.r.levels[3].triangle_count);
    }
    run_free(&rn);
    mesh_free(&m);
}

/* ---- open meshes whose vertices have few faces ----------------------------- */

/* vertices removed with another triangulation of their hole, over all levels */
static uint64_t removals_of(const run *rn)
{
    uint64_t n = 0;
    for (uint32_t k = 0; k < rn->r.level_count; ++k) n += rn->r.levels[k].stats.removals;
    return n;
}

/* The link condition's floors where a border is near, for collapses and
 * vertex removals: a disc fanned from its centre (each rim vertex has 2
 * faces, so every collapse leaves a rim vertex with 1 face: the old floor of
 * 3 faces everywhere refused them all and the disc kept its 200 triangles at
 * every level), a crown whose centre only a removal can take, a strip one
 * cell wide (every vertex on the border) and a lone triangle (nothing may
 * go: its collapse is the one the border floor refuses). Each stays a disc
 * at every level, within its bound. */
static void test_border_floors(void)
{
    mesh m;
    mesh_init(&m);
    const uint32_t sectors = 200;
    const uint32_t centre = mesh_vertex(&m, 0, 0, 0);
    for (uint32_t t = 0; t < sectors; ++t) {
        const double a = 2.0 * M_PI * t / sectors;
        mesh_vertex(&m, cos(a), sin(a), 0.02 * sin(3.0 * a));
    }
    for (uint32_t t = 0; t < sectors; ++t) mesh_tri(&m, centre, 1 + t, 1 + (t + 1) % sectors);
    run rn;
    if (run_simplify(&rn, &m, default_ladder, 4, 0, 0) == LP_OK) {
        check_structure("fan", &rn);
        check_topology("fan", &rn, 1, 1);
        check_levels("fan", &rn, 8);
        CHECK(rn.r.levels[0].triangle_count < sectors / 4, "the fan simplifies at 1 %%: %u of %u",
              rn.r.levels[0].triangle_count, sectors);
    }
    run_free(&rn);
    mesh_free(&m);

    mesh_init(&m);
    mesh_grid(&m, 60, 1, 0, 1, 0, 0.02, NULL, NULL);
    if (run_simplify(&rn, &m, default_ladder, 4, 0, 0) == LP_OK) {
        check_structure("strip", &rn);
        check_topology("strip", &rn, 1, 1);
        check_levels("strip", &rn, 8);
        CHECK(rn.r.levels[3].triangle_count < rn.w.triangle_count / 4, "the strip simplifies: %u of %u",
              rn.r.levels[3].triangle_count, rn.w.triangle_count);
    }
    run_free(&rn);
    mesh_free(&m);

    /* A crown: a hexagon fanned from its centre, the odd corners pulled in to
     * 0.6 and raised by 0.025, every corner on the border with 2 faces. At 1 %
     * no collapse of the centre is certified, but a vertex removal is (4
     * triangles); it needs a diagonal between two border vertices and leaves
     * a border corner 1 face, which the removal's rules forbade until they
     * took link_ok's floors (found by a sweep over such crowns: this one
     * kept its 6 triangles then). The checker is on. */
    mesh_init(&m);
    const uint32_t hub = mesh_vertex(&m, 0, 0, 0);
    for (uint32_t t = 0; t < 6; ++t) {
        const double a = 2.0 * M_PI * t / 6, r = t % 2 ? 0.6 : 1.0;
        mesh_vertex(&m, r * cos(a), r * sin(a), t % 2 ? 0.025 : 0.0);
    }
    for (uint32_t t = 0; t < 6; ++t) mesh_tri(&m, hub, 1 + t, 1 + (t + 1) % 6);
    if (run_simplify(&rn, &m, default_ladder, 4, 0, 1) == LP_OK) {
        check_structure("crown", &rn);
        check_topology("crown", &rn, 1, 1);
        check_levels("crown", &rn, 8);
        CHECK(rn.r.levels[0].triangle_count == 4 && removals_of(&rn) == 1,
              "the crown's centre is removed at 1 %%: %u triangles, %llu removals", rn.r.levels[0].triangle_count,
              (unsigned long long)removals_of(&rn));
    }
    run_free(&rn);
    mesh_free(&m);

    mesh_init(&m);
    mesh_tri(&m, mesh_vertex(&m, 0, 0, 0), mesh_vertex(&m, 1, 0, 0), mesh_vertex(&m, 0.5, 0.01, 0));
    if (run_simplify(&rn, &m, default_ladder, 4, 0, 0) == LP_OK) {
        check_topology("triangle", &rn, 1, 1);
        for (uint32_t k = 0; k < rn.r.level_count; ++k)
            CHECK(rn.r.levels[k].triangle_count == 1, "triangle level %u: %u triangles", k, rn.r.levels[k].triangle_count);
    }
    run_free(&rn);
    mesh_free(&m);
}

/* ---- hubs (simplify.h: SIMPLIFY_HUB_FACES) ---------------------------------- */

/* The most faces around one vertex of level k (k == UINT32_MAX: the weld's
 * triangles). */
static uint32_t max_faces_around(const run *rn, uint32_t k)
{
    uint32_t *count = calloc(rn->w.vertex_count + 1, sizeof *count), most = 0;
    if (!count) abort();
    const uint32_t n = k == UINT32_MAX ? rn->w.triangle_count : rn->r.levels[k].triangle_count;
    for (uint32_t f = 0; f < n; ++f)
        for (int c = 0; c < 3; ++c) {
            const uint32_t v = k == UINT32_MAX ? rn->w.triangle_vertices[3 * (size_t)f + (uint32_t)c] : level_vertex(rn, k, f, c);
            if (++count[v] > most) most = count[v];
        }
    free(count);
    return most;
}

/* A cone of 5,000 faces around its apex (a hub) beside a bumpy sphere, in
 * one mesh: the apex and its 5,000 neighbours are held (before the limit
 * the cone cost about n squared: a cone of 100,000 faces did not finish in 7
 * minutes), so every level keeps the cone whole, while the sphere simplifies
 * as usual, within its bound. And no collapse makes a hub (below). */
static void test_hubs(void)
{
    mesh m;
    mesh_init(&m);
    /* in region rounds a finer sphere, so that its regions have interior
     * vertices beside the held cone's (run_simplify checks the rounds commit) */
    build_icosphere(&m, g_region_vertices ? 4 : 3, geom_vec3d(0, 0, 0));
    const uint32_t sphere_faces = m.nt, sectors = 5000;
    const uint32_t apex = mesh_vertex(&m, 3, 0, 1);
    for (uint32_t t = 0; t < sectors; ++t) {
        const double a = 2.0 * M_PI * t / sectors;
        mesh_vertex(&m, 3 + cos(a), sin(a), 0);
    }
    for (uint32_t t = 0; t < sectors; ++t) mesh_tri(&m, apex, apex + 1 + t, apex + 1 + (t + 1) % sectors);
    run rn;
    if (run_simplify(&rn, &m, default_ladder, 4, 0, 0) == LP_OK) {
        check_structure("cone and sphere", &rn);
        check_levels("cone and sphere", &rn, 8);
        CHECK(rn.r.held_vertices == sectors + 1, "the apex and its neighbours are held: %u", rn.r.held_vertices);
        for (uint32_t k = 0; k < rn.r.level_count; ++k) {
            uint32_t cone = 0;
            const simplify_level *L = &rn.r.levels[k];
            for (uint32_t f = 0; f < L->triangle_count; ++f) cone += level_vertex(&rn, k, f, 0) == apex ||
                                                                   level_vertex(&rn, k, f, 1) == apex ||
                                                                   level_vertex(&rn, k, f, 2) == apex;
            CHECK(cone == sectors, "level %u keeps the cone's %u faces: %u", k + 1, sectors, cone);
            CHECK(L->triangle_count - cone < sphere_faces / 4, "level %u simplifies the sphere: %u of %u faces", k + 1,
                  L->triangle_count - cone, sphere_faces);
        }
    }
    run_free(&rn);
    mesh_free(&m);

    /* No collapse makes a hub: the bumpy sphere (at most 6 faces around a
     * vertex) with the limit at 7 instead of 4,096 keeps every vertex of every
     * level at 7 faces or fewer, and is still simplified within its bounds;
     * with the default limit its levels have a vertex with 8. Not in region
     * rounds: at 7 nearly every first collapse of the sphere is refused, so a
     * round commits nothing, which run_simplify's check refuses. */
    if (g_region_vertices) return;
    mesh_init(&m);
    build_icosphere(&m, 3, geom_vec3d(0, 0, 0));
    uint32_t most_default = 0;
    if (run_simplify(&rn, &m, default_ladder, 4, 0, 0) == LP_OK)
        for (uint32_t k = 0; k < rn.r.level_count; ++k) {
            const uint32_t most = max_faces_around(&rn, k);
            if (most > most_default) most_default = most;
        }
    run_free(&rn);
    CHECK(most_default > 7, "with the default limit a level has a vertex with more than 7 faces: %u", most_default);
    g_hub_faces = 7;
    if (run_simplify(&rn, &m, default_ladder, 4, 0, 0) == LP_OK) {
        check_structure("sphere, limit 7", &rn);
        check_topology("sphere, limit 7", &rn, 2, 0);
        check_levels("sphere, limit 7", &rn, 8);
        check_simplified("sphere, limit 7", &rn, m.nt);
        CHECK(max_faces_around(&rn, UINT32_MAX) <= 6 && rn.r.held_vertices == 0, "no hub in the sphere: %u held",
              rn.r.held_vertices);
        for (uint32_t k = 0; k < rn.r.level_count; ++k)
            CHECK(max_faces_around(&rn, k) <= 7, "sphere, limit 7, level %u: %u faces around one vertex", k + 1,
                  max_faces_around(&rn, k));
    }
    g_hub_faces = 0;
    run_free(&rn);
    mesh_free(&m);
}

/* ---- patience (simplify.c: retry_due) ------------------------------------------ */

/* Whether runs x and y made the same levels: faces, primitives, bounds,
 * placed positions and commit counts (why: the first difference). Also the
 * determinism tests' comparison (below). */
static int same_result(const run *x, const run *y, char *why, size_t n)
{
    if (x->r.level_count != y->r.level_count) return snprintf(why, n, "level count"), 0;
    for (uint32_t k = 0; k < x->r.level_count; ++k) {
        const simplify_level *a = &x->r.levels[k], *b = &y->r.levels[k];
        if (a->triangle_count != b->triangle_count)
            return snprintf(why, n, "level %u: %u vs %u triangles", k, a->triangle_count, b->triangle_count), 0;
        if (memcmp(a->wedges, b->wedges, 3 * (size_t)a->triangle_count * sizeof *a->wedges))
            return snprintf(why, n, "level %u: faces differ", k), 0;
        if (memcmp(a->primitive, b->primitive, (size_t)a->triangle_count * sizeof *a->primitive))
            return snprintf(why, n, "level %u: primitives differ", k), 0;
        if (memcmp(&a->bound, &b->bound, sizeof a->bound))
            return snprintf(why, n, "level %u: bound %.17g vs %.17g", k, a->bound, b->bound), 0;
        if (!a->positions != !b->positions ||
            (a->positions && memcmp(a->positions, b->positions, 3 * (size_t)x->w.vertex_count * sizeof *a->positions)))
            return snprintf(why, n, "level %u: placed positions differ", k), 0;
        if (a->stats.commits != b->stats.commits)
            return snprintf(why, n, "level %u: %llu vs %llu commits", k, (unsigned long long)a->stats.commits,
                            (unsigned long long)b->stats.commits), 0;
    }
    return 1;
}

/* A flat disc of 1,000 sectors fanned from its centre. Every collapse on
 * the rim changes the centre's neighbourhood, and at 1 % no collapse of the
 * centre is certified (a sliver from the centre to the rim would need more
 * than CERT_MAX_WITNESSES faces of a fan from a rim vertex). Tried again
 * after every such change, the centre was evaluated about once per rim
 * collapse (1,983 candidates for 1,001 vertices, 1.2 s); with patience it
 * waits for an eighth of its faces to go. Patience changes when a vertex is
 * tried, not what a try decides: here the levels are the same face for face.
 * Then patience for every vertex (from 3 faces) on a bumpy sphere with the
 * checker on, which at the end of each level checks that every rejected
 * vertex whose neighbourhood changed was tried again (the level's last,
 * impatient pass): its levels are sound and simplified as usual. */
static void test_patience(void)
{
    mesh m;
    run patient, eager;
    /* the disc not in region rounds: every region's interior would touch
     * the centre, so the rounds would commit nothing, which run_simplify's
     * check refuses */
    if (g_region_vertices) goto sphere;
    mesh_init(&m);
    const uint32_t sectors = 1000;
    const uint32_t centre = mesh_vertex(&m, 0, 0, 0);
    for (uint32_t t = 0; t < sectors; ++t) {
        const double a = 2.0 * M_PI * t / sectors;
        mesh_vertex(&m, cos(a), sin(a), 0);
    }
    for (uint32_t t = 0; t < sectors; ++t) mesh_tri(&m, centre, 1 + t, 1 + (t + 1) % sectors);
    const int ok_patient = run_simplify(&patient, &m, default_ladder, 4, 0, 0) == LP_OK;
    g_patient_faces = UINT32_MAX;
    const int ok_eager = run_simplify(&eager, &m, default_ladder, 4, 0, 0) == LP_OK;
    g_patient_faces = 0;
    if (ok_patient && ok_eager) {
        check_structure("disc, patient", &patient);
        check_topology("disc, patient", &patient, 1, 1);
        check_levels("disc, patient", &patient, 8);
        check_simplified("disc, patient", &patient, m.nt);
        const uint64_t tried = patient.r.levels[0].stats.candidates, tried_eager = eager.r.levels[0].stats.candidates;
        CHECK(tried_eager > 3 * (uint64_t)m.nv / 2, "without patience the centre is tried after each rim collapse: %llu "
              "candidates at 1 %% for %u vertices", (unsigned long long)tried_eager, m.nv);
        CHECK(tried < 5 * (uint64_t)m.nv / 4, "with patience about once per vertex: %llu candidates at 1 %% for %u vertices",
              (unsigned long long)tried, m.nv);
        char why[200];
        CHECK(same_result(&patient, &eager, why, sizeof why), "the disc's levels with and without patience: %s", why);
    }
    run_free(&patient);
    run_free(&eager);
    mesh_free(&m);

sphere:
    mesh_init(&m);
    build_icosphere(&m, 3, geom_vec3d(0, 0, 0));
    g_patient_faces = 3;
    if (run_simplify(&patient, &m, default_ladder, 4, 0, 1) == LP_OK) {
        check_structure("sphere, patience from 3 faces", &patient);
        check_topology("sphere, patience from 3 faces", &patient, 2, 0);
        check_levels("sphere, patience from 3 faces", &patient, 8);
        check_simplified("sphere, patience from 3 faces", &patient, m.nt);
    }
    g_patient_faces = 0;
    run_free(&patient);
    mesh_free(&m);
}

/* ---- translation by 1e5 ------------------------------------------------------- */

/* The same bumpy sphere at the origin and moved by (1e5, 1e5, 1e5): every
 * coordinate is a multiple of 1/128 below 2^17, so both are exactly the same
 * shape in float. Level sizes within 10 %, bounds <= eps of the (equal)
 * diagonal, sampled <= bound for both. */
static void test_translated_1e5(void)
{
    mesh a, b;
    mesh_init(&a);
    mesh_init(&b);
    build_icosphere(&a, 3, geom_vec3d(0, 0, 0));
    build_icosphere(&b, 3, geom_vec3d(1e5, 1e5, 1e5));
    int exact = 1;
    for (uint32_t i = 0; i < 3 * a.nv; ++i) exact &= (double)b.pos[i] - 1e5 == (double)a.pos[i];
    CHECK(exact, "the moved copy is exact in float");
    run ra, rb;
    int ok_a = run_simplify(&ra, &a, default_ladder, 4, 0, 0) == LP_OK;
    int ok_b = run_simplify(&rb, &b, default_ladder, 4, 0, 0) == LP_OK;
    if (ok_a && ok_b) {
        CHECK(ra.r.diagonal == rb.r.diagonal, "same diagonal: %.17g %.17g", ra.r.diagonal, rb.r.diagonal);
        for (uint32_t k = 0; k < 4; ++k) {
            uint32_t na = ra.r.levels[k].triangle_count, nb = rb.r.levels[k].triangle_count;
            uint32_t hi = na > nb ? na : nb, lo = na > nb ? nb : na;
            CHECK(hi - lo <= hi / 10 + 2, "level %u: %u triangles at the origin, %u at 1e5", k, na, nb);
            CHECK(rb.r.levels[k].bound / rb.r.diagonal <= default_ladder[k],
                  "level %u: relative bound %g > %g at 1e5", k, rb.r.levels[k].bound / rb.r.diagonal, default_ladder[k]);
            CHECK(ra.r.levels[k].bound / ra.r.diagonal <= default_ladder[k], "level %u: relative bound %g", k,
                  ra.r.levels[k].bound / ra.r.diagonal);
            printf("#   level %u: %u / %u triangles, bound %.6g / %.6g\n", k, na, nb, ra.r.levels[k].bound,
                   rb.r.levels[k].bound);
        }
        check_structure("origin", &ra);
        check_structure("moved", &rb);
        check_levels("origin", &ra, 8);
        check_levels("moved", &rb, 8);
        check_topology("moved", &rb, 2, 0);
    }
    run_free(&ra);
    run_free(&rb);
    mesh_free(&a);
    mesh_free(&b);
}

/* ---- determinism -------------------------------------------------------------- */

static void test_thread_count_invariance(void)
{
    mesh m;
    mesh_init(&m);
    build_icosphere(&m, 3, geom_vec3d(0, 0, 0)); /* 642 vertices: more than one batch (512) per pass */
    run r1, r2, r8;
    int ok = run_simplify(&r1, &m, default_ladder, 4, 1, 0) == LP_OK;
    ok &= run_simplify(&r2, &m, default_ladder, 4, 2, 0) == LP_OK;
    ok &= run_simplify(&r8, &m, default_ladder, 4, 8, 0) == LP_OK;
    if (ok) {
        char why[200];
        CHECK(same_result(&r1, &r2, why, sizeof why), "1 vs 2 threads: %s", why);
        CHECK(same_result(&r1, &r8, why, sizeof why), "1 vs 8 threads: %s", why);
        CHECK(r1.r.levels[0].stats.batches > 1, "several batches: %u", r1.r.levels[0].stats.batches);
        printf("#   sphere 1280: %u %u %u %u triangles; 1 thread %.2f s, 8 threads %.2f s\n",
               r1.r.levels[0].triangle_count, r1.r.levels[1].triangle_count, r1.r.levels[2].triangle_count,
               r1.r.levels[3].triangle_count, r1.seconds, r8.seconds);
        check_structure("sphere1280", &r8);
        check_topology("sphere1280", &r8, 2, 0);
    }
    run_free(&r1);
    run_free(&r2);
    run_free(&r8);
    /* and an open mesh with borders: the sawtooth */
    mesh_free(&m);
    mesh_init(&m);
    uint32_t first = mesh_grid(&m, 40, 20, 0, 1, 0, 0.5, NULL, NULL);
    for (uint32_t i = 0; i <= 40; ++i) m.pos[3 * (first + i) + 1] = (float)saw_y(i, 0.1);
    ok = run_simplify(&r1, &m, default_ladder, 4, 1, 0) == LP_OK;
    ok &= run_simplify(&r8, &m, default_ladder, 4, 8, 0) == LP_OK;
    if (ok) {
        char why[200];
        CHECK(same_result(&r1, &r8, why, sizeof why), "sawtooth, 1 vs 8 threads: %s", why);
    }
    run_free(&r1);
    run_free(&r8);
    mesh_free(&m);
}

/* ---- the invariant checker during real runs ----------------------------------- */

/* options.verify = 1 re-checks the registrations both ways, the faces and the
 * certificates after every commit: a real run must come through with LP_OK,
 * and produce exactly what the unchecked run produces. */
static void test_verify_mode(void)
{
    mesh m;
    mesh_init(&m);
    spike_ctx s = {10, 10, 29, 27, 0.15};
    mesh_grid(&m, 24, 24, 0, 1, 0, 1, spike_height, &s);
    run a, b;
    int ok = run_simplify(&a, &m, default_ladder, 4, 0, 1) == LP_OK;
    ok &= run_simplify(&b, &m, default_ladder, 4, 0, 0) == LP_OK;
    if (ok) {
        char why[200];
        CHECK(same_result(&a, &b, why, sizeof why), "verify changes the result: %s", why);
        CHECK(a.r.levels[0].stats.commits > 100, "commits %llu", (unsigned long long)a.r.levels[0].stats.commits);
    }
    run_free(&a);
    run_free(&b);
    mesh_free(&m);

    mesh_init(&m);
    build_torus(&m, 24, 12);
    ok = run_simplify(&a, &m, default_ladder, 4, 2, 1) == LP_OK;
    if (ok) check_topology("torus verify", &a, 0, 0);
    run_free(&a);
    mesh_free(&m);

    mesh_init(&m);
    build_box(&m, 8, 10.0, 0.05);
    ok = run_simplify(&a, &m, default_ladder, 4, 2, 1) == LP_OK;
    if (ok) check_topology("box verify", &a, 2, 0);
    run_free(&a);
    mesh_free(&m);
}

/* The batches' reservations next to hubs. A UV sphere's poles (48 faces
 * each) are hubs with the limit at 32, so the first ring is held and the
 * second ring's candidates have held neighbours: a reservation must see
 * another's W through a held vertex's star (the hub's star is not walked).
 * With placement on every level, a W (the 2-ball) holds the pole itself.
 * options.verify re-decides every reservation by walking the candidate's
 * 2-ball and fails on any difference; the checked run must also give exactly
 * the unchecked run's levels, with the poles' stars whole and the rest
 * simplified within its bounds. */
static void test_hub_reservations(void)
{
    const uint32_t segments = 48, rings = 10;
    mesh m;
    mesh_init(&m);
    const uint32_t north = mesh_vertex(&m, 0, 0, 1);
    for (uint32_t r = 1; r < rings; ++r)
        for (uint32_t i = 0; i < segments; ++i) {
            const double th = M_PI * r / rings, ph = 2.0 * M_PI * i / segments;
            mesh_vertex(&m, sin(th) * cos(ph), sin(th) * sin(ph), cos(th));
        }
    const uint32_t south = mesh_vertex(&m, 0, 0, -1);
#define RING(r, i) (north + 1 + ((r) - 1) * segments + (i) % segments)
    for (uint32_t i = 0; i < segments; ++i) mesh_tri(&m, north, RING(1, i), RING(1, i + 1));
    for (uint32_t r = 1; r + 1 < rings; ++r)
        for (uint32_t i = 0; i < segments; ++i) {
            mesh_tri(&m, RING(r, i), RING(r + 1, i), RING(r, i + 1));
            mesh_tri(&m, RING(r, i + 1), RING(r + 1, i), RING(r + 1, i + 1));
        }
    for (uint32_t i = 0; i < segments; ++i) mesh_tri(&m, south, RING(rings - 1, i + 1), RING(rings - 1, i));
#undef RING
    g_hub_faces = 32;
    g_full_edge_levels = 0xf;
    run checked, plain;
    int ok = run_simplify(&checked, &m, default_ladder, 4, 0, 1) == LP_OK;
    ok &= run_simplify(&plain, &m, default_ladder, 4, 0, 0) == LP_OK;
    g_hub_faces = 0;
    g_full_edge_levels = 0;
    if (ok) {
        char why[200];
        CHECK(same_result(&checked, &plain, why, sizeof why), "verify changes the result: %s", why);
        check_structure("uv sphere, hubs", &plain);
        check_topology("uv sphere, hubs", &plain, 2, 0);
        check_levels("uv sphere, hubs", &plain, 8);
        CHECK(plain.r.held_vertices == 2 + 2 * segments, "the poles and their rings are held: %u",
              plain.r.held_vertices);
        for (uint32_t k = 0; k < plain.r.level_count; ++k) {
            uint32_t at_poles = 0;
            const simplify_level *L = &plain.r.levels[k];
            for (uint32_t f = 0; f < L->triangle_count; ++f)
                for (int c = 0; c < 3; ++c) {
                    const uint32_t v = level_vertex(&plain, k, f, c);
                    at_poles += v == north || v == south;
                }
            CHECK(at_poles == 2 * segments, "level %u keeps the poles' %u faces: %u", k + 1, 2 * segments, at_poles);
            CHECK(L->triangle_count < m.nt * 3 / 4, "level %u simplifies between the held rings: %u of %u faces",
                  k + 1, L->triangle_count, m.nt);
        }
    }
    run_free(&checked);
    run_free(&plain);
    mesh_free(&m);
}

/* Two closed boxes that pass through each other (parts of one mesh that
 * overlap, as in many game and CAD assets): a slab A, 10 x 10 x 2, and a slab
 * B, 2 thick, standing upright through it. The guard refuses a new face
 * that crosses a face the faces it replaces did not already meet (README
 * "The guarantee"), so the crossing curves move with the faces that carry
 * them, and the flat sides simplify through them: every level keeps at most
 * 1/16 of the 2,304 input triangles (24 at the first level, the two boxes'
 * 12 each), where a guard refusing every crossing kept each face along them
 * (564 to 598). Every level keeps both boxes' topology, stays within
 * its bound, and is the same with the invariant checker on; neither box ever
 * crosses itself: only A's faces cross B's. */
static void test_crossing_parts(void)
{
    const uint32_t n = 16;
    mesh m;
    mesh_init(&m);
    build_box(&m, n, 10.0, 2.0);
    const uint32_t a_vertices = m.nv;
    build_box(&m, n, 10.0, 2.0);
    /* B: a proper rotation (x, y, z) -> (z, -y, x), then a shift that keeps
     * its corners off A's planes */
    for (uint32_t v = a_vertices; v < m.nv; ++v) {
        float *p = m.pos + 3 * (size_t)v;
        const float x = p[0], y = p[1], z = p[2];
        p[0] = z + 4.1f;
        p[1] = 10.3f - y;
        p[2] = x - 4.05f;
    }
    run rn, checked;
    int ok = run_simplify(&rn, &m, default_ladder, 4, 2, 0) == LP_OK;
    ok &= run_simplify(&checked, &m, default_ladder, 4, 1, 1) == LP_OK;
    if (ok) {
        char why[200];
        CHECK(same_result(&checked, &rn, why, sizeof why), "verify changes the result: %s", why);
        check_structure("crossing boxes", &rn);
        check_topology("crossing boxes", &rn, 4, 0);
        check_levels("crossing boxes", &rn, 8);
        for (uint32_t k = 0; k < rn.r.level_count; ++k) {
            const uint32_t count = rn.r.levels[k].triangle_count;
            CHECK(count <= m.nt / 16, "crossing boxes level %u keeps %u of %u triangles: the guard holds the faces "
                  "along the crossing", k + 1, count, m.nt);
            vec3d(*t)[3] = level_tris(&rn, k), (*part[2])[3];
            uint32_t part_count[2] = {0, 0};
            part[0] = malloc(((size_t)count + 1) * sizeof *part[0]);
            part[1] = malloc(((size_t)count + 1) * sizeof *part[1]);
            if (!part[0] || !part[1]) abort();
            for (uint32_t f = 0; f < count; ++f) { /* a level's corners are input vertices: A's or B's */
                int in_a = 0;
                for (uint32_t v = 0; v < a_vertices && !in_a; ++v)
                    in_a = t[f][0].x == m.pos[3 * v] && t[f][0].y == m.pos[3 * v + 1] && t[f][0].z == m.pos[3 * v + 2];
                memcpy(part[!in_a][part_count[!in_a]++], t[f], sizeof t[f]);
            }
            for (int b = 0; b < 2; ++b) {
                uint32_t ex[2], bad = count_intersections(part[b], part_count[b], ex);
                CHECK(bad == 0, "crossing boxes level %u: box %c (%u triangles) crosses itself in %u face pairs, e.g. %u "
                      "and %u", k + 1, "AB"[b], part_count[b], bad, ex[0], ex[1]);
            }
            uint32_t ex[2];
            CHECK(count_intersections(t, count, ex) > 0, "crossing boxes level %u: A no longer crosses B", k + 1);
            free(part[0]);
            free(part[1]);
            free(t);
        }
    }
    run_free(&rn);
    run_free(&checked);
    mesh_free(&m);
}

/* ---- vertex removal with another triangulation of the hole ---------------------- */

/* Where no collapse is certified, a vertex is removed with another
 * triangulation of its hole (simplify.h). On a bumpy sphere and a torus at
 * fine eps, where such vertices occur: some are removed, and every level still
 * passes everything a collapse must (sampled two-sided distance <= bound <=
 * eps, Euler characteristic and border loops, manifold, structure); with the
 * invariant checker on (it re-checks after every removal too) and with 1, 2
 * or 8 threads, the result is the same. */
static void test_removal(void)
{
    static const double fine[] = {0.001, 0.0025, 0.005, 0.01};
    mesh m;
    mesh_init(&m);
    build_icosphere(&m, 4, geom_vec3d(0, 0, 0));
    run a, b;
    if (run_simplify(&a, &m, fine, 4, 0, 0) == LP_OK) {
        CHECK(removals_of(&a) > 0, "bumpy sphere: no vertex removed");
        printf("#   bumpy sphere: %llu removals; %u %u %u %u triangles\n", (unsigned long long)removals_of(&a),
               a.r.levels[0].triangle_count, a.r.levels[1].triangle_count, a.r.levels[2].triangle_count,
               a.r.levels[3].triangle_count);
        check_structure("bumpy sphere", &a);
        check_topology("bumpy sphere", &a, 2, 0);
        check_levels("bumpy sphere", &a, 8);
    }
    run_free(&a);
    mesh_free(&m);

    mesh_init(&m);
    build_torus(&m, 96, 48);
    int ok = run_simplify(&a, &m, fine, 4, 1, 0) == LP_OK;
    ok &= run_simplify(&b, &m, fine, 4, 2, 1) == LP_OK;
    if (ok) {
        char why[200];
        CHECK(removals_of(&a) > 0, "torus: no vertex removed");
        CHECK(same_result(&a, &b, why, sizeof why), "torus, 1 thread vs 2 threads and the checker: %s", why);
        printf("#   torus: %llu removals\n", (unsigned long long)removals_of(&a));
        check_structure("torus", &a);
        check_topology("torus", &a, 0, 0);
        check_levels("torus", &a, 8);
    }
    run_free(&a);
    run_free(&b);
    if (run_simplify(&b, &m, fine, 4, 8, 0) == LP_OK && run_simplify(&a, &m, fine, 4, 1, 0) == LP_OK) {
        char why[200];
        CHECK(same_result(&a, &b, why, sizeof why), "torus, 1 vs 8 threads: %s", why);
    }
    run_free(&a);
    run_free(&b);
    mesh_free(&m);
}

/* ---- full-edge placement (lod.placement = "optimal") --------------------------- */

/* Vertices level k uses at a position other than the weld's. */
static uint32_t placed_vertices(const run *rn, uint32_t k)
{
    const simplify_level *L = &rn->r.levels[k];
    if (!L->positions) return 0;
    uint32_t n = 0;
    for (uint32_t v = 0; v < rn->w.vertex_count; ++v)
        n += level_has_vertex(rn, k, v) && memcmp(L->positions + 3 * (size_t)v, rn->w.positions + 3 * (size_t)v,
                                                   3 * sizeof(float)) != 0;
    return n;
}

/* Every level with placement allowed: sampled two-sided distance <= bound <=
 * eps on the placed positions, topology and structure as with half-edge
 * collapses, vertices really placed, no more triangles in total than the
 * half-edge run, the same result for 1, 2 and 8 threads and with the
 * invariant checker on. Placement on levels 3 and 4 only: levels 1 and 2 are
 * exactly the half-edge run's and carry no positions. One level alone: fewer
 * triangles than without placement (it starts where half-edge converged). */
static void test_optimal_placement(void)
{
    mesh m;
    mesh_init(&m);
    build_icosphere(&m, 4, geom_vec3d(0, 0, 0));
    run half, full, full2, full8, verified;
    g_full_edge_levels = 0;
    int ok = run_simplify(&half, &m, default_ladder, 4, 2, 0) == LP_OK;
    g_full_edge_levels = 0xf;
    ok &= run_simplify(&full, &m, default_ladder, 4, 1, 0) == LP_OK;
    ok &= run_simplify(&full2, &m, default_ladder, 4, 2, 0) == LP_OK;
    ok &= run_simplify(&full8, &m, default_ladder, 4, 8, 0) == LP_OK;
    ok &= run_simplify(&verified, &m, default_ladder, 4, 2, 1) == LP_OK;
    if (ok) {
        char why[200];
        check_structure("placed sphere", &full);
        check_topology("placed sphere", &full, 2, 0);
        check_levels("placed sphere", &full, 8);
        uint32_t sum_half = 0, sum_full = 0, placed = 0;
        for (uint32_t k = 0; k < 4; ++k) {
            sum_half += half.r.levels[k].triangle_count;
            sum_full += full.r.levels[k].triangle_count;
            placed += placed_vertices(&full, k);
            CHECK(full.r.levels[k].positions != NULL, "level %u carries positions", k);
            printf("#   level %u: half-edge %u triangles, placed %u triangles (%u vertices placed)\n", k,
                   half.r.levels[k].triangle_count, full.r.levels[k].triangle_count, placed_vertices(&full, k));
        }
        CHECK(placed > 0, "placement moved no vertex");
        CHECK(sum_full <= sum_half, "placement gave more triangles: %u > %u", sum_full, sum_half);
        CHECK(same_result(&full, &full2, why, sizeof why), "placed, 1 vs 2 threads: %s", why);
        CHECK(same_result(&full, &full8, why, sizeof why), "placed, 1 vs 8 threads: %s", why);
        CHECK(same_result(&full2, &verified, why, sizeof why), "placed, verify changes the result: %s", why);
    }
    run_free(&full);
    run_free(&full2);
    run_free(&full8);
    run_free(&verified);
    g_full_edge_levels = 0xc; /* levels 3 and 4 */
    if (run_simplify(&full, &m, default_ladder, 4, 2, 1) == LP_OK && ok) {
        /* the first two levels (no placement) are the half-edge run's */
        int same = 1;
        for (uint32_t k = 0; k < 2; ++k)
            same &= full.r.levels[k].triangle_count == half.r.levels[k].triangle_count &&
                    memcmp(full.r.levels[k].wedges, half.r.levels[k].wedges,
                           3 * (size_t)half.r.levels[k].triangle_count * sizeof(uint32_t)) == 0 &&
                    full.r.levels[k].positions == NULL;
        CHECK(same, "levels 1 and 2 without placement equal the half-edge run's");
        CHECK(full.r.levels[2].positions != NULL && placed_vertices(&full, 2) + placed_vertices(&full, 3) > 0,
              "levels 3 and 4 placed vertices");
        check_levels("placed levels 3-4", &full, 8);
        check_topology("placed levels 3-4", &full, 2, 0);
    }
    g_full_edge_levels = 0;
    run_free(&full);
    run_free(&half);

    /* one level: placement starts where half-edge collapses have converged,
     * so it can only remove more */
    static const double one[1] = {0.03};
    g_full_edge_levels = 0;
    ok = run_simplify(&half, &m, one, 1, 2, 0) == LP_OK;
    g_full_edge_levels = 1;
    ok &= run_simplify(&full, &m, one, 1, 2, 0) == LP_OK;
    if (ok) {
        CHECK(full.r.levels[0].triangle_count < half.r.levels[0].triangle_count,
              "one level: placed %u triangles, half-edge %u", full.r.levels[0].triangle_count,
              half.r.levels[0].triangle_count);
        check_levels("placed sphere, one level", &full, 8);
    }
    g_full_edge_levels = 0;
    run_free(&full);
    run_free(&half);
    mesh_free(&m);

    /* an open, bumpy sheet with a border: border vertices never move */
    mesh_init(&m);
    spike_ctx sc = {10, 10, 29, 27, 0.15};
    mesh_grid(&m, 24, 24, 0, 1, 0, 1, spike_height, &sc);
    g_full_edge_levels = 0xf;
    if (run_simplify(&full, &m, default_ladder, 4, 2, 1) == LP_OK) {
        check_levels("placed sheet", &full, 8);
        check_structure("placed sheet", &full);
        int border_kept = 1;
        for (uint32_t k = 0; k < 4; ++k)
            for (uint32_t v = 0; full.r.levels[k].positions && v < full.w.vertex_count; ++v)
                if (full.w.vertex_kind[v] != WELD_MANIFOLD &&
                    memcmp(full.r.levels[k].positions + 3 * (size_t)v, full.w.positions + 3 * (size_t)v, 3 * sizeof(float)))
                    border_kept = 0;
        CHECK(border_kept, "a border vertex was placed");
    }
    g_full_edge_levels = 0;
    run_free(&full);
    mesh_free(&m);
}

static void run_cases(void)
{
    RUN(test_spike_and_pit);
    RUN(test_v_groove);
    RUN(test_thin_plate);
    RUN(test_thin_plate_no_self_intersection);
    RUN(test_crossing_parts);
    RUN(test_sawtooth_border);
    RUN(test_materials);
    RUN(test_euler_closed);
    RUN(test_border_floors);
    RUN(test_translated_1e5);
    RUN(test_thread_count_invariance);
    RUN(test_verify_mode);
    RUN(test_hub_reservations);
    RUN(test_optimal_placement);
    RUN(test_removal);
}

int main(void)
{
    run_cases();
    RUN(test_hubs);
    RUN(test_patience);
    /* Every case again through region rounds (simplify.c: each region
     * simplified on its own, in parallel): regions of 64 vertices, so that
     * these small meshes have many regions and boundaries run everywhere. */
    g_region_vertices = 64;
    run_cases();
    RUN(test_hubs);
    RUN(test_patience);
    RUN(test_wavy_shell_regions);
    RUN(test_hill_over_coarse_hill_regions);
    RUN(test_double_sided_sheet);
    RUN(test_double_sided_decal);
    RUN(test_double_sided_shuffled);
    return check_summary();
}
