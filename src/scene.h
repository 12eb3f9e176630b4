/* scene.h - the scene model: what lodpipe works on, in plain C structs.
 *
 * scene_load reads a glTF file through third_party/gltf_io and builds:
 * meshes -> primitives -> attribute streams (float arrays) + triangle indices;
 * nodes with world transforms; for each mesh, the nodes of the default scene
 * that instance it. The gltf_doc handle keeps everything else of the document,
 * untouched, for writing back.
 *
 * Promises after LP_OK:
 * - every reference the model follows (node -> mesh/skin/camera/children,
 *   scene -> nodes, primitive -> accessors/material) is in range;
 * - the node graph is a forest (no cycles, no node with two parents, depth
 *   <= SCENE_MAX_DEPTH);
 * - every triangle index is < its primitive's vertex_count; every POSITION
 *   value is finite;
 * - triangle strips and fans are expanded into triangle lists; points and
 *   lines have no triangles and pass through; a primitive without POSITION is
 *   skipped (with a warning), as the spec tells clients to do.
 * Otherwise it returns LP_INVALID or LP_IO with a message naming the object.
 */
#ifndef LODPIPE_SCENE_H
#define LODPIPE_SCENE_H

#include <stddef.h>
#include <stdint.h>

#include "gltf_io/gltf_io.h"
#include "status.h"

#define SCENE_MAX_DEPTH 4096

typedef struct scene_stream {
    const char *name;   /* attribute semantic, owned by the document */
    int64_t accessor;
    uint32_t components;
    float *values;      /* vertex_count * components */
} scene_stream;

typedef struct scene_primitive {
    uint32_t index;     /* position within the glTF mesh's primitives */
    int32_t mode;       /* glTF mode 0..6 */
    int64_t material;   /* -1: none */
    int64_t indices;    /* index accessor, -1: not indexed */
    int skipped;        /* 1: no POSITION; not processed */
    uint32_t vertex_count;
    const float *positions;   /* = streams[position_stream].values, xyz */
    uint32_t stream_count;
    scene_stream *streams;    /* every attribute, POSITION included */
    uint32_t triangle_count;  /* 0 for points and lines */
    uint32_t *triangles;      /* 3 * triangle_count vertex indices */
    uint32_t target_count;    /* morph targets (kept as accessors) */
} scene_primitive;

typedef struct scene_mesh {
    const char *name;
    uint32_t primitive_count;
    scene_primitive *primitives;
    uint32_t instance_count;  /* nodes of the default scene that use this mesh */
    uint32_t *instances;
    uint64_t triangle_count;
    int has_bbox;
    double bbox_min[3], bbox_max[3]; /* over vertices used by triangles */
    double diagonal;
} scene_mesh;

typedef struct scene_node {
    const char *name;
    int64_t mesh, skin, parent;
    int in_scene;        /* reachable from the default scene */
    double world[16];    /* column-major, mesh space -> world */
    uint32_t lod_count;  /* MSFT_lod ids already present */
    const int64_t *lod_ids;
} scene_node;

/* One animation channel of the input, as the LOD chains follow it (filled
 * and kept by lodchain.c, which alone edits channels). */
typedef struct scene_channel {
    uint32_t animation, channel;
    int64_t node;         /* the node it animates, -1: none */
    int64_t mesh_weights; /* the mesh whose default weights it drives by pointer, -1: none */
    char property[64];    /* the node's property it drives ("translation", "weights", "weights/2", ...),
                             or the mesh's ("weights", "weights/2") */
} scene_channel;

/* Warnings of a load kept as text (inspect lists them); the rest are counted. */
#define SCENE_MAX_WARNINGS_KEPT 4096

typedef struct scene {
    gltf_doc *doc;
    int64_t default_scene; /* -1: the file has no scenes */
    uint32_t mesh_count;
    scene_mesh *meshes;
    uint32_t node_count;
    scene_node *nodes;
    uint32_t warning_count;    /* every warning of the load */
    uint32_t warning_capacity; /* warnings[0 .. min(count, capacity)) are kept */
    char (*warnings)[256];     /* the first SCENE_MAX_WARNINGS_KEPT, for the CLI to print */
    /* the input's animation channels, indexed once (not per chained mesh:
     * scenes of thousands of animated meshes); NULL until lodchain needs them */
    scene_channel *channels;
    size_t channel_count;
} scene;

typedef struct scene_options {
    gltf_load_options load;
} scene_options;

int scene_load(const char *path, const scene_options *options, scene *out, lp_error *err);
/* The same for a file in memory; `path` stands for its name (extension and
 * folder for external uris), see gltf_load_memory. */
int scene_load_memory(const void *bytes, size_t size, const char *path, const scene_options *options, scene *out,
                      lp_error *err);
void scene_free(scene *s);

/* Frees the vertex streams and triangle arrays of mesh `mesh`'s primitives
 * and leaves those primitives with no streams, no positions, no triangles
 * (counts 0); everything else (materials, modes, the mesh's name, counts,
 * bounds, instances) stays. For a caller done with the mesh's geometry, e.g.
 * `lodpipe simplify` once the mesh is welded (the weld result borrows
 * nothing from the scene), so that a large mesh is not held twice while it
 * is simplified. Out of range: nothing happens. */
void scene_release_mesh_data(scene *s, uint32_t mesh);

/* Decodes mesh `mesh`'s primitives again after scene_release_mesh_data: the
 * same streams and triangles as scene_load gave, read from the document, for
 * a caller that let them go while it held something larger (the main job
 * while the mesh is simplified). The load's warnings are not repeated.
 * Primitives that still hold their data are left as they are. The document's
 * accessors of this mesh must not have changed since the load. */
int scene_reload_mesh_data(scene *s, uint32_t mesh, lp_error *err);

/* How much a column-major 4x4 transform can stretch a length: the largest
 * singular value of its 3x3 part (the longest column when it has no shear;
 * under shear the longest column is less). */
double scene_max_scale(const double m[16]);

/* How much node `node` stretches mesh-space lengths into the world, in
 * *stretch: scene_max_scale of its world transform; for a skinned node, whose
 * own transform glTF ignores (its joints place the mesh), the largest over
 * the skin's joints of scene_max_scale(joint world * inverse bind matrix), in
 * the rest pose (the node transforms as read, as for animated nodes).
 * Inverse bind matrices that are not float MAT4 count as identities. Returns
 * LP_OK, or LP_INVALID when a joint stretches beyond float range. */
int scene_mesh_stretch(const scene *s, uint32_t node, double *stretch, lp_error *err);

/* Node n's own transform (its matrix, or its TRS), column-major, as the
 * document holds it now. */
void scene_local_transform(const scene *s, uint32_t n, double out[16]);

#endif
