/* lodchain.c - see lodchain.h. */
#include "lodchain.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accessor.h"
#include "bvh.h"
#include "jsonw.h"
#include "measure.h"
#include "sha256.h"
#include "threads.h"

static void warn(lodchain_summary *out, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void warn(lodchain_summary *out, const char *fmt, ...)
{
    if (out->warning_count < sizeof out->warnings / sizeof out->warnings[0]) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(out->warnings[out->warning_count], sizeof out->warnings[0], fmt, ap);
        va_end(ap);
    }
    out->warning_count++;
}

/* Levels worth writing: not empty, and removing at least min_reduction of the
 * previous kept level's triangles. */
uint32_t lodchain_kept_levels(const weld_result *w, const simplify_result *r, double min_reduction,
                              uint32_t kept[SIMPLIFY_MAX_LEVELS])
{
    uint32_t n = 0, previous = weld_level0_triangles(w); /* level 0, as the levels count */
    for (uint32_t k = 0; k < r->level_count; ++k) {
        uint32_t t = r->levels[k].triangle_count;
        if (t == 0 || (double)t > (1.0 - min_reduction) * previous) continue;
        kept[n++] = k;
        previous = t;
    }
    return n;
}

/* ---- vertex order ------------------------------------------------------------ */

/* Per wedge of the mesh, the first level that no longer uses it: LOD0 =
 * level 0 uses every wedge, so 1 at least. Taken from the levels' faces,
 * wedge by wedge (a glTF vertex is one wedge): a position vertex can outlive
 * one of its wedges (a wedge used only by triangles that weld dropped as
 * degenerate, or a seam side whose faces are all gone), and such a vertex
 * must not sit among the ones the level still uses. The levels' wedge sets
 * nest (faces only die, and a changed face takes a wedge from a face that
 * survives), so ordering by it gives every level a prefix. NULL when out of
 * memory. */
static uint8_t *wedge_deaths(const weld_result *w, const simplify_result *r)
{
    uint8_t *death = malloc((size_t)w->wedge_count + 1);
    if (!death) return NULL;
    memset(death, 1, w->wedge_count);
    for (uint32_t k = 0; k < r->level_count; ++k)
        for (size_t c = 0; c < 3 * (size_t)r->levels[k].triangle_count; ++c)
            death[r->levels[k].wedges[c]] = (uint8_t)(k + 2);
    return death;
}

/* new_of_old for primitive p's vertex_count glTF vertices, last to die
 * first (wedge_deaths), in index order among equal deaths; vertices no
 * triangle uses die "at level 0" and go last. A stable counting sort: a
 * death is one byte, and a vertex keeps its place among its equals. */
static int vertex_order(const weld_result *w, const uint8_t *wedge_death, uint32_t p, uint32_t vertex_count,
                        uint32_t *new_of_old)
{
    uint8_t *death = calloc((size_t)vertex_count + 1, 1);
    if (!death) return -1;
    for (uint32_t x = 0; x < w->wedge_count; ++x)
        if (w->wedge_primitive[x] == p && w->wedge_index[x] < vertex_count) death[w->wedge_index[x]] = wedge_death[x];
    uint32_t start[UINT8_MAX + 1] = {0}; /* first new index of each death value */
    for (uint32_t i = 0; i < vertex_count; ++i) start[death[i]]++;
    uint32_t next = 0;
    for (int d = UINT8_MAX; d >= 0; --d) {
        const uint32_t count = start[d];
        start[d] = next;
        next += count;
    }
    for (uint32_t i = 0; i < vertex_count; ++i) new_of_old[i] = start[death[i]]++;
    free(death);
    return 0;
}

/* ---- accessors ------------------------------------------------------------------ */

static int set_json(gltf_doc *doc, lp_error *err, const char *value, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static int set_json(gltf_doc *doc, lp_error *err, const char *value, const char *fmt, ...)
{
    char pointer[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(pointer, sizeof pointer, fmt, ap);
    va_end(ap);
    if (gltf_set_json(doc, pointer, value) != 0) return lp_fail(err, LP_INVALID, "cannot set %s", pointer);
    return LP_OK;
}

/* Copies the members `keys` (NULL-terminated; "a/b" reaches into an object)
 * of object `from` of `array` to object `to` of the same array, those it has:
 * what a new object takes over from the one it stands for. */
static void copy_members(gltf_doc *doc, const char *array, long long from, long long to, const char *const *keys)
{
    char source[160], target[160];
    for (; *keys; ++keys) {
        snprintf(source, sizeof source, "/%s/%lld/%s", array, from, *keys);
        snprintf(target, sizeof target, "/%s/%lld/%s", array, to, *keys);
        gltf_copy_json(doc, source, target); /* absent: nothing to copy */
    }
}

/* Rewrites accessor a's data in the new vertex order, in place: it keeps its
 * number and JSON and points at a new bufferView (sparse data folded in),
 * which takes the place of the old view (gltf_view_replaces: its name, extras
 * and extensions come along when nothing else keeps the old view). */
static int reorder_accessor(gltf_doc *doc, int64_t a, const uint32_t *new_of_old, uint32_t vertex_count,
                            lp_error *err)
{
    uint8_t *raw;
    uint32_t count, elem;
    int rc = accessor_read_raw(doc, a, &raw, &count, &elem, err);
    if (rc) return rc;
    if (count != vertex_count) {
        free(raw);
        return lp_fail(err, LP_INVALID, "accessors[%lld] has %u elements, not %u", (long long)a, count, vertex_count);
    }
    const uint32_t stride = (elem + 3u) & ~3u; /* vertex data stays 4-byte aligned */
    uint8_t *out = calloc((size_t)count * stride + 1, 1);
    if (!out) {
        free(raw);
        return lp_no_memory(err, "out of memory");
    }
    for (uint32_t i = 0; i < count; ++i) memcpy(out + (size_t)new_of_old[i] * stride, raw + (size_t)i * elem, elem);
    int64_t view = gltf_add_view(doc, out, (size_t)count * stride, stride != elem ? stride : 0, 34962);
    free(raw);
    free(out);
    if (view < 0) return lp_no_memory(err, "out of memory");
    gltf_accessor old;
    if (gltf_get_accessor(doc, (size_t)a, &old) == 0 && old.buffer_view >= 0)
        gltf_view_replaces(doc, view, old.buffer_view);
    char value[32];
    snprintf(value, sizeof value, "%lld", (long long)view);
    rc = set_json(doc, err, value, "/accessors/%lld/bufferView", (long long)a);
    gltf_remove_jsonf(doc, "/accessors/%lld/byteOffset", (long long)a);
    gltf_remove_jsonf(doc, "/accessors/%lld/sparse", (long long)a);
    return rc;
}

/* Writes indices as a new bufferView; returns the view, or -1. The type is
 * the accessor's (component_type) or, when 0, 16-bit if the largest index
 * fits (a coarse level uses a short prefix of the vertices), else 32-bit;
 * 65535 is avoided, it reads as a primitive restart in some APIs. */
static int64_t index_view(gltf_doc *doc, const uint32_t *idx, size_t n, int *component_type)
{
    if (!*component_type) {
        uint32_t largest = 0;
        for (size_t i = 0; i < n; ++i)
            if (idx[i] > largest) largest = idx[i];
        *component_type = largest < 65535 ? 5123 : 5125;
    }
    size_t size = *component_type == 5121 ? 1 : (*component_type == 5123 ? 2 : 4);
    uint8_t *bytes = calloc(n * size + 4, 1);
    if (!bytes) return -1;
    for (size_t i = 0; i < n; ++i) {
        if (size == 1) bytes[i] = (uint8_t)idx[i];
        else if (size == 2) {
            uint16_t v = (uint16_t)idx[i];
            memcpy(bytes + 2 * i, &v, 2);
        } else {
            memcpy(bytes + 4 * i, &idx[i], 4);
        }
    }
    size_t padded = (n * size + 3) & ~(size_t)3;
    int64_t view = gltf_add_view(doc, bytes, padded, 0, 34963);
    free(bytes);
    return view;
}

/* A new index accessor over idx; returns its number, or -1. */
static int64_t append_indices(gltf_doc *doc, const uint32_t *idx, size_t n)
{
    int type = 0;
    int64_t view = index_view(doc, idx, n, &type);
    if (view < 0) return -1;
    char json[160];
    snprintf(json, sizeof json, "{\"bufferView\":%lld,\"componentType\":%d,\"count\":%zu,\"type\":\"SCALAR\"}",
             (long long)view, type, n);
    return gltf_append_json(doc, "accessors", json);
}

/* ---- LOD0: the original mesh, vertices in death order -------------------------- */

/* 1 when the input referenced each accessor of the primitive once (here).
 * The input's counts are the current ones for these accessors: what earlier
 * chains appended refers to their own meshes' accessors, or to ones shared
 * with them, which the input already referenced twice; and asking the input
 * costs nothing, where counting in the document walks all of it. */
static int exclusive(const gltf_doc *doc, const gltf_primitive *g)
{
    if (g->indices >= 0 && gltf_accessor_refs_at_load(doc, (size_t)g->indices) != 1) return 0;
    for (size_t a = 0; a < g->attribute_count; ++a)
        if (gltf_accessor_refs_at_load(doc, (size_t)g->attributes[a].accessor) != 1) return 0;
    for (size_t t = 0; t < g->target_count; ++t)
        for (size_t a = 0; a < g->target_attribute_counts[t]; ++a)
            if (gltf_accessor_refs_at_load(doc, (size_t)g->target_attributes[t][a].accessor) != 1) return 0;
    return 1;
}

/* Reorders primitive p of mesh m (when nothing else shares its accessors) and
 * rewrites its own indices to match. new_of_old is the identity otherwise. */
static int reorder_primitive(scene *s, uint32_t m, uint32_t p, const uint32_t *order, uint32_t *new_of_old,
                             int *reordered, lp_error *err)
{
    const scene_primitive *pr = &s->meshes[m].primitives[p];
    gltf_primitive g;
    gltf_get_primitive(s->doc, m, p, &g);
    *reordered = 0;
    int changes = 0;
    for (uint32_t i = 0; i < pr->vertex_count; ++i) changes |= order[i] != i;
    if (!changes || !exclusive(s->doc, &g)) {
        for (uint32_t i = 0; i < pr->vertex_count; ++i) new_of_old[i] = i;
        return LP_OK;
    }
    memcpy(new_of_old, order, (size_t)pr->vertex_count * sizeof *new_of_old);
    int rc = LP_OK;
    for (size_t a = 0; a < g.attribute_count && !rc; ++a)
        rc = reorder_accessor(s->doc, g.attributes[a].accessor, new_of_old, pr->vertex_count, err);
    for (size_t t = 0; t < g.target_count && !rc; ++t)
        for (size_t a = 0; a < g.target_attribute_counts[t] && !rc; ++a)
            rc = reorder_accessor(s->doc, g.target_attributes[t][a].accessor, new_of_old, pr->vertex_count, err);
    if (rc) return rc;
    /* the primitive's own indices, in its own mode, renumbered */
    uint32_t *idx = NULL, n = 0;
    if (g.indices >= 0) {
        rc = accessor_read_indices(s->doc, g.indices, pr->vertex_count, &idx, &n, err);
        if (rc) return rc;
    } else {
        n = pr->vertex_count;
        idx = malloc(((size_t)n + 1) * sizeof *idx);
        if (!idx) return lp_no_memory(err, "out of memory");
        for (uint32_t i = 0; i < n; ++i) idx[i] = i;
    }
    for (uint32_t i = 0; i < n; ++i) idx[i] = new_of_old[idx[i]];
    char value[32];
    if (g.indices >= 0) {
        gltf_accessor acc;
        gltf_get_accessor(s->doc, (size_t)g.indices, &acc);
        int type = acc.component_type;
        int64_t view = index_view(s->doc, idx, n, &type);
        if (view < 0) rc = lp_no_memory(err, "out of memory");
        else if (acc.buffer_view >= 0) gltf_view_replaces(s->doc, view, acc.buffer_view);
        snprintf(value, sizeof value, "%lld", (long long)view);
        if (!rc) rc = set_json(s->doc, err, value, "/accessors/%lld/bufferView", (long long)g.indices);
        gltf_remove_jsonf(s->doc, "/accessors/%lld/byteOffset", (long long)g.indices);
        gltf_remove_jsonf(s->doc, "/accessors/%lld/sparse", (long long)g.indices);
    } else {
        int64_t a = append_indices(s->doc, idx, n);
        if (a < 0) rc = lp_no_memory(err, "out of memory");
        snprintf(value, sizeof value, "%lld", (long long)a);
        if (!rc) rc = set_json(s->doc, err, value, "/meshes/%u/primitives/%u/indices", m, p);
    }
    free(idx);
    *reordered = !rc;
    return rc;
}

/* ---- level meshes ---------------------------------------------------------------- */

/* A level that placed vertices (full-edge placement, level->positions) cannot
 * index the original POSITION accessor as it is. This writes a new accessor
 * for primitive p (POSITION accessor `base`, vertices in the written order)
 * in which the vertices the level uses are where the level put them:
 * when base is plain float VEC3 data, a sparse accessor over base's own
 * bufferView that substitutes only the moved vertices (the level shares the
 * rest); otherwise every position as new float VEC3 data. Returns its number,
 * -2 when no vertex of the primitive moved (base serves as it is), -1 when
 * memory runs out. */
static int64_t level_positions(gltf_doc *doc, const scene_primitive *pr, uint32_t p, int64_t base, const weld_result *w,
                               const simplify_level *level, const uint32_t *new_of_old)
{
    const size_t n = pr->vertex_count;
    float *out = malloc((3 * n + 1) * sizeof *out);
    uint8_t *moved = calloc(n + 1, 1);
    if (!out || !moved) {
        free(out);
        free(moved);
        return -1;
    }
    for (size_t i = 0; i < n; ++i) memcpy(out + 3 * (size_t)new_of_old[i], pr->positions + 3 * i, 3 * sizeof *out);
    size_t moved_count = 0;
    for (size_t i = 0; i < 3 * (size_t)level->triangle_count; ++i) { /* only the vertices the level uses */
        const uint32_t x = level->wedges[i];
        if (w->wedge_primitive[x] != p || w->wedge_index[x] >= n) continue;
        const uint32_t at = new_of_old[w->wedge_index[x]];
        const float *from = level->positions + 3 * (size_t)w->wedge_vertex[x];
        if (memcmp(out + 3 * (size_t)at, from, 3 * sizeof *out) == 0) continue;
        memcpy(out + 3 * (size_t)at, from, 3 * sizeof *out);
        moved_count += !moved[at];
        moved[at] = 1;
    }
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < 3 * n; ++i) {
        lo[i % 3] = fmin(lo[i % 3], out[i]);
        hi[i % 3] = fmax(hi[i % 3], out[i]);
    }
    gltf_accessor acc;
    const int sparse = gltf_get_accessor(doc, (size_t)base, &acc) == 0 && acc.buffer_view >= 0 &&
                       acc.component_type == 5126 && acc.components == 3 && !acc.is_matrix && !acc.has_sparse &&
                       acc.count == n;
    int64_t data_view = -1, index_view_id = -1;
    if (moved_count && sparse) {
        uint32_t *indices = malloc((moved_count + 1) * sizeof *indices);
        float *values = malloc((3 * moved_count + 1) * sizeof *values);
        if (indices && values) {
            size_t k = 0;
            for (size_t i = 0; i < n; ++i) /* ascending, as the spec requires */
                if (moved[i]) {
                    indices[k] = (uint32_t)i;
                    memcpy(values + 3 * k, out + 3 * i, 3 * sizeof *values);
                    k++;
                }
            index_view_id = gltf_add_view(doc, indices, moved_count * sizeof *indices, 0, 0);
            data_view = gltf_add_view(doc, values, 3 * moved_count * sizeof *values, 0, 0);
            /* two accessors on one vertex bufferView need its byteStride;
             * 12 is what a tightly packed float VEC3 view has implicitly */
            char pointer[64];
            snprintf(pointer, sizeof pointer, "/bufferViews/%lld/byteStride", (long long)acc.buffer_view);
            char *stride = gltf_get_json(doc, pointer);
            if (!stride && gltf_set_json(doc, pointer, "12") != 0) data_view = -1;
            free(stride);
        }
        free(indices);
        free(values);
    } else if (moved_count) {
        data_view = gltf_add_view(doc, out, 3 * n * sizeof *out, 0, 34962);
    }
    free(out);
    free(moved);
    if (!moved_count) return -2;
    if (data_view < 0 || (sparse && index_view_id < 0)) return -1;
    jsonw j = {0};
    if (sparse)
        jsonw_printf(&j, "{\"bufferView\":%lld,\"byteOffset\":%llu,", (long long)acc.buffer_view,
                     (unsigned long long)acc.byte_offset);
    else
        jsonw_printf(&j, "{\"bufferView\":%lld,", (long long)data_view);
    jsonw_printf(&j, "\"componentType\":5126,\"count\":%zu,\"type\":\"VEC3\",\"min\":[", n);
    for (int c = 0; c < 3; ++c) {
        if (c) jsonw_raw(&j, ",");
        jsonw_number(&j, lo[c]);
    }
    jsonw_raw(&j, "],\"max\":[");
    for (int c = 0; c < 3; ++c) {
        if (c) jsonw_raw(&j, ",");
        jsonw_number(&j, hi[c]);
    }
    jsonw_raw(&j, "]");
    if (sparse)
        jsonw_printf(&j,
                     ",\"sparse\":{\"count\":%zu,\"indices\":{\"bufferView\":%lld,\"componentType\":5125},"
                     "\"values\":{\"bufferView\":%lld}}",
                     moved_count, (long long)index_view_id, (long long)data_view);
    jsonw_raw(&j, "}");
    int64_t a = j.failed ? -1 : gltf_append_json(doc, "accessors", j.text);
    jsonw_free(&j);
    return a;
}

/* The name of an object lodpipe adds for glTF object `kind`[index] (malloc'd;
 * NULL when out of memory): "<name><suffix>", or "<kind><index><suffix>" when
 * the object has no name (or ""), so that what the user sees in a client
 * leads back to the object it belongs to, as `simplify`'s mesh<K>_level<L>.obj
 * does; a bare "_LOD1" would name nothing. lodpipe only appends objects, so
 * the index is the same in the output. */
static char *derived_name(const char *name, const char *kind, uint32_t index, const char *suffix)
{
    char unnamed[32];
    if (!name[0]) {
        snprintf(unnamed, sizeof unnamed, "%s%u", kind, index);
        name = unnamed;
    }
    size_t name_len = strlen(name), suffix_len = strlen(suffix);
    char *out = malloc(name_len + suffix_len + 1);
    if (!out) return NULL;
    memcpy(out, name, name_len);
    memcpy(out + name_len, suffix, suffix_len + 1);
    return out;
}

/* "<name>_LOD<number>" (derived_name), the name of a level's mesh or node. */
static char *lod_name(const char *name, const char *kind, uint32_t index, uint32_t number)
{
    char suffix[32];
    snprintf(suffix, sizeof suffix, "_LOD%u", number);
    return derived_name(name, kind, index, suffix);
}

static int64_t write_level_mesh(scene *s, uint32_t m, const weld_result *w, const simplify_level *level,
                                uint32_t number, uint32_t *const *new_of_old, lp_error *err)
{
    const scene_mesh *mesh = &s->meshes[m];
    char *name = lod_name(mesh->name, "mesh", m, number);
    if (!name) return lp_no_memory(err, "out of memory"), -1;
    jsonw j = {0};
    jsonw_raw(&j, "{\"name\":");
    jsonw_string(&j, name);
    free(name);
    jsonw_raw(&j, ",\"primitives\":[]}");
    int64_t lod = j.failed ? -1 : gltf_append_json(s->doc, "meshes", j.text);
    jsonw_free(&j);
    if (lod < 0) return lp_no_memory(err, "out of memory"), -1;
    /* the mesh's own properties: default morph weights, and extras and
     * extensions (extras.targetNames names the morph targets for clients) */
    copy_members(s->doc, "meshes", m, lod, (const char *const[]){"weights", "extras", "extensions", NULL});
    char from[96], to[96];
    uint32_t written = 0;
    for (uint32_t p = 0; p < mesh->primitive_count; ++p) {
        const scene_primitive *pr = &mesh->primitives[p];
        snprintf(from, sizeof from, "/meshes/%u/primitives/%u", m, p);
        snprintf(to, sizeof to, "/meshes/%lld/primitives/-", (long long)lod);
        if (pr->skipped || pr->mode < 4 || pr->triangle_count == 0) { /* passes through */
            if (gltf_copy_json(s->doc, from, to) != 0) return lp_fail(err, LP_INVALID, "cannot copy %s", from), -1;
            written++;
            continue;
        }
        size_t n = 0;
        for (uint32_t t = 0; t < level->triangle_count; ++t) n += level->primitive[t] == p;
        if (n == 0) continue;
        uint32_t *idx = malloc(3 * n * sizeof *idx);
        if (!idx) return lp_no_memory(err, "out of memory"), -1;
        size_t k = 0;
        for (uint32_t t = 0; t < level->triangle_count; ++t) {
            if (level->primitive[t] != p) continue;
            for (int c = 0; c < 3; ++c) idx[k++] = new_of_old[p][w->wedge_index[level->wedges[3 * (size_t)t + c]]];
        }
        int64_t a = append_indices(s->doc, idx, k);
        free(idx);
        if (a < 0 || gltf_copy_json(s->doc, from, to) != 0) return lp_no_memory(err, "out of memory"), -1;
        char value[32];
        snprintf(value, sizeof value, "%lld", (long long)a);
        if (set_json(s->doc, err, value, "/meshes/%lld/primitives/%u/indices", (long long)lod, written)) return -1;
        if (level->positions) {
            gltf_primitive g;
            gltf_get_primitive(s->doc, m, p, &g);
            const int64_t base = gltf_primitive_attribute(&g, "POSITION");
            int64_t moved = base < 0 ? -2 : level_positions(s->doc, pr, p, base, w, level, new_of_old[p]);
            if (moved == -1) return lp_no_memory(err, "out of memory"), -1;
            snprintf(value, sizeof value, "%lld", (long long)moved);
            if (moved >= 0 &&
                set_json(s->doc, err, value, "/meshes/%lld/primitives/%u/attributes/POSITION", (long long)lod, written))
                return -1;
        }
        gltf_remove_jsonf(s->doc, "/meshes/%lld/primitives/%u/mode", (long long)lod, written); /* triangles */
        written++;
    }
    return lod;
}

/* ---- nodes --------------------------------------------------------------------- */

/* The JSON pointer array index at p (decimal digits, no leading zero), with
 * *after set past it; -1 when there is none. */
static long long pointer_index(const char *p, const char **after)
{
    const char *digits = p;
    long long n = 0;
    while (*p >= '0' && *p <= '9' && n < (1LL << 40)) n = n * 10 + (*p++ - '0');
    if (p == digits || (*digits == '0' && p - digits > 1)) return -1;
    *after = p;
    return n;
}

/* A KHR_animation_pointer pointer "/<array>/N/rest": N, and *rest after its
 * slash; -1 when the pointer is not into that array. */
static long long pointer_into(const char *pointer, const char *array, const char **rest)
{
    const size_t len = strlen(array);
    if (!pointer || pointer[0] != '/' || strncmp(pointer + 1, array, len) != 0 || pointer[len + 1] != '/') return -1;
    const char *after;
    const long long n = pointer_index(pointer + len + 2, &after);
    if (n < 0 || *after != '/') return -1;
    *rest = after + 1;
    return n;
}

/* "weights", or "weights/K": one morph weight (the glTF object model's
 * /nodes/{}/weights/{} and /meshes/{}/weights/{}). */
static int is_weights_property(const char *property)
{
    const char *after;
    return strncmp(property, "weights", 7) == 0 &&
           (property[7] == 0 || (property[7] == '/' && pointer_index(property + 8, &after) >= 0 && *after == 0));
}

/* Channel c of animation a: the node it animates (-1: none) and the
 * property, as the node's JSON pointer suffix: the target's path
 * ("translation", "weights", ...), or for a KHR_animation_pointer channel
 * (path "pointer") what follows "/nodes/N/" in its pointer (e.g.
 * "extensions/KHR_node_visibility/visible", "weights/2"); at most 63
 * characters, else ""; and *mesh_weights: the mesh whose default weights it
 * drives by a pointer "/meshes/M/weights" or "/meshes/M/weights/K" (property
 * then what follows "/meshes/M/"), else -1. Returns 0, or -1 when there is
 * no channel c. */
static int channel_target(const scene *s, size_t a, size_t c, int64_t *node, char property[64], int64_t *mesh_weights)
{
    gltf_channel ch;
    if (gltf_get_channel(s->doc, a, c, &ch) != 0) return -1;
    *node = ch.node;
    *mesh_weights = -1;
    property[0] = 0;
    if (strlen(ch.path) < 64) strcpy(property, ch.path);
    if (strcmp(property, "pointer") != 0) return 0;
    property[0] = 0;
    const char *rest = NULL;
    *node = pointer_into(ch.pointer, "nodes", &rest);
    if (*node >= 0 && strlen(rest) < 64) strcpy(property, rest);
    else *node = -1;
    const long long mesh = pointer_into(ch.pointer, "meshes", &rest);
    if (mesh >= 0 && is_weights_property(rest) && strlen(rest) < 64) {
        *mesh_weights = mesh;
        strcpy(property, rest);
    }
    return 0;
}

/* Points channel c of animation a at the same property of object `index` of
 * `array` ("nodes", or "meshes" for a pointer to a mesh's weights): its
 * KHR_animation_pointer pointer, or else its target node. */
static int retarget_channel(scene *s, size_t a, size_t c, const char *array, int64_t index, const char *property)
{
    gltf_channel ch;
    if (gltf_get_channel(s->doc, a, c, &ch) != 0) return -1;
    char pointer[160];
    if (ch.pointer) {
        size_t len = strlen(array) + strlen(property);
        char *value = malloc(len + 32);
        jsonw j = {0};
        if (value) {
            snprintf(value, len + 32, "/%s/%lld/%s", array, (long long)index, property);
            jsonw_string(&j, value);
        }
        snprintf(pointer, sizeof pointer, "/animations/%zu/channels/%zu/target/extensions/KHR_animation_pointer/pointer",
                 a, c);
        const int rc = !value || j.failed ? -1 : gltf_set_json(s->doc, pointer, j.text);
        jsonw_free(&j);
        free(value);
        return rc;
    }
    char value[32];
    snprintf(pointer, sizeof pointer, "/animations/%zu/channels/%zu/target/node", a, c);
    snprintf(value, sizeof value, "%lld", (long long)index);
    return gltf_set_json(s->doc, pointer, value);
}

/* The properties of a node that its LOD nodes copy and so must animate alike. */
static int followed_property(const char *property)
{
    static const char *const kFollowed[] = {"translation", "rotation", "scale",
                                            "extensions/KHR_node_visibility/visible"};
    for (size_t k = 0; k < sizeof kFollowed / sizeof kFollowed[0]; ++k)
        if (strcmp(property, kFollowed[k]) == 0) return 1;
    return is_weights_property(property);
}

/* What a LOD node copies of the node it stands for (write_lod_node): a
 * client shows it in the node's place, every instance at every level. */
static const char *const kLodNodeCopies[] = {"matrix", "translation", "rotation", "scale", "skin", "weights",
                                             "extensions/EXT_mesh_gpu_instancing", "extensions/KHR_node_visibility",
                                             NULL};

/* 1 when a client that shows a LOD node in node n's place would lose part of
 * n: its children (clients replace a node together with them), its camera,
 * its extras (game metadata such as {"collider": true}: copies on every LOD
 * node would multiply what the user wrote once), or an extension the LOD node
 * does not copy (a KHR_lights_punctual light, one lodpipe does not know);
 * MSFT_lod, which the chain writes, aside. Empty extras ({}) hold nothing. */
static int lost_in_swap(const gltf_doc *doc, uint32_t n, const gltf_node *g)
{
    if (g->child_count || g->camera >= 0) return 1;
    char pointer[96];
    snprintf(pointer, sizeof pointer, "/nodes/%u/extras", n);
    char *extras = gltf_get_json(doc, pointer);
    const int has_extras = extras && strcmp(extras, "{}") != 0;
    free(extras);
    if (has_extras) return 1;
    size_t copied = 0;
    for (const char *const *key = kLodNodeCopies; *key; ++key) {
        if (strncmp(*key, "extensions/", 11) != 0) continue;
        snprintf(pointer, sizeof pointer, "/nodes/%u/%s", n, *key);
        char *value = gltf_get_json(doc, pointer);
        copied += value != NULL;
        free(value);
    }
    snprintf(pointer, sizeof pointer, "/nodes/%u/extensions/MSFT_lod", n);
    char *value = gltf_get_json(doc, pointer);
    copied += value != NULL;
    free(value);
    return g->extension_count > copied;
}

/* A node that a LOD node cannot stand in for without losing part of it
 * (lost_in_swap: children, a camera, extras, a light, ...) cannot simply carry
 * MSFT_lod: that part would vanish at coarse levels. Such a node keeps its
 * transform, children, camera, extras and extensions and hands its mesh (with skin,
 * morph weights and EXT_mesh_gpu_instancing, and animations of those weights)
 * to a new child with the identity transform, which carries the chain.
 * Returns the node that carries the mesh now, or -1. */
static int64_t mesh_carrier(scene *s, uint32_t n, lp_error *err)
{
    gltf_node g;
    gltf_get_node(s->doc, n, &g);
    if (!lost_in_swap(s->doc, n, &g)) return n;
    jsonw j = {0};
    char *name = derived_name(s->nodes[n].name, "node", n, "_mesh");
    jsonw_raw(&j, "{\"name\":");
    if (name) jsonw_string(&j, name);
    free(name);
    jsonw_printf(&j, ",\"mesh\":%lld}", (long long)s->nodes[n].mesh);
    int64_t carrier = !name || j.failed ? -1 : gltf_append_json(s->doc, "nodes", j.text);
    jsonw_free(&j);
    if (carrier < 0) return lp_no_memory(err, "out of memory"), -1;
    char from[96], to[96], value[32];
    for (const char *const *key = (const char *const[]){"skin", "weights", "extensions/EXT_mesh_gpu_instancing", NULL};
         *key; ++key) {
        snprintf(from, sizeof from, "/nodes/%u/%s", n, *key);
        snprintf(to, sizeof to, "/nodes/%lld/%s", (long long)carrier, *key);
        if (gltf_copy_json(s->doc, from, to) == 0) gltf_remove_json(s->doc, from);
    }
    /* the instancing went with the mesh; an extensions object it leaves empty goes too */
    snprintf(from, sizeof from, "/nodes/%u/extensions", n);
    char *left = gltf_get_json(s->doc, from);
    if (left && strcmp(left, "{}") == 0) gltf_remove_json(s->doc, from);
    free(left);
    snprintf(from, sizeof from, "/nodes/%u/mesh", n);
    gltf_remove_json(s->doc, from);
    snprintf(to, sizeof to, "/nodes/%u/children/-", n);
    snprintf(value, sizeof value, "%lld", (long long)carrier);
    if (gltf_set_json(s->doc, to, value) != 0) return lp_fail(err, LP_INVALID, "cannot add a child to nodes[%u]", n), -1;
    /* morph weight animations follow the mesh */
    for (size_t i = 0; i < s->channel_count; ++i) {
        scene_channel *e = &s->channels[i];
        if (e->node != (int64_t)n || !is_weights_property(e->property)) continue;
        if (retarget_channel(s, e->animation, e->channel, "nodes", carrier, e->property) != 0)
            return lp_fail(err, LP_INVALID, "cannot retarget an animation channel to nodes[%lld]", (long long)carrier), -1;
        e->node = carrier;
    }
    return carrier;
}

/* A LOD node named after scene node `named`, copying kLodNodeCopies of
 * document node `from` (the transform, skin, weights, instancing and
 * visibility: a client shows the LOD node in its place, every instance at
 * every level). */
static int64_t write_lod_node(scene *s, uint32_t named, int64_t from_node, int64_t lod_mesh, uint32_t number,
                              lp_error *err)
{
    char *name = lod_name(s->nodes[named].name, "node", named, number);
    if (!name) return lp_no_memory(err, "out of memory"), -1;
    jsonw j = {0};
    jsonw_raw(&j, "{\"name\":");
    jsonw_string(&j, name);
    free(name);
    jsonw_printf(&j, ",\"mesh\":%lld}", (long long)lod_mesh);
    int64_t id = j.failed ? -1 : gltf_append_json(s->doc, "nodes", j.text);
    jsonw_free(&j);
    if (id < 0) return lp_no_memory(err, "out of memory"), -1;
    copy_members(s->doc, "nodes", from_node, id, kLodNodeCopies);
    return id;
}

/* s->channels: every channel of the input, read once (channels appended for
 * LOD nodes and meshes never need following). */
static int index_channels(scene *s, lp_error *err)
{
    if (s->channels) return LP_OK;
    size_t total = 0;
    const size_t animations = gltf_count(s->doc, GLTF_ANIMATIONS);
    for (size_t a = 0; a < animations; ++a) total += gltf_channel_count(s->doc, a);
    s->channels = calloc(total + 1, sizeof *s->channels);
    if (!s->channels) return lp_no_memory(err, "out of memory");
    for (size_t a = 0; a < animations; ++a)
        for (size_t c = 0; c < gltf_channel_count(s->doc, a); ++c) {
            scene_channel *e = &s->channels[s->channel_count++];
            e->animation = (uint32_t)a;
            e->channel = (uint32_t)c;
            channel_target(s, a, c, &e->node, e->property, &e->mesh_weights);
        }
    return LP_OK;
}

/* Appends to its animation a copy of indexed channel e, pointed at `target`
 * (a node, or with `mesh` a mesh's weights): same sampler and property. */
static int append_channel_copy(scene *s, const scene_channel *e, int64_t target, int mesh)
{
    char pointer[160], to[128];
    snprintf(pointer, sizeof pointer, "/animations/%u/channels/%u", e->animation, e->channel);
    char *channel = gltf_get_json(s->doc, pointer);
    if (!channel) return -1;
    const size_t at = gltf_channel_count(s->doc, e->animation);
    snprintf(to, sizeof to, "/animations/%u/channels/-", e->animation);
    int rc = gltf_set_json(s->doc, to, channel);
    free(channel);
    if (rc != 0) return -1;
    return retarget_channel(s, e->animation, at, mesh ? "meshes" : "nodes", target, e->property);
}

/* The channels that animate mesh m's default morph weights by pointer, copied
 * once for each of its LOD meshes (which copied those weights): a client
 * showing a level would otherwise freeze the morph. Appended, same sampler. */
static int follow_mesh_weights(scene *s, uint32_t m, const lodchain_level *levels, uint32_t level_count, lp_error *err)
{
    for (size_t i = 0; i < s->channel_count; ++i) {
        if (s->channels[i].mesh_weights != (int64_t)m) continue;
        for (uint32_t k = 0; k < level_count; ++k)
            if (append_channel_copy(s, &s->channels[i], levels[k].mesh, 1) != 0)
                return lp_fail(err, LP_INVALID, "cannot add an animation channel for a LOD mesh");
    }
    return LP_OK;
}

/* The animation channels that move document node `node` (translation,
 * rotation, scale), drive its morph weights or its KHR_node_visibility,
 * whether by target node and path or by a KHR_animation_pointer, copied once
 * for each of its LOD nodes, which a client shows in its place: otherwise an
 * animated node's coarse levels would stand still (or stay visible). Same
 * sampler, appended after the channels the animation had. */
static int follow_animations(scene *s, int64_t node, const int64_t *lod_nodes, uint32_t lod_count, lp_error *err)
{
    for (size_t i = 0; i < s->channel_count; ++i) {
        const scene_channel *e = &s->channels[i];
        if (e->node != node || !followed_property(e->property)) continue;
        for (uint32_t k = 0; k < lod_count; ++k)
            if (append_channel_copy(s, e, lod_nodes[k], 0) != 0)
                return lp_fail(err, LP_INVALID, "cannot add an animation channel for a LOD node");
    }
    return LP_OK;
}

/* EXT_mesh_gpu_instancing on document node `node`: the largest absolute
 * component of its instances' SCALE (1 without instancing or SCALE): an
 * instance's size on screen is the node's times its own. */
static int instance_max_scale(const scene *s, uint32_t node, double *scale, lp_error *err)
{
    *scale = 1.0;
    char pointer[96];
    snprintf(pointer, sizeof pointer, "/nodes/%u/extensions/EXT_mesh_gpu_instancing/attributes/SCALE", node);
    char *text = gltf_get_json(s->doc, pointer);
    if (!text) return LP_OK;
    const long long index = strtoll(text, NULL, 10); /* the loader checked it names an accessor */
    free(text);
    float *v = NULL;
    uint32_t count = 0, components = 0;
    int rc = accessor_read_floats(s->doc, index, &v, &count, &components, err);
    if (!rc && count) {
        double best = 0;
        int finite = 1;
        for (size_t i = 0; i < (size_t)count * components; ++i) {
            finite &= isfinite(v[i]) != 0; /* fmax would skip a NaN */
            best = fmax(best, fabs((double)v[i]));
        }
        *scale = best;
        if (!finite)
            rc = lp_fail(err, LP_INVALID, "nodes[%u].extensions.EXT_mesh_gpu_instancing: a SCALE value is NaN or "
                                          "infinite, so no switching distance can be written", node);
    }
    free(v);
    return rc;
}

/* MSFT_lod and the switching metadata on document node `node`, whose world
 * transform is scene node `placed`'s. */
static int annotate_node(scene *s, int64_t node_id, uint32_t placed, uint32_t m, const lodchain_summary *chain,
                         const int64_t *lod_nodes, const lodchain_options *o, double diagonal, lp_error *err)
{
    const uint32_t node = (uint32_t)node_id;
    double instance_scale;
    int rc = instance_max_scale(s, node, &instance_scale, err);
    if (rc) return rc;
    double stretch;
    if ((rc = scene_mesh_stretch(s, placed, &stretch, err)) != 0) return rc;
    const double scale = stretch * instance_scale;
    if (!(scale <= FLT_MAX))
        return lp_fail(err, LP_INVALID, "nodes[%u]: its instances stretch the mesh beyond float range", node);
    const double radius = 0.5 * diagonal * scale;
    jsonw ids = {0}, coverage = {0}, meta = {0};
    jsonw_raw(&ids, "{\"ids\":[");
    jsonw_raw(&coverage, "[");
    jsonw_raw(&meta, "{\"camera\":{\"pixel_error\":");
    jsonw_number(&meta, o->camera.pixel_error);
    jsonw_raw(&meta, ",\"viewport_height\":");
    jsonw_number(&meta, o->camera.viewport_height);
    jsonw_raw(&meta, ",\"fov_y\":");
    jsonw_number(&meta, o->camera.fov_y);
    const double lod0_error = o->added_error ? o->added_error[0] : 0.0;
    jsonw_printf(&meta, "},\"levels\":[{\"node\":%u,\"mesh\":%u,\"error\":", node, m);
    jsonw_number(&meta, lod0_error);
    jsonw_raw(&meta, ",\"error_fraction\":");
    jsonw_number(&meta, diagonal > 0 ? lod0_error / diagonal : 0.0);
    jsonw_printf(&meta, ",\"triangles\":%llu,\"distance\":0,\"screen_coverage\":1",
                 (unsigned long long)s->meshes[m].triangle_count);
    if (o->added_error) {
        jsonw_raw(&meta, ",\"quantization_error\":");
        jsonw_number(&meta, lod0_error);
    }
    jsonw_raw(&meta, "}");
    for (uint32_t k = 0; k < chain->level_count; ++k) {
        const lodchain_level *l = &chain->levels[k];
        double d = switching_distance(l->error, scale, &o->camera);
        double c = switching_coverage(radius, d, &o->camera);
        jsonw_printf(&ids, "%s%lld", k ? "," : "", (long long)lod_nodes[k]);
        if (k) jsonw_raw(&coverage, ",");
        jsonw_number(&coverage, c);
        jsonw_printf(&meta, ",{\"node\":%lld,\"mesh\":%lld,\"error\":", (long long)lod_nodes[k], (long long)l->mesh);
        jsonw_number(&meta, l->error);
        jsonw_raw(&meta, ",\"error_fraction\":");
        jsonw_number(&meta, diagonal > 0 ? l->error / diagonal : 0.0);
        jsonw_printf(&meta, ",\"triangles\":%u,\"distance\":", l->triangles);
        jsonw_number(&meta, d);
        jsonw_raw(&meta, ",\"screen_coverage\":");
        jsonw_number(&meta, c);
        if (o->added_error) {
            jsonw_raw(&meta, ",\"quantization_error\":");
            jsonw_number(&meta, l->added_error);
        }
        if (chain->target_count) {
            jsonw_raw(&meta, ",\"morph_errors\":[");
            for (uint32_t t = 0; t < chain->target_count; ++t) {
                if (t) jsonw_raw(&meta, ",");
                jsonw_number(&meta, chain->morph_errors[(size_t)k * chain->target_count + t]);
            }
            jsonw_raw(&meta, "]");
        }
        jsonw_raw(&meta, "}");
    }
    jsonw_raw(&ids, "]}");
    jsonw_raw(&coverage, ",");
    jsonw_number(&coverage, switching_cull_coverage(&o->camera));
    jsonw_raw(&coverage, "]");
    jsonw_raw(&meta, "]}");
    if (ids.failed || coverage.failed || meta.failed) rc = lp_no_memory(err, "out of memory");
    if (!rc) rc = set_json(s->doc, err, ids.text, "/nodes/%u/extensions/MSFT_lod", node);
    /* a node with extras of its own hands the chain to a carrier
     * (lost_in_swap), so this node's extras are absent or {} */
    if (!rc) rc = set_json(s->doc, err, coverage.text, "/nodes/%u/extras/MSFT_screencoverage", node);
    if (!rc) rc = set_json(s->doc, err, meta.text, "/nodes/%u/extras/lodpipe", node);
    jsonw_free(&ids);
    jsonw_free(&coverage);
    jsonw_free(&meta);
    return rc;
}

/* ---- morph targets ----------------------------------------------------------------- */

int lodchain_mesh_triangles(const scene *s, uint32_t m, const weld_result *w, const simplify_level *level, int t,
                            float **positions, uint32_t **triangles, measure_mesh *out, lp_error *err)
{
    const scene_mesh *mesh = &s->meshes[m];
    size_t vertices = 0, tris = 0;
    for (uint32_t p = 0; p < mesh->primitive_count; ++p)
        if (!mesh->primitives[p].skipped && mesh->primitives[p].triangle_count) {
            vertices += mesh->primitives[p].vertex_count;
            tris += level ? 0 : mesh->primitives[p].triangle_count;
        }
    if (level) tris = level->triangle_count;
    uint32_t *base = calloc(mesh->primitive_count + 1, sizeof *base);
    *positions = malloc((3 * vertices + 1) * sizeof **positions);
    *triangles = malloc((3 * tris + 1) * sizeof **triangles);
    if (!base || !*positions || !*triangles) {
        free(base);
        return lp_no_memory(err, "out of memory");
    }
    size_t v = 0, k = 0;
    for (uint32_t p = 0; p < mesh->primitive_count; ++p) {
        const scene_primitive *pr = &mesh->primitives[p];
        if (pr->skipped || !pr->triangle_count) continue;
        base[p] = (uint32_t)v;
        memcpy(*positions + 3 * v, pr->positions, 3 * (size_t)pr->vertex_count * sizeof(float));
        if (level && level->positions) /* where the level placed its vertices */
            for (uint32_t x = 0; x < w->wedge_count; ++x)
                if (w->wedge_primitive[x] == p && w->wedge_index[x] < pr->vertex_count)
                    memcpy(*positions + 3 * (v + w->wedge_index[x]), level->positions + 3 * (size_t)w->wedge_vertex[x],
                           3 * sizeof(float));
        if (t >= 0 && (uint32_t)t < pr->target_count) {
            gltf_primitive g;
            gltf_get_primitive(s->doc, m, p, &g);
            for (size_t a = 0; a < g.target_attribute_counts[t]; ++a) {
                if (strcmp(g.target_attributes[t][a].name, "POSITION") != 0) continue;
                float *delta;
                uint32_t count, comps;
                int rc = accessor_read_floats(s->doc, g.target_attributes[t][a].accessor, &delta, &count, &comps, err);
                if (rc) {
                    free(base);
                    return rc;
                }
                for (uint32_t i = 0; i < count && i < pr->vertex_count && comps == 3; ++i)
                    for (int c = 0; c < 3; ++c) (*positions)[3 * (v + i) + c] += delta[3 * (size_t)i + c];
                free(delta);
            }
        }
        if (!level)
            for (size_t i = 0; i < 3 * (size_t)pr->triangle_count; ++i) (*triangles)[k++] = (uint32_t)v + pr->triangles[i];
        v += pr->vertex_count;
    }
    if (level)
        for (uint32_t i = 0; i < 3 * level->triangle_count; ++i) {
            uint32_t wedge = level->wedges[i];
            (*triangles)[k++] = base[w->wedge_primitive[wedge]] + w->wedge_index[wedge];
        }
    free(base);
    *out = (measure_mesh){*positions, (uint32_t)v, *triangles, (uint32_t)(k / 3)};
    return LP_OK;
}

/* The first target before t that moves LOD0 exactly as t does (a, its moved
 * mesh), or t; records the digest of t's moved positions in digests[t]. A
 * digest match is confirmed by moving LOD0 by the earlier target again and
 * comparing the bytes. */
static uint32_t same_morph(const scene *s, uint32_t m, const weld_result *w, uint8_t (*digests)[SHA256_BYTES],
                           uint32_t t, const measure_mesh *a, lp_error *err)
{
    sha256_bytes(a->positions, 3 * (size_t)a->vertex_count * sizeof *a->positions, digests[t]);
    for (uint32_t u = 0; u < t; ++u) {
        if (memcmp(digests[u], digests[t], SHA256_BYTES) != 0) continue;
        float *up = NULL;
        uint32_t *ut = NULL;
        measure_mesh other;
        int equal = lodchain_mesh_triangles(s, m, w, NULL, (int)u, &up, &ut, &other, err) == LP_OK &&
                    other.vertex_count == a->vertex_count &&
                    memcmp(other.positions, a->positions, 3 * (size_t)a->vertex_count * sizeof *a->positions) == 0;
        free(up);
        free(ut);
        if (equal) return u;
    }
    return t;
}

/* Which earlier target each target repeats: same[t] is the first target
 * that moves LOD0 exactly as t does, t itself when none does. */
static int repeated_targets(const scene *s, uint32_t m, const weld_result *w, uint32_t targets, uint32_t *same,
                            lp_error *err)
{
    uint8_t (*digests)[SHA256_BYTES] = calloc(targets, sizeof *digests);
    if (!digests) return lp_no_memory(err, "out of memory");
    int rc = LP_OK;
    for (uint32_t t = 0; t < targets && !rc; ++t) {
        float *positions = NULL;
        uint32_t *triangles = NULL;
        measure_mesh a;
        rc = lodchain_mesh_triangles(s, m, w, NULL, (int)t, &positions, &triangles, &a, err);
        if (!rc) same[t] = same_morph(s, m, w, digests, t, &a, err);
        free(positions);
        free(triangles);
    }
    free(digests);
    return rc;
}

/* Targets measured at once: at most this many, and at most MORPH_BATCH_BYTES
 * of them (each holds LOD0 moved by it, its BVH and the levels that place
 * their own vertices moved by it), so that a large mesh with many targets
 * does not hold them all; at least one. */
#define MORPH_BATCH_TARGETS 64
#define MORPH_BATCH_BYTES ((size_t)512 << 20)

/* One distinct target of a batch: LOD0 and every kept level moved by it. A
 * level that shares LOD0's vertices shares its moved positions and the
 * level's triangle list (the same for every target); only a level that
 * places its own vertices has its own copy. */
typedef struct morph_slot {
    uint32_t target;
    float *positions;
    uint32_t *triangles;
    measure_mesh lod0;
    bvh tree; /* over lod0, built once for all its levels */
    int built;
    float *level_positions[SIMPLIFY_MAX_LEVELS];
    uint32_t *level_triangles[SIMPLIFY_MAX_LEVELS];
    measure_mesh level[SIMPLIFY_MAX_LEVELS];
} morph_slot;

/* A batch's measurements on the job's threads: job j measures slot j / levels
 * against level j % levels and writes its own entry of errors, so the bytes
 * written do not depend on the thread count or on which thread ran what. */
typedef struct morph_work {
    const morph_slot *slots;
    uint32_t slot_count, level_count, target_count;
    double spacing;
    double *errors; /* lodchain_summary.morph_errors */
} morph_work;

/* Job j of a batch (an item of lp_team_for). */
static void morph_item(void *arg, uint32_t j)
{
    morph_work *work = arg;
    const morph_slot *slot = &work->slots[j / work->level_count];
    const uint32_t k = j % work->level_count;
    /* what measure_two_sided gives, LOD0's tree built once: -1 when it cannot be built */
    work->errors[(size_t)k * work->target_count + slot->target] =
        slot->built ? measure_two_sided_with(&slot->lod0, &slot->tree, &slot->level[k], work->spacing) : -1.0;
}

static void free_slot(morph_slot *slot, uint32_t level_count)
{
    bvh_free(&slot->tree);
    free(slot->positions);
    free(slot->triangles);
    for (uint32_t k = 0; k < level_count; ++k) {
        free(slot->level_positions[k]);
        free(slot->level_triangles[k]);
    }
    memset(slot, 0, sizeof *slot);
}

/* Fills slot with target t's meshes; levels[k] are the kept levels' triangle
 * lists (unmoved; triangles index the same vertices whatever the target). */
static int fill_slot(const scene *s, uint32_t m, const weld_result *w, const simplify_result *r, const uint32_t *kept,
                     const measure_mesh *levels, uint32_t level_count, uint32_t t, morph_slot *slot, lp_error *err)
{
    slot->target = t;
    int rc = lodchain_mesh_triangles(s, m, w, NULL, (int)t, &slot->positions, &slot->triangles, &slot->lod0, err);
    if (rc) return rc;
    const bvh_result built = bvh_build(&slot->tree, slot->lod0.positions, slot->lod0.vertex_count,
                                       slot->lod0.triangles, slot->lod0.triangle_count);
    if (built == BVH_ERROR_OUT_OF_MEMORY) return lp_no_memory(err, "out of memory measuring morph target %u", t);
    slot->built = built == BVH_OK;
    for (uint32_t k = 0; k < level_count && !rc; ++k) {
        const simplify_level *level = &r->levels[kept[k]];
        if (level->positions)
            rc = lodchain_mesh_triangles(s, m, w, level, (int)t, &slot->level_positions[k], &slot->level_triangles[k],
                                         &slot->level[k], err);
        else
            slot->level[k] = (measure_mesh){slot->lod0.positions, slot->lod0.vertex_count, levels[k].triangles,
                                            levels[k].triangle_count};
    }
    return rc;
}

/* Bytes a slot holds, roughly: positions and triangles of LOD0 (and of each
 * level with its own vertices) and ~32 bytes a triangle of BVH. */
static size_t slot_bytes(const scene_mesh *mesh, const simplify_result *r, const uint32_t *kept,
                         const measure_mesh *levels, uint32_t level_count)
{
    const size_t vertices = levels[0].vertex_count; /* LOD0's, shared by every level */
    size_t bytes = 12 * vertices + 44 * (size_t)mesh->triangle_count;
    for (uint32_t k = 0; k < level_count; ++k)
        if (r->levels[kept[k]].positions) bytes += 12 * vertices + 12 * (size_t)levels[k].triangle_count;
    return bytes;
}

/* Measures every kept level against LOD0 under every morph target: each
 * distinct target once, in batches measured on the job's threads. */
static int measure_morphs(const scene *s, uint32_t m, const weld_result *w, const simplify_result *r,
                          const uint32_t *kept, uint32_t threads, lodchain_summary *out, lp_error *err)
{
    const scene_mesh *mesh = &s->meshes[m];
    uint32_t targets = 0;
    for (uint32_t p = 0; p < mesh->primitive_count; ++p)
        if (!mesh->primitives[p].skipped && mesh->primitives[p].target_count > targets)
            targets = mesh->primitives[p].target_count;
    if (!targets) return LP_OK;
    const uint32_t level_count = out->level_count;
    out->target_count = targets;
    out->morph_errors = calloc((size_t)level_count * targets + 1, sizeof *out->morph_errors);
    /* targets that move LOD0 the same way (one accessor shared by thousands
     * of targets, say) have the same errors: each is measured once, found by
     * a digest of its moved positions and confirmed byte for byte */
    uint32_t *same = calloc(targets, sizeof *same);
    morph_slot *slots = calloc(MORPH_BATCH_TARGETS, sizeof *slots);
    float *unmoved[SIMPLIFY_MAX_LEVELS] = {0}; /* a level's positions without a target: not used */
    uint32_t *level_triangles[SIMPLIFY_MAX_LEVELS] = {0};
    measure_mesh levels[SIMPLIFY_MAX_LEVELS];
    int rc = out->morph_errors && same && slots ? LP_OK : lp_no_memory(err, "out of memory");
    if (!rc) rc = repeated_targets(s, m, w, targets, same, err);
    for (uint32_t k = 0; k < level_count && !rc; ++k)
        rc = lodchain_mesh_triangles(s, m, w, &r->levels[kept[k]], -1, &unmoved[k], &level_triangles[k], &levels[k], err);
    uint32_t batch = 1;
    if (!rc) {
        const size_t bytes = slot_bytes(mesh, r, kept, levels, level_count);
        batch = bytes && MORPH_BATCH_BYTES / bytes < MORPH_BATCH_TARGETS ? (uint32_t)(MORPH_BATCH_BYTES / bytes)
                                                                          : MORPH_BATCH_TARGETS;
        if (batch < 1) batch = 1;
    }
    morph_work work = {slots, 0, level_count, targets, r->diagonal / 400.0, out->morph_errors};
    for (uint32_t t = 0; t < targets && !rc;) {
        work.slot_count = 0;
        for (; t < targets && work.slot_count < batch && !rc; ++t)
            if (same[t] == t) rc = fill_slot(s, m, w, r, kept, levels, level_count, t, &slots[work.slot_count++], err);
        if (!rc) lp_team_for(lp_threads(threads, LP_TEAM_MAX), work.slot_count * level_count, morph_item, &work);
        for (uint32_t i = 0; i < work.slot_count && !rc; ++i) /* a level's tree could not be built */
            for (uint32_t k = 0; k < level_count && !rc; ++k)
                if (out->morph_errors[(size_t)k * targets + work.slots[i].target] == MEASURE_NO_MEMORY)
                    rc = lp_no_memory(err, "out of memory measuring morph target %u", work.slots[i].target);
        for (uint32_t i = 0; i < work.slot_count; ++i) free_slot(&slots[i], level_count);
    }
    for (uint32_t t = 0; t < targets && !rc; ++t)
        for (uint32_t k = 0; k < level_count && same[t] < t; ++k)
            out->morph_errors[(size_t)k * targets + t] = out->morph_errors[(size_t)k * targets + same[t]];
    for (uint32_t k = 0; k < level_count; ++k) {
        free(unmoved[k]);
        free(level_triangles[k]);
    }
    free(slots);
    free(same);
    return rc;
}

void lodchain_summary_free(lodchain_summary *summary)
{
    free(summary->morph_errors);
    summary->morph_errors = NULL;
}

/* ---- the whole chain --------------------------------------------------------------- */

int lodchain_write(scene *s, uint32_t m, const weld_result *w, const simplify_result *r,
                   const lodchain_options *o, lodchain_summary *out, lp_error *err)
{
    memset(out, 0, sizeof *out);
    uint32_t kept[SIMPLIFY_MAX_LEVELS];
    const uint32_t level_count = lodchain_kept_levels(w, r, o->min_reduction, kept);
    if (level_count == 0) return LP_OK;
    const scene_mesh *mesh = &s->meshes[m];
    int rc = index_channels(s, err); /* before any channel is added or retargeted */
    if (rc) return rc;
    out->level_count = level_count; /* before the reorder: morphs are measured in the original order */
    rc = measure_morphs(s, m, w, r, kept, o->threads, out, err);
    out->level_count = 0;
    if (rc) return rc;
    uint32_t **new_of_old = calloc(mesh->primitive_count + 1, sizeof *new_of_old);
    uint8_t *wedge_death = wedge_deaths(w, r);
    rc = new_of_old && wedge_death ? LP_OK : lp_no_memory(err, "out of memory");
    for (uint32_t p = 0; p < mesh->primitive_count && !rc; ++p) {
        const scene_primitive *pr = &mesh->primitives[p];
        if (pr->skipped || pr->mode < 4 || pr->triangle_count == 0) continue;
        uint32_t *order = malloc(((size_t)pr->vertex_count + 1) * sizeof *order);
        new_of_old[p] = malloc(((size_t)pr->vertex_count + 1) * sizeof *new_of_old[p]);
        if (!order || !new_of_old[p] || vertex_order(w, wedge_death, p, pr->vertex_count, order))
            rc = lp_no_memory(err, "out of memory");
        int reordered = 0;
        if (!rc && o->keep_vertex_order)
            for (uint32_t i = 0; i < pr->vertex_count; ++i) new_of_old[p][i] = i;
        else if (!rc)
            rc = reorder_primitive(s, m, p, order, new_of_old[p], &reordered, err);
        if (!rc && !reordered && !o->keep_vertex_order) out->primitives_not_reordered++;
        free(order);
    }
    free(wedge_death);
    for (uint32_t k = 0; k < level_count && !rc; ++k) {
        const simplify_level *level = &r->levels[kept[k]];
        int64_t lod = write_level_mesh(s, m, w, level, k + 1, new_of_old, err);
        if (lod < 0) {
            rc = err->code ? err->code : LP_INVALID;
            break;
        }
        const double added = o->added_error ? o->added_error[kept[k] + 1] : 0.0;
        /* A coarser level records no smaller error than the finer one (a
         * larger bound is still a true one): switching distances and
         * MSFT_screencoverage then run the way clients expect. */
        const double finer = k ? out->levels[k - 1].error : o->added_error ? o->added_error[0] : 0.0;
        const double error = level->bound + added > finer ? level->bound + added : finer;
        out->levels[k] = (lodchain_level){kept[k] + 1, lod, level->triangle_count, level->eps, error, added};
        out->level_count = k + 1;
    }
    if (!rc) rc = follow_mesh_weights(s, m, out->levels, out->level_count, err);
    for (uint32_t n = 0; n < s->node_count && !rc; ++n) {
        if (s->nodes[n].mesh != (int64_t)m) continue;
        if (s->nodes[n].lod_count) {
            warn(out, "nodes[%u] already has MSFT_lod; left as it is", n);
            continue;
        }
        int64_t lod_nodes[SIMPLIFY_MAX_LEVELS];
        int64_t carrier = mesh_carrier(s, n, err);
        if (carrier < 0) {
            rc = err->code ? err->code : LP_INVALID;
            break;
        }
        for (uint32_t k = 0; k < out->level_count && !rc; ++k) {
            lod_nodes[k] = write_lod_node(s, n, carrier, out->levels[k].mesh, k + 1, err);
            if (lod_nodes[k] < 0) rc = err->code ? err->code : LP_INVALID;
        }
        if (!rc) rc = follow_animations(s, carrier, lod_nodes, out->level_count, err);
        if (!rc) rc = annotate_node(s, carrier, n, m, out, lod_nodes, o, r->diagonal, err);
        out->nodes++;
    }
    if (!rc && out->nodes) gltf_use_extension(s->doc, "MSFT_lod", 0);
    for (uint32_t p = 0; new_of_old && p < mesh->primitive_count; ++p) free(new_of_old[p]);
    free(new_of_old);
    return rc;
}
