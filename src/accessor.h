/* accessor.h - glTF accessors turned into plain arrays, trusting nothing.
 *
 * Promises: every byte these functions read lies inside a bufferView that the
 * document owns; the accessor's declared count, offset, stride, component type
 * and sparse substitution are checked against that view before anything is
 * allocated; a failure names the accessor ("accessors[7]: ...") and is
 * LP_INVALID. Values are decoded as the glTF 2.0 spec says: float as is,
 * normalized integers mapped to [0,1] / [-1,1], other integers converted to
 * their float value (KHR_mesh_quantization). */
#ifndef LODPIPE_ACCESSOR_H
#define LODPIPE_ACCESSOR_H

#include <stddef.h>
#include <stdint.h>

#include "gltf_io/gltf_io.h"
#include "status.h"

/* Largest element count lodpipe accepts in one accessor (2^28). */
#define ACCESSOR_MAX_COUNT (1u << 28)

/* Decodes accessor `index` (SCALAR, VECn, or a matrix of 4-byte components,
 * column-major; other matrices are refused) into count * components floats in
 * *out (caller frees). */
int accessor_read_floats(const gltf_doc *doc, int64_t index, float **out, uint32_t *count,
                         uint32_t *components, lp_error *err);

/* Decodes an index accessor (unsigned byte/short/int SCALAR) and checks every
 * index against vertex_count. *out holds count indices (caller frees). */
int accessor_read_indices(const gltf_doc *doc, int64_t index, uint32_t vertex_count,
                          uint32_t **out, uint32_t *count, lp_error *err);

/* The accessor's elements as raw bytes, sparse substitution applied, tightly
 * packed (count * elem_size bytes in *out, caller frees): what a rewritten
 * copy of the accessor needs. Matrices only of 4-byte components (others have
 * padded columns). */
int accessor_read_raw(const gltf_doc *doc, int64_t index, uint8_t **out, uint32_t *count, uint32_t *elem_size,
                      lp_error *err);

#endif
