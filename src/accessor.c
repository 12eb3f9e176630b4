/* accessor.c - see accessor.h. */
#include "accessor.h"

#include <stdlib.h>
#include <string.h>

static uint32_t component_size(int32_t type)
{
    switch (type) {
    case 5120: case 5121: return 1;
    case 5122: case 5123: return 2;
    case 5125: case 5126: return 4;
    default: return 0;
    }
}

/* One component as a float, per the spec's normalization rules. */
static float decode_component(const uint8_t *p, int32_t type, int normalized)
{
    switch (type) {
    case 5120: { int8_t v; memcpy(&v, p, 1); return normalized ? (v / 127.0f < -1.0f ? -1.0f : v / 127.0f) : (float)v; }
    case 5121: { uint8_t v; memcpy(&v, p, 1); return normalized ? v / 255.0f : (float)v; }
    case 5122: { int16_t v; memcpy(&v, p, 2); return normalized ? (v / 32767.0f < -1.0f ? -1.0f : v / 32767.0f) : (float)v; }
    case 5123: { uint16_t v; memcpy(&v, p, 2); return normalized ? v / 65535.0f : (float)v; }
    case 5125: { uint32_t v; memcpy(&v, p, 4); return (float)v; }
    default: { float v; memcpy(&v, p, 4); return v; }
    }
}

static uint32_t decode_index(const uint8_t *p, uint32_t size)
{
    if (size == 1) return p[0];
    if (size == 2) { uint16_t v; memcpy(&v, p, 2); return v; }
    uint32_t v;
    memcpy(&v, p, 4);
    return v;
}

/* Checks that `count` elements of `elem` bytes, `stride` apart, starting at
 * `offset`, lie inside view `view_index`; returns its bytes. */
static const uint8_t *span_in_view(const gltf_doc *doc, int64_t view_index, uint64_t offset, uint64_t count,
                                   uint64_t elem, uint64_t stride, int64_t accessor, const char *what,
                                   lp_error *err)
{
    gltf_view view;
    if (view_index < 0 || gltf_get_view(doc, (size_t)view_index, &view) != 0) {
        lp_fail(err, LP_INVALID, "accessors[%lld]: %sbufferView %lld does not exist", (long long)accessor, what,
                (long long)view_index);
        return NULL;
    }
    if (count == 0) return view.data;
    /* count <= 2^28 and stride, elem <= 2^8: no overflow in 64 bits */
    uint64_t need = stride * (count - 1) + elem;
    if (offset > view.byte_length || need > view.byte_length - offset) {
        lp_fail(err, LP_INVALID,
                "accessors[%lld]: %s%llu elements need %llu bytes from offset %llu but bufferViews[%lld] has %llu",
                (long long)accessor, what, (unsigned long long)count, (unsigned long long)need,
                (unsigned long long)offset, (long long)view_index, (unsigned long long)view.byte_length);
        return NULL;
    }
    return view.data + offset;
}

/* Validates the accessor's header: a known type, a sane count. */
static int accessor_header(const gltf_doc *doc, int64_t index, gltf_accessor *acc, lp_error *err)
{
    if (index < 0 || gltf_get_accessor(doc, (size_t)index, acc) != 0)
        return lp_fail(err, LP_INVALID, "accessors[%lld] does not exist", (long long)index);
    if (!component_size(acc->component_type))
        return lp_fail(err, LP_INVALID, "accessors[%lld]: unknown componentType %d", (long long)index,
                       acc->component_type);
    if (acc->components == 0)
        return lp_fail(err, LP_INVALID, "accessors[%lld]: unknown type", (long long)index);
    if (acc->count > ACCESSOR_MAX_COUNT)
        return lp_fail(err, LP_INVALID, "accessors[%lld]: count %llu exceeds the limit of %u", (long long)index,
                       (unsigned long long)acc->count, ACCESSOR_MAX_COUNT);
    if (acc->normalized && (acc->component_type == 5125 || acc->component_type == 5126))
        return lp_fail(err, LP_INVALID, "accessors[%lld]: normalized is only allowed for byte and short components",
                       (long long)index);
    return LP_OK;
}

int accessor_read_floats(const gltf_doc *doc, int64_t index, float **out, uint32_t *count,
                         uint32_t *components, lp_error *err)
{
    uint8_t *raw;
    uint32_t n, elem;
    *out = NULL;
    int rc = accessor_read_raw(doc, index, &raw, &n, &elem, err);
    if (rc) return rc;
    gltf_accessor acc;
    gltf_get_accessor(doc, (size_t)index, &acc);
    const uint32_t csize = component_size(acc.component_type), comps = (uint32_t)acc.components;
    float *values = malloc((n ? (size_t)n * comps : 1) * sizeof *values);
    if (!values) {
        free(raw);
        return lp_no_memory(err, "accessors[%lld]: out of memory", (long long)index);
    }
    for (size_t i = 0; i < (size_t)n * comps; ++i)
        values[i] = decode_component(raw + i * csize, acc.component_type, acc.normalized);
    free(raw);
    *out = values;
    *count = n;
    *components = comps;
    return LP_OK;
}

int accessor_read_indices(const gltf_doc *doc, int64_t index, uint32_t vertex_count, uint32_t **out,
                          uint32_t *count, lp_error *err)
{
    gltf_accessor acc;
    *out = NULL;
    int rc = accessor_header(doc, index, &acc, err);
    if (rc) return rc;
    if (acc.components != 1 || acc.is_matrix || acc.normalized ||
        (acc.component_type != 5121 && acc.component_type != 5123 && acc.component_type != 5125))
        return lp_fail(err, LP_INVALID, "accessors[%lld]: indices must be unsigned byte/short/int SCALAR",
                       (long long)index);
    if (acc.has_sparse) {
        /* rare for indices; decode through the general path, then convert */
        float *values;
        uint32_t n, comps;
        rc = accessor_read_floats(doc, index, &values, &n, &comps, err);
        if (rc) return rc;
        uint32_t *idx = malloc((n ? n : 1) * sizeof *idx);
        if (!idx) {
            free(values);
            return lp_no_memory(err, "accessors[%lld]: out of memory", (long long)index);
        }
        for (uint32_t i = 0; i < n; ++i) {
            if (!(values[i] >= 0.0f && values[i] < (float)vertex_count)) {
                free(values);
                free(idx);
                return lp_fail(err, LP_INVALID, "accessors[%lld]: index at position %u is out of range (%u vertices)",
                               (long long)index, i, vertex_count);
            }
            idx[i] = (uint32_t)values[i];
        }
        free(values);
        *out = idx;
        *count = n;
        return LP_OK;
    }
    if (acc.buffer_view < 0)
        return lp_fail(err, LP_INVALID, "accessors[%lld]: index accessor has no bufferView", (long long)index);
    const uint32_t size = component_size(acc.component_type);
    gltf_view view;
    uint64_t stride = size;
    if (gltf_get_view(doc, (size_t)acc.buffer_view, &view) == 0 && view.byte_stride) stride = view.byte_stride;
    const uint8_t *base = span_in_view(doc, acc.buffer_view, acc.byte_offset, acc.count, size, stride, index, "", err);
    if (!base) return err->code;
    uint32_t *idx = malloc(acc.count ? (size_t)acc.count * sizeof *idx : sizeof *idx);
    if (!idx) return lp_no_memory(err, "accessors[%lld]: out of memory", (long long)index);
    for (uint64_t i = 0; i < acc.count; ++i) {
        idx[i] = decode_index(base + i * stride, size);
        if (idx[i] >= vertex_count) {
            uint32_t bad = idx[i];
            free(idx);
            return lp_fail(err, LP_INVALID, "accessors[%lld]: index %u at position %llu is out of range (%u vertices)",
                           (long long)index, bad, (unsigned long long)i, vertex_count);
        }
    }
    *out = idx;
    *count = (uint32_t)acc.count;
    return LP_OK;
}

int accessor_read_raw(const gltf_doc *doc, int64_t index, uint8_t **out, uint32_t *count, uint32_t *elem_size,
                      lp_error *err)
{
    gltf_accessor acc;
    *out = NULL;
    int rc = accessor_header(doc, index, &acc, err);
    if (rc) return rc;
    const uint32_t csize = component_size(acc.component_type);
    /* a matrix's columns start on 4-byte boundaries: packed only with
     * 4-byte components (inverse bind matrices are float) */
    if (acc.is_matrix && csize != 4)
        return lp_fail(err, LP_INVALID, "accessors[%lld]: a matrix of %u-byte components is not read", (long long)index,
                       csize);
    const uint64_t elem = (uint64_t)csize * (uint32_t)acc.components;
    uint64_t stride = elem;
    const uint8_t *base = NULL;
    if (acc.buffer_view >= 0) {
        gltf_view view;
        if (gltf_get_view(doc, (size_t)acc.buffer_view, &view) == 0 && view.byte_stride) stride = view.byte_stride;
        if (stride < elem)
            return lp_fail(err, LP_INVALID, "accessors[%lld]: byteStride %llu is smaller than an element",
                           (long long)index, (unsigned long long)stride);
        base = span_in_view(doc, acc.buffer_view, acc.byte_offset, acc.count, elem, stride, index, "", err);
        if (!base) return err->code;
    }
    uint8_t *bytes = calloc(acc.count ? (size_t)(acc.count * elem) : 1, 1);
    if (!bytes) return lp_no_memory(err, "accessors[%lld]: out of memory", (long long)index);
    if (base)
        for (uint64_t i = 0; i < acc.count; ++i) memcpy(bytes + i * elem, base + i * stride, (size_t)elem);
    if (acc.has_sparse) {
        uint32_t isize = component_size(acc.sparse_indices_type);
        const uint8_t *idx = NULL, *val = NULL;
        if (!isize || acc.sparse_indices_type == 5120 || acc.sparse_indices_type == 5122 ||
            acc.sparse_indices_type == 5126 || acc.sparse_count > acc.count)
            rc = lp_fail(err, LP_INVALID, "accessors[%lld]: invalid sparse substitution", (long long)index);
        if (!rc) idx = span_in_view(doc, acc.sparse_indices_view, acc.sparse_indices_offset, acc.sparse_count, isize,
                                    isize, index, "sparse indices: ", err);
        if (!rc && idx) val = span_in_view(doc, acc.sparse_values_view, acc.sparse_values_offset, acc.sparse_count,
                                           elem, elem, index, "sparse values: ", err);
        if (!rc && (!idx || !val)) rc = err->code;
        for (uint64_t s = 0; !rc && s < acc.sparse_count; ++s) {
            uint32_t target = decode_index(idx + s * isize, isize);
            if (target >= acc.count)
                rc = lp_fail(err, LP_INVALID, "accessors[%lld]: sparse index %u is out of range", (long long)index, target);
            else
                memcpy(bytes + (uint64_t)target * elem, val + s * elem, (size_t)elem);
        }
        if (rc) {
            free(bytes);
            return rc;
        }
    }
    *out = bytes;
    *count = (uint32_t)acc.count;
    *elem_size = (uint32_t)elem;
    return LP_OK;
}
