/* weld.c - welding a glTF mesh into one topology; see weld.h.
 *
 * Follows: Hoppe, "Progressive meshes" (SIGGRAPH 1996) and "Efficient
 * implementation of progressive meshes" (1998) for wedges (one position, one
 * attribute set per face corner group); Garland & Heckbert, "Simplifying
 * surfaces with color and texture using quadric error metrics" (1998) for
 * attribute discontinuities as constraints; and the idea of meshoptimizer's
 * simplifier (Kapoulkine) of classifying vertices once into manifold /
 * border / seam / locked and allowing collapses by a small table. The code
 * is our own.
 *
 * The outline, each step a static function below:
 *   count_input        sizes and limits
 *   weld_positions     glTF vertex -> provisional position id (hash by bits)
 *   number_kept        drop degenerate triangles, number kept vertices and wedges
 *   fill_arrays        wedges, triangles, positions
 *   build_vertex_triangles   CSR vertex -> triangles
 *   classify_wedges    wedge classes (hash by attribute values)
 *   pair_edges         opposite edge / border / non-manifold (per vertex, from
 *                      the vertex-triangle lists)
 *   mark_seams         seam flag of manifold interior edges
 *   classify_vertices  walk each umbrella, apply the kind rules
 *   take_backs         reversed repeats out of the topology, as backs, their
 *                      fronts one consistent side (orient_pairs) (only
 *                      when it has a non-manifold edge; then built again)
 *   lock_back_borders  where backs start, stop or change primitive
 *   find_dangling      dropped triangles that may lie off the surface
 *   keep_dangling      ... kept beside the topology, their vertices locked */
#include "weld.h"

#include <assert.h>
#include <stdlib.h>
#include <string.h>

#include "keymap.h"
#include "threads.h"

#define NONE UINT32_MAX

/* ---- hashing (deterministic, no seeds from the environment) ---------------- */

/* -0.0 and +0.0 are the same point and the same attribute value. */
static uint32_t float_key(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u == 0x80000000u ? 0u : u;
}

static uint32_t hash_step(uint32_t h, uint32_t v)
{
    return keymap_hash(h ^ (v + 0x9e3779b9u + (h << 6) + (h >> 2)));
}

/* Smallest power of two >= 2 * n (at least 16): load factor <= 1/2. */
static size_t table_capacity(size_t n)
{
    size_t c = 16;
    while (c < 2 * n) c *= 2;
    return c;
}

static void *alloc_array(size_t count, size_t size)
{
    return malloc((count ? count : 1) * size);
}

static int is_welded(const scene_primitive *p)
{
    return !p->skipped && p->triangle_count > 0;
}

/* ---- the work area ---------------------------------------------------------- */

typedef struct weld_work {
    const scene_mesh *mesh;
    const char *name;
    uint32_t *prim_base;     /* per primitive: first global glTF-vertex number */
    uint32_t vertex_total;   /* glTF vertices over welded primitives */
    uint32_t input_triangles;

    uint32_t *gv_position;   /* global glTF vertex -> provisional position id */
    uint32_t *gv_wedge;      /* global glTF vertex -> wedge id */
    uint32_t *prov_key;      /* provisional position -> 3 float keys */
    uint32_t prov_count;
    uint32_t *prov_final;    /* provisional position -> final vertex id or NONE */
    uint32_t *dangling_triangle; /* per dangling triangle: its number in its primitive */
    int classes_done;        /* the wedge classes are made (a second build_topology keeps them) */
} weld_work;

static void work_free(weld_work *k)
{
    free(k->prim_base);
    free(k->gv_position);
    free(k->gv_wedge);
    free(k->prov_key);
    free(k->prov_final);
    free(k->dangling_triangle);
}

static int out_of_memory(weld_work *k, lp_error *err)
{
    return lp_no_memory(err, "mesh \"%s\": out of memory while welding", k->name);
}

/* ---- steps ------------------------------------------------------------------ */

static int count_input(weld_work *k, lp_error *err)
{
    const scene_mesh *m = k->mesh;
    uint64_t vertices = 0, triangles = 0;
    k->prim_base = alloc_array(m->primitive_count, sizeof *k->prim_base);
    if (!k->prim_base) return out_of_memory(k, err);
    for (uint32_t p = 0; p < m->primitive_count; ++p) {
        const scene_primitive *pr = &m->primitives[p];
        k->prim_base[p] = (uint32_t)vertices;
        if (!is_welded(pr)) continue;
        if (!pr->positions || !pr->triangles)
            return lp_fail(err, LP_INVALID, "mesh \"%s\".primitives[%u]: triangles without positions", k->name, p);
        vertices += pr->vertex_count;
        triangles += pr->triangle_count;
        if (vertices > WELD_MAX_VERTICES || triangles > WELD_MAX_TRIANGLES)
            return lp_fail(err, LP_INVALID, "mesh \"%s\": too large to weld (more than %u triangles or %u vertices)",
                           k->name, WELD_MAX_TRIANGLES, WELD_MAX_VERTICES);
        for (size_t i = 0; i < 3 * (size_t)pr->triangle_count; ++i)
            if (pr->triangles[i] >= pr->vertex_count)
                return lp_fail(err, LP_INVALID, "mesh \"%s\".primitives[%u]: triangle %zu uses vertex %u of %u",
                               k->name, p, i / 3, pr->triangles[i], pr->vertex_count);
    }
    k->vertex_total = (uint32_t)vertices;
    k->input_triangles = (uint32_t)triangles;
    return LP_OK;
}

/* Every glTF vertex used by any triangle (kept or not) gets the id of its
 * position, numbered by first appearance; one hash lookup per glTF vertex. */
static int weld_positions(weld_work *k, lp_error *err)
{
    const scene_mesh *m = k->mesh;
    size_t bound = k->vertex_total < 3 * (size_t)k->input_triangles ? k->vertex_total : 3 * (size_t)k->input_triangles;
    size_t cap = table_capacity(bound);
    uint32_t *table = alloc_array(cap, sizeof *table);
    k->gv_position = alloc_array(k->vertex_total, sizeof *k->gv_position);
    k->prov_key = alloc_array(3 * bound, sizeof *k->prov_key);
    if (!table || !k->gv_position || !k->prov_key) {
        free(table);
        return out_of_memory(k, err);
    }
    memset(table, 0xff, cap * sizeof *table);
    memset(k->gv_position, 0xff, (k->vertex_total ? k->vertex_total : 1) * sizeof *k->gv_position);
    k->prov_count = 0;
    for (uint32_t p = 0; p < m->primitive_count; ++p) {
        const scene_primitive *pr = &m->primitives[p];
        if (!is_welded(pr)) continue;
        for (size_t i = 0; i < 3 * (size_t)pr->triangle_count; ++i) {
            uint32_t *slot_of_gv = &k->gv_position[k->prim_base[p] + pr->triangles[i]];
            if (*slot_of_gv != NONE) continue;
            const float *xyz = pr->positions + 3 * (size_t)pr->triangles[i];
            uint32_t key[3] = {float_key(xyz[0]), float_key(xyz[1]), float_key(xyz[2])};
            size_t s = hash_step(hash_step(hash_step(0x504f53u, key[0]), key[1]), key[2]) & (cap - 1);
            for (;; s = (s + 1) & (cap - 1)) {
                uint32_t id = table[s];
                if (id == NONE) {
                    id = k->prov_count++;
                    assert(id < bound);
                    memcpy(k->prov_key + 3 * (size_t)id, key, sizeof key);
                    table[s] = id;
                    *slot_of_gv = id;
                    break;
                }
                if (memcmp(k->prov_key + 3 * (size_t)id, key, sizeof key) == 0) {
                    *slot_of_gv = id;
                    break;
                }
            }
        }
    }
    free(table);
    return LP_OK;
}

static int triangle_is_degenerate(const weld_work *k, uint32_t p, size_t t)
{
    const uint32_t *tri = k->mesh->primitives[p].triangles + 3 * t;
    const uint32_t base = k->prim_base[p];
    uint32_t a = k->gv_position[base + tri[0]];
    uint32_t b = k->gv_position[base + tri[1]];
    uint32_t c = k->gv_position[base + tri[2]];
    return a == b || b == c || c == a;
}

/* A triangle with two corners on one position vertex has zero area: dropping
 * it removes nothing a renderer draws, and nothing of the surface's area.
 * Its point set is a segment (or a point); when that segment is an edge of a
 * kept triangle (the usual case: a sliver left over from a strip or from
 * welding) the union of the triangles is unchanged too. find_dangling
 * finds the rare drops where it is not, and keep_dangling keeps those beside
 * the topology. Kept triangles then have three
 * distinct position vertices, which the umbrella walk relies on.
 * Numbers kept position vertices and wedges by first appearance. */
static int number_kept(weld_work *k, weld_result *out, lp_error *err)
{
    const scene_mesh *m = k->mesh;
    k->prov_final = alloc_array(k->prov_count, sizeof *k->prov_final);
    k->gv_wedge = alloc_array(k->vertex_total, sizeof *k->gv_wedge);
    if (!k->prov_final || !k->gv_wedge) return out_of_memory(k, err);
    memset(k->prov_final, 0xff, (k->prov_count ? k->prov_count : 1) * sizeof *k->prov_final);
    memset(k->gv_wedge, 0xff, (k->vertex_total ? k->vertex_total : 1) * sizeof *k->gv_wedge);
    uint32_t vertices = 0, wedges = 0, kept = 0, dropped = 0;
    for (uint32_t p = 0; p < m->primitive_count; ++p) {
        const scene_primitive *pr = &m->primitives[p];
        if (!is_welded(pr)) continue;
        out->stats.primitives++;
        for (size_t t = 0; t < pr->triangle_count; ++t) {
            if (triangle_is_degenerate(k, p, t)) {
                dropped++;
                continue;
            }
            kept++;
            for (int c = 0; c < 3; ++c) {
                uint32_t gv = k->prim_base[p] + pr->triangles[3 * t + (size_t)c];
                uint32_t *final = &k->prov_final[k->gv_position[gv]];
                if (*final == NONE) *final = vertices++;
                if (k->gv_wedge[gv] == NONE) k->gv_wedge[gv] = wedges++;
            }
        }
    }
    out->vertex_count = vertices;
    out->wedge_count = wedges;
    out->triangle_count = kept;
    out->stats.input_triangles = k->input_triangles;
    out->stats.triangles = kept;
    out->stats.degenerate_triangles = dropped;
    out->stats.vertices = vertices;
    out->stats.wedges = wedges;
    return LP_OK;
}

static int allocate_result(weld_work *k, weld_result *out, lp_error *err)
{
    const size_t v = out->vertex_count, w = out->wedge_count, c = 3 * (size_t)out->triangle_count;
    out->positions = alloc_array(3 * v, sizeof *out->positions);
    out->vertex_kind = alloc_array(v, sizeof *out->vertex_kind);
    out->vertex_triangle_offsets = alloc_array(v + 1, sizeof *out->vertex_triangle_offsets);
    out->vertex_triangles = alloc_array(c, sizeof *out->vertex_triangles);
    out->wedge_primitive = alloc_array(w, sizeof *out->wedge_primitive);
    out->wedge_index = alloc_array(w, sizeof *out->wedge_index);
    out->wedge_vertex = alloc_array(w, sizeof *out->wedge_vertex);
    out->wedge_class = alloc_array(w, sizeof *out->wedge_class);
    out->triangle_wedges = alloc_array(c, sizeof *out->triangle_wedges);
    out->triangle_vertices = alloc_array(c, sizeof *out->triangle_vertices);
    out->triangle_primitive = alloc_array(out->triangle_count, sizeof *out->triangle_primitive);
    out->edge_opposite = alloc_array(c, sizeof *out->edge_opposite);
    out->edge_flags = alloc_array(c, sizeof *out->edge_flags);
    if (!out->positions || !out->vertex_kind || !out->vertex_triangle_offsets || !out->vertex_triangles ||
        !out->wedge_primitive || !out->wedge_index || !out->wedge_vertex || !out->wedge_class ||
        !out->triangle_wedges || !out->triangle_vertices || !out->triangle_primitive || !out->edge_opposite ||
        !out->edge_flags)
        return out_of_memory(k, err);
    return LP_OK;
}

/* Second walk over the kept triangles, in the same order as number_kept, so
 * each wedge and vertex is first met exactly when its number comes up. */
static void fill_arrays(weld_work *k, weld_result *out)
{
    const scene_mesh *m = k->mesh;
    uint32_t t_out = 0, next_wedge = 0, next_vertex = 0;
    for (uint32_t p = 0; p < m->primitive_count; ++p) {
        const scene_primitive *pr = &m->primitives[p];
        if (!is_welded(pr)) continue;
        for (size_t t = 0; t < pr->triangle_count; ++t) {
            if (triangle_is_degenerate(k, p, t)) continue;
            for (int c = 0; c < 3; ++c) {
                uint32_t index = pr->triangles[3 * t + (size_t)c];
                uint32_t gv = k->prim_base[p] + index;
                uint32_t prov = k->gv_position[gv];
                uint32_t vertex = k->prov_final[prov];
                uint32_t wedge = k->gv_wedge[gv];
                if (vertex == next_vertex) {
                    for (int a = 0; a < 3; ++a) {
                        uint32_t bits = k->prov_key[3 * (size_t)prov + (size_t)a];
                        memcpy(&out->positions[3 * (size_t)vertex + (size_t)a], &bits, sizeof bits);
                    }
                    next_vertex++;
                }
                if (wedge == next_wedge) {
                    out->wedge_primitive[wedge] = p;
                    out->wedge_index[wedge] = index;
                    out->wedge_vertex[wedge] = vertex;
                    next_wedge++;
                }
                out->triangle_wedges[3 * (size_t)t_out + (size_t)c] = wedge;
                out->triangle_vertices[3 * (size_t)t_out + (size_t)c] = vertex;
            }
            out->triangle_primitive[t_out++] = p;
        }
    }
    assert(t_out == out->triangle_count && next_wedge == out->wedge_count && next_vertex == out->vertex_count);
}

static void build_vertex_triangles(weld_result *out)
{
    uint32_t *off = out->vertex_triangle_offsets;
    const size_t corners = 3 * (size_t)out->triangle_count;
    memset(off, 0, ((size_t)out->vertex_count + 1) * sizeof *off);
    for (size_t i = 0; i < corners; ++i) off[out->triangle_vertices[i] + 1]++;
    for (uint32_t v = 0; v < out->vertex_count; ++v) off[v + 1] += off[v];
    /* fill using off[v] as a cursor, then shift back */
    for (size_t i = 0; i < corners; ++i) out->vertex_triangles[off[out->triangle_vertices[i]]++] = (uint32_t)(i / 3);
    for (uint32_t v = out->vertex_count; v > 0; --v) off[v] = off[v - 1];
    off[0] = 0;
}

/* ---- wedge classes ---------------------------------------------------------- */

static int is_position_stream(const scene_primitive *pr, const scene_stream *st)
{
    return st->values == pr->positions;
}

static uint32_t wedge_hash(const weld_result *out, const scene_mesh *m, uint32_t w)
{
    const scene_primitive *pr = &m->primitives[out->wedge_primitive[w]];
    uint32_t h = hash_step(hash_step(0x57454447u, out->wedge_primitive[w]), out->wedge_vertex[w]);
    for (uint32_t s = 0; s < pr->stream_count; ++s) {
        const scene_stream *st = &pr->streams[s];
        if (is_position_stream(pr, st) || !st->values) continue;
        const float *x = st->values + (size_t)out->wedge_index[w] * st->components;
        for (uint32_t c = 0; c < st->components; ++c) h = hash_step(h, float_key(x[c]));
    }
    return h;
}

static int wedges_equal(const weld_result *out, const scene_mesh *m, uint32_t a, uint32_t b)
{
    if (out->wedge_primitive[a] != out->wedge_primitive[b] || out->wedge_vertex[a] != out->wedge_vertex[b]) return 0;
    const scene_primitive *pr = &m->primitives[out->wedge_primitive[a]];
    for (uint32_t s = 0; s < pr->stream_count; ++s) {
        const scene_stream *st = &pr->streams[s];
        if (is_position_stream(pr, st) || !st->values) continue;
        const float *x = st->values + (size_t)out->wedge_index[a] * st->components;
        const float *y = st->values + (size_t)out->wedge_index[b] * st->components;
        for (uint32_t c = 0; c < st->components; ++c)
            if (float_key(x[c]) != float_key(y[c])) return 0;
    }
    return 1;
}

static int classify_wedges(weld_work *k, weld_result *out, lp_error *err)
{
    size_t cap = table_capacity(out->wedge_count);
    uint32_t *table = alloc_array(cap, sizeof *table);
    if (!table) return out_of_memory(k, err);
    memset(table, 0xff, cap * sizeof *table);
    uint32_t classes = 0;
    for (uint32_t w = 0; w < out->wedge_count; ++w) {
        size_t s = wedge_hash(out, k->mesh, w) & (cap - 1);
        for (;; s = (s + 1) & (cap - 1)) {
            if (table[s] == NONE) {
                table[s] = w;
                out->wedge_class[w] = w;
                classes++;
                break;
            }
            if (wedges_equal(out, k->mesh, table[s], w)) {
                out->wedge_class[w] = table[s];
                break;
            }
        }
    }
    out->stats.wedge_classes = classes;
    free(table);
    return LP_OK;
}

/* ---- edges ------------------------------------------------------------------ */

static uint32_t edge_next(uint32_t e)
{
    return e % 3 == 2 ? e - 2 : e + 1;
}

static uint32_t edge_prev(uint32_t e)
{
    return e % 3 == 0 ? e + 2 : e - 1;
}

/* Corner (0..2) of vertex v in triangle t; t is incident to v. */
static uint32_t corner_of(const weld_result *out, uint32_t t, uint32_t v)
{
    const uint32_t *tv = out->triangle_vertices + 3 * (size_t)t;
    return tv[0] == v ? 0u : tv[1] == v ? 1u : 2u;
}

/* A triangle edge seen from the lower of its two vertices: the other vertex,
 * and the edge. */
typedef struct edge_end {
    uint32_t other, edge;
} edge_end;

static int edge_end_before(const edge_end *x, const edge_end *y)
{
    return x->other < y->other || (x->other == y->other && x->edge < y->edge);
}

static int compare_edge_ends(const void *a, const void *b)
{
    const edge_end *x = a, *y = b;
    return edge_end_before(x, y) ? -1 : edge_end_before(y, x) ? 1 : 0;
}

/* By other vertex, then edge: a total order (edges are distinct). */
static void sort_edge_ends(edge_end *x, size_t n)
{
    if (n > 32) {
        qsort(x, n, sizeof *x, compare_edge_ends);
        return;
    }
    for (size_t i = 1; i < n; ++i)
        for (size_t j = i; j > 0 && edge_end_before(&x[j], &x[j - 1]); --j) {
            edge_end t = x[j];
            x[j] = x[j - 1];
            x[j - 1] = t;
        }
}

/* The triangle edges on one undirected edge, ascending: one is a border;
 * two running opposite ways are each other's opposite; anything else is
 * non-manifold. */
static void pair_group(weld_result *out, weld_stats *stats, const edge_end *group, size_t n)
{
    stats->edges++;
    if (n == 1) {
        out->edge_opposite[group[0].edge] = WELD_EDGE_IS_BORDER;
        out->edge_flags[group[0].edge] = WELD_FLAG_BORDER;
        stats->border_edges++;
        return;
    }
    const uint32_t e = group[0].edge, o = group[n - 1].edge;
    if (n == 2 && out->triangle_vertices[o] == out->triangle_vertices[edge_next(e)]) {
        out->edge_opposite[e] = o;
        out->edge_opposite[o] = e;
        out->edge_flags[e] = out->edge_flags[o] = 0;
        return;
    }
    for (size_t i = 0; i < n; ++i) {
        out->edge_opposite[group[i].edge] = WELD_EDGE_IS_NONMANIFOLD;
        out->edge_flags[group[i].edge] = WELD_FLAG_NONMANIFOLD;
    }
    stats->nonmanifold_edges++;
}

/* Opposite edges from the vertex-triangle lists: each undirected edge is
 * found at its lower vertex, among the edges of the triangles around it
 * (the one leaving it and the one entering it in each), sorted by the other
 * vertex. Local to each vertex's few triangles, where a hash table over all
 * edges missed the cache twice per edge (1.1M triangles: 0.46 s, now a
 * fraction of it); the sort keeps hub vertices at d log d. For the vertices
 * [begin, end): it writes only their edges, and counts into *stats. */
static int pair_edges(weld_result *out, uint32_t begin, uint32_t end, weld_stats *stats)
{
    const uint32_t *off = out->vertex_triangle_offsets;
    uint32_t max_degree = 0;
    for (uint32_t v = begin; v < end; ++v)
        if (off[v + 1] - off[v] > max_degree) max_degree = off[v + 1] - off[v];
    edge_end *ends = alloc_array(2 * (size_t)max_degree, sizeof *ends);
    if (!ends) return -1;
    for (uint32_t v = begin; v < end; ++v) {
        size_t n = 0;
        for (uint32_t i = off[v]; i < off[v + 1]; ++i) {
            const uint32_t t = out->vertex_triangles[i];
            const uint32_t leave = 3 * t + corner_of(out, t, v), enter = edge_prev(leave);
            const uint32_t to = out->triangle_vertices[edge_next(leave)], from = out->triangle_vertices[enter];
            if (to > v) ends[n++] = (edge_end){to, leave};
            if (from > v) ends[n++] = (edge_end){from, enter};
        }
        sort_edge_ends(ends, n);
        for (size_t i = 0, j; i < n; i = j) {
            for (j = i + 1; j < n && ends[j].other == ends[i].other; ++j) {}
            pair_group(out, stats, ends + i, j - i);
        }
    }
    free(ends);
    return 0;
}

/* A manifold interior edge e (a -> b) with opposite o (b -> a) is a seam when
 * the wedge classes differ at a or at b. Classes include the primitive. For
 * the edges [begin, end), counting into *stats. */
static void mark_seams(weld_result *out, uint32_t begin, uint32_t end, weld_stats *stats)
{
    const uint32_t *cls = out->wedge_class, *tw = out->triangle_wedges;
    for (uint32_t e = begin; e < end; ++e) {
        uint32_t o = out->edge_opposite[e];
        if (o >= WELD_EDGE_IS_NONMANIFOLD) continue;
        if (cls[tw[e]] != cls[tw[edge_next(o)]] || cls[tw[edge_next(e)]] != cls[tw[o]]) {
            out->edge_flags[e] |= WELD_FLAG_SEAM;
            if (e < o) stats->seam_edges++;
        }
    }
}

/* ---- vertex kinds ------------------------------------------------------------ */


/* Walks the fan of v that contains its first incident triangle, across
 * manifold interior edges only, counting triangles, border edges met, seam
 * edges crossed, and among those the ones where v's OWN wedge class changes
 * (the others change only at the far end, e.g. the spokes of a UV sphere's
 * pole seen from the ring around it). The edge leaving v in triangle t at
 * corner c is 3t + c; its opposite enters v, so v starts the next edge of the
 * opposite. Then the rule table of weld.h:
 *   non-manifold edge at v, or triangles outside the fan   LOCKED
 *   open fan,   v's class never changes                    BORDER
 *   open fan,   otherwise (a seam reaches the border)      LOCKED
 *   closed fan, v's class never changes                    MANIFOLD
 *   closed fan, 2 seam edges, v's class changes at both    SEAM
 *   closed fan, otherwise                                  LOCKED
 * A MANIFOLD or BORDER vertex may thus have seam edges whose change is at
 * the other end; weld_collapse_allowed keeps it from collapsing along them. */
static weld_kind classify_vertex(const weld_result *out, uint32_t v, int *several_fans)
{
    const uint32_t begin = out->vertex_triangle_offsets[v], end = out->vertex_triangle_offsets[v + 1];
    const uint32_t degree = end - begin;
    const uint32_t *cls = out->wedge_class, *tw = out->triangle_wedges;
    *several_fans = 0;
    for (uint32_t i = begin; i < end; ++i) {
        uint32_t t = out->vertex_triangles[i];
        uint32_t leave = 3 * t + corner_of(out, t, v);
        if (out->edge_opposite[leave] == WELD_EDGE_IS_NONMANIFOLD ||
            out->edge_opposite[edge_prev(leave)] == WELD_EDGE_IS_NONMANIFOLD)
            return WELD_LOCKED;
    }
    const uint32_t t0 = out->vertex_triangles[begin];
    uint32_t fan = 1, seams = 0, changes = 0, borders = 0, closed = 0;
    /* forward: across the edge leaving v; v's corner is `leave` itself */
    uint32_t leave = 3 * t0 + corner_of(out, t0, v);
    while (fan <= degree) {
        uint32_t o = out->edge_opposite[leave];
        if (o == WELD_EDGE_IS_BORDER) {
            borders++;
            break;
        }
        if (out->edge_flags[leave] & WELD_FLAG_SEAM) {
            seams++;
            changes += cls[tw[leave]] != cls[tw[edge_next(o)]];
        }
        if (o / 3 == t0) {
            closed = 1;
            break;
        }
        fan++;
        leave = edge_next(o);
    }
    if (!closed) {
        /* backward: across the edge entering v; v's corner is the next one */
        uint32_t enter = edge_prev(3 * t0 + corner_of(out, t0, v));
        while (fan <= degree) {
            uint32_t o = out->edge_opposite[enter];
            if (o == WELD_EDGE_IS_BORDER) {
                borders++;
                break;
            }
            if (out->edge_flags[enter] & WELD_FLAG_SEAM) {
                seams++;
                changes += cls[tw[edge_next(enter)]] != cls[tw[o]];
            }
            fan++;
            enter = edge_prev(o);
        }
    }
    if (fan != degree) {
        *several_fans = 1;
        return WELD_LOCKED;
    }
    if (!closed) {
        assert(borders == 2);
        return changes == 0 ? WELD_BORDER : WELD_LOCKED;
    }
    if (changes == 0) return WELD_MANIFOLD;
    return seams == 2 && changes == 2 ? WELD_SEAM : WELD_LOCKED;
}

/* The kinds of the vertices [begin, end), counting the non-manifold ones
 * into *stats (count_kinds counts the kinds). */
static void classify_vertices(weld_result *out, uint32_t begin, uint32_t end, weld_stats *stats)
{
    for (uint32_t v = begin; v < end; ++v) {
        int several_fans;
        out->vertex_kind[v] = (uint8_t)classify_vertex(out, v, &several_fans);
        if (several_fans) stats->nonmanifold_vertices++;
    }
}

/* Vertex and wedge counts by kind, from vertex_kind. */
static void count_kinds(weld_result *out)
{
    memset(out->stats.vertices_by_kind, 0, sizeof out->stats.vertices_by_kind);
    memset(out->stats.wedges_by_kind, 0, sizeof out->stats.wedges_by_kind);
    for (uint32_t v = 0; v < out->vertex_count; ++v) out->stats.vertices_by_kind[out->vertex_kind[v]]++;
    for (uint32_t w = 0; w < out->wedge_count; ++w) out->stats.wedges_by_kind[out->vertex_kind[out->wedge_vertex[w]]]++;
}

/* ---- the topology on threads --------------------------------------------------- */

/* Fewer triangles than this: the topology is built on the calling thread
 * alone (threads cost more than they save). */
#define WELD_THREADS_MIN_TRIANGLES 16384u
#define WELD_THREADS_MAX 16u

typedef enum { STEP_PAIR, STEP_SEAMS, STEP_KINDS } topology_step;

/* One thread's share of a step: vertices (edges for STEP_SEAMS) [begin,
 * end), and what it counted. */
typedef struct topology_part {
    weld_result *out;
    topology_step step;
    uint32_t begin, end;
    int failed;
    weld_stats stats;
} topology_part;

/* Range i of a step (an item of lp_team_for). */
static void run_part(void *parts, uint32_t i)
{
    topology_part *part = &((topology_part *)parts)[i];
    if (part->step == STEP_PAIR) part->failed = pair_edges(part->out, part->begin, part->end, &part->stats);
    else if (part->step == STEP_SEAMS) mark_seams(part->out, part->begin, part->end, &part->stats);
    else classify_vertices(part->out, part->begin, part->end, &part->stats);
}

/* Runs a step over [0, count) cut into `threads` ranges: each range writes
 * only its own elements, and the counts are sums, so the result is that of
 * one range, whichever thread runs which. Returns 0, or -1 when memory runs
 * out. */
static int run_step(weld_result *out, topology_step step, uint32_t count, unsigned threads)
{
    topology_part parts[WELD_THREADS_MAX];
    for (unsigned t = 0; t < threads; ++t)
        parts[t] = (topology_part){.out = out, .step = step,
                                   .begin = (uint32_t)((uint64_t)count * t / threads),
                                   .end = (uint32_t)((uint64_t)count * (t + 1) / threads)};
    lp_team_for(threads, threads, run_part, parts);
    int failed = 0;
    for (unsigned t = 0; t < threads; ++t) {
        const weld_stats *c = &parts[t].stats;
        failed |= parts[t].failed;
        out->stats.edges += c->edges;
        out->stats.border_edges += c->border_edges;
        out->stats.nonmanifold_edges += c->nonmanifold_edges;
        out->stats.seam_edges += c->seam_edges;
        out->stats.nonmanifold_vertices += c->nonmanifold_vertices;
    }
    return failed ? -1 : 0;
}

typedef struct wedge_job {
    weld_work *k;
    weld_result *out;
    lp_error err;
    int rc;
} wedge_job;

static void *run_classify_wedges(void *p)
{
    wedge_job *job = p;
    job->rc = classify_wedges(job->k, job->out, &job->err);
    return NULL;
}

/* From the filled arrays: the vertex-triangle lists, the wedge classes
 * (beside them on a thread of their own), the edge pairing, the seams and
 * the vertex kinds, the last three cut into vertex (edge) ranges over the
 * threads. */
static int build_topology(weld_work *k, weld_result *out, unsigned threads, lp_error *err)
{
    if (out->triangle_count < WELD_THREADS_MIN_TRIANGLES) threads = 1;
    if (threads > WELD_THREADS_MAX) threads = WELD_THREADS_MAX;
    wedge_job job = {.k = k, .out = out};
    lp_beside wedges;
    if (k->classes_done) memset(&wedges, 0, sizeof wedges);
    else lp_beside_start(&wedges, threads > 1, run_classify_wedges, &job);
    k->classes_done = 1;
    build_vertex_triangles(out);
    lp_beside_join(&wedges);
    if (job.rc) {
        *err = job.err;
        return job.rc;
    }
    if (run_step(out, STEP_PAIR, out->vertex_count, threads)) return out_of_memory(k, err);
    run_step(out, STEP_SEAMS, 3 * out->triangle_count, threads);
    run_step(out, STEP_KINDS, out->vertex_count, threads);
    count_kinds(out);
    return LP_OK;
}

/* ---- back faces (weld.h) ------------------------------------------------------ */

/* The winding of a triangle's three distinct vertex numbers: the parity of
 * the permutation that sorts them (rotations keep it, a reversal flips it). */
static int winding_parity(const uint32_t *v)
{
    return ((v[0] > v[1]) + (v[0] > v[2]) + (v[1] > v[2])) & 1;
}

static uint32_t sorted_triple_hash(const uint32_t *v)
{
    uint32_t a = v[0], b = v[1], c = v[2], x;
    if (a > b) x = a, a = b, b = x;
    if (b > c) x = b, b = c, c = x;
    if (a > b) x = a, a = b, b = x;
    return hash_step(hash_step(hash_step(0x4241434bu, a), b), c);
}

static int same_vertex_set(const uint32_t *x, const uint32_t *y)
{
    for (int i = 0; i < 3; ++i)
        if (x[i] != y[0] && x[i] != y[1] && x[i] != y[2]) return 0;
    return 1;
}

/* Open addressing over queues of triangles with one vertex set and winding
 * (each queue is named by the triangle that opened it). */
typedef struct back_queues {
    const weld_result *out;
    size_t cap;
    uint32_t *opener, *head, *tail; /* per slot */
    uint32_t *next;                 /* per triangle: the next in its queue */
} back_queues;

/* The slot of the queue for t's vertex set with the given winding parity:
 * the one opened, or the empty slot where it would open. */
static size_t back_queue_slot(const back_queues *q, uint32_t t, int parity)
{
    const uint32_t *tv = q->out->triangle_vertices + 3 * (size_t)t;
    size_t slot = hash_step(sorted_triple_hash(tv), (uint32_t)parity) & (q->cap - 1);
    for (;; slot = (slot + 1) & (q->cap - 1)) {
        const uint32_t o = q->opener[slot];
        if (o == NONE) return slot;
        const uint32_t *ov = q->out->triangle_vertices + 3 * (size_t)o;
        if (same_vertex_set(ov, tv) && winding_parity(ov) == parity) return slot;
    }
}

/* A triangle with a non-manifold edge: a back shares all three edges with
 * its front, so it and the front have one unless the two are alone (a
 * two-triangle pillow, which stays as it is). */
static int on_nonmanifold_edge(const weld_result *out, uint32_t t)
{
    return ((out->edge_flags[3 * (size_t)t] | out->edge_flags[3 * (size_t)t + 1] | out->edge_flags[3 * (size_t)t + 2]) &
            WELD_FLAG_NONMANIFOLD) != 0;
}

/* back_of[t] = the back paired with triangle t (NONE if none) and is_back[t],
 * pairing in input order among the triangles on a non-manifold edge: each
 * with the earliest unpaired earlier one of the same vertex set and opposite
 * winding (queues: O(1) per triangle however many repeat). Returns the number
 * of pairs, or -1 when memory runs out. */
static long pair_backs(const weld_result *out, uint32_t *back_of, uint8_t *is_back)
{
    const uint32_t n = out->triangle_count;
    uint32_t candidates = 0;
    for (uint32_t t = 0; t < n; ++t) candidates += (uint32_t)on_nonmanifold_edge(out, t);
    back_queues q = {out, table_capacity(candidates), NULL, NULL, NULL, NULL};
    q.opener = alloc_array(q.cap, sizeof *q.opener);
    q.head = alloc_array(q.cap, sizeof *q.head);
    q.tail = alloc_array(q.cap, sizeof *q.tail);
    q.next = alloc_array(n, sizeof *q.next);
    long pairs = -1;
    if (q.opener && q.head && q.tail && q.next) {
        memset(q.opener, 0xff, q.cap * sizeof *q.opener);
        pairs = 0;
        for (uint32_t t = 0; t < n; ++t) {
            back_of[t] = NONE;
            is_back[t] = 0;
            q.next[t] = NONE;
            if (!on_nonmanifold_edge(out, t)) continue;
            const int parity = winding_parity(out->triangle_vertices + 3 * (size_t)t);
            const size_t other = back_queue_slot(&q, t, !parity);
            if (q.opener[other] != NONE && q.head[other] != NONE) {
                const uint32_t front = q.head[other];
                q.head[other] = q.next[front];
                back_of[front] = t;
                is_back[t] = 1;
                pairs++;
                continue;
            }
            const size_t own = back_queue_slot(&q, t, parity);
            if (q.opener[own] == NONE) q.opener[own] = q.head[own] = t;
            else if (q.head[own] == NONE) q.head[own] = t; /* drained */
            else q.next[q.tail[own]] = t;
            q.tail[own] = t;
        }
    }
    free(q.opener);
    free(q.head);
    free(q.tail);
    free(q.next);
    return pairs;
}

typedef struct pair_edge {
    uint64_t key;     /* the edge's vertices, lower << 32 | higher */
    uint32_t pair;    /* dense pair number */
    uint32_t forward; /* the pair's front runs lower -> higher */
} pair_edge;

static int compare_pair_edges(const void *a, const void *b)
{
    const pair_edge *x = a, *y = b;
    if (x->key != y->key) return x->key < y->key ? -1 : 1;
    return (x->pair > y->pair) - (x->pair < y->pair);
}

/* Do entries i and i + 1 of the sorted edges, and no others, hold one edge? */
static int shared_by_two(const pair_edge *e, size_t n, size_t i)
{
    return e[i].key == e[i + 1].key && (i + 2 >= n || e[i + 2].key != e[i].key) && (i == 0 || e[i - 1].key != e[i].key);
}

/* Which of a pair is the front is a choice: pair_backs takes the earlier
 * triangle, which gives a consistently oriented front layer when the input
 * lists one side first (or each front before its back), but not when an
 * index optimizer has shuffled the two sides of a primitive together: then
 * neighbouring fronts disagree in winding, their edges look non-manifold and
 * the layer is locked. So the front of each pair is chosen again by a flood
 * over the pairs, across each edge that exactly two pairs share: a
 * neighbour's front must run the edge the other way. The first pair of each
 * connected set keeps its front, so an input whose earlier triangles already
 * agree is left as it is; a pair whose two triangles are in different
 * primitives is never turned (its front's primitive would change). Returns
 * 0, or -1 when memory runs out. */
static int orient_pairs(const weld_result *out, uint32_t *back_of, uint8_t *is_back, long pairs)
{
    const uint32_t n = out->triangle_count;
    const size_t np = (size_t)pairs;
    uint32_t *front = alloc_array(np, sizeof *front), *offset = alloc_array(np + 1, sizeof *offset);
    pair_edge *e = alloc_array(3 * np, sizeof *e);
    uint32_t *adjacent = alloc_array(6 * np, sizeof *adjacent), *queue = alloc_array(np, sizeof *queue);
    uint8_t *same = alloc_array(6 * np, 1), *state = alloc_array(np, 1);
    int rc = -1;
    if (!front || !offset || !e || !adjacent || !queue || !same || !state) goto done;
    size_t k = 0;
    for (uint32_t f = 0; f < n; ++f) {
        if (back_of[f] == NONE) continue;
        const uint32_t *tv = out->triangle_vertices + 3 * (size_t)f;
        for (int c = 0; c < 3; ++c) {
            const uint32_t a = tv[c], b = tv[(c + 1) % 3];
            e[3 * k + (size_t)c] = (pair_edge){(uint64_t)(a < b ? a : b) << 32 | (a < b ? b : a), (uint32_t)k, a < b};
        }
        front[k++] = f;
    }
    qsort(e, 3 * np, sizeof *e, compare_pair_edges);
    /* adjacency (CSR) over the edges exactly two pairs share; same[i]: both
     * fronts run the edge the same way (then one of them must turn) */
    memset(offset, 0, (np + 1) * sizeof *offset);
    for (size_t i = 0; i + 1 < 3 * np; ++i)
        if (shared_by_two(e, 3 * np, i)) {
            offset[e[i].pair + 1]++;
            offset[e[i + 1].pair + 1]++;
        }
    for (size_t p = 0; p < np; ++p) offset[p + 1] += offset[p];
    uint32_t *fill = queue; /* the queue is free until the flood */
    for (size_t p = 0; p < np; ++p) fill[p] = offset[p];
    for (size_t i = 0; i + 1 < 3 * np; ++i)
        if (shared_by_two(e, 3 * np, i)) {
            const pair_edge *x = &e[i], *y = &e[i + 1];
            same[fill[x->pair]] = same[fill[y->pair]] = x->forward == y->forward;
            adjacent[fill[x->pair]++] = y->pair;
            adjacent[fill[y->pair]++] = x->pair;
        }
    memset(state, 0, np); /* 0 not reached, 1 keeps its front, 2 turns */
    for (size_t start = 0; start < np; ++start) {
        if (state[start]) continue;
        state[start] = 1;
        size_t head = 0, tail = 0;
        queue[tail++] = (uint32_t)start;
        while (head < tail) {
            const uint32_t p = queue[head++];
            for (uint32_t i = offset[p]; i < offset[p + 1]; ++i) {
                const uint32_t q = adjacent[i];
                if (state[q]) continue;
                const int turn = (state[p] == 2) != same[i];
                const uint32_t f = front[q];
                state[q] = turn && out->triangle_primitive[f] == out->triangle_primitive[back_of[f]] ? 2 : 1;
                queue[tail++] = q;
            }
        }
    }
    for (size_t p = 0; p < np; ++p) {
        if (state[p] != 2) continue;
        const uint32_t f = front[p], b = back_of[f];
        back_of[f] = NONE;
        is_back[f] = 1;
        back_of[b] = f;
        is_back[b] = 0;
    }
    rc = 0;
done:
    free(front);
    free(offset);
    free(e);
    free(adjacent);
    free(queue);
    free(same);
    free(state);
    return rc;
}

typedef struct back_map_entry {
    uint64_t key; /* front wedge class << 32 | back primitive */
    uint32_t wedge;
} back_map_entry;

static int compare_back_map_entries(const void *a, const void *b)
{
    const back_map_entry *x = a, *y = b;
    if (x->key != y->key) return x->key < y->key ? -1 : 1;
    return (x->wedge > y->wedge) - (x->wedge < y->wedge);
}

/* The key of corner c of front f paired with back b: the front's wedge class
 * and the back's primitive. */
static uint64_t corner_back_key(const weld_result *out, uint32_t f, int c, uint32_t b)
{
    return (uint64_t)out->wedge_class[out->triangle_wedges[3 * (size_t)f + (size_t)c]] << 32 | out->triangle_primitive[b];
}

/* The map's entries of the pairs, sorted, into e (3 per pair). */
static size_t back_map_entries(const weld_result *out, const uint32_t *back_of, back_map_entry *e)
{
    size_t n = 0;
    for (uint32_t f = 0; f < out->triangle_count; ++f) {
        const uint32_t b = back_of[f];
        if (b == NONE) continue;
        for (int c = 0; c < 3; ++c) {
            const uint32_t vertex = out->triangle_vertices[3 * (size_t)f + (size_t)c];
            int bc = 0;
            while (out->triangle_vertices[3 * (size_t)b + (size_t)bc] != vertex) bc++;
            e[n].key = corner_back_key(out, f, c, b);
            e[n++].wedge = out->wedge_class[out->triangle_wedges[3 * (size_t)b + (size_t)bc]];
        }
    }
    qsort(e, n, sizeof *e, compare_back_map_entries);
    return n;
}

/* Unpairs every pair with a corner whose key has two back classes (an
 * attribute seam on the back alone: the front's wedge cannot tell which back
 * value a moved corner would carry). Such a pair stays in the topology as two
 * triangles, its edges non-manifold and so locked, like an unpaired repeat.
 * e holds the sorted entries; returns the number of pairs unpaired. */
static long unpair_conflicts(const weld_result *out, uint32_t *back_of, uint8_t *is_back, back_map_entry *e, size_t n)
{
    size_t conflicts = 0; /* their keys, compacted to the front of e */
    for (size_t i = 1; i < n; ++i)
        if (e[i].key == e[i - 1].key && e[i].wedge != e[i - 1].wedge &&
            (conflicts == 0 || e[conflicts - 1].key != e[i].key))
            e[conflicts++].key = e[i].key;
    long unpaired = 0;
    for (uint32_t f = 0; f < out->triangle_count && conflicts; ++f) {
        const uint32_t b = back_of[f];
        if (b == NONE) continue;
        for (int c = 0; c < 3; ++c) {
            const uint64_t key = corner_back_key(out, f, c, b);
            size_t lo = 0, hi = conflicts;
            while (lo < hi) {
                const size_t mid = lo + (hi - lo) / 2;
                if (e[mid].key < key) lo = mid + 1;
                else hi = mid;
            }
            if (lo < conflicts && e[lo].key == key) {
                back_of[f] = NONE;
                is_back[b] = 0;
                unpaired++;
                break;
            }
        }
    }
    return unpaired;
}

/* The back layer's wedge class for each (front wedge class, back primitive)
 * of the pairs, into out->back_map_*, after unpairing the pairs whose keys
 * would have two (*pairs is what remains). Returns 1 when pairs remain (the
 * map stored), 0 when none does, -1 when memory runs out. */
static int build_back_map(weld_result *out, uint32_t *back_of, uint8_t *is_back, long *pairs)
{
    back_map_entry *e = alloc_array(3 * (size_t)*pairs, sizeof *e);
    if (!e) return -1;
    size_t n = back_map_entries(out, back_of, e);
    const long unpaired = unpair_conflicts(out, back_of, is_back, e, n);
    if (unpaired) {
        /* the keys left were never in conflict: fewer pairs cannot make one */
        *pairs -= unpaired;
        n = back_map_entries(out, back_of, e);
    }
    size_t keys = 0;
    for (size_t i = 0; i < n; ++i)
        if (!i || e[i].key != e[i - 1].key) e[keys++] = e[i];
    if (!keys) {
        free(e);
        return 0;
    }
    out->back_map_key = alloc_array(keys, sizeof *out->back_map_key);
    out->back_map_wedge = alloc_array(keys, sizeof *out->back_map_wedge);
    if (!out->back_map_key || !out->back_map_wedge) {
        free(e);
        return -1;
    }
    for (size_t i = 0; i < keys; ++i) {
        out->back_map_key[i] = e[i].key;
        out->back_map_wedge[i] = e[i].wedge;
    }
    out->back_map_count = (uint32_t)keys;
    free(e);
    return 1;
}

/* Takes the backs (weld.h) out of the triangle arrays, keeping the others in
 * order, into out->back_* and out->triangle_back, and builds the topology
 * again without them. Runs after a first build_topology (its edge flags and
 * wedge classes), and only when that found a non-manifold edge: every pair
 * but a lone pillow has one, so a manifold mesh pays nothing. */
static int take_backs(weld_work *k, weld_result *out, unsigned threads, lp_error *err)
{
    const uint32_t n = out->triangle_count;
    uint32_t *back_of = alloc_array(n, sizeof *back_of);
    uint8_t *is_back = alloc_array(n, sizeof *is_back);
    long pairs = back_of && is_back ? pair_backs(out, back_of, is_back) : -1;
    int map = 0;
    if (pairs > 0 && orient_pairs(out, back_of, is_back, pairs) < 0) pairs = -1;
    if (pairs > 0) map = build_back_map(out, back_of, is_back, &pairs);
    if (pairs < 0 || map < 0) {
        free(back_of);
        free(is_back);
        return out_of_memory(k, err);
    }
    if (map == 1) {
        out->back_wedges = alloc_array(3 * (size_t)pairs, sizeof *out->back_wedges);
        out->back_primitive = alloc_array((size_t)pairs, sizeof *out->back_primitive);
        uint32_t *new_of = alloc_array(n, sizeof *new_of); /* old triangle -> kept number */
        if (!out->back_wedges || !out->back_primitive || !new_of) {
            free(new_of);
            free(back_of);
            free(is_back);
            return out_of_memory(k, err);
        }
        uint32_t kept = 0, backs = 0;
        for (uint32_t t = 0; t < n; ++t) {
            if (is_back[t]) {
                memcpy(out->back_wedges + 3 * (size_t)backs, out->triangle_wedges + 3 * (size_t)t,
                       3 * sizeof *out->back_wedges);
                out->back_primitive[backs] = out->triangle_primitive[t];
                new_of[t] = backs++; /* a back's number among the backs */
                continue;
            }
            memmove(out->triangle_wedges + 3 * (size_t)kept, out->triangle_wedges + 3 * (size_t)t,
                    3 * sizeof *out->triangle_wedges);
            memmove(out->triangle_vertices + 3 * (size_t)kept, out->triangle_vertices + 3 * (size_t)t,
                    3 * sizeof *out->triangle_vertices);
            out->triangle_primitive[kept] = out->triangle_primitive[t];
            new_of[t] = kept++;
        }
        /* back_of becomes triangle_back: kept <= t, so each entry is read before it is written */
        for (uint32_t t = 0; t < n; ++t)
            if (!is_back[t]) back_of[new_of[t]] = back_of[t] == NONE ? WELD_NO_BACK : new_of[back_of[t]];
        free(new_of);
        out->triangle_back = back_of;
        back_of = NULL;
        out->back_count = backs;
        out->triangle_count = kept;
        out->stats.triangles = kept;
        out->stats.back_triangles = backs;
        /* the counts of the first build start again */
        out->stats.edges = out->stats.border_edges = out->stats.nonmanifold_edges = 0;
        out->stats.seam_edges = out->stats.nonmanifold_vertices = 0;
    }
    free(back_of);
    free(is_back);
    return map == 1 ? build_topology(k, out, threads, err) : LP_OK;
}

/* Up to this many primitives around a vertex are told apart by
 * lock_back_borders; a vertex with more is locked. */
#define BACK_BORDER_PRIMITIVES 8

/* A vertex where triangles of one primitive with a back meet triangles of
 * the same primitive without one, or with backs of different primitives, is
 * locked: a face that moved over it could carry its back (or the lack of
 * one) onto ground that had another. Where the primitive changes too (a
 * material seam of a mesh whose every primitive has its backs), the seam
 * already keeps each primitive's faces on their own ground, so such a
 * vertex keeps its kind and may slide along the seam. */
static void lock_back_borders(weld_result *out)
{
    if (!out->back_count) return;
    for (uint32_t v = 0; v < out->vertex_count; ++v) {
        uint32_t primitive[BACK_BORDER_PRIMITIVES], back[BACK_BORDER_PRIMITIVES], seen = 0;
        for (uint32_t i = out->vertex_triangle_offsets[v]; i < out->vertex_triangle_offsets[v + 1]; ++i) {
            const uint32_t t = out->vertex_triangles[i], b = out->triangle_back[t];
            const uint32_t p = out->triangle_primitive[t], back_primitive = b == WELD_NO_BACK ? NONE : out->back_primitive[b];
            uint32_t j = 0;
            while (j < seen && primitive[j] != p) j++;
            if (j == seen && seen < BACK_BORDER_PRIMITIVES) {
                primitive[seen] = p;
                back[seen++] = back_primitive;
            } else if (j == seen || back[j] != back_primitive) {
                out->vertex_kind[v] = WELD_LOCKED;
                break;
            }
        }
    }
    count_kinds(out);
}

/* A dropped triangle is "dangling" when its segment (two distinct positions)
 * is not an edge of a kept triangle, or its point (one position) is not a
 * kept vertex. Conservative: such a segment may still lie inside the surface;
 * keeping it costs only its vertices' lock (keep_dangling). */
/* Is {a, b} (a != b) an edge of a kept triangle? Any kept triangle that has
 * both has it as an edge: looked for around the endpoint with fewer. */
static int is_kept_edge(const weld_result *out, uint32_t a, uint32_t b)
{
    const uint32_t *off = out->vertex_triangle_offsets;
    if (off[b + 1] - off[b] < off[a + 1] - off[a]) {
        uint32_t t = a;
        a = b;
        b = t;
    }
    for (uint32_t i = off[a]; i < off[a + 1]; ++i) {
        const uint32_t *tv = out->triangle_vertices + 3 * (size_t)out->vertex_triangles[i];
        if (tv[0] == b || tv[1] == b || tv[2] == b) return 1;
    }
    return 0;
}

static int compare_u64(const void *a, const void *b)
{
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* The point set of dropped triangle t of primitive p as position vertices:
 * a segment a-b, or a point (a == b); NONE for a position that no kept
 * triangle uses. */
static void dropped_segment(const weld_work *k, uint32_t p, size_t t, uint32_t *a, uint32_t *b)
{
    const uint32_t *tri = k->mesh->primitives[p].triangles + 3 * t;
    uint32_t q[3];
    for (int c = 0; c < 3; ++c) q[c] = k->prov_final[k->gv_position[k->prim_base[p] + tri[c]]];
    *a = q[0];
    *b = q[0] == q[1] ? q[2] : q[1];
}

static uint64_t segment_key(uint32_t a, uint32_t b)
{
    return a < b ? (uint64_t)a << 32 | b : (uint64_t)b << 32 | a;
}

/* What a dropped triangle's point set is, besides a segment's segment_key
 * (whose high half is a position vertex, never NONE, so neither value can be
 * one): a point on a kept position, or something on a position no kept
 * triangle uses. */
#define DROPPED_POINT (UINT64_MAX - 1)
#define DROPPED_OFF UINT64_MAX

/* Finds the dropped triangles that dangle, in input order, into
 * dangling_primitive and k->dangling_triangle (their number in the
 * primitive). A dropped triangle whose two positions are kept is a segment:
 * it dangles unless it is an edge of a kept triangle. Each distinct segment
 * is looked up once (many dropped triangles on one pair of hub vertices must
 * not each walk a hub's triangles). */
static int find_dangling(weld_work *k, weld_result *out, lp_error *err)
{
    const scene_mesh *m = k->mesh;
    const uint32_t dropped = out->stats.degenerate_triangles;
    /* per dropped triangle, in input order: its point set (segment_key or a
     * DROPPED_ value); and the distinct segments, to look up */
    uint64_t *point_set = alloc_array(dropped, sizeof *point_set);
    uint64_t *segments = alloc_array(dropped, sizeof *segments);
    uint8_t *is_edge = alloc_array(dropped, sizeof *is_edge);
    out->dangling_primitive = alloc_array(dropped, sizeof *out->dangling_primitive);
    k->dangling_triangle = alloc_array(dropped, sizeof *k->dangling_triangle);
    if (!point_set || !segments || !is_edge || !out->dangling_primitive || !k->dangling_triangle) {
        free(point_set);
        free(segments);
        free(is_edge);
        return out_of_memory(k, err);
    }
    uint32_t n = 0;
    size_t count = 0;
    for (uint32_t p = 0; p < m->primitive_count; ++p) {
        const scene_primitive *pr = &m->primitives[p];
        if (!is_welded(pr)) continue;
        for (size_t t = 0; t < pr->triangle_count; ++t) {
            if (!triangle_is_degenerate(k, p, t)) continue;
            uint32_t a, b;
            dropped_segment(k, p, t, &a, &b);
            point_set[n] = a == NONE || b == NONE ? DROPPED_OFF : a == b ? DROPPED_POINT : segment_key(a, b);
            if (point_set[n] < DROPPED_POINT) segments[count++] = point_set[n];
            out->dangling_primitive[n] = p;
            k->dangling_triangle[n++] = (uint32_t)t;
        }
    }
    if (count) qsort(segments, count, sizeof *segments, compare_u64);
    size_t unique = 0;
    for (size_t i = 0; i < count; ++i)
        if (!unique || segments[i] != segments[unique - 1]) segments[unique++] = segments[i];
    for (size_t i = 0; i < unique; ++i)
        is_edge[i] = (uint8_t)is_kept_edge(out, (uint32_t)(segments[i] >> 32), (uint32_t)segments[i]);
    /* keep the ones that dangle, in order */
    uint32_t kept = 0;
    for (uint32_t i = 0; i < n; ++i) {
        int dangles = point_set[i] == DROPPED_OFF;
        if (point_set[i] < DROPPED_POINT) {
            const uint64_t *at = bsearch(&point_set[i], segments, unique, sizeof *segments, compare_u64);
            assert(at); /* every segment was listed */
            dangles = !is_edge[at - segments];
        }
        if (!dangles) continue;
        out->dangling_primitive[kept] = out->dangling_primitive[i];
        k->dangling_triangle[kept++] = k->dangling_triangle[i];
    }
    free(point_set);
    free(segments);
    free(is_edge);
    out->dangling_count = kept;
    out->stats.degenerate_dangling = kept;
    return LP_OK;
}

/* Sets *array to a block of count elements of size bytes holding its first
 * elements; 0, or -1 with *array unchanged when memory runs out. */
static int grow_array(void **array, size_t count, size_t size)
{
    void *p = realloc(*array, (count ? count : 1) * size);
    if (!p) return -1;
    *array = p;
    return 0;
}

/* Numbers the positions and wedges of the dangling triangles that no kept
 * triangle uses (after the kept ones, by first appearance) and returns how
 * many vertices and wedges there are then. */
static void number_dangling(weld_work *k, const weld_result *out, uint32_t *vertices, uint32_t *wedges)
{
    *vertices = out->vertex_count;
    *wedges = out->wedge_count;
    for (uint32_t i = 0; i < out->dangling_count; ++i) {
        const uint32_t p = out->dangling_primitive[i];
        const uint32_t *tri = k->mesh->primitives[p].triangles + 3 * (size_t)k->dangling_triangle[i];
        for (int c = 0; c < 3; ++c) {
            const uint32_t gv = k->prim_base[p] + tri[c];
            uint32_t *final = &k->prov_final[k->gv_position[gv]];
            if (*final == NONE) *final = (*vertices)++;
            if (k->gv_wedge[gv] == NONE) k->gv_wedge[gv] = (*wedges)++;
        }
    }
}

/* A dangling triangle is a segment (or point) that may lie off the welded
 * surface, where no simplified face can be certified to stay within eps of
 * it: the levels carry it as it is instead, covered by itself. Its positions
 * and wedges join the vertex and wedge arrays (new vertices without a
 * triangle), and its vertices are locked so that it stays valid and in
 * place in every level. */
static int keep_dangling(weld_work *k, weld_result *out, lp_error *err)
{
    const uint32_t n = out->dangling_count, old_vertices = out->vertex_count, old_wedges = out->wedge_count;
    if (!n) return LP_OK;
    uint32_t vertices, wedges;
    number_dangling(k, out, &vertices, &wedges);
    if (grow_array((void **)&out->positions, 3 * (size_t)vertices, sizeof *out->positions) ||
        grow_array((void **)&out->vertex_kind, vertices, sizeof *out->vertex_kind) ||
        grow_array((void **)&out->vertex_triangle_offsets, (size_t)vertices + 1, sizeof *out->vertex_triangle_offsets) ||
        grow_array((void **)&out->wedge_primitive, wedges, sizeof *out->wedge_primitive) ||
        grow_array((void **)&out->wedge_index, wedges, sizeof *out->wedge_index) ||
        grow_array((void **)&out->wedge_vertex, wedges, sizeof *out->wedge_vertex) ||
        grow_array((void **)&out->wedge_class, wedges, sizeof *out->wedge_class))
        return out_of_memory(k, err);
    out->dangling_wedges = alloc_array(3 * (size_t)n, sizeof *out->dangling_wedges);
    out->dangling_vertices = alloc_array(3 * (size_t)n, sizeof *out->dangling_vertices);
    if (!out->dangling_wedges || !out->dangling_vertices) return out_of_memory(k, err);
    for (uint32_t v = old_vertices; v < vertices; ++v) /* no triangle of the topology */
        out->vertex_triangle_offsets[v + 1] = out->vertex_triangle_offsets[old_vertices];
    for (uint32_t i = 0; i < n; ++i) {
        const uint32_t p = out->dangling_primitive[i];
        const uint32_t *tri = k->mesh->primitives[p].triangles + 3 * (size_t)k->dangling_triangle[i];
        for (int c = 0; c < 3; ++c) {
            const uint32_t gv = k->prim_base[p] + tri[c], prov = k->gv_position[gv];
            const uint32_t vertex = k->prov_final[prov], wedge = k->gv_wedge[gv];
            if (vertex >= old_vertices)
                for (int a = 0; a < 3; ++a) {
                    const uint32_t bits = k->prov_key[3 * (size_t)prov + (size_t)a];
                    memcpy(&out->positions[3 * (size_t)vertex + (size_t)a], &bits, sizeof bits);
                }
            if (wedge >= old_wedges) {
                out->wedge_primitive[wedge] = p;
                out->wedge_index[wedge] = tri[c];
                out->wedge_vertex[wedge] = vertex;
                out->wedge_class[wedge] = wedge;
            }
            out->dangling_wedges[3 * (size_t)i + (size_t)c] = wedge;
            out->dangling_vertices[3 * (size_t)i + (size_t)c] = vertex;
        }
    }
    for (size_t c = 0; c < 3 * (size_t)n; ++c) out->vertex_kind[out->dangling_vertices[c]] = WELD_LOCKED;
    out->vertex_count = vertices;
    out->wedge_count = wedges;
    out->stats.vertices = vertices;
    out->stats.wedges = wedges;
    out->stats.wedge_classes += wedges - old_wedges;
    count_kinds(out);
    return LP_OK;
}

/* ---- public ----------------------------------------------------------------- */

int weld_build(const scene_mesh *mesh, uint32_t threads, weld_result *out, lp_error *err)
{
    memset(out, 0, sizeof *out);
    weld_work k;
    memset(&k, 0, sizeof k);
    k.mesh = mesh;
    k.name = mesh->name ? mesh->name : "";
    int rc = count_input(&k, err);
    if (!rc) rc = weld_positions(&k, err);
    if (!rc) rc = number_kept(&k, out, err);
    if (!rc) rc = allocate_result(&k, out, err);
    if (!rc) {
        fill_arrays(&k, out);
        const unsigned topology_threads = lp_threads(threads, WELD_THREADS_MAX);
        rc = build_topology(&k, out, topology_threads, err);
        if (!rc && out->stats.nonmanifold_edges) rc = take_backs(&k, out, topology_threads, err);
        if (!rc) lock_back_borders(out);
    }
    if (!rc) rc = find_dangling(&k, out, err);
    if (!rc) rc = keep_dangling(&k, out, err);
    work_free(&k);
    if (rc) weld_free(out);
    return rc;
}

void weld_free(weld_result *w)
{
    free(w->positions);
    free(w->vertex_kind);
    free(w->vertex_triangle_offsets);
    free(w->vertex_triangles);
    free(w->wedge_primitive);
    free(w->wedge_index);
    free(w->wedge_vertex);
    free(w->wedge_class);
    free(w->triangle_wedges);
    free(w->triangle_vertices);
    free(w->triangle_primitive);
    free(w->edge_opposite);
    free(w->edge_flags);
    free(w->dangling_wedges);
    free(w->dangling_vertices);
    free(w->dangling_primitive);
    free(w->back_wedges);
    free(w->back_primitive);
    free(w->triangle_back);
    free(w->back_map_key);
    free(w->back_map_wedge);
    memset(w, 0, sizeof *w);
}

void weld_release_edge_opposite(weld_result *w)
{
    free(w->edge_opposite);
    w->edge_opposite = NULL;
}

uint32_t weld_back_wedge(const weld_result *w, uint32_t front_class, uint32_t back_primitive)
{
    const uint64_t key = (uint64_t)front_class << 32 | back_primitive;
    uint32_t lo = 0, hi = w->back_map_count;
    while (lo < hi) {
        const uint32_t mid = lo + (hi - lo) / 2;
        if (w->back_map_key[mid] < key) lo = mid + 1;
        else hi = mid;
    }
    return lo < w->back_map_count && w->back_map_key[lo] == key ? w->back_map_wedge[lo] : NONE;
}

uint32_t weld_level0_triangles(const weld_result *w)
{
    return w->triangle_count + w->back_count + w->dangling_count;
}

/* Rows: vertex kind. Columns: the edge it would collapse along, as
 * 0 manifold interior, 1 seam, 2 border, 3 non-manifold. */
static const uint8_t collapse_rule[WELD_KIND_COUNT][4] = {
    /* MANIFOLD */ {1, 0, 0, 0}, /* onto anything, except across a far-end seam */
    /* BORDER   */ {0, 0, 1, 0}, /* only along its border */
    /* SEAM     */ {0, 1, 0, 0}, /* only along its seam, both wedges together */
    /* LOCKED   */ {0, 0, 0, 0}, /* never moves */
};

int weld_collapse_allowed(weld_kind kind, uint8_t flags)
{
    if ((unsigned)kind >= WELD_KIND_COUNT) return 0;
    int column = (flags & WELD_FLAG_NONMANIFOLD) ? 3 : (flags & WELD_FLAG_BORDER) ? 2 : (flags & WELD_FLAG_SEAM) ? 1 : 0;
    return collapse_rule[kind][column];
}

const char *weld_kind_name(weld_kind kind)
{
    static const char *const names[WELD_KIND_COUNT] = {"manifold", "border", "seam", "locked"};
    return (unsigned)kind < WELD_KIND_COUNT ? names[kind] : "?";
}
