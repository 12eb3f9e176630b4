/* dracoout.c - see dracoout.h.
 *
 * The float slack of the grid bound. Draco 1.5 (AttributeQuantizationTransform
 * with Quantizer / Dequantizer, core/quantization_utils.h) computes, all in
 * float32 with M = 2^b - 1 and D = r / M:
 *     encode  q = floor(fl(fl(x - o) * fl(M / r)) + 0.5)
 *     decode  x' = fl(fl(float(q) * fl(r / M)) + o)
 * With u = 2^-24 and 0 <= x - o <= r: fl(x - o) is off by <= u r; the product
 * carries three relative roundings, so it is within 3.01 u M of (x - o) / D;
 * adding 0.5 rounds by <= u (M + 1); hence |q - (x - o) / D| <= 1/2 + 4.02 u M
 * + u, i.e. |q D - (x - o)| <= D / 2 + 4.1 u r. Decoding: float(q) (inexact
 * above 24 bits), fl(r / M) and their product are three relative roundings of
 * a value <= r (1 + 5u): <= 3.1 u r; the final sum rounds by <= u (|o| + r +
 * D). Together |x' - x| <= D / 2 + 8.3 u r + 1.0 u |o|, which
 * 2^-20 r + 2^-23 |o| = 16 u r + 2 u |o| covers with about twice the room in
 * each term. The origin's term is kept apart from the range's: a mesh 1e5
 * units from the origin has only float32's resolution there (its half-ulp,
 * 0.0039, is u |o|), and a common factor of 16 on |o| refused Draco for
 * levels whose eps was 15 times that. */
#include "dracoout.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accessor.h"
#include "draco_codec/draco_codec.h"
#include "jsonw.h"

#define FLOAT_SLACK_RANGE (1.0 / 1048576.0) /* 2^-20 */
#define FLOAT_SLACK_ORIGIN (1.0 / 8388608.0) /* 2^-23 */

/* Draco keeps an explicit grid's origin and range in its options as text,
 * std::to_string's six decimals, and parses them back with atof: the grid it
 * encodes with is (float)atof("%f" of the value). A range of 3.5e-8 became 0
 * (every position decoded to one point) and any origin moved by up to 5e-7,
 * so the grid is chosen among the values that survive that text exactly. */
static float as_draco_text(float x)
{
    char text[64];
    snprintf(text, sizeof text, "%f", (double)x);
    return (float)atof(text);
}

/* The largest (down) or smallest (up) value that survives Draco's text
 * unchanged and is <= x (down) or >= x (up). */
static float draco_text_value(double x, int up)
{
    float v = as_draco_text((float)x);
    for (int step = 0; step < 64 && (up ? (double)v < x : (double)v > x); ++step) {
        float next = as_draco_text(v + (up ? 1e-6f : -1e-6f));
        v = next != v ? next : nextafterf(v, up ? INFINITY : -INFINITY);
    }
    return v;
}

void dracoout_grid_of(const double lo[3], const double hi[3], int bits, dracoout_grid *g)
{
    memset(g, 0, sizeof *g);
    g->bits = bits;
    double extent = 0;
    int origin_exact = 1;
    for (int c = 0; c < 3; ++c) {
        g->origin[c] = draco_text_value(lo[c], 0);
        origin_exact &= (double)g->origin[c] == lo[c];
        if (hi[c] - (double)g->origin[c] > extent) extent = hi[c] - (double)g->origin[c];
    }
    if (!(extent > 0) && origin_exact) {
        /* every vertex is the origin: it quantizes to 0 and decodes to
         * fl(fl(0 * D) + o) = o exactly, whatever the range */
        g->range = 1.0f;
        return;
    }
    float range = draco_text_value(extent > 0 ? extent : 1.0, 1); /* every value inside [o, o + r] */
    g->range = range;
    const double step = (double)range / (double)((1u << bits) - 1u);
    double sum = 0;
    for (int c = 0; c < 3; ++c) {
        g->axis_bound[c] = 0.5 * step + FLOAT_SLACK_RANGE * (double)range + FLOAT_SLACK_ORIGIN * fabs((double)g->origin[c]);
        sum += g->axis_bound[c] * g->axis_bound[c];
    }
    g->bound = sqrt(sum);
}

/* ---- the plan: bits and bounds before anything is written ---------------------- */

/* Is primitive p's POSITION stored as floats (quantized) rather than integers
 * (stored losslessly)? */
static int float_positions(const scene *s, const scene_primitive *pr)
{
    for (uint32_t a = 0; a < pr->stream_count; ++a)
        if (strcmp(pr->streams[a].name, "POSITION") == 0) {
            gltf_accessor acc;
            if (gltf_get_accessor(s->doc, (size_t)pr->streams[a].accessor, &acc) != 0) return 1;
            return acc.component_type == 5126;
        }
    return 1;
}

static int encodable(const scene_primitive *pr)
{
    return !pr->skipped && pr->mode >= 4 && pr->triangle_count > 0;
}

/* Per-primitive bounding boxes of the vertices a triangle set uses: LOD0's
 * (level NULL) or a level's. lo/hi hold 3 doubles per primitive; used[p] says
 * whether primitive p has any triangle. */
static void level_boxes(const scene_mesh *mesh, const weld_result *w, const simplify_level *level, double *lo,
                        double *hi, uint8_t *used)
{
    for (uint32_t p = 0; p < mesh->primitive_count; ++p) {
        used[p] = 0;
        for (int c = 0; c < 3; ++c) {
            lo[3 * p + c] = INFINITY;
            hi[3 * p + c] = -INFINITY;
        }
    }
    const size_t corners = level ? 3 * (size_t)level->triangle_count : 0;
    for (uint32_t p = 0; !level && p < mesh->primitive_count; ++p) {
        const scene_primitive *pr = &mesh->primitives[p];
        if (!encodable(pr)) continue;
        for (size_t i = 0; i < 3 * (size_t)pr->triangle_count; ++i) {
            const float *x = pr->positions + 3 * (size_t)pr->triangles[i];
            used[p] = 1;
            for (int c = 0; c < 3; ++c) {
                if (x[c] < lo[3 * p + c]) lo[3 * p + c] = x[c];
                if (x[c] > hi[3 * p + c]) hi[3 * p + c] = x[c];
            }
        }
    }
    for (size_t i = 0; i < corners; ++i) {
        const uint32_t wedge = level->wedges[i];
        const uint32_t p = w->wedge_primitive[wedge];
        const float *x = level->positions ? level->positions + 3 * (size_t)w->wedge_vertex[wedge]
                                          : mesh->primitives[p].positions + 3 * (size_t)w->wedge_index[wedge];
        used[p] = 1;
        for (int c = 0; c < 3; ++c) {
            if (x[c] < lo[3 * p + c]) lo[3 * p + c] = x[c];
            if (x[c] > hi[3 * p + c]) hi[3 * p + c] = x[c];
        }
    }
}

/* The box of the level's grid: one grid for all its quantized primitives,
 * over the union of their boxes, so that a position two
 * primitives share (a material seam, a back face's corner) decodes to the
 * same point in both: a grid per primitive would open cracks between them.
 * Integer positions are stored losslessly, unless `placed`: a level that
 * placed vertices writes them as a float POSITION accessor of its own
 * (lodchain.c), quantized. The box is empty when nothing is quantized. */
static void grid_box(const scene *s, const scene_mesh *mesh, const double *lo, const double *hi, const uint8_t *used,
                     int placed, double box_lo[3], double box_hi[3])
{
    for (int c = 0; c < 3; ++c) {
        box_lo[c] = INFINITY;
        box_hi[c] = -INFINITY;
    }
    for (uint32_t p = 0; p < mesh->primitive_count; ++p) {
        if (!used[p] || (!placed && !float_positions(s, &mesh->primitives[p]))) continue;
        for (int c = 0; c < 3; ++c) {
            if (lo[3 * p + c] < box_lo[c]) box_lo[c] = lo[3 * p + c];
            if (hi[3 * p + c] > box_hi[c]) box_hi[c] = hi[3 * p + c];
        }
    }
}

/* The bound of the grid over a level's box at `bits`; 0 for an empty box
 * (nothing quantized). */
static double grid_bound(const double box_lo[3], const double box_hi[3], int bits)
{
    if (!(box_lo[0] <= box_hi[0])) return 0;
    dracoout_grid g;
    dracoout_grid_of(box_lo, box_hi, bits, &g);
    return g.bound;
}

int dracoout_budget(const scene *s, uint32_t m, const dracoout_options *o, double smallest_eps, int placing,
                    int *bits, double *budget, lp_error *err)
{
    const scene_mesh *mesh = &s->meshes[m];
    const size_t n = (size_t)mesh->primitive_count + 1;
    double *lo = malloc(3 * n * sizeof *lo), *hi = malloc(3 * n * sizeof *hi);
    uint8_t *used = malloc(n);
    if (!lo || !hi || !used) {
        free(lo);
        free(hi);
        free(used);
        return lp_no_memory(err, "out of memory");
    }
    level_boxes(mesh, NULL, NULL, lo, hi, used);
    double box_lo[3], box_hi[3];
    grid_box(s, mesh, lo, hi, used, placing, box_lo, box_hi);
    for (*bits = o->position_bits;; ++*bits) {
        *budget = grid_bound(box_lo, box_hi, *bits);
        if (*budget <= 0.25 * smallest_eps || *bits >= DRACOOUT_MAX_BITS) break;
    }
    free(lo);
    free(hi);
    free(used);
    if (*budget > 0.5 * smallest_eps)
        return lp_fail(err, LP_PROMISE,
                       "mesh %u \"%s\": Draco's position quantization %.3g is more than half the smallest eps %.3g even "
                       "at %d bits (float32 cannot resolve the mesh that finely)",
                       m, mesh->name, *budget, smallest_eps, *bits);
    return LP_OK;
}

int dracoout_plan_mesh(const scene *s, uint32_t m, const weld_result *w, const simplify_result *r,
                       double min_reduction, const dracoout_options *o, int start_bits, dracoout_plan *plan,
                       lp_error *err)
{
    const scene_mesh *mesh = &s->meshes[m];
    memset(plan, 0, sizeof *plan);
    plan->configured_bits = plan->position_bits = o->position_bits;
    const uint32_t levels = r ? r->level_count : 0;
    const size_t n = (size_t)mesh->primitive_count + 1;
    double *lo = malloc((levels + 1) * 3 * n * sizeof *lo), *hi = malloc((levels + 1) * 3 * n * sizeof *hi);
    uint8_t *used = malloc((levels + 1) * n);
    if (!lo || !hi || !used) {
        free(lo);
        free(hi);
        free(used);
        return lp_no_memory(err, "out of memory");
    }
    for (uint32_t k = 0; k <= levels; ++k) {
        level_boxes(mesh, w, k ? &r->levels[k - 1] : NULL, lo + 3 * n * k, hi + 3 * n * k, used + n * k);
        grid_box(s, mesh, lo + 3 * n * k, hi + 3 * n * k, used + n * k, k && r->levels[k - 1].positions,
                 plan->grid_lo[k], plan->grid_hi[k]);
    }
    uint32_t kept[SIMPLIFY_MAX_LEVELS];
    const uint32_t kept_count = r ? lodchain_kept_levels(w, r, min_reduction, kept) : 0;
    int rc = LP_OK;
    for (int bits = start_bits;; ++bits) {
        for (uint32_t k = 0; k <= levels; ++k) plan->added_error[k] = grid_bound(plan->grid_lo[k], plan->grid_hi[k], bits);
        uint32_t worst = 0;
        double excess = 0;
        for (uint32_t i = 0; i < kept_count; ++i) {
            const simplify_level *l = &r->levels[kept[i]];
            double over = l->bound + plan->added_error[kept[i] + 1] - l->eps;
            if (over > excess) {
                excess = over;
                worst = kept[i];
            }
        }
        plan->position_bits = bits;
        if (excess <= 0) break;
        if (bits >= DRACOOUT_MAX_BITS) {
            const simplify_level *l = &r->levels[worst];
            rc = lp_fail(err, LP_PROMISE,
                         "mesh %u \"%s\" level %u: certified bound %.9g plus Draco's position quantization %.3g "
                         "exceeds eps %.9g even at %d bits",
                         m, mesh->name, worst + 1, l->bound, plan->added_error[worst + 1], l->eps, bits);
            break;
        }
    }
    free(lo);
    free(hi);
    free(used);
    return rc;
}

/* ---- writing ----------------------------------------------------------------------- */

static const char *type_name(int components)
{
    static const char *const names[5] = {"", "SCALAR", "VEC2", "VEC3", "VEC4"};
    return components >= 1 && components <= 4 ? names[components] : "";
}

static uint32_t component_size(int type)
{
    return type == 5120 || type == 5121 ? 1 : type == 5122 || type == 5123 ? 2 : 4;
}

/* One component of raw little-endian data as a double (no normalization:
 * accessor min/max are in the stored type's units). */
static double component_value(const uint8_t *p, int type)
{
    switch (type) {
    case 5120: { int8_t v; memcpy(&v, p, 1); return v; }
    case 5121: return p[0];
    case 5122: { int16_t v; memcpy(&v, p, 2); return v; }
    case 5123: { uint16_t v; memcpy(&v, p, 2); return v; }
    case 5125: { uint32_t v; memcpy(&v, p, 4); return v; }
    default: { float v; memcpy(&v, p, 4); return v; }
    }
}

/* ",\"min\":[..],\"max\":[..]" of count packed elements. */
static void json_min_max(jsonw *j, const uint8_t *data, uint32_t count, int type, int components)
{
    if (!count) return;
    const uint32_t size = component_size(type);
    double lo[4], hi[4];
    for (int c = 0; c < components; ++c) lo[c] = hi[c] = component_value(data + (size_t)c * size, type);
    for (uint32_t i = 1; i < count; ++i)
        for (int c = 0; c < components; ++c) {
            double v = component_value(data + ((size_t)i * components + c) * size, type);
            if (v < lo[c]) lo[c] = v;
            if (v > hi[c]) hi[c] = v;
        }
    for (int pass = 0; pass < 2; ++pass) {
        jsonw_raw(j, pass ? "],\"max\":[" : ",\"min\":[");
        for (int c = 0; c < components; ++c) {
            if (c) jsonw_raw(j, ",");
            jsonw_number(j, pass ? hi[c] : lo[c]);
        }
    }
    jsonw_raw(j, "]");
}

/* Accessor `a` made to describe count elements of (type, components,
 * normalized) with the given data view (-1: none, Draco fills it) and min/max
 * from data when data is not NULL. Rewritten in place when only one object
 * uses it (same number, name and extras: *result = a), else a new accessor. */
static int describe_accessor(gltf_doc *doc, int64_t a, uint32_t count, int type, int components, int normalized,
                             int64_t view, const uint8_t *data, int64_t *result, lp_error *err)
{
    jsonw j = {0};
    jsonw_printf(&j, "{");
    if (view >= 0) jsonw_printf(&j, "\"bufferView\":%lld,", (long long)view);
    jsonw_printf(&j, "\"componentType\":%d,\"count\":%u,\"type\":\"%s\"", type, count, type_name(components));
    if (normalized) jsonw_raw(&j, ",\"normalized\":true");
    if (data) json_min_max(&j, data, count, type, components);
    jsonw_raw(&j, "}");
    if (j.failed) return lp_no_memory(err, "out of memory");
    int rc = LP_OK;
    if (a >= 0 && gltf_accessor_refs(doc, (size_t)a) == 1) {
        static const char *const kKeys[] = {"bufferView", "byteOffset", "componentType", "normalized",
                                            "count",      "type",       "min",           "max", "sparse"};
        /* the description goes into a scratch accessor at the end, its keys are
         * moved over, and the scratch one is removed (it is last: no renumbering) */
        int64_t scratch = gltf_append_json(doc, "accessors", j.text);
        if (scratch < 0) rc = lp_no_memory(err, "out of memory");
        for (size_t k = 0; k < sizeof kKeys / sizeof kKeys[0] && !rc; ++k) {
            char from[96], to[96];
            snprintf(from, sizeof from, "/accessors/%lld/%s", (long long)scratch, kKeys[k]);
            snprintf(to, sizeof to, "/accessors/%lld/%s", (long long)a, kKeys[k]);
            gltf_remove_json(doc, to);
            gltf_copy_json(doc, from, to); /* -1 when the description has no such key */
        }
        if (scratch >= 0) gltf_remove_jsonf(doc, "/accessors/%lld", (long long)scratch);
        *result = a;
    } else {
        *result = gltf_append_json(doc, "accessors", j.text);
        if (*result < 0) rc = lp_no_memory(err, "out of memory");
    }
    jsonw_free(&j);
    return rc;
}

/* Adds a vertex-data view of count packed elements of elem bytes (each padded
 * to 4-byte alignment) to the given buffer slot. */
static int64_t vertex_view(gltf_doc *doc, const uint8_t *data, uint32_t count, uint32_t elem, int target, int slot)
{
    const uint32_t stride = (elem + 3u) & ~3u;
    uint8_t *out = calloc((size_t)count * stride + 4, 1);
    if (!out) return -1;
    for (uint32_t i = 0; i < count; ++i) memcpy(out + (size_t)i * stride, data + (size_t)i * elem, elem);
    size_t size = ((size_t)count * stride + 3) & ~(size_t)3;
    int64_t view = gltf_add_view_in(doc, out, size, target == 34962 && stride != elem ? stride : 0, target, slot);
    free(out);
    return view;
}

static draco_semantic semantic_of(const char *name, int type, int components)
{
    if (strcmp(name, "POSITION") == 0) return DRACO_SEMANTIC_POSITION;
    if (strcmp(name, "NORMAL") == 0 && type == 5126 && components == 3) return DRACO_SEMANTIC_NORMAL;
    if (strncmp(name, "TEXCOORD_", 9) == 0) return DRACO_SEMANTIC_TEXCOORD;
    if (strncmp(name, "COLOR_", 6) == 0) return DRACO_SEMANTIC_COLOR;
    return DRACO_SEMANTIC_GENERIC;
}

static int bits_of(draco_semantic s, const dracoout_options *o, int position_bits)
{
    switch (s) {
    case DRACO_SEMANTIC_POSITION: return position_bits;
    case DRACO_SEMANTIC_NORMAL: return o->normal_bits;
    case DRACO_SEMANTIC_TEXCOORD: return o->texcoord_bits;
    case DRACO_SEMANTIC_COLOR: return o->color_bits;
    default: return o->generic_bits;
    }
}

/* One primitive's data, compacted to the vertices its triangles use. */
typedef struct packed_primitive {
    uint32_t point_count, face_count;
    uint32_t *points;  /* point i = original vertex points[i] */
    uint32_t *faces;   /* 3 * face_count point indices */
    uint32_t attribute_count;
    draco_encode_attribute *attributes;
    uint8_t **values;  /* per attribute, point_count packed elements */
    int64_t *accessors;
    int position;      /* attribute index of POSITION */
    dracoout_grid grid;
} packed_primitive;

static void packed_free(packed_primitive *pp)
{
    for (uint32_t a = 0; pp->values && a < pp->attribute_count; ++a) free(pp->values[a]);
    free(pp->values);
    free(pp->points);
    free(pp->faces);
    free(pp->attributes);
    free(pp->accessors);
    memset(pp, 0, sizeof *pp);
}

/* Gathers elements points[i] of count x elem raw bytes. */
static uint8_t *gather(const uint8_t *raw, uint32_t elem, const uint32_t *points, uint32_t n)
{
    uint8_t *out = malloc((size_t)n * elem + 1);
    if (!out) return NULL;
    for (uint32_t i = 0; i < n; ++i) memcpy(out + (size_t)i * elem, raw + (size_t)points[i] * elem, elem);
    return out;
}

static int pack_primitive(const gltf_doc *doc, const gltf_primitive *g, const uint32_t *triangles,
                          uint32_t triangle_count, uint32_t vertex_count, const dracoout_options *o, int position_bits,
                          const double box_lo[3], const double box_hi[3], packed_primitive *pp, lp_error *err)
{
    memset(pp, 0, sizeof *pp);
    pp->position = -1;
    uint32_t *new_of_old = malloc(((size_t)vertex_count + 1) * sizeof *new_of_old);
    pp->points = malloc(((size_t)vertex_count + 1) * sizeof *pp->points);
    pp->faces = malloc((3 * (size_t)triangle_count + 1) * sizeof *pp->faces);
    pp->attribute_count = (uint32_t)g->attribute_count;
    pp->attributes = calloc(g->attribute_count + 1, sizeof *pp->attributes);
    pp->values = calloc(g->attribute_count + 1, sizeof *pp->values);
    pp->accessors = calloc(g->attribute_count + 1, sizeof *pp->accessors);
    if (!new_of_old || !pp->points || !pp->faces || !pp->attributes || !pp->values || !pp->accessors) {
        free(new_of_old);
        return lp_no_memory(err, "out of memory");
    }
    /* points in ascending original order: deterministic, and the identity when
     * every vertex is used */
    for (uint32_t v = 0; v < vertex_count; ++v) new_of_old[v] = UINT32_MAX;
    for (size_t i = 0; i < 3 * (size_t)triangle_count; ++i) new_of_old[triangles[i]] = 0;
    for (uint32_t v = 0; v < vertex_count; ++v)
        if (new_of_old[v] == 0) {
            new_of_old[v] = pp->point_count;
            pp->points[pp->point_count++] = v;
        }
    for (size_t i = 0; i < 3 * (size_t)triangle_count; ++i) pp->faces[i] = new_of_old[triangles[i]];
    pp->face_count = triangle_count;
    free(new_of_old);
    for (uint32_t a = 0; a < pp->attribute_count; ++a) {
        const int64_t index = g->attributes[a].accessor;
        gltf_accessor acc;
        uint8_t *raw;
        uint32_t count, elem;
        int rc = accessor_read_raw(doc, index, &raw, &count, &elem, err);
        if (rc) return rc;
        gltf_get_accessor(doc, (size_t)index, &acc);
        if (count != vertex_count || acc.components < 1 || acc.components > 4) {
            free(raw);
            return lp_fail(err, LP_INVALID, "accessors[%lld]: %s cannot go into a Draco stream", (long long)index,
                           g->attributes[a].name);
        }
        pp->values[a] = gather(raw, elem, pp->points, pp->point_count);
        free(raw);
        if (!pp->values[a]) return lp_no_memory(err, "out of memory");
        draco_encode_attribute *d = &pp->attributes[a];
        d->semantic = semantic_of(g->attributes[a].name, acc.component_type, acc.components);
        d->gltf_component_type = acc.component_type;
        d->normalized = acc.normalized;
        d->components = acc.components;
        d->values = pp->values[a];
        /* Quantized skin weights no longer sum to 1 (a validator error, and a
         * visible shrink of skinned vertices): stored losslessly. */
        d->quantization_bits = strncmp(g->attributes[a].name, "WEIGHTS_", 8) == 0 ? 0 : bits_of(d->semantic, o, position_bits);
        pp->accessors[a] = index;
        if (d->semantic == DRACO_SEMANTIC_POSITION) pp->position = (int)a;
    }
    if (pp->position < 0) return lp_fail(err, LP_INVALID, "a primitive without POSITION cannot be Draco-compressed");
    draco_encode_attribute *pos = &pp->attributes[pp->position];
    if (pos->gltf_component_type == 5126 && pos->components == 3) {
        const float *x = (const float *)(const void *)pp->values[pp->position];
        for (size_t i = 0; i < 3 * (size_t)pp->point_count; ++i)
            if (!(x[i] >= box_lo[i % 3] && x[i] <= box_hi[i % 3]))
                return lp_fail(err, LP_PROMISE, "Draco: a position lies outside its level's grid box");
        dracoout_grid_of(box_lo, box_hi, position_bits, &pp->grid);
        pos->explicit_grid = 1;
        memcpy(pos->origin, pp->grid.origin, sizeof pp->grid.origin);
        pos->range = pp->grid.range;
    }
    return LP_OK;
}

/* Encodes pp and decodes the stream again: the face count must survive and,
 * with sequential connectivity (point order kept), every decoded position must
 * lie within the grid's bound of its exact value. Edgebreaker may drop a
 * face it cannot represent, or refuse a primitive whose every face is
 * degenerate; then sequential is used. */
static int encode_checked(const packed_primitive *pp, const dracoout_options *o, int sequential, uint8_t **stream,
                          size_t *size, uint32_t *ids, draco_mesh **decoded, int *used_sequential, lp_error *err)
{
    char why[256] = "";
    for (int attempt = 0; attempt < 2; ++attempt) {
        draco_encode_options eo = {o->speed, sequential, 1};
        const int encoded = draco_encode_mesh(pp->point_count, pp->faces, pp->face_count, pp->attributes,
                                              pp->attribute_count, &eo, stream, size, ids, why, sizeof why);
        /* (not a refusal: sequential would make other bytes of the same input) */
        if (encoded == DRACO_OUT_OF_MEMORY) return lp_no_memory(err, "%s", why);
        if (encoded != 0) {
            /* edgebreaker refuses a primitive whose every face has a repeated
             * point ("All triangles are degenerate."), e.g. one made only of
             * zero-area triangles off the surface; sequential keeps them */
            if (sequential) return lp_fail(err, LP_INVALID, "Draco: %s", why);
            sequential = 1;
            continue;
        }
        const int decoded_rc = draco_decode_mesh(*stream, *size, decoded, why, sizeof why);
        if (decoded_rc != 0) {
            free(*stream);
            if (decoded_rc == DRACO_OUT_OF_MEMORY) return lp_no_memory(err, "%s", why);
            return lp_fail(err, LP_PROMISE, "Draco: our own stream does not decode: %s", why);
        }
        if (draco_mesh_num_faces(*decoded) == pp->face_count) break;
        draco_mesh_free(*decoded);
        free(*stream);
        *decoded = NULL;
        if (sequential) return lp_fail(err, LP_PROMISE, "Draco: the stream lost faces");
        sequential = 1;
    }
    *used_sequential = sequential;
    if (!sequential || pp->attributes[pp->position].gltf_component_type != 5126) return LP_OK;
    if (draco_mesh_num_points(*decoded) != pp->point_count)
        return lp_fail(err, LP_PROMISE, "Draco: sequential stream changed the point count");
    float *x = malloc(3 * (size_t)pp->point_count * sizeof *x + 1);
    if (!x) return lp_no_memory(err, "out of memory");
    int rc = LP_OK;
    if (draco_mesh_read_attribute(*decoded, ids[pp->position], 5126, 3, x, why, sizeof why) != 0)
        rc = lp_fail(err, LP_PROMISE, "Draco: %s", why);
    const float *exact = (const float *)(const void *)pp->values[pp->position];
    for (size_t i = 0; !rc && i < 3 * (size_t)pp->point_count; ++i)
        if (fabs((double)x[i] - (double)exact[i]) > pp->grid.axis_bound[i % 3])
            rc = lp_fail(err, LP_PROMISE, "Draco: a decoded position moved %.3g, beyond the grid's bound %.3g",
                         fabs((double)x[i] - (double)exact[i]), pp->grid.axis_bound[i % 3]);
    free(x);
    return rc;
}

/* The decoded attribute a (for the fallback and POSITION's min/max), in the
 * accessor's component type; caller frees. */
static uint8_t *decoded_values(const draco_mesh *dm, const packed_primitive *pp, uint32_t a, uint32_t id,
                               lp_error *err)
{
    const draco_encode_attribute *d = &pp->attributes[a];
    const uint32_t points = draco_mesh_num_points(dm);
    uint8_t *out = malloc((size_t)points * d->components * component_size(d->gltf_component_type) + 1);
    char why[256] = "";
    if (!out) {
        lp_no_memory(err, "out of memory");
        return NULL;
    }
    if (draco_mesh_read_attribute(dm, id, d->gltf_component_type, d->components, out, why, sizeof why) != 0) {
        free(out);
        lp_fail(err, LP_PROMISE, "Draco: %s", why);
        return NULL;
    }
    return out;
}

/* Rewrites morph target accessors in the compacted order (left alone when
 * every vertex is used: the order is the same). */
static int compact_targets(gltf_doc *doc, uint32_t mesh, uint32_t prim, const gltf_primitive *g,
                           const packed_primitive *pp, uint32_t vertex_count, lp_error *err)
{
    if (pp->point_count == vertex_count) return LP_OK;
    for (size_t t = 0; t < g->target_count; ++t)
        for (size_t a = 0; a < g->target_attribute_counts[t]; ++a) {
            const gltf_attribute *ta = &g->target_attributes[t][a];
            gltf_accessor acc;
            uint8_t *raw;
            uint32_t count, elem;
            int rc = accessor_read_raw(doc, ta->accessor, &raw, &count, &elem, err);
            if (rc) return rc;
            gltf_get_accessor(doc, (size_t)ta->accessor, &acc);
            uint8_t *data = count == vertex_count ? gather(raw, elem, pp->points, pp->point_count) : NULL;
            free(raw);
            if (!data) return lp_fail(err, LP_INVALID, "accessors[%lld]: morph target does not match its primitive",
                                      (long long)ta->accessor);
            int64_t view = vertex_view(doc, data, pp->point_count, elem, 34962, 0), result = -1;
            rc = view < 0 ? lp_no_memory(err, "out of memory")
                          : describe_accessor(doc, ta->accessor, pp->point_count, acc.component_type, acc.components,
                                              acc.normalized, view, data, &result, err);
            free(data);
            if (rc) return rc;
            char value[32];
            snprintf(value, sizeof value, "%lld", (long long)result);
            if (gltf_set_jsonf(doc, value, "/meshes/%u/primitives/%u/targets/%zu/%s", mesh, prim, t, ta->name) != 0)
                return lp_fail(err, LP_INVALID, "cannot set a morph target");
        }
    return LP_OK;
}

/* Writes the encoded primitive into the document. */
static int write_primitive(gltf_doc *doc, uint32_t mesh, uint32_t prim, const gltf_primitive *g,
                           const packed_primitive *pp, const uint8_t *stream, size_t size, const uint32_t *ids,
                           const draco_mesh *dm, const dracoout_options *o, lp_error *err)
{
    const uint32_t points = draco_mesh_num_points(dm), faces = draco_mesh_num_faces(dm);
    int64_t stream_view = gltf_add_view_in(doc, stream, size, 0, 0, 0);
    if (stream_view < 0) return lp_no_memory(err, "out of memory");
    jsonw ext = {0};
    jsonw_printf(&ext, "{\"bufferView\":%lld,\"attributes\":{", (long long)stream_view);
    int rc = LP_OK;
    for (uint32_t a = 0; a < pp->attribute_count && !rc; ++a) {
        const draco_encode_attribute *d = &pp->attributes[a];
        const int is_position = (int)a == pp->position;
        uint8_t *values = (is_position || o->fallback) ? decoded_values(dm, pp, a, ids[a], err) : NULL;
        if ((is_position || o->fallback) && !values) rc = err->code;
        int64_t view = -1, result = -1;
        if (!rc && o->fallback) {
            view = vertex_view(doc, values, points, (uint32_t)d->components * component_size(d->gltf_component_type),
                               34962, 1);
            if (view < 0) rc = lp_no_memory(err, "out of memory");
        }
        if (!rc)
            rc = describe_accessor(doc, pp->accessors[a], points, d->gltf_component_type, d->components, d->normalized,
                                   view, is_position ? values : NULL, &result, err);
        free(values);
        char value[32];
        snprintf(value, sizeof value, "%lld", (long long)result);
        if (!rc && gltf_set_jsonf(doc, value, "/meshes/%u/primitives/%u/attributes/%s", mesh, prim, g->attributes[a].name))
            rc = lp_fail(err, LP_INVALID, "cannot set an attribute");
        if (a) jsonw_raw(&ext, ",");
        jsonw_string(&ext, g->attributes[a].name);
        jsonw_printf(&ext, ":%u", ids[a]);
    }
    jsonw_raw(&ext, "}}");
    /* indices */
    const int index_type = points <= 65535 ? 5123 : 5125;
    int64_t index_view = -1, index_accessor = -1;
    if (!rc && o->fallback) {
        uint32_t *idx = malloc(3 * (size_t)faces * sizeof *idx + 4);
        uint8_t *bytes = malloc(3 * (size_t)faces * 4 + 4);
        if (!idx || !bytes) rc = lp_no_memory(err, "out of memory");
        if (!rc) {
            draco_mesh_read_indices(dm, idx);
            for (size_t i = 0; i < 3 * (size_t)faces; ++i) {
                if (index_type == 5123) {
                    uint16_t v = (uint16_t)idx[i];
                    memcpy(bytes + 2 * i, &v, 2);
                } else {
                    memcpy(bytes + 4 * i, &idx[i], 4);
                }
            }
            size_t n = (3 * (size_t)faces * component_size(index_type) + 3) & ~(size_t)3;
            index_view = gltf_add_view_in(doc, bytes, n, 0, 34963, 1);
            if (index_view < 0) rc = lp_no_memory(err, "out of memory");
        }
        free(idx);
        free(bytes);
    }
    if (!rc)
        rc = describe_accessor(doc, g->indices, 3 * faces, index_type, 1, 0, index_view, NULL, &index_accessor, err);
    if (!rc) {
        char value[32];
        snprintf(value, sizeof value, "%lld", (long long)index_accessor);
        if (ext.failed || gltf_set_jsonf(doc, value, "/meshes/%u/primitives/%u/indices", mesh, prim) != 0 ||
            gltf_set_jsonf(doc, ext.text, "/meshes/%u/primitives/%u/extensions/KHR_draco_mesh_compression", mesh, prim) != 0)
            rc = lp_no_memory(err, "out of memory writing the Draco primitive");
        gltf_remove_jsonf(doc, "/meshes/%u/primitives/%u/mode", mesh, prim); /* triangles */
    }
    jsonw_free(&ext);
    return rc;
}

/* Encodes primitive prim of document mesh `mesh` with the given triangles,
 * on the grid the plan chose for its ladder level (0: LOD0). */
static int encode_primitive(scene *s, uint32_t mesh, uint32_t prim, const uint32_t *triangles, uint32_t triangle_count,
                            uint32_t vertex_count, const dracoout_options *o, const dracoout_plan *plan,
                            uint32_t ladder_level, dracoout_stats *stats, lp_error *err)
{
    gltf_primitive g;
    gltf_get_primitive(s->doc, mesh, prim, &g);
    packed_primitive pp;
    const double allowed = plan->added_error[ladder_level];
    int rc = pack_primitive(s->doc, &g, triangles, triangle_count, vertex_count, o, plan->position_bits,
                            plan->grid_lo[ladder_level], plan->grid_hi[ladder_level], &pp, err);
    /* the grid of the data we encode must be the one the plan bounded */
    if (!rc && pp.grid.bound > allowed * (1 + 1e-12))
        rc = lp_fail(err, LP_PROMISE, "meshes[%u].primitives[%u]: Draco grid bound %.9g exceeds the planned %.9g", mesh,
                     prim, pp.grid.bound, allowed);
    uint8_t *stream = NULL;
    size_t size = 0;
    uint32_t *ids = calloc(pp.attribute_count + 1, sizeof *ids);
    draco_mesh *dm = NULL;
    int sequential = 0;
    if (!rc && !ids) rc = lp_no_memory(err, "out of memory");
    if (!rc) rc = encode_checked(&pp, o, g.target_count > 0, &stream, &size, ids, &dm, &sequential, err);
    if (!rc) rc = compact_targets(s->doc, mesh, prim, &g, &pp, vertex_count, err);
    if (!rc) rc = write_primitive(s->doc, mesh, prim, &g, &pp, stream, size, ids, dm, o, err);
    if (!rc) {
        stats->primitives++;
        stats->sequential += (uint32_t)sequential;
        stats->stream_bytes += size;
    }
    if (dm) draco_mesh_free(dm);
    free(stream);
    free(ids);
    packed_free(&pp);
    return rc;
}

int dracoout_write_mesh(scene *s, uint32_t m, const lodchain_summary *chain, const dracoout_options *o,
                        const dracoout_plan *plan, dracoout_stats *stats, lp_error *err)
{
    const scene_mesh *mesh = &s->meshes[m];
    int rc = LP_OK;
    gltf_sync_mesh_records(s->doc); /* the level meshes lodchain appended */
    /* levels first: their vertex accessors are LOD0's, shared until LOD0 goes
     * last and can rewrite them in place */
    for (uint32_t k = 0; chain && k < chain->level_count && !rc; ++k) {
        const uint32_t lod = (uint32_t)chain->levels[k].mesh;
        for (uint32_t p = 0; p < gltf_primitive_count(s->doc, lod) && !rc; ++p) {
            gltf_primitive g;
            gltf_get_primitive(s->doc, lod, p, &g);
            const int64_t position = gltf_primitive_attribute(&g, "POSITION");
            if (g.mode != 4 || g.indices < 0 || position < 0) continue; /* points, lines, skipped: as they are */
            gltf_accessor acc;
            gltf_get_accessor(s->doc, (size_t)position, &acc);
            uint32_t *idx = NULL, n = 0;
            rc = accessor_read_indices(s->doc, g.indices, (uint32_t)acc.count, &idx, &n, err);
            if (!rc && n >= 3)
                rc = encode_primitive(s, lod, p, idx, n / 3, (uint32_t)acc.count, o, plan, chain->levels[k].ladder_level,
                                      stats, err);
            free(idx);
        }
    }
    for (uint32_t p = 0; p < mesh->primitive_count && !rc; ++p) {
        const scene_primitive *pr = &mesh->primitives[p];
        if (!encodable(pr)) continue;
        rc = encode_primitive(s, m, p, pr->triangles, pr->triangle_count, pr->vertex_count, o, plan, 0, stats, err);
    }
    if (!rc && stats->primitives) gltf_use_extension(s->doc, "KHR_draco_mesh_compression", !o->fallback);
    return rc;
}
