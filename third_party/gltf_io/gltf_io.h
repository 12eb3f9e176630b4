/* gltf_io.h - plain C face of the glTF reader/writer (tinygltf 2.7 + nlohmann json).
 *
 * What it promises
 * - gltf_load reads a .gltf (external files, data: URIs) or .glb, checks the JSON
 *   against the glTF 2.0 schema's types (every index a non-negative integer, every
 *   object an object, ...), checks every bufferView against its buffer, and decodes
 *   compressed geometry (KHR_draco_mesh_compression through third_party/draco_codec,
 *   EXT_meshopt_compression and KHR_meshopt_compression through libmeshoptimizer's
 *   decoders; a KHR stream it has no codec for takes the file's uncompressed fallback,
 *   or is refused when there is none). After a successful
 *   load the document looks as if it had been written uncompressed: decoded data sits
 *   in bufferViews of its own, the accessors point at them, and the decoded
 *   extensions are gone from the primitives, bufferViews and extensionsUsed/Required.
 *   Every byte span this module hands out lies inside memory it owns.
 * - It does NOT check references between objects (accessor -> bufferView, node ->
 *   mesh, ...) nor accessor ranges: the caller (src/scene) does, trusting nothing.
 * - gltf_serialize writes the document back: the JSON exactly as it was read (key
 *   order, numbers, names, extras, unknown extensions) apart from the caller's edits;
 *   all binary data repacked into ONE buffer (bufferView indices renumbered only when
 *   a view became unused: by decoding, or by an edit; views the input itself left
 *   unused are kept), plus a side buffer file when gltf_add_view_in asked for one. The format follows the output name: ".glb",
 *   or else JSON + "<name>.bin". Images keep their storage form: bufferView and
 *   data: URI images stay inside; an external image file is written beside the
 *   output under its original relative uri (so textures shared by several assets
 *   stay shared).
 * - No C++ exception leaves a call. Out of memory: a call that runs out gives
 *   its failure value (-1, NULL, 0) and marks the document
 *   (gltf_out_of_memory), which gltf_serialize then refuses to write, since
 *   an edit may be missing; a reserve set aside at start-up lets the
 *   library's destructors, which allocate, unwind instead of ending the
 *   process.
 * - It holds no algorithm of lodpipe's: it moves bytes and JSON.
 */
#ifndef LODPIPE_GLTF_IO_H
#define LODPIPE_GLTF_IO_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct gltf_doc gltf_doc;

/* Status codes, the same numbers as lodpipe's exit codes. */
enum { GLTF_OK = 0, GLTF_INVALID = 2, GLTF_IO = 4 };

typedef struct gltf_load_options {
    int allow_external_uris; /* accept absolute uris and uris with ".." segments */
    uint64_t max_file_bytes; /* refuse inputs (and referenced files) larger than this; 0 = default cap */
} gltf_load_options;

/* Loads `path`. Returns GLTF_OK and a document, or GLTF_INVALID / GLTF_IO with a
 * one-line reason in err (without the file name; the caller adds it). */
int gltf_load(const char *path, const gltf_load_options *options, gltf_doc **out,
              char *err, size_t errlen);
/* The same for a file already in memory (size bytes, copied): `path` stands for
 * where it came from; only its extension and folder are used (external uris are
 * resolved against that folder, under the same rules). For the fuzz harnesses. */
int gltf_load_memory(const void *bytes, size_t size, const char *path, const gltf_load_options *options,
                     gltf_doc **out, char *err, size_t errlen);
void gltf_free(gltf_doc *doc);
/* Frees every byte of binary data the document holds (buffers, images, decoded
 * views), keeping the JSON and the records: counts, names, accessors,
 * primitives, nodes and scenes still read as before. For a caller that has
 * copied out what it needs (the scene model's float streams and indices) and
 * writes no glTF: afterwards gltf_get_view returns -1 and gltf_serialize
 * fails. */
void gltf_release_binary(gltf_doc *doc);

/* The files the load read besides `path` itself: every buffer and image named
 * by a uri that is not a data: URI, as a path the process can open (the
 * input's folder joined with the percent-decoded uri; the bare uri when the
 * input has no folder), each once, buffers first then images, in document
 * order. What a build system must watch (lodpipe --depfile) and what the batch
 * cache hashes. */
size_t gltf_external_file_count(const gltf_doc *doc);
const char *gltf_external_file(const gltf_doc *doc, size_t index); /* "" when out of range */

/* ---- reading: counts and plain records, valid until gltf_free ---------------- */

typedef enum {
    GLTF_ACCESSORS, GLTF_ANIMATIONS, GLTF_BUFFERS, GLTF_BUFFER_VIEWS, GLTF_CAMERAS,
    GLTF_IMAGES, GLTF_MATERIALS, GLTF_MESHES, GLTF_NODES, GLTF_SAMPLERS, GLTF_SCENES,
    GLTF_SKINS, GLTF_TEXTURES, GLTF_KIND_COUNT
} gltf_kind;

size_t gltf_count(const gltf_doc *doc, gltf_kind kind);
/* The object's "name", or "" when it has none or the index is out of range. */
const char *gltf_name(const gltf_doc *doc, gltf_kind kind, size_t index);

typedef struct gltf_view {
    const uint8_t *data;  /* byte_length bytes owned by the document */
    uint64_t byte_length;
    uint64_t byte_stride; /* 0 = tightly packed */
} gltf_view;
int gltf_get_view(const gltf_doc *doc, size_t index, gltf_view *out); /* 0, or -1 if out of range */

typedef struct gltf_accessor {
    int64_t buffer_view; /* -1: none (all zeros, before sparse substitution) */
    uint64_t byte_offset;
    int32_t component_type; /* 5120..5126 as in the spec; validated by the caller */
    int32_t normalized;
    uint64_t count;
    int32_t components; /* SCALAR 1, VEC2 2, VEC3 3, VEC4 4, MAT2 4, MAT3 9, MAT4 16; 0 unknown */
    int32_t is_matrix;
    int32_t has_sparse;
    uint64_t sparse_count;
    int64_t sparse_indices_view;
    uint64_t sparse_indices_offset;
    int32_t sparse_indices_type;
    int64_t sparse_values_view;
    uint64_t sparse_values_offset;
} gltf_accessor;
int gltf_get_accessor(const gltf_doc *doc, size_t index, gltf_accessor *out);

typedef struct gltf_attribute {
    const char *name; /* "POSITION", "TEXCOORD_0", ... */
    int64_t accessor;
} gltf_attribute;

typedef struct gltf_primitive {
    int32_t mode;      /* 0..6; default 4 */
    int64_t indices;   /* -1: not indexed */
    int64_t material;  /* -1: none */
    size_t attribute_count;
    const gltf_attribute *attributes;
    size_t target_count;
    const size_t *target_attribute_counts;        /* per target */
    const gltf_attribute *const *target_attributes; /* per target */
    int32_t was_draco; /* decoded from KHR_draco_mesh_compression at load */
} gltf_primitive;
size_t gltf_primitive_count(const gltf_doc *doc, size_t mesh);
int gltf_get_primitive(const gltf_doc *doc, size_t mesh, size_t prim, gltf_primitive *out);
/* The accessor of g's attribute `name` ("POSITION", ...), or -1 when g has none. */
int64_t gltf_primitive_attribute(const gltf_primitive *g, const char *name);

typedef struct gltf_node {
    int64_t mesh, skin, camera; /* -1: none */
    size_t child_count;
    const int64_t *children;
    int32_t has_matrix;
    double matrix[16]; /* column-major; identity when absent */
    double translation[3], rotation[4], scale[3]; /* TRS (defaults when absent) */
    size_t weight_count;
    size_t lod_count;     /* MSFT_lod ids on this node, if any */
    const int64_t *lod_ids;
    int32_t has_screencoverage; /* extras.MSFT_screencoverage present */
    size_t extension_count;     /* members of its "extensions" object */
} gltf_node;
int gltf_get_node(const gltf_doc *doc, size_t index, gltf_node *out);

typedef struct gltf_scene {
    size_t node_count;
    const int64_t *nodes;
} gltf_scene;
int gltf_get_scene(const gltf_doc *doc, size_t index, gltf_scene *out);
/* The "scene" property, or -1 when absent. */
int64_t gltf_default_scene(const gltf_doc *doc);

/* Channel c of animation a as the document holds it now. The strings point
 * into the document: valid until its next edit. */
typedef struct gltf_channel {
    int64_t node;        /* target.node, -1 when absent */
    const char *path;    /* target.path, "" when absent */
    const char *pointer; /* target.extensions.KHR_animation_pointer.pointer, NULL when absent */
} gltf_channel;
size_t gltf_channel_count(const gltf_doc *doc, size_t animation); /* 0 when there is no animation a */
int gltf_get_channel(const gltf_doc *doc, size_t animation, size_t channel, gltf_channel *out); /* 0, or -1 */

/* The extensionsUsed / extensionsRequired lists. */
size_t gltf_extension_count(const gltf_doc *doc, int required);
const char *gltf_extension_name(const gltf_doc *doc, int required, size_t index);

/* ---- editing (later stages add LOD meshes and nodes) ------------------------ */

/* Adds a bufferView holding a copy of bytes; target 0 = none (34962 vertex data,
 * 34963 indices). Returns its index, or -1 on allocation failure. */
int64_t gltf_add_view(gltf_doc *doc, const void *bytes, size_t size, uint64_t byte_stride,
                      int target);
/* As gltf_add_view, into output buffer `slot`: 0 the main buffer, 1 a side
 * buffer written as its own file "<OUT stem>.fallback.bin" (also beside a
 * .glb), for data most clients never fetch (Draco's uncompressed fallback). */
int64_t gltf_add_view_in(gltf_doc *doc, const void *bytes, size_t size, uint64_t byte_stride, int target, int slot);
/* Records that `view`, added since loading, takes the place of the older
 * `old_view` (an accessor's data rewritten into it). When the written file no
 * longer has old_view (nothing points at it any more), view carries its name,
 * extras and extensions, through a replaced replacement too; when old_view
 * stays (it holds other data still in use), it keeps them and view gets none.
 * Several views may take the place of one (the accessors of an interleaved
 * view, each rewritten): each carries them. Returns 0, or -1 when view is not
 * newer than old_view or either does not exist. */
int gltf_view_replaces(gltf_doc *doc, int64_t view, int64_t old_view);
/* Builds the primitive records (gltf_primitive_count, gltf_get_primitive) of
 * meshes appended since loading; records of earlier meshes stay as they were
 * (pointers into them stay valid). */
void gltf_sync_mesh_records(gltf_doc *doc);
/* Appends the JSON object `json` to the top-level array `array` ("accessors",
 * "meshes", "nodes", ...), creating it if absent. Returns the new index, or -1 when
 * json does not parse to an object. */
int64_t gltf_append_json(gltf_doc *doc, const char *array, const char *json);
/* Sets the value at the JSON pointer (RFC 6901, e.g. "/nodes/3/extensions/MSFT_lod")
 * to `json`, creating missing objects on the way. Returns 0, or -1. */
int gltf_set_json(gltf_doc *doc, const char *pointer, const char *json);
/* Removes the value at the JSON pointer (0), or -1 when there is none. */
int gltf_remove_json(gltf_doc *doc, const char *pointer);
/* The same two with the pointer given printf-style ("/meshes/%u/primitives/%u/mode");
 * -1 also when the formatted pointer does not fit 256 bytes. */
int gltf_set_jsonf(gltf_doc *doc, const char *json, const char *pointer_format, ...)
    __attribute__((format(printf, 3, 4)));
int gltf_remove_jsonf(gltf_doc *doc, const char *pointer_format, ...) __attribute__((format(printf, 2, 3)));
/* Copies the value at `from` to `to` (both JSON pointers; `to` may end in
 * "/-" to append to an array). Returns 0, or -1 when `from` does not exist. */
int gltf_copy_json(gltf_doc *doc, const char *from, const char *to);
/* The value at the pointer serialized as JSON text (caller frees), or NULL. */
char *gltf_get_json(const gltf_doc *doc, const char *pointer);
/* How many times accessor `index` is referenced: by primitive attributes,
 * morph targets and indices, skins' inverseBindMatrices, animation sampler
 * input/output, and any "accessor" inside an extension (e.g. instancing). */
size_t gltf_accessor_refs(const gltf_doc *doc, size_t index);
/* The same count as the load left the document (0 for an accessor appended
 * since): no walk of the document per call, for a question about the input
 * asked once per primitive. */
size_t gltf_accessor_refs_at_load(const gltf_doc *doc, size_t index);
/* The count gltf_accessor_refs gives, made afresh by a walk of the document
 * as it is now (no cache): for tests of the cache's upkeep. */
size_t gltf_accessor_refs_walk(const gltf_doc *doc, size_t index);

/* Adds name to extensionsUsed (and to extensionsRequired when required). */
void gltf_use_extension(gltf_doc *doc, const char *name, int required);

/* 1 when a call on the document ran out of memory (its edit may be missing). */
int gltf_out_of_memory(const gltf_doc *doc);

/* ---- writing ------------------------------------------------------------------ */

typedef struct gltf_out_file {
    char *name;   /* relative to the output's folder; the first is the main file */
    uint8_t *bytes;
    size_t size;
} gltf_out_file;

/* Serializes the document for the output path `out_path` (only its name and
 * extension are used). Returns GLTF_OK with the files to write, or an error
 * (GLTF_INVALID "out of memory ..." for a document gltf_out_of_memory marks,
 * or when memory runs out while writing). */
int gltf_serialize(const gltf_doc *doc, const char *out_path, gltf_out_file **files,
                   size_t *file_count, char *err, size_t errlen);
void gltf_free_files(gltf_out_file *files, size_t file_count);

#ifdef __cplusplus
}
#endif

#endif
