/* draco_codec.h - plain C face of the Draco library (Debian libdraco-dev).
 *
 * A thin bridge: it decodes and encodes Draco mesh streams and converts
 * attribute values to glTF component types. It holds no algorithm of
 * lodpipe's. Every call checks what the stream says against what the caller
 * asks for, so a hostile stream yields an error, never an out-of-bounds access.
 */
#ifndef LODPIPE_DRACO_CODEC_H
#define LODPIPE_DRACO_CODEC_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct draco_mesh draco_mesh;

/* What the calls below return when memory ran out (-1: anything else), so
 * that a caller never takes it for a stream or mesh Draco refuses. */
#define DRACO_OUT_OF_MEMORY (-2)

/* Decodes a Draco *triangle mesh* stream (point clouds are refused).
 * Returns 0 and sets *out, or -1 (DRACO_OUT_OF_MEMORY when memory ran out)
 * with a one-line reason in err. */
int draco_decode_mesh(const void *data, size_t size, draco_mesh **out,
                      char *err, size_t errlen);
void draco_mesh_free(draco_mesh *mesh);

uint32_t draco_mesh_num_points(const draco_mesh *mesh);
uint32_t draco_mesh_num_faces(const draco_mesh *mesh);

/* Writes 3 * num_faces point indices. Returns 0. */
int draco_mesh_read_indices(const draco_mesh *mesh, uint32_t *out);

/* Converts the attribute with Draco unique id `unique_id` to `components`
 * values of glTF component type `gltf_component_type` (5120..5126) per point,
 * tightly packed into out (num_points * components * size bytes). Integer
 * outputs are taken as the stream's raw integers; normalized integer streams
 * read into floats are normalized. Returns 0, or -1 with a reason when the
 * attribute is absent, has fewer components than asked, or a value does not
 * fit the requested type. */
int draco_mesh_read_attribute(const draco_mesh *mesh, uint32_t unique_id,
                              int gltf_component_type, int components,
                              void *out, char *err, size_t errlen);

/* ---- encoding ------------------------------------------------------------------ */

/* What an attribute is for Draco: it picks the prediction scheme (octahedral
 * normals, portable texture coordinates, parallelogram positions). */
typedef enum draco_semantic {
    DRACO_SEMANTIC_POSITION, DRACO_SEMANTIC_NORMAL, DRACO_SEMANTIC_COLOR,
    DRACO_SEMANTIC_TEXCOORD, DRACO_SEMANTIC_GENERIC
} draco_semantic;

typedef struct draco_encode_attribute {
    draco_semantic semantic;
    int gltf_component_type; /* 5120..5126 */
    int normalized;          /* 0 or 1, as the glTF accessor says */
    int components;          /* 1..4 */
    const void *values;      /* point_count * components values, tightly packed */
    /* Float attributes only: quantization bits (1..30), or 0 to store the
     * values losslessly. Integer attributes are always stored losslessly
     * (their bits are ignored). */
    int quantization_bits;
    /* Float attributes only: 1 = quantize on the grid given here instead of
     * the one Draco would derive from the values: grid point i on axis c is
     * origin[c] + i * range / (2^bits - 1). Every value must lie in
     * [origin, origin + range]. */
    int explicit_grid;
    float origin[4];
    float range;
} draco_encode_attribute;

typedef struct draco_encode_options {
    int speed;      /* 0 (smallest) .. 10 (fastest), for encoding and decoding */
    int sequential; /* 1: sequential connectivity, which keeps every face and the
                       point order as given (what plain morph-target accessors
                       need); 0: edgebreaker, which may reorder both */
    int deduplicate; /* 1: merge equal attribute values and equal points first
                        (edgebreaker then sees shared vertices across seams) */
} draco_encode_options;

/* Encodes a triangle mesh of point_count points, face_count faces (3 point
 * indices each, all < point_count) and the given attributes. On success
 * returns 0, sets *out / *out_size to a malloc'ed stream (caller frees) and
 * unique_ids[a] to attribute a's id in the stream (what the glTF extension's
 * "attributes" map names). Returns -1 (DRACO_OUT_OF_MEMORY when memory ran
 * out) with a reason in err otherwise. */
int draco_encode_mesh(uint32_t point_count, const uint32_t *indices, uint32_t face_count,
                      const draco_encode_attribute *attributes, size_t attribute_count,
                      const draco_encode_options *options, uint8_t **out, size_t *out_size,
                      uint32_t *unique_ids, char *err, size_t errlen);

#ifdef __cplusplus
}
#endif

#endif
