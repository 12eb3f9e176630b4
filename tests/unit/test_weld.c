/* test_weld.c - welding on small meshes built by hand: a flat-shaded cube (all
 * edges seams, corners locked), smooth octahedra and a triangle-soup sphere
 * (closed, manifold, Euler characteristic 2), open grids (border), a grid cut
 * into two materials (seam with locked ends), a cylinder with a UV seam, a
 * bow-tie, a pinch, a fin, an inconsistently oriented pair, degenerate
 * triangles, -0.0 against +0.0, skipped primitives, bad indices, and
 * determinism. Every result also goes through check_invariants, which
 * re-derives the adjacency from scratch. */
#include "check.h"
#include "weld.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* ---- building meshes ------------------------------------------------------ */

#define MAX_V 8192
#define MAX_T 8192
#define MAX_P 4

/* One primitive's data: positions and optional normals / UVs. */
typedef struct {
    float pos[3 * MAX_V], nrm[3 * MAX_V], uv[2 * MAX_V];
    uint32_t tri[3 * MAX_T];
    uint32_t vcount, tcount;
} pbuf;

typedef struct {
    scene_mesh mesh;
    scene_primitive prims[MAX_P];
    scene_stream streams[MAX_P][3];
} tmesh;

static pbuf *pbuf_new(void)
{
    pbuf *b = calloc(1, sizeof *b);
    if (!b) abort();
    return b;
}

static uint32_t pbuf_vertex(pbuf *b, float x, float y, float z, const float *n, const float *uv)
{
    uint32_t i = b->vcount++;
    if (i >= MAX_V) abort();
    b->pos[3 * i] = x;
    b->pos[3 * i + 1] = y;
    b->pos[3 * i + 2] = z;
    if (n) memcpy(&b->nrm[3 * i], n, 3 * sizeof(float));
    if (uv) memcpy(&b->uv[2 * i], uv, 2 * sizeof(float));
    return i;
}

static void pbuf_tri(pbuf *b, uint32_t a, uint32_t c, uint32_t d)
{
    uint32_t t = b->tcount++;
    if (t >= MAX_T) abort();
    b->tri[3 * t] = a;
    b->tri[3 * t + 1] = c;
    b->tri[3 * t + 2] = d;
}

static void tmesh_init(tmesh *m, const char *name)
{
    memset(m, 0, sizeof *m);
    m->mesh.name = name;
    m->mesh.primitives = m->prims;
}

/* Adds a triangle primitive reading b; streams: POSITION, then NORMAL and
 * TEXCOORD_0 when asked. */
static scene_primitive *tmesh_add(tmesh *m, pbuf *b, int64_t material, int with_normals, int with_uv)
{
    uint32_t p = m->mesh.primitive_count++;
    if (p >= MAX_P) abort();
    scene_primitive *pr = &m->prims[p];
    scene_stream *st = m->streams[p];
    pr->index = p;
    pr->mode = 4;
    pr->material = material;
    pr->indices = -1;
    pr->vertex_count = b->vcount;
    pr->positions = b->pos;
    pr->triangle_count = b->tcount;
    pr->triangles = b->tri;
    st[0].name = "POSITION";
    st[0].components = 3;
    st[0].values = b->pos;
    pr->stream_count = 1;
    if (with_normals) {
        st[pr->stream_count].name = "NORMAL";
        st[pr->stream_count].components = 3;
        st[pr->stream_count++].values = b->nrm;
    }
    if (with_uv) {
        st[pr->stream_count].name = "TEXCOORD_0";
        st[pr->stream_count].components = 2;
        st[pr->stream_count++].values = b->uv;
    }
    pr->streams = st;
    m->mesh.triangle_count += b->tcount;
    return pr;
}

/* ---- invariants, re-derived the slow way ------------------------------------ */

static uint32_t nxt(uint32_t e)
{
    return e % 3 == 2 ? e - 2 : e + 1;
}

static uint32_t fkey(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u == 0x80000000u ? 0u : u;
}

static int attrs_equal(const scene_mesh *m, uint32_t pa, uint32_t ia, uint32_t pb, uint32_t ib)
{
    if (pa != pb) return 0;
    const scene_primitive *pr = &m->primitives[pa];
    for (uint32_t s = 0; s < pr->stream_count; ++s) {
        const scene_stream *st = &pr->streams[s];
        for (uint32_t c = 0; c < st->components; ++c)
            if (fkey(st->values[ia * st->components + c]) != fkey(st->values[ib * st->components + c])) return 0;
    }
    return 1;
}

static void check_invariants(const weld_result *w, const scene_mesh *m)
{
    const weld_stats *s = &w->stats;
    uint32_t sum_v = 0, sum_w = 0;
    for (int k = 0; k < WELD_KIND_COUNT; ++k) {
        sum_v += s->vertices_by_kind[k];
        sum_w += s->wedges_by_kind[k];
    }
    CHECK(sum_v == w->vertex_count && s->vertices == w->vertex_count, "vertex counts %u %u %u", sum_v, s->vertices,
          w->vertex_count);
    CHECK(sum_w == w->wedge_count && s->wedges == w->wedge_count, "wedge counts %u %u", sum_w, w->wedge_count);
    CHECK(s->triangles == w->triangle_count, "triangles");
    CHECK(s->input_triangles == s->triangles + s->degenerate_triangles + s->back_triangles,
          "input = kept + dropped + backs");
    CHECK(s->back_triangles == w->back_count, "back count");
    CHECK(s->degenerate_dangling <= s->degenerate_triangles, "dangling <= dropped");

    /* corners, wedges, positions; numbering by first appearance */
    uint32_t next_v = 0, next_w = 0;
    int ok_corner = 1, ok_order = 1, ok_pos = 1;
    for (uint32_t t = 0; t < w->triangle_count; ++t) {
        const uint32_t *tv = &w->triangle_vertices[3 * t];
        if (tv[0] == tv[1] || tv[1] == tv[2] || tv[0] == tv[2]) ok_corner = 0;
        for (int c = 0; c < 3; ++c) {
            uint32_t wd = w->triangle_wedges[3 * t + (uint32_t)c];
            if (wd >= w->wedge_count || w->wedge_vertex[wd] != tv[c]) ok_corner = 0;
            if (w->wedge_primitive[wd] != w->triangle_primitive[t]) ok_corner = 0;
            if (tv[c] > next_v || wd > next_w) ok_order = 0;
            if (tv[c] == next_v) next_v++;
            if (wd == next_w) next_w++;
            const scene_primitive *pr = &m->primitives[w->wedge_primitive[wd]];
            for (int a = 0; a < 3; ++a)
                if (fkey(pr->positions[3 * w->wedge_index[wd] + (uint32_t)a]) != fkey(w->positions[3 * tv[c] + (uint32_t)a]))
                    ok_pos = 0;
        }
    }
    CHECK(ok_corner, "corners: distinct vertices, wedge vertex and primitive agree");
    /* then the dangling triangles' own positions and wedges, by first appearance among them; their
     * vertices locked */
    /* (backs were numbered where they came in the input, among the others: the
     * order is checked only without them; check_backs checks the backs) */
    if (w->back_count) ok_order = 1;
    uint32_t kept_wedges = next_w;
    for (uint32_t i = 0; i < 3 * w->back_count; ++i)
        if (w->back_wedges[i] + 1 > kept_wedges) kept_wedges = w->back_wedges[i] + 1;
    CHECK(w->dangling_count == s->degenerate_dangling, "dangling kept %u of %u", w->dangling_count, s->degenerate_dangling);
    int ok_dangling = 1;
    for (uint32_t i = 0; i < 3 * w->dangling_count; ++i) {
        uint32_t v = w->dangling_vertices[i], wd = w->dangling_wedges[i];
        if (wd >= w->wedge_count || w->wedge_vertex[wd] != v || w->vertex_kind[v] != WELD_LOCKED ||
            w->wedge_primitive[wd] != w->dangling_primitive[i / 3])
            ok_dangling = 0;
        if (!w->back_count && (v > next_v || wd > next_w)) ok_order = 0;
        if (v == next_v) next_v++;
        if (wd == next_w) next_w++;
        if (wd < w->wedge_count) {
            const scene_primitive *pr = &m->primitives[w->wedge_primitive[wd]];
            for (int a = 0; a < 3; ++a)
                if (fkey(pr->positions[3 * w->wedge_index[wd] + (uint32_t)a]) != fkey(w->positions[3 * v + (uint32_t)a]))
                    ok_pos = 0;
        }
    }
    CHECK(ok_dangling, "dangling triangles: wedge vertex and primitive agree, vertices locked");
    CHECK(ok_order && (w->back_count || (next_v == w->vertex_count && next_w == w->wedge_count)),
          "first-appearance numbering");
    CHECK(ok_pos, "wedge positions equal their vertex position");

    /* wedge classes: representative is the lowest equal wedge (a wedge only dangling triangles use is
     * its own class) */
    int ok_class = 1;
    uint32_t classes = 0;
    for (uint32_t a = 0; a < w->wedge_count; ++a) {
        uint32_t rep = a;
        for (uint32_t b = 0; b < a && a < kept_wedges; ++b)
            if (w->wedge_vertex[b] == w->wedge_vertex[a] &&
                attrs_equal(m, w->wedge_primitive[a], w->wedge_index[a], w->wedge_primitive[b], w->wedge_index[b])) {
                rep = b;
                break;
            }
        if (w->wedge_class[a] != rep) ok_class = 0;
        if (rep == a) classes++;
    }
    CHECK(ok_class, "wedge classes match brute force");
    CHECK(classes == s->wedge_classes, "class count %u vs %u", classes, s->wedge_classes);

    /* vertex -> triangles */
    int ok_csr = w->vertex_triangle_offsets[0] == 0 && w->vertex_triangle_offsets[w->vertex_count] == 3 * w->triangle_count;
    for (uint32_t v = 0; v < w->vertex_count && ok_csr; ++v) {
        uint32_t b = w->vertex_triangle_offsets[v], e = w->vertex_triangle_offsets[v + 1];
        uint32_t expect = 0;
        for (uint32_t i = 0; i < 3 * w->triangle_count; ++i) expect += w->triangle_vertices[i] == v;
        if (e < b || e - b != expect) ok_csr = 0;
        for (uint32_t i = b; i < e && ok_csr; ++i) {
            uint32_t t = w->vertex_triangles[i];
            if (i > b && t <= w->vertex_triangles[i - 1]) ok_csr = 0;
            const uint32_t *tv = &w->triangle_vertices[3 * t];
            if (tv[0] != v && tv[1] != v && tv[2] != v) ok_csr = 0;
        }
    }
    CHECK(ok_csr, "vertex-triangle CSR");

    /* edges, brute force over all pairs */
    int ok_edge = 1;
    uint32_t border = 0, nonmanifold = 0, seam = 0, edges = 0;
    const uint32_t corners = 3 * w->triangle_count;
    for (uint32_t e = 0; e < corners; ++e) {
        uint32_t a = w->triangle_vertices[e], b = w->triangle_vertices[nxt(e)];
        uint32_t uses = 0, reverse = 0, rev_edge = UINT32_MAX, lowest = e;
        for (uint32_t f = 0; f < corners; ++f) {
            uint32_t x = w->triangle_vertices[f], y = w->triangle_vertices[nxt(f)];
            if ((x == a && y == b) || (x == b && y == a)) {
                uses++;
                if (f < lowest) lowest = f;
            }
            if (x == b && y == a) {
                reverse++;
                rev_edge = f;
            }
        }
        uint32_t o = w->edge_opposite[e];
        uint8_t fl = w->edge_flags[e];
        if (uses == 1) {
            if (o != WELD_EDGE_IS_BORDER || fl != WELD_FLAG_BORDER) ok_edge = 0;
        } else if (uses == 2 && reverse == 1) {
            if (o != rev_edge || (fl & ~WELD_FLAG_SEAM)) ok_edge = 0;
            const uint32_t *cl = w->wedge_class, *tw = w->triangle_wedges;
            int differ = cl[tw[e]] != cl[tw[nxt(o)]] || cl[tw[nxt(e)]] != cl[tw[o]];
            if (differ != !!(fl & WELD_FLAG_SEAM)) ok_edge = 0;
            if ((w->edge_flags[o] & WELD_FLAG_SEAM) != (fl & WELD_FLAG_SEAM)) ok_edge = 0;
        } else {
            if (o != WELD_EDGE_IS_NONMANIFOLD || fl != WELD_FLAG_NONMANIFOLD) ok_edge = 0;
        }
        if (lowest == e) {
            edges++;
            border += uses == 1;
            nonmanifold += !(uses == 1 || (uses == 2 && reverse == 1));
            seam += !!(fl & WELD_FLAG_SEAM);
        }
    }
    CHECK(ok_edge, "opposite edges and flags match brute force");
    CHECK(edges == s->edges, "edges %u vs %u", edges, s->edges);
    CHECK(border == s->border_edges, "border edges %u vs %u", border, s->border_edges);
    CHECK(nonmanifold == s->nonmanifold_edges, "non-manifold edges %u vs %u", nonmanifold, s->nonmanifold_edges);
    CHECK(seam == s->seam_edges, "seam edges %u vs %u", seam, s->seam_edges);

    /* the kind rules, re-derived per vertex from the edges around it */
    int ok_kind = 1;
    for (uint32_t v = 0; v < w->vertex_count; ++v) {
        uint32_t vborder = 0, vseam = 0, vnm = 0, vchange = 0;
        for (uint32_t e = 0; e < corners; ++e) {
            uint32_t a = w->triangle_vertices[e], b = w->triangle_vertices[nxt(e)];
            if (a != v && b != v) continue;
            vborder += !!(w->edge_flags[e] & WELD_FLAG_BORDER);
            vnm += !!(w->edge_flags[e] & WELD_FLAG_NONMANIFOLD);
            uint32_t o = w->edge_opposite[e];
            /* each undirected seam edge has two sides: count it once */
            if ((w->edge_flags[e] & WELD_FLAG_SEAM) && e < o) {
                vseam++;
                const uint32_t *cl = w->wedge_class, *tw = w->triangle_wedges;
                vchange += a == v ? cl[tw[e]] != cl[tw[nxt(o)]] : cl[tw[nxt(e)]] != cl[tw[o]];
            }
        }
        int kind = w->vertex_kind[v];
        if (vnm && kind != WELD_LOCKED) ok_kind = 0;
        if (kind == WELD_MANIFOLD && (vborder || vchange)) ok_kind = 0;
        if (kind == WELD_BORDER && (vborder != 2 || vchange)) ok_kind = 0;
        if (kind == WELD_SEAM && (vborder || vseam != 2 || vchange != 2)) ok_kind = 0;
        int dangles = 0;
        for (uint32_t i = 0; i < 3 * w->dangling_count; ++i) dangles |= w->dangling_vertices[i] == v;
        /* a back border (weld.h): two triangles of one primitive around v differ in their back's
         * primitive, or in having one */
        int back_border = 0;
        for (uint32_t t = 0; t < w->triangle_count && w->back_count && !back_border; ++t) {
            const uint32_t *tv = &w->triangle_vertices[3 * t];
            if (tv[0] != v && tv[1] != v && tv[2] != v) continue;
            for (uint32_t u = t + 1; u < w->triangle_count; ++u) {
                const uint32_t *uv = &w->triangle_vertices[3 * u];
                if ((uv[0] != v && uv[1] != v && uv[2] != v) || w->triangle_primitive[u] != w->triangle_primitive[t])
                    continue;
                const uint32_t bt = w->triangle_back[t], bu = w->triangle_back[u];
                const uint64_t st = bt == WELD_NO_BACK ? UINT32_MAX : w->back_primitive[bt];
                const uint64_t su = bu == WELD_NO_BACK ? UINT32_MAX : w->back_primitive[bu];
                if (st != su) back_border = 1;
            }
        }
        if (back_border && kind != WELD_LOCKED) ok_kind = 0;
        dangles |= back_border;
        if (kind == WELD_LOCKED && !vnm && vborder == 0 && vchange == 0 && !dangles) {
            /* locked without a reason at the edges or a dangling triangle: must be several fans */
            if (w->stats.nonmanifold_vertices == 0) ok_kind = 0;
        }
    }
    CHECK(ok_kind, "kinds agree with the edges around each vertex");
}

/* Each back (weld.h) is the reverse of exactly one front triangle, its wedges
 * sit on the front's vertices in the back's primitive, and weld_back_wedge
 * gives the back's class for the front's class at each corner. */
static void check_backs(const weld_result *w)
{
    uint8_t *used = calloc((size_t)w->back_count + 1, 1);
    int ok = used != NULL;
    uint32_t fronts = 0;
    for (uint32_t t = 0; t < w->triangle_count && ok && w->back_count; ++t) {
        const uint32_t b = w->triangle_back[t];
        if (b == WELD_NO_BACK) continue;
        fronts++;
        if (b >= w->back_count || used[b]) {
            ok = 0;
            break;
        }
        used[b] = 1;
        const uint32_t *tv = &w->triangle_vertices[3 * t], *bw = &w->back_wedges[3 * b];
        /* the back, read in reverse from the corner on tv[0], must be tv */
        int start = -1;
        for (int k = 0; k < 3; ++k)
            if (w->wedge_vertex[bw[k]] == tv[0]) start = k;
        if (start < 0) {
            ok = 0;
            break;
        }
        for (int k = 0; k < 3; ++k) {
            const uint32_t back_wedge = bw[(start + 3 - k) % 3];
            if (w->wedge_vertex[back_wedge] != tv[k] || w->wedge_primitive[back_wedge] != w->back_primitive[b]) ok = 0;
            const uint32_t front_class = w->wedge_class[w->triangle_wedges[3 * t + (uint32_t)k]];
            if (weld_back_wedge(w, front_class, w->back_primitive[b]) != w->wedge_class[back_wedge]) ok = 0;
        }
    }
    CHECK(ok && fronts == w->back_count, "backs: %u fronts for %u backs, each the reverse of its front", fronts,
          w->back_count);
    free(used);
}

static int euler(const weld_result *w)
{
    return (int)w->vertex_count - (int)w->stats.edges + (int)w->triangle_count;
}

static uint32_t count_kind(const weld_result *w, weld_kind k)
{
    return w->stats.vertices_by_kind[k];
}

/* Position vertex at exactly (x, y, z), or UINT32_MAX. */
static uint32_t find_vertex(const weld_result *w, float x, float y, float z)
{
    for (uint32_t v = 0; v < w->vertex_count; ++v)
        if (w->positions[3 * v] == x && w->positions[3 * v + 1] == y && w->positions[3 * v + 2] == z) return v;
    return UINT32_MAX;
}

static int weld_ok(const tmesh *m, weld_result *w)
{
    lp_error err;
    memset(&err, 0, sizeof err);
    int rc = weld_build(&m->mesh, 1, w, &err);
    CHECK(rc == LP_OK, "weld_build failed: %s", err.msg);
    if (rc == LP_OK) check_invariants(w, &m->mesh);
    if (rc == LP_OK) check_backs(w);
    return rc == LP_OK;
}

/* ---- shapes ----------------------------------------------------------------- */

/* Cube [-1,1]^3 as 6 separate quads (24 vertices) with face normals. */
static void build_cube(pbuf *b)
{
    for (int k = 0; k < 3; ++k)
        for (int s = -1; s <= 1; s += 2) {
            int u = (k + 1) % 3, v = (k + 2) % 3;
            float n[3] = {0, 0, 0};
            n[k] = (float)s;
            static const float ab[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
            uint32_t q[4];
            for (int i = 0; i < 4; ++i) {
                float p[3];
                p[k] = (float)s;
                p[u] = ab[i][0];
                p[v] = ab[i][1];
                float uv[2] = {ab[i][0] * 0.5f + 0.5f, ab[i][1] * 0.5f + 0.5f};
                q[i] = pbuf_vertex(b, p[0], p[1], p[2], n, uv);
            }
            if (s > 0) {
                pbuf_tri(b, q[0], q[1], q[2]);
                pbuf_tri(b, q[0], q[2], q[3]);
            } else {
                pbuf_tri(b, q[0], q[2], q[1]);
                pbuf_tri(b, q[0], q[3], q[2]);
            }
        }
}

static const float octa_pos[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
/* outward, consistently oriented */
static const uint32_t octa_tri[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                        {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};

/* Octahedron subdivided `levels` times onto the unit sphere, as a triangle
 * soup (every triangle has its own three vertices), normal = position. The
 * midpoint of an edge is computed the same way from both sides ((a + b) is
 * commutative), so shared vertices are bitwise equal. */
static void soup_sphere_rec(pbuf *b, const float *p0, const float *p1, const float *p2, int level)
{
    if (level == 0) {
        uint32_t a = pbuf_vertex(b, p0[0], p0[1], p0[2], p0, NULL);
        uint32_t c = pbuf_vertex(b, p1[0], p1[1], p1[2], p1, NULL);
        uint32_t d = pbuf_vertex(b, p2[0], p2[1], p2[2], p2, NULL);
        pbuf_tri(b, a, c, d);
        return;
    }
    float m[3][3];
    const float *ends[3][2] = {{p0, p1}, {p1, p2}, {p2, p0}};
    for (int i = 0; i < 3; ++i) {
        float x = ends[i][0][0] + ends[i][1][0], y = ends[i][0][1] + ends[i][1][1], z = ends[i][0][2] + ends[i][1][2];
        float len = sqrtf(x * x + y * y + z * z);
        m[i][0] = x / len;
        m[i][1] = y / len;
        m[i][2] = z / len;
    }
    soup_sphere_rec(b, p0, m[0], m[2], level - 1);
    soup_sphere_rec(b, m[0], p1, m[1], level - 1);
    soup_sphere_rec(b, m[2], m[1], p2, level - 1);
    soup_sphere_rec(b, m[0], m[1], m[2], level - 1);
}

/* Grid columns i0..i1 (vertices), rows 0..n, spacing 1, uv = (i/n, j/n). */
static void build_grid(pbuf *b, int i0, int i1, int n)
{
    uint32_t base = b->vcount;
    int cols = i1 - i0 + 1;
    float nrm[3] = {0, 0, 1};
    for (int j = 0; j <= n; ++j)
        for (int i = i0; i <= i1; ++i) {
            float uv[2] = {(float)i / (float)n, (float)j / (float)n};
            pbuf_vertex(b, (float)i, (float)j, 0.0f, nrm, uv);
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < cols - 1; ++i) {
            uint32_t a = base + (uint32_t)(j * cols + i), c = a + 1, d = a + (uint32_t)cols + 1, e = a + (uint32_t)cols;
            pbuf_tri(b, a, c, d);
            pbuf_tri(b, a, d, e);
        }
}

/* Open cylinder: n segments around, rows 0..rows, the column at angle 0
 * stored twice (u = 0 and u = 1) with the same position and normal. */
static void build_cylinder(pbuf *b, int n, int rows)
{
    for (int r = 0; r <= rows; ++r)
        for (int j = 0; j <= n; ++j) {
            double ang = 2.0 * 3.14159265358979323846 * (double)(j % n) / (double)n;
            float c = (float)cos(ang), s = (float)sin(ang);
            float nrm[3] = {c, s, 0};
            float uv[2] = {(float)j / (float)n, (float)r / (float)rows};
            pbuf_vertex(b, c, s, (float)r, nrm, uv);
        }
    for (int r = 0; r < rows; ++r)
        for (int j = 0; j < n; ++j) {
            uint32_t a = (uint32_t)(r * (n + 1) + j), c = a + 1, d = a + (uint32_t)n + 2, e = a + (uint32_t)n + 1;
            pbuf_tri(b, a, c, d);
            pbuf_tri(b, a, d, e);
        }
}

/* ---- tests ------------------------------------------------------------------ */

static void test_cube_flat_shaded(void)
{
    pbuf *b = pbuf_new();
    build_cube(b);
    tmesh m;
    tmesh_init(&m, "cube");
    tmesh_add(&m, b, 0, 1, 1);
    weld_result w;
    if (weld_ok(&m, &w)) {
        CHECK(w.vertex_count == 8, "vertices %u", w.vertex_count);
        CHECK(w.wedge_count == 24, "wedges %u", w.wedge_count);
        CHECK(w.stats.wedge_classes == 24, "classes %u", w.stats.wedge_classes);
        CHECK(w.triangle_count == 12, "triangles %u", w.triangle_count);
        CHECK(w.stats.edges == 18, "edges %u", w.stats.edges);
        /* the 12 cube edges are seams (normals differ); the 6 face diagonals are not */
        CHECK(w.stats.seam_edges == 12, "every cube edge is a seam: %u", w.stats.seam_edges);
        for (uint32_t e = 0; e < 3 * w.triangle_count; ++e) {
            const float *p = &w.positions[3 * w.triangle_vertices[e]];
            const float *q = &w.positions[3 * w.triangle_vertices[e % 3 == 2 ? e - 2 : e + 1]];
            int differ = (p[0] != q[0]) + (p[1] != q[1]) + (p[2] != q[2]);
            CHECK(!!(w.edge_flags[e] & WELD_FLAG_SEAM) == (differ == 1), "edge %u: seam iff a cube edge", e);
        }
        CHECK(w.stats.border_edges == 0 && w.stats.nonmanifold_edges == 0, "closed, manifold");
        CHECK(count_kind(&w, WELD_LOCKED) == 8, "all 8 corners locked: %u", count_kind(&w, WELD_LOCKED));
        CHECK(w.stats.wedges_by_kind[WELD_LOCKED] == 24, "wedges on locked vertices");
        CHECK(euler(&w) == 2, "Euler %d", euler(&w));
        CHECK(w.vertex_triangle_offsets[1] - w.vertex_triangle_offsets[0] > 0, "vertex 0 has triangles");
    }
    weld_free(&w);

    /* the same cube with positions only: one class per vertex, all manifold */
    tmesh_init(&m, "cube-positions");
    tmesh_add(&m, b, 0, 0, 0);
    if (weld_ok(&m, &w)) {
        CHECK(w.wedge_count == 24 && w.stats.wedge_classes == 8, "wedges %u classes %u", w.wedge_count,
              w.stats.wedge_classes);
        CHECK(w.stats.seam_edges == 0, "no seams: %u", w.stats.seam_edges);
        CHECK(count_kind(&w, WELD_MANIFOLD) == 8, "manifold %u", count_kind(&w, WELD_MANIFOLD));
    }
    weld_free(&w);
    free(b);
}

static void test_octahedron_smooth(void)
{
    pbuf *b = pbuf_new();
    for (int i = 0; i < 6; ++i) pbuf_vertex(b, octa_pos[i][0], octa_pos[i][1], octa_pos[i][2], octa_pos[i], NULL);
    for (int t = 0; t < 8; ++t) pbuf_tri(b, octa_tri[t][0], octa_tri[t][1], octa_tri[t][2]);
    tmesh m;
    tmesh_init(&m, "octahedron");
    tmesh_add(&m, b, -1, 1, 0);
    weld_result w;
    if (weld_ok(&m, &w)) {
        CHECK(w.vertex_count == 6 && w.wedge_count == 6 && w.triangle_count == 8, "V %u W %u T %u", w.vertex_count,
              w.wedge_count, w.triangle_count);
        CHECK(count_kind(&w, WELD_MANIFOLD) == 6, "all manifold: %u", count_kind(&w, WELD_MANIFOLD));
        CHECK(w.stats.border_edges == 0 && w.stats.seam_edges == 0 && w.stats.nonmanifold_edges == 0, "clean");
        CHECK(euler(&w) == 2, "Euler %d", euler(&w));
        /* first appearance: triangle 0 is (0, 2, 4) */
        CHECK(w.positions[3 * 1 + 1] == 1.0f && w.positions[3 * 2 + 2] == 1.0f, "vertex order");
        for (uint32_t e = 0; e < 3 * w.triangle_count; ++e)
            CHECK(w.edge_opposite[e] < 3 * w.triangle_count, "edge %u has an opposite", e);
    }
    weld_free(&w);
    free(b);
}

static void test_soup_sphere(void)
{
    pbuf *b = pbuf_new();
    for (int t = 0; t < 8; ++t)
        soup_sphere_rec(b, octa_pos[octa_tri[t][0]], octa_pos[octa_tri[t][1]], octa_pos[octa_tri[t][2]], 2);
    tmesh m;
    tmesh_init(&m, "soup-sphere");
    tmesh_add(&m, b, -1, 1, 0);
    weld_result w;
    if (weld_ok(&m, &w)) {
        CHECK(w.triangle_count == 128, "F %u", w.triangle_count);
        CHECK(w.vertex_count == 66, "V %u", w.vertex_count);
        CHECK(w.stats.edges == 192, "E %u", w.stats.edges);
        CHECK(w.wedge_count == 384 && w.stats.wedge_classes == 66, "W %u classes %u", w.wedge_count,
              w.stats.wedge_classes);
        CHECK(count_kind(&w, WELD_MANIFOLD) == 66, "all manifold: %u", count_kind(&w, WELD_MANIFOLD));
        CHECK(euler(&w) == 2, "Euler %d", euler(&w));
    }
    weld_free(&w);
    free(b);
}

static void test_open_grid(void)
{
    pbuf *b = pbuf_new();
    build_grid(b, 0, 4, 4);
    tmesh m;
    tmesh_init(&m, "grid");
    tmesh_add(&m, b, 0, 1, 1);
    weld_result w;
    if (weld_ok(&m, &w)) {
        CHECK(w.vertex_count == 25 && w.triangle_count == 32, "V %u T %u", w.vertex_count, w.triangle_count);
        CHECK(count_kind(&w, WELD_BORDER) == 16, "border %u", count_kind(&w, WELD_BORDER));
        CHECK(count_kind(&w, WELD_MANIFOLD) == 9, "manifold %u", count_kind(&w, WELD_MANIFOLD));
        CHECK(w.stats.border_edges == 16, "border edges %u", w.stats.border_edges);
        CHECK(euler(&w) == 1, "Euler %d (a disk)", euler(&w));
        static const float corners[4][2] = {{0, 0}, {4, 0}, {4, 4}, {0, 4}};
        for (int i = 0; i < 4; ++i) {
            uint32_t v = find_vertex(&w, corners[i][0], corners[i][1], 0);
            CHECK(v != UINT32_MAX && w.vertex_kind[v] == WELD_BORDER, "grid corner %d is a border vertex", i);
        }
        uint32_t centre = find_vertex(&w, 2, 2, 0);
        CHECK(centre != UINT32_MAX && w.vertex_kind[centre] == WELD_MANIFOLD, "centre manifold");
    }
    weld_free(&w);
    free(b);
}

static void test_grid_two_materials(void)
{
    pbuf *left = pbuf_new(), *right = pbuf_new();
    build_grid(left, 0, 2, 4);
    build_grid(right, 2, 4, 4);
    tmesh m;
    tmesh_init(&m, "grid-2mat");
    tmesh_add(&m, left, 0, 1, 1);
    tmesh_add(&m, right, 1, 1, 1);
    weld_result w;
    if (weld_ok(&m, &w)) {
        CHECK(w.vertex_count == 25 && w.wedge_count == 30, "V %u W %u", w.vertex_count, w.wedge_count);
        CHECK(w.stats.seam_edges == 4, "seam edges along x = 2: %u", w.stats.seam_edges);
        for (int j = 0; j <= 4; ++j) {
            uint32_t v = find_vertex(&w, 2, (float)j, 0);
            int expect = (j == 0 || j == 4) ? WELD_LOCKED : WELD_SEAM;
            CHECK(v != UINT32_MAX && w.vertex_kind[v] == expect, "(2,%d) is %s", j,
                  v == UINT32_MAX ? "missing" : weld_kind_name((weld_kind)w.vertex_kind[v]));
        }
        CHECK(count_kind(&w, WELD_SEAM) == 3 && count_kind(&w, WELD_LOCKED) == 2, "seam %u locked %u",
              count_kind(&w, WELD_SEAM), count_kind(&w, WELD_LOCKED));
        CHECK(count_kind(&w, WELD_BORDER) == 14 && count_kind(&w, WELD_MANIFOLD) == 6, "border %u manifold %u",
              count_kind(&w, WELD_BORDER), count_kind(&w, WELD_MANIFOLD));
        CHECK(w.stats.border_edges == 16, "still one boundary: %u", w.stats.border_edges);
        for (uint32_t t = 0; t < w.triangle_count; ++t) {
            float cx = (w.positions[3 * w.triangle_vertices[3 * t]] + w.positions[3 * w.triangle_vertices[3 * t + 1]] +
                        w.positions[3 * w.triangle_vertices[3 * t + 2]]) / 3.0f;
            CHECK(w.triangle_primitive[t] == (cx < 2.0f ? 0u : 1u), "triangle %u primitive", t);
        }
    }
    weld_free(&w);

    /* the same split inside ONE primitive with equal attribute values: no seam */
    pbuf *one = pbuf_new();
    build_grid(one, 0, 2, 4);
    build_grid(one, 2, 4, 4);
    tmesh_init(&m, "grid-duplicated");
    tmesh_add(&m, one, 0, 1, 1);
    if (weld_ok(&m, &w)) {
        CHECK(w.wedge_count == 30 && w.stats.wedge_classes == 25, "W %u classes %u", w.wedge_count,
              w.stats.wedge_classes);
        CHECK(w.stats.seam_edges == 0, "equal values are no seam: %u", w.stats.seam_edges);
        CHECK(count_kind(&w, WELD_MANIFOLD) == 9 && count_kind(&w, WELD_BORDER) == 16, "kinds");
    }
    weld_free(&w);
    free(left);
    free(right);
    free(one);
}

/* A UV cut that ends inside the surface: on the 4x4 grid, the triangles right
 * of x = 2 and below y = 2 use their own copies of (2,0) and (2,1) with u
 * shifted. (2,1) has two seam edges (SEAM), (2,0) is a border vertex on the
 * seam (LOCKED), and (2,2), where the cut ends, has ONE seam edge, whose
 * change is at the far end, and one wedge class: MANIFOLD, but it must not
 * collapse along the cut (that would merge the two wedges of (2,1)). */
static void test_seam_loose_end(void)
{
    pbuf *b = pbuf_new();
    build_grid(b, 0, 4, 4);
    float nrm[3] = {0, 0, 1};
    float uv0[2] = {0.5f + 0.5f, 0.0f}, uv1[2] = {0.5f + 0.5f, 0.25f};
    uint32_t copy0 = pbuf_vertex(b, 2, 0, 0, nrm, uv0), copy1 = pbuf_vertex(b, 2, 1, 0, nrm, uv1);
    const uint32_t orig0 = 2, orig1 = 5 + 2; /* (i, j) is vertex j * 5 + i */
    for (uint32_t t = 0; t < b->tcount; ++t) {
        uint32_t *tri = &b->tri[3 * t];
        float cx = (b->pos[3 * tri[0]] + b->pos[3 * tri[1]] + b->pos[3 * tri[2]]) / 3.0f;
        float cy = (b->pos[3 * tri[0] + 1] + b->pos[3 * tri[1] + 1] + b->pos[3 * tri[2] + 1]) / 3.0f;
        if (cx < 2.0f || cy > 2.0f) continue;
        for (int c = 0; c < 3; ++c) {
            if (tri[c] == orig0) tri[c] = copy0;
            if (tri[c] == orig1) tri[c] = copy1;
        }
    }
    tmesh m;
    tmesh_init(&m, "slit");
    tmesh_add(&m, b, 0, 1, 1);
    weld_result w;
    if (weld_ok(&m, &w)) {
        CHECK(w.stats.seam_edges == 2, "seam edges %u", w.stats.seam_edges);
        uint32_t v0 = find_vertex(&w, 2, 0, 0), v1 = find_vertex(&w, 2, 1, 0), v2 = find_vertex(&w, 2, 2, 0);
        CHECK(v0 != UINT32_MAX && w.vertex_kind[v0] == WELD_LOCKED, "(2,0) border on seam: locked");
        CHECK(v1 != UINT32_MAX && w.vertex_kind[v1] == WELD_SEAM, "(2,1) seam");
        CHECK(v2 != UINT32_MAX && w.vertex_kind[v2] == WELD_MANIFOLD, "(2,2) end of the cut: manifold");
        CHECK(count_kind(&w, WELD_MANIFOLD) == 8 && count_kind(&w, WELD_BORDER) == 15, "manifold %u border %u",
              count_kind(&w, WELD_MANIFOLD), count_kind(&w, WELD_BORDER));
        uint32_t along = 0, across = 0;
        for (uint32_t e = 0; e < 3 * w.triangle_count && v2 != UINT32_MAX; ++e) {
            if (w.triangle_vertices[e] != v2) continue; /* edges leaving (2,2) */
            if (w.triangle_vertices[nxt(e)] == v1) {
                along++;
                CHECK(!weld_collapse_allowed(WELD_MANIFOLD, w.edge_flags[e]), "not along the cut");
            } else {
                across++;
                CHECK(weld_collapse_allowed(WELD_MANIFOLD, w.edge_flags[e]), "any other way");
            }
        }
        CHECK(along == 1 && across == 5, "edges leaving (2,2): %u along, %u others", along, across);
    }
    weld_free(&w);
    free(b);
}

/* A UV-sphere style bipyramid: a ring of 6 shared vertices and two poles,
 * each pole stored once per triangle with its own u (as UV spheres do). Every
 * spoke is a seam; the poles (six seam edges, six classes) are LOCKED; the
 * ring vertices keep one value all around: MANIFOLD, not along the spokes. */
static void test_pole_fan(void)
{
    const int n = 6;
    pbuf *b = pbuf_new();
    float nrm[3] = {0, 0, 1};
    for (int j = 0; j < n; ++j) {
        double ang = 2.0 * 3.14159265358979323846 * j / n;
        float uv[2] = {(float)j / (float)n, 0.5f};
        pbuf_vertex(b, (float)cos(ang), (float)sin(ang), 0, nrm, uv);
    }
    for (int j = 0; j < n; ++j) {
        uint32_t a = (uint32_t)j, c = (uint32_t)((j + 1) % n);
        float uv_top[2] = {((float)j + 0.5f) / (float)n, 1.0f}, uv_bot[2] = {((float)j + 0.5f) / (float)n, 0.0f};
        uint32_t top = pbuf_vertex(b, 0, 0, 1, nrm, uv_top), bot = pbuf_vertex(b, 0, 0, -1, nrm, uv_bot);
        pbuf_tri(b, a, c, top);
        pbuf_tri(b, c, a, bot);
    }
    tmesh m;
    tmesh_init(&m, "bipyramid");
    tmesh_add(&m, b, 0, 1, 1);
    weld_result w;
    if (weld_ok(&m, &w)) {
        CHECK(w.vertex_count == 8 && euler(&w) == 2, "V %u Euler %d", w.vertex_count, euler(&w));
        CHECK(w.stats.seam_edges == 12, "spokes are seams: %u", w.stats.seam_edges);
        CHECK(count_kind(&w, WELD_LOCKED) == 2, "poles locked: %u", count_kind(&w, WELD_LOCKED));
        CHECK(count_kind(&w, WELD_MANIFOLD) == 6, "ring manifold: %u", count_kind(&w, WELD_MANIFOLD));
        uint32_t top = find_vertex(&w, 0, 0, 1);
        CHECK(top != UINT32_MAX && w.vertex_kind[top] == WELD_LOCKED, "top pole locked");
    }
    weld_free(&w);
    free(b);
}

static void test_cylinder_uv_seam(void)
{
    const int n = 8, rows = 3;
    pbuf *b = pbuf_new();
    build_cylinder(b, n, rows);
    tmesh m;
    tmesh_init(&m, "cylinder");
    tmesh_add(&m, b, 0, 1, 1);
    weld_result w;
    if (weld_ok(&m, &w)) {
        CHECK(w.vertex_count == (uint32_t)(n * (rows + 1)), "V %u", w.vertex_count);
        CHECK(w.wedge_count == (uint32_t)((n + 1) * (rows + 1)), "W %u", w.wedge_count);
        CHECK(w.stats.seam_edges == (uint32_t)rows, "seam edges %u", w.stats.seam_edges);
        CHECK(w.stats.border_edges == (uint32_t)(2 * n), "border edges %u", w.stats.border_edges);
        CHECK(euler(&w) == 0, "Euler %d (an annulus)", euler(&w));
        for (int r = 0; r <= rows; ++r) {
            uint32_t v = find_vertex(&w, 1.0f, 0.0f, (float)r);
            int expect = (r == 0 || r == rows) ? WELD_LOCKED : WELD_SEAM;
            CHECK(v != UINT32_MAX && w.vertex_kind[v] == expect, "seam row %d is %s", r,
                  v == UINT32_MAX ? "missing" : weld_kind_name((weld_kind)w.vertex_kind[v]));
        }
        CHECK(count_kind(&w, WELD_SEAM) == (uint32_t)(rows - 1), "seam %u", count_kind(&w, WELD_SEAM));
        CHECK(count_kind(&w, WELD_LOCKED) == 2, "locked %u", count_kind(&w, WELD_LOCKED));
        CHECK(count_kind(&w, WELD_BORDER) == (uint32_t)(2 * (n - 1)), "border %u", count_kind(&w, WELD_BORDER));
        CHECK(count_kind(&w, WELD_MANIFOLD) == (uint32_t)((rows - 1) * (n - 1)), "manifold %u",
              count_kind(&w, WELD_MANIFOLD));
        /* mirrored-UV style: the two wedges on the seam have equal normals */
        uint32_t v = find_vertex(&w, 1.0f, 0.0f, 1.0f);
        uint32_t found = 0, wa = 0, wb = 0;
        for (uint32_t i = 0; i < w.wedge_count; ++i)
            if (w.wedge_vertex[i] == v) {
                if (found == 0) wa = i;
                else wb = i;
                found++;
            }
        CHECK(found == 2, "two wedges on the seam vertex: %u", found);
        if (found == 2) {
            CHECK(memcmp(&b->nrm[3 * w.wedge_index[wa]], &b->nrm[3 * w.wedge_index[wb]], 3 * sizeof(float)) == 0,
                  "same normal on both sides");
            CHECK(b->uv[2 * w.wedge_index[wa]] != b->uv[2 * w.wedge_index[wb]], "different u");
            CHECK(w.wedge_class[wa] != w.wedge_class[wb], "different classes");
        }
    }
    weld_free(&w);
    free(b);
}

static void test_bowtie_and_pinch(void)
{
    pbuf *b = pbuf_new();
    pbuf_vertex(b, 0, 0, 0, NULL, NULL);
    pbuf_vertex(b, 1, 0, 0, NULL, NULL);
    pbuf_vertex(b, 1, 1, 0, NULL, NULL);
    pbuf_vertex(b, -1, 0, 0, NULL, NULL);
    pbuf_vertex(b, -1, -1, 0, NULL, NULL);
    pbuf_tri(b, 0, 1, 2);
    pbuf_tri(b, 0, 3, 4);
    tmesh m;
    tmesh_init(&m, "bowtie");
    tmesh_add(&m, b, 0, 0, 0);
    weld_result w;
    if (weld_ok(&m, &w)) {
        CHECK(w.vertex_kind[0] == WELD_LOCKED, "centre locked: %s", weld_kind_name((weld_kind)w.vertex_kind[0]));
        CHECK(w.stats.nonmanifold_vertices == 1, "non-manifold vertices %u", w.stats.nonmanifold_vertices);
        CHECK(w.stats.nonmanifold_edges == 0, "no non-manifold edge");
        CHECK(count_kind(&w, WELD_BORDER) == 4, "the rest border: %u", count_kind(&w, WELD_BORDER));
        CHECK(w.stats.border_edges == 6, "border edges %u", w.stats.border_edges);
    }
    weld_free(&w);

    /* two closed tetrahedra touching at one vertex: no border, still locked */
    pbuf *p = pbuf_new();
    static const uint32_t tet[4][3] = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};
    pbuf_vertex(p, 0, 0, 0, NULL, NULL);
    pbuf_vertex(p, 1, 0, 0, NULL, NULL);
    pbuf_vertex(p, 0, 1, 0, NULL, NULL);
    pbuf_vertex(p, 1, 1, 1, NULL, NULL);
    pbuf_vertex(p, -1, 0, 0, NULL, NULL);
    pbuf_vertex(p, 0, -1, 0, NULL, NULL);
    pbuf_vertex(p, -1, -1, -1, NULL, NULL);
    for (int t = 0; t < 4; ++t) pbuf_tri(p, tet[t][0], tet[t][1], tet[t][2]);
    for (int t = 0; t < 4; ++t)
        pbuf_tri(p, tet[t][0] ? tet[t][0] + 3 : 0, tet[t][1] ? tet[t][1] + 3 : 0, tet[t][2] ? tet[t][2] + 3 : 0);
    tmesh_init(&m, "pinch");
    tmesh_add(&m, p, 0, 0, 0);
    if (weld_ok(&m, &w)) {
        CHECK(w.stats.border_edges == 0 && w.stats.nonmanifold_edges == 0, "closed, manifold edges");
        CHECK(w.vertex_kind[0] == WELD_LOCKED, "pinch vertex locked");
        CHECK(w.stats.nonmanifold_vertices == 1, "non-manifold vertices %u", w.stats.nonmanifold_vertices);
        CHECK(count_kind(&w, WELD_MANIFOLD) == 6, "others manifold: %u", count_kind(&w, WELD_MANIFOLD));
    }
    weld_free(&w);
    free(b);
    free(p);
}

static void test_fin_and_flipped(void)
{
    pbuf *b = pbuf_new();
    pbuf_vertex(b, 0, 0, 0, NULL, NULL);
    pbuf_vertex(b, 1, 0, 0, NULL, NULL);
    pbuf_vertex(b, 0, 1, 0, NULL, NULL);
    pbuf_vertex(b, 0, -1, 0, NULL, NULL);
    pbuf_vertex(b, 0, 0, 1, NULL, NULL);
    pbuf_tri(b, 0, 1, 2);
    pbuf_tri(b, 1, 0, 3);
    pbuf_tri(b, 0, 1, 4);
    tmesh m;
    tmesh_init(&m, "fin");
    tmesh_add(&m, b, 0, 0, 0);
    weld_result w;
    if (weld_ok(&m, &w)) {
        CHECK(w.stats.nonmanifold_edges == 1, "non-manifold edges %u", w.stats.nonmanifold_edges);
        CHECK(w.vertex_kind[0] == WELD_LOCKED && w.vertex_kind[1] == WELD_LOCKED, "fin edge ends locked");
        CHECK(count_kind(&w, WELD_BORDER) == 3, "tips border: %u", count_kind(&w, WELD_BORDER));
        CHECK(w.edge_opposite[0] == WELD_EDGE_IS_NONMANIFOLD && w.edge_opposite[3] == WELD_EDGE_IS_NONMANIFOLD &&
                  w.edge_opposite[6] == WELD_EDGE_IS_NONMANIFOLD,
              "all three sides marked");
        CHECK(!weld_collapse_allowed((weld_kind)w.vertex_kind[2], w.edge_flags[0]), "no collapse along the fin edge");
    }
    weld_free(&w);

    /* two triangles using edge 0 -> 1 in the same direction */
    pbuf *f = pbuf_new();
    pbuf_vertex(f, 0, 0, 0, NULL, NULL);
    pbuf_vertex(f, 1, 0, 0, NULL, NULL);
    pbuf_vertex(f, 0, 1, 0, NULL, NULL);
    pbuf_vertex(f, 0, -1, 0, NULL, NULL);
    pbuf_tri(f, 0, 1, 2);
    pbuf_tri(f, 0, 1, 3);
    tmesh_init(&m, "flipped");
    tmesh_add(&m, f, 0, 0, 0);
    if (weld_ok(&m, &w)) {
        CHECK(w.stats.nonmanifold_edges == 1, "inconsistent orientation is non-manifold: %u",
              w.stats.nonmanifold_edges);
        CHECK(w.vertex_kind[0] == WELD_LOCKED && w.vertex_kind[1] == WELD_LOCKED, "ends locked");
        CHECK(w.stats.border_edges == 4, "border edges %u", w.stats.border_edges);
    }
    weld_free(&w);
    free(b);
    free(f);
}

/* Adds to b the reverse of each of its triangles [first, first + count) for
 * which keep(triangle) says so, reading positions from b itself. */
static void add_reversed(pbuf *to, const pbuf *from, uint32_t first, uint32_t count, uint32_t offset, int left_only)
{
    for (uint32_t t = first; t < first + count; ++t) {
        const uint32_t *tv = &from->tri[3 * t];
        if (left_only && (from->pos[3 * tv[0]] > 2.0f || from->pos[3 * tv[1]] > 2.0f || from->pos[3 * tv[2]] > 2.0f))
            continue;
        pbuf_tri(to, tv[0] + offset, tv[2] + offset, tv[1] + offset);
    }
}

/* A double-sided sheet: the reverse of every triangle is its back, out of the
 * topology, which is then the single sheet's (weld.h "back faces"). */
static void test_double_sided(void)
{
    weld_result w;
    tmesh m;
    /* one primitive, the back on the same vertices */
    pbuf *b = pbuf_new();
    build_grid(b, 0, 4, 4);
    add_reversed(b, b, 0, 32, 0, 0);
    tmesh_init(&m, "double");
    tmesh_add(&m, b, 0, 1, 1);
    if (weld_ok(&m, &w)) {
        CHECK(w.back_count == 32 && w.triangle_count == 32, "backs %u, topology %u", w.back_count, w.triangle_count);
        CHECK(count_kind(&w, WELD_BORDER) == 16 && count_kind(&w, WELD_MANIFOLD) == 9 && count_kind(&w, WELD_LOCKED) == 0,
              "kinds of a single grid: border %u manifold %u locked %u", count_kind(&w, WELD_BORDER),
              count_kind(&w, WELD_MANIFOLD), count_kind(&w, WELD_LOCKED));
        CHECK(w.stats.nonmanifold_edges == 0 && euler(&w) == 1, "a disk: non-manifold %u, Euler %d",
              w.stats.nonmanifold_edges, euler(&w));
        uint32_t first_back = UINT32_MAX;
        for (uint32_t t = 0; t < w.triangle_count; ++t)
            if (w.triangle_back[t] < first_back) first_back = w.triangle_back[t];
        CHECK(w.triangle_back[0] == 0 && first_back == 0, "the first front has the first back");
    }
    weld_free(&w);

    /* the two sides shuffled together in one primitive (as an index optimizer leaves
     * them): every third pair lists its reversed triangle first. The fronts are chosen
     * again so that they agree: the topology is the single sheet's, nothing locked */
    pbuf *sh = pbuf_new();
    build_grid(sh, 0, 4, 4);
    const uint32_t grid_tris = sh->tcount;
    uint32_t *grid_tri = malloc(3 * (size_t)grid_tris * sizeof *grid_tri);
    if (!grid_tri) abort();
    memcpy(grid_tri, sh->tri, 3 * (size_t)grid_tris * sizeof *grid_tri);
    sh->tcount = 0;
    for (uint32_t t = 0; t < grid_tris; ++t) {
        const uint32_t *g = grid_tri + 3 * (size_t)t;
        if (t % 3 == 1) pbuf_tri(sh, g[0], g[2], g[1]);
        pbuf_tri(sh, g[0], g[1], g[2]);
        if (t % 3 != 1) pbuf_tri(sh, g[0], g[2], g[1]);
    }
    free(grid_tri);
    tmesh_init(&m, "shuffled");
    tmesh_add(&m, sh, 0, 1, 1);
    if (weld_ok(&m, &w)) {
        CHECK(w.back_count == 32 && w.triangle_count == 32, "backs %u, topology %u", w.back_count, w.triangle_count);
        CHECK(w.stats.nonmanifold_edges == 0 && euler(&w) == 1 && count_kind(&w, WELD_LOCKED) == 0 &&
                  count_kind(&w, WELD_BORDER) == 16 && count_kind(&w, WELD_MANIFOLD) == 9,
              "a disk with one orientation: non-manifold %u, Euler %d, locked %u", w.stats.nonmanifold_edges, euler(&w),
              count_kind(&w, WELD_LOCKED));
        CHECK(w.triangle_back[0] != WELD_NO_BACK, "the first pair keeps its front");
    }
    weld_free(&w);
    free(sh);

    /* the back as its own primitive and material, normals turned over */
    pbuf *c = pbuf_new();
    build_grid(c, 0, 4, 4);
    for (uint32_t v = 0; v < c->vcount; ++v) c->nrm[3 * v + 2] = -1.0f;
    pbuf *front = pbuf_new();
    build_grid(front, 0, 4, 4);
    c->tcount = 0;
    add_reversed(c, front, 0, 32, 0, 0);
    tmesh_init(&m, "two primitives");
    tmesh_add(&m, front, 0, 1, 1);
    tmesh_add(&m, c, 7, 1, 1);
    if (weld_ok(&m, &w)) {
        CHECK(w.back_count == 32 && w.triangle_count == 32 && count_kind(&w, WELD_LOCKED) == 0,
              "backs %u, topology %u, locked %u", w.back_count, w.triangle_count, count_kind(&w, WELD_LOCKED));
        const uint32_t centre = find_vertex(&w, 2, 2, 0);
        uint32_t front_wedge = UINT32_MAX;
        for (uint32_t x = 0; x < w.wedge_count; ++x)
            if (w.wedge_vertex[x] == centre && w.wedge_primitive[x] == 0) front_wedge = x;
        const uint32_t back = front_wedge == UINT32_MAX ? UINT32_MAX : weld_back_wedge(&w, w.wedge_class[front_wedge], 1);
        CHECK(back != UINT32_MAX && w.wedge_primitive[back] == 1 && w.wedge_vertex[back] == centre &&
                  c->nrm[3 * w.wedge_index[back] + 2] == -1.0f,
              "the centre's back wedge is the back primitive's, facing down");
        CHECK(weld_back_wedge(&w, w.wedge_class[front_wedge], 0) == UINT32_MAX, "no back in the front's primitive");
    }
    weld_free(&w);

    /* backs on the left half only: the line where they stop is locked */
    pbuf *h = pbuf_new();
    build_grid(h, 0, 4, 4);
    add_reversed(h, h, 0, 32, 0, 1);
    tmesh_init(&m, "half");
    tmesh_add(&m, h, 0, 1, 1);
    if (weld_ok(&m, &w)) {
        CHECK(w.back_count == 16, "backs %u", w.back_count);
        int line_locked = 1, others_free = 1;
        for (uint32_t v = 0; v < w.vertex_count; ++v) {
            if (w.positions[3 * v] == 2.0f) line_locked &= w.vertex_kind[v] == WELD_LOCKED;
            else others_free &= w.vertex_kind[v] != WELD_LOCKED;
        }
        CHECK(line_locked && others_free, "locked exactly where the backs stop");
    }
    weld_free(&w);

    /* two materials, each double-sided in its own primitive: the material seam is no back
     * border (each side keeps its backs), its inner vertices stay seam vertices */
    pbuf *ml = pbuf_new(), *mr = pbuf_new();
    build_grid(ml, 0, 2, 4);
    build_grid(mr, 2, 4, 4);
    add_reversed(ml, ml, 0, 16, 0, 0);
    add_reversed(mr, mr, 0, 16, 0, 0);
    tmesh_init(&m, "two materials, double");
    tmesh_add(&m, ml, 0, 1, 1);
    tmesh_add(&m, mr, 1, 1, 1);
    if (weld_ok(&m, &w)) {
        CHECK(w.back_count == 32 && w.triangle_count == 32, "backs %u, topology %u", w.back_count, w.triangle_count);
        for (int j = 1; j <= 3; ++j) {
            const uint32_t v = find_vertex(&w, 2, (float)j, 0);
            CHECK(v != UINT32_MAX && w.vertex_kind[v] == WELD_SEAM, "(2,%d) is %s", j,
                  v == UINT32_MAX ? "missing" : weld_kind_name((weld_kind)w.vertex_kind[v]));
        }
        CHECK(count_kind(&w, WELD_LOCKED) == 2, "locked: the seam's two ends only (%u)", count_kind(&w, WELD_LOCKED));
    }
    weld_free(&w);
    free(ml);
    free(mr);

    /* a back with a UV seam the front lacks (at x = 2): the pairs with a corner on the seam
     * stay in the topology, both layers (non-manifold, locked), the others are backs */
    pbuf *sd = pbuf_new();
    build_grid(sd, 0, 4, 4);
    const uint32_t base = sd->vcount;
    build_grid(sd, 0, 4, 4); /* the back's own vertices */
    for (uint32_t v = base; v < sd->vcount; ++v)
        if (sd->pos[3 * v] > 2.0f) sd->uv[2 * v] += 0.5f;
    sd->tcount = 32;
    const uint32_t seam_base = sd->vcount; /* column x = 2 again, with the right side's UV */
    for (uint32_t v = base; v < seam_base; ++v)
        if (sd->pos[3 * v] == 2.0f) {
            float uv[2] = {sd->uv[2 * v] + 0.5f, sd->uv[2 * v + 1]};
            pbuf_vertex(sd, 2.0f, sd->pos[3 * v + 1], 0.0f, &sd->nrm[3 * v], uv);
        }
    for (uint32_t t = 0; t < 32; ++t) {
        uint32_t tv[3];
        int right = 1;
        for (int k = 0; k < 3; ++k) {
            tv[k] = sd->tri[3 * t + (uint32_t)k] + base;
            right &= sd->pos[3 * tv[k]] >= 2.0f;
        }
        for (int k = 0; k < 3 && right; ++k)
            if (sd->pos[3 * tv[k]] == 2.0f) tv[k] = seam_base + (uint32_t)(sd->pos[3 * tv[k] + 1]);
        pbuf_tri(sd, tv[0], tv[2], tv[1]);
    }
    tmesh_init(&m, "back seam");
    tmesh_add(&m, sd, 0, 1, 1);
    if (weld_ok(&m, &w)) {
        CHECK(w.back_count == 16 && w.triangle_count == 48 && w.stats.nonmanifold_edges > 0,
              "backs %u, topology %u, non-manifold %u", w.back_count, w.triangle_count, w.stats.nonmanifold_edges);
        int seam_strip_locked = 1, outer_free = 1, outer_backed = 1;
        for (uint32_t v = 0; v < w.vertex_count; ++v) {
            const float x = w.positions[3 * v];
            if (x >= 1.0f && x <= 3.0f) seam_strip_locked &= w.vertex_kind[v] == WELD_LOCKED;
            else outer_free &= w.vertex_kind[v] != WELD_LOCKED;
        }
        for (uint32_t t = 0; t < w.triangle_count; ++t) {
            int outer = 1;
            for (int k = 0; k < 3; ++k) {
                const float x = w.positions[3 * w.triangle_vertices[3 * t + (uint32_t)k]];
                outer &= x <= 1.0f || x >= 3.0f;
            }
            if (outer) outer_backed &= w.triangle_back[t] != WELD_NO_BACK;
        }
        CHECK(seam_strip_locked && outer_free && outer_backed,
              "the strip the seam touches locked (%d), the outer columns free (%d) and with backs (%d)",
              seam_strip_locked, outer_free, outer_backed);
    }
    weld_free(&w);

    /* a repeat in the same winding is no back; a third layer stays in the topology */
    pbuf *r = pbuf_new();
    build_grid(r, 0, 4, 4);
    pbuf_tri(r, r->tri[0], r->tri[1], r->tri[2]);
    tmesh_init(&m, "same winding");
    tmesh_add(&m, r, 0, 1, 1);
    if (weld_ok(&m, &w)) CHECK(w.back_count == 0 && w.triangle_count == 33, "backs %u", w.back_count);
    weld_free(&w);
    r->tcount = 32;
    add_reversed(r, r, 0, 32, 0, 0);
    add_reversed(r, r, 0, 1, 0, 0);
    tmesh_init(&m, "three layers");
    tmesh_add(&m, r, 0, 1, 1);
    if (weld_ok(&m, &w))
        CHECK(w.back_count == 32 && w.triangle_count == 33 && w.triangle_back[32] == WELD_NO_BACK,
              "backs %u, topology %u", w.back_count, w.triangle_count);
    weld_free(&w);
    /* a lone two-sided triangle shares its edges with nothing else: a closed pillow, left as it is */
    pbuf *pillow = pbuf_new();
    pbuf_vertex(pillow, 0, 0, 0, NULL, NULL);
    pbuf_vertex(pillow, 1, 0, 0, NULL, NULL);
    pbuf_vertex(pillow, 0, 1, 0, NULL, NULL);
    pbuf_tri(pillow, 0, 1, 2);
    pbuf_tri(pillow, 0, 2, 1);
    tmesh_init(&m, "pillow");
    tmesh_add(&m, pillow, 0, 0, 0);
    if (weld_ok(&m, &w))
        CHECK(w.back_count == 0 && w.triangle_count == 2 && w.stats.nonmanifold_edges == 0, "backs %u, topology %u",
              w.back_count, w.triangle_count);
    weld_free(&w);
    free(pillow);
    free(b);
    free(c);
    free(front);
    free(h);
    free(sd);
    free(r);
}

static void test_degenerate(void)
{
    pbuf *b = pbuf_new();
    pbuf_vertex(b, 0, 0, 0, NULL, NULL); /* 0 */
    pbuf_vertex(b, 1, 0, 0, NULL, NULL); /* 1 */
    pbuf_vertex(b, 1, 1, 0, NULL, NULL); /* 2 */
    pbuf_vertex(b, 0, 1, 0, NULL, NULL); /* 3 */
    pbuf_vertex(b, 0, 0, 0, NULL, NULL); /* 4: same position as 0 */
    pbuf_vertex(b, 5, 5, 5, NULL, NULL); /* 5: only in a dropped triangle */
    pbuf_vertex(b, 6, 6, 6, NULL, NULL); /* 6: only in a dropped triangle */
    pbuf_tri(b, 5, 5, 6);                /* dropped, dangling (and first!) */
    pbuf_tri(b, 0, 1, 2);
    pbuf_tri(b, 0, 0, 1); /* dropped by index; segment 0-1 is an edge */
    pbuf_tri(b, 2, 2, 2); /* dropped; a point on the surface */
    pbuf_tri(b, 4, 1, 0); /* dropped after welding (4 == 0) */
    pbuf_tri(b, 0, 2, 3);
    pbuf_tri(b, 1, 3, 3); /* dropped; segment 1-3 is no edge: dangling (conservative) */
    pbuf *z = pbuf_new();  /* a kept zero-area triangle: three distinct collinear points */
    pbuf_vertex(z, 10, 0, 0, NULL, NULL);
    pbuf_vertex(z, 11, 0, 0, NULL, NULL);
    pbuf_vertex(z, 12, 0, 0, NULL, NULL);
    pbuf_tri(z, 0, 1, 2);
    tmesh m;
    tmesh_init(&m, "degenerate");
    tmesh_add(&m, b, 0, 0, 0);
    tmesh_add(&m, z, 0, 0, 0);
    weld_result w;
    if (weld_ok(&m, &w)) {
        CHECK(w.stats.input_triangles == 8, "input %u", w.stats.input_triangles);
        CHECK(w.stats.degenerate_triangles == 5, "dropped %u", w.stats.degenerate_triangles);
        CHECK(w.stats.degenerate_dangling == 2, "dangling %u", w.stats.degenerate_dangling);
        CHECK(w.triangle_count == 3, "kept %u", w.triangle_count);
        /* the dangling segment 5-6 off the surface brings its two positions and wedges, after the kept ones */
        CHECK(w.vertex_count == 9, "7 kept positions + 2 only the dangling triangle uses: %u", w.vertex_count);
        CHECK(w.wedge_count == 9, "wedges %u", w.wedge_count);
        const uint32_t v5 = find_vertex(&w, 5, 5, 5), v6 = find_vertex(&w, 6, 6, 6);
        CHECK(v5 == 7 && v6 == 8, "(5,5,5) and (6,6,6) numbered last: %u %u", v5, v6);
        CHECK(w.positions[0] == 0 && w.positions[3] == 1, "first kept triangle numbers first");
        CHECK(w.triangle_primitive[2] == 1, "the collinear triangle is kept, primitive 1");
        for (uint32_t i = 0; i < w.wedge_count; ++i) CHECK(w.wedge_index[i] != 4, "no wedge for vertex 4");
        /* the dangling triangles, in input order, kept beside the topology as they are */
        CHECK(w.dangling_count == 2, "dangling kept %u", w.dangling_count);
        if (w.dangling_count == 2) {
            const uint32_t v1 = find_vertex(&w, 1, 0, 0), v3 = find_vertex(&w, 0, 1, 0);
            const uint32_t expect[6] = {v5, v5, v6, v1, v3, v3};
            for (int c = 0; c < 6; ++c) {
                CHECK(w.dangling_vertices[c] == expect[c], "dangling corner %d: vertex %u", c, w.dangling_vertices[c]);
                CHECK(w.wedge_vertex[w.dangling_wedges[c]] == w.dangling_vertices[c], "dangling corner %d: wedge", c);
                CHECK(w.wedge_primitive[w.dangling_wedges[c]] == 0, "dangling corner %d: primitive", c);
            }
            CHECK(w.wedge_index[w.dangling_wedges[0]] == 5 && w.wedge_index[w.dangling_wedges[2]] == 6, "glTF vertices 5, 6");
            CHECK(w.dangling_primitive[0] == 0 && w.dangling_primitive[1] == 0, "primitives");
            /* their vertices are locked (they stay in every level); the others keep their kinds */
            for (uint32_t v = 0; v < w.vertex_count; ++v) {
                const int dangles = v == v1 || v == v3 || v == v5 || v == v6;
                CHECK((w.vertex_kind[v] == WELD_LOCKED) == dangles, "vertex %u: kind %u", v, w.vertex_kind[v]);
            }
            CHECK(w.vertex_triangle_offsets[v5] == w.vertex_triangle_offsets[v6 + 1], "no triangles at 5, 6");
        }
        CHECK(w.stats.vertices_by_kind[WELD_LOCKED] == 4, "kind statistics follow the lock: %u",
              w.stats.vertices_by_kind[WELD_LOCKED]);
    }
    weld_free(&w);
    free(b);
    free(z);
}

static void test_negative_zero(void)
{
    pbuf *b = pbuf_new();
    const float up[3] = {0, 0, 1}, up_neg[3] = {-0.0f, -0.0f, 1};
    pbuf_vertex(b, 0, 0, 0, up, NULL);             /* 0 */
    pbuf_vertex(b, 1, 0, 0, up, NULL);             /* 1 */
    pbuf_vertex(b, 0, 1, 0, up, NULL);             /* 2 */
    pbuf_vertex(b, -0.0f, -0.0f, -0.0f, up_neg, NULL); /* 3: same point as 0 */
    pbuf_vertex(b, 0, -1, 0, up, NULL);            /* 4 */
    pbuf_vertex(b, 1, -0.0f, 0, up, NULL);         /* 5: same point as 1 */
    pbuf_tri(b, 0, 1, 2);
    pbuf_tri(b, 5, 3, 4);
    tmesh m;
    tmesh_init(&m, "negzero");
    tmesh_add(&m, b, 0, 1, 0);
    weld_result w;
    if (weld_ok(&m, &w)) {
        CHECK(w.vertex_count == 4, "V %u", w.vertex_count);
        CHECK(w.wedge_count == 6 && w.stats.wedge_classes == 4, "W %u classes %u", w.wedge_count,
              w.stats.wedge_classes);
        CHECK(w.stats.seam_edges == 0, "-0.0 normal equals +0.0 normal");
        CHECK(w.edge_opposite[0] == 3, "shared edge paired: %u", w.edge_opposite[0]);
        uint32_t bits;
        memcpy(&bits, &w.positions[0], sizeof bits);
        CHECK(bits == 0, "stored as +0.0");
    }
    weld_free(&w);
    free(b);
}

static void test_skipped_primitives(void)
{
    pbuf *g = pbuf_new();
    build_grid(g, 0, 2, 2);
    pbuf *lines = pbuf_new();
    pbuf_vertex(lines, 0, 0, 0, NULL, NULL);
    pbuf_vertex(lines, 9, 9, 9, NULL, NULL);
    tmesh m;
    tmesh_init(&m, "mixed");
    m.mesh.primitive_count = 1; /* primitives[0]: no POSITION */
    m.prims[0].skipped = 1;
    m.prims[0].mode = 4;
    scene_primitive *l = tmesh_add(&m, lines, 0, 0, 0);
    l->mode = 1; /* lines: no triangles */
    tmesh_add(&m, g, 3, 1, 1);
    weld_result w;
    if (weld_ok(&m, &w)) {
        CHECK(w.stats.primitives == 1, "one primitive welded: %u", w.stats.primitives);
        CHECK(w.vertex_count == 9 && w.triangle_count == 8, "V %u T %u", w.vertex_count, w.triangle_count);
        for (uint32_t i = 0; i < w.wedge_count; ++i) CHECK(w.wedge_primitive[i] == 2, "wedge %u primitive", i);
        for (uint32_t t = 0; t < w.triangle_count; ++t) CHECK(w.triangle_primitive[t] == 2, "triangle %u primitive", t);
    }
    weld_free(&w);

    /* nothing to weld at all */
    tmesh_init(&m, "empty");
    if (weld_ok(&m, &w))
        CHECK(w.vertex_count == 0 && w.triangle_count == 0 && w.stats.edges == 0, "empty result");
    weld_free(&w);
    free(g);
    free(lines);
}

static void test_bad_index(void)
{
    pbuf *b = pbuf_new();
    pbuf_vertex(b, 0, 0, 0, NULL, NULL);
    pbuf_vertex(b, 1, 0, 0, NULL, NULL);
    pbuf_tri(b, 0, 1, 2);
    tmesh m;
    tmesh_init(&m, "bad");
    tmesh_add(&m, b, 0, 0, 0);
    weld_result w;
    lp_error err;
    memset(&err, 0, sizeof err);
    int rc = weld_build(&m.mesh, 1, &w, &err);
    CHECK(rc == LP_INVALID && err.code == LP_INVALID, "rc %d", rc);
    CHECK(strstr(err.msg, "bad") != NULL, "message names the mesh: %s", err.msg);
    CHECK(w.positions == NULL && w.vertex_count == 0, "result empty after failure");
    weld_free(&w);
    free(b);
}

static int results_equal(const weld_result *a, const weld_result *b)
{
    if (memcmp(&a->stats, &b->stats, sizeof a->stats) != 0) return 0;
    if (a->vertex_count != b->vertex_count || a->wedge_count != b->wedge_count ||
        a->triangle_count != b->triangle_count)
        return 0;
    size_t v = a->vertex_count, w = a->wedge_count, c = 3 * (size_t)a->triangle_count;
    return !memcmp(a->positions, b->positions, 3 * v * sizeof(float)) &&
           !memcmp(a->vertex_kind, b->vertex_kind, v) &&
           !memcmp(a->vertex_triangle_offsets, b->vertex_triangle_offsets, (v + 1) * 4) &&
           !memcmp(a->vertex_triangles, b->vertex_triangles, c * 4) &&
           !memcmp(a->wedge_primitive, b->wedge_primitive, w * 4) && !memcmp(a->wedge_index, b->wedge_index, w * 4) &&
           !memcmp(a->wedge_vertex, b->wedge_vertex, w * 4) && !memcmp(a->wedge_class, b->wedge_class, w * 4) &&
           !memcmp(a->triangle_wedges, b->triangle_wedges, c * 4) &&
           !memcmp(a->triangle_vertices, b->triangle_vertices, c * 4) &&
           !memcmp(a->triangle_primitive, b->triangle_primitive, c / 3 * 4) &&
           !memcmp(a->edge_opposite, b->edge_opposite, c * 4) && !memcmp(a->edge_flags, b->edge_flags, c);
}

static void test_deterministic(void)
{
    pbuf *b = pbuf_new(), *copy;
    build_cylinder(b, 12, 4);
    copy = pbuf_new();
    memcpy(copy, b, sizeof *b);
    tmesh m1, m2;
    tmesh_init(&m1, "one");
    tmesh_add(&m1, b, 0, 1, 1);
    tmesh_init(&m2, "two");
    tmesh_add(&m2, copy, 0, 1, 1);
    weld_result w1, w2, w3;
    if (weld_ok(&m1, &w1) && weld_ok(&m2, &w2) && weld_ok(&m1, &w3)) {
        CHECK(results_equal(&w1, &w2), "same input at another address, same output");
        CHECK(results_equal(&w1, &w3), "same input twice, same output");
        /* dropping the edge pairing leaves everything else as it was */
        weld_release_edge_opposite(&w3);
        CHECK(w3.edge_opposite == NULL, "edge_opposite released");
        weld_release_edge_opposite(&w3);
        w3.edge_opposite = w1.edge_opposite; /* borrowed for the comparison only */
        CHECK(results_equal(&w1, &w3), "the rest unchanged after the release");
        w3.edge_opposite = NULL;
    }
    weld_free(&w1);
    weld_free(&w2);
    weld_free(&w3);
    free(b);
    free(copy);
}

/* A mesh large enough for the threaded topology (four primitives, 28,800
 * triangles: two copies of one cylinder, every edge non-manifold, and two
 * grids of two materials side by side, a seam between them, that pinch the
 * cylinder): the same result for any thread count. */
static void test_threads_same_result(void)
{
    pbuf *cyl = pbuf_new(), *grid = pbuf_new(), *grid2 = pbuf_new();
    build_cylinder(cyl, 60, 60);
    build_grid(grid, 0, 60, 60);
    build_grid(grid2, 60, 120, 60);
    tmesh m;
    tmesh_init(&m, "threads");
    tmesh_add(&m, cyl, 0, 1, 1);
    tmesh_add(&m, cyl, 1, 1, 0);
    tmesh_add(&m, grid, 0, 1, 1);
    tmesh_add(&m, grid2, 1, 1, 1);
    weld_result one;
    if (weld_ok(&m, &one)) {
        CHECK(one.stats.nonmanifold_edges > 0 && one.stats.seam_edges > 0, "the mesh has what the threads split");
        const uint32_t thread_counts[3] = {2, 3, 5};
        for (int k = 0; k < 3; ++k) {
            weld_result more;
            lp_error err;
            memset(&err, 0, sizeof err);
            CHECK(weld_build(&m.mesh, thread_counts[k], &more, &err) == LP_OK, "%u threads: %s", thread_counts[k],
                  err.msg);
            CHECK(results_equal(&one, &more), "%u threads: the same result as one", thread_counts[k]);
            weld_free(&more);
        }
    }
    weld_free(&one);
    free(cyl);
    free(grid);
    free(grid2);
}

static void test_collapse_rules(void)
{
    CHECK(weld_collapse_allowed(WELD_MANIFOLD, 0), "manifold along an interior edge");
    CHECK(!weld_collapse_allowed(WELD_MANIFOLD, WELD_FLAG_BORDER), "manifold has no border edge");
    CHECK(weld_collapse_allowed(WELD_BORDER, WELD_FLAG_BORDER), "border along border");
    CHECK(!weld_collapse_allowed(WELD_BORDER, 0), "border not inwards");
    CHECK(weld_collapse_allowed(WELD_SEAM, WELD_FLAG_SEAM), "seam along seam");
    CHECK(!weld_collapse_allowed(WELD_SEAM, 0), "seam not across");
    CHECK(!weld_collapse_allowed(WELD_LOCKED, 0) && !weld_collapse_allowed(WELD_LOCKED, WELD_FLAG_SEAM) &&
              !weld_collapse_allowed(WELD_LOCKED, WELD_FLAG_BORDER),
          "locked never");
    for (int k = 0; k < WELD_KIND_COUNT; ++k)
        CHECK(!weld_collapse_allowed((weld_kind)k, WELD_FLAG_NONMANIFOLD), "never along a non-manifold edge");
    CHECK(!weld_collapse_allowed((weld_kind)7, 0), "unknown kind");
    CHECK(strcmp(weld_kind_name(WELD_SEAM), "seam") == 0, "names");
}

int main(void)
{
    RUN(test_cube_flat_shaded);
    RUN(test_octahedron_smooth);
    RUN(test_soup_sphere);
    RUN(test_open_grid);
    RUN(test_grid_two_materials);
    RUN(test_seam_loose_end);
    RUN(test_pole_fan);
    RUN(test_cylinder_uv_seam);
    RUN(test_bowtie_and_pinch);
    RUN(test_fin_and_flipped);
    RUN(test_degenerate);
    RUN(test_negative_zero);
    RUN(test_skipped_primitives);
    RUN(test_bad_index);
    RUN(test_deterministic);
    RUN(test_threads_same_result);
    RUN(test_collapse_rules);
    RUN(test_double_sided);
    return check_summary();
}
