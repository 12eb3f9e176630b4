/* draco_codec.h - plain C face of the Draco library (Debian libdraco-dev).
 *
 * A thin bridge: it decodes (and, later, encodes) Draco mesh streams and
 * converts attribute values to glTF component types. It holds no algorithm of
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

/* Decodes a Draco *triangle mesh* stream (point clouds are refused).
 * Returns 0 and sets *out, or -1 with a one-line reason in err. */
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

#ifdef __cplusplus
}
#endif

#endif
