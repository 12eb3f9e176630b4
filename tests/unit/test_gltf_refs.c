/* test_gltf_refs.c - gltf_accessor_refs keeps its cached counts right across
 * the edits lodpipe makes (gltf_io.cpp: edit_keeps_counts, before_edit,
 * after_reference_set): after every edit below, every accessor's count equals
 * a fresh walk of the document (gltf_accessor_refs_walk). The edits are those
 * of the Draco encoder (a scratch accessor, its keys copied over, removed
 * again; a primitive's references set; the Draco extension; mode removed) and
 * of the chain writer (meshes and nodes appended, extensions set), plus some
 * that must drop the cache (an accessor removed from the middle, a copy into
 * a reference, an extension naming an accessor). */
#include "check.h"
#include "gltf_io/gltf_io.h"

#include <stdio.h>
#include <string.h>

/* Two accessors (positions, indices) of one triangle, a node, a data: URI buffer. */
static const char DOC[] =
    "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
    "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"mode\":4}]}],"
    "\"buffers\":[{\"byteLength\":44,\"uri\":\"data:application/octet-stream;base64,"
    "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA=\"}],"
    "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36},{\"buffer\":0,\"byteOffset\":36,\"byteLength\":6}],"
    "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]},"
    "{\"bufferView\":1,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]}";

/* Every accessor's cached count against a fresh walk (asking also makes the
 * cache valid, so the next edit goes through its upkeep). */
static void check_counts(const gltf_doc *doc, const char *after)
{
    const size_t n = gltf_count(doc, GLTF_ACCESSORS);
    for (size_t a = 0; a < n + 2; ++a) {
        const size_t cached = gltf_accessor_refs(doc, a), walked = gltf_accessor_refs_walk(doc, a);
        CHECK(cached == walked, "after %s: accessor %zu counted %zu, a walk finds %zu", after, a, cached, walked);
    }
}

static void test_counts_across_edits(void)
{
    gltf_doc *doc = NULL;
    char err[256];
    CHECK(gltf_load_memory(DOC, sizeof DOC - 1, "refs.gltf", NULL, &doc, err, sizeof err) == 0, "load: %s", err);
    if (!doc) return;
    check_counts(doc, "the load");
    CHECK(gltf_accessor_refs(doc, 0) == 1 && gltf_accessor_refs(doc, 1) == 1, "one reference each");
    const char *scratch_json = "{\"componentType\":5126,\"count\":2,\"type\":\"VEC3\"}";
    /* the Draco encoder's in-place rewrite */
    int64_t scratch = gltf_append_json(doc, "accessors", scratch_json);
    check_counts(doc, "a scratch accessor appended");
    CHECK(gltf_remove_json(doc, "/accessors/0/count") == 0 && gltf_copy_json(doc, "/accessors/2/count", "/accessors/0/count") == 0,
          "keys moved");
    check_counts(doc, "an accessor's key copied");
    CHECK(scratch == 2 && gltf_remove_json(doc, "/accessors/2") == 0, "scratch removed");
    check_counts(doc, "the last accessor removed");
    /* references moved to new accessors, the extension, mode */
    int64_t a2 = gltf_append_json(doc, "accessors", scratch_json), a3 = gltf_append_json(doc, "accessors", scratch_json);
    CHECK(gltf_set_json(doc, "/meshes/0/primitives/0/attributes/POSITION", "2") == 0 && a2 == 2, "POSITION set");
    check_counts(doc, "a primitive attribute set");
    CHECK(gltf_set_json(doc, "/meshes/0/primitives/0/indices", "3") == 0 && a3 == 3, "indices set");
    check_counts(doc, "a primitive's indices set");
    CHECK(gltf_set_json(doc, "/meshes/0/primitives/0/extensions/KHR_draco_mesh_compression",
                        "{\"bufferView\":0,\"attributes\":{\"POSITION\":1}}") == 0, "Draco extension");
    check_counts(doc, "the Draco extension set");
    CHECK(gltf_remove_json(doc, "/meshes/0/primitives/0/mode") == 0, "mode removed");
    check_counts(doc, "mode removed");
    gltf_use_extension(doc, "KHR_draco_mesh_compression", 1);
    check_counts(doc, "an extension named used and required");
    /* the chain writer's appends */
    CHECK(gltf_append_json(doc, "meshes", "{\"primitives\":[{\"attributes\":{\"POSITION\":2},\"indices\":0}]}") == 1, "a mesh");
    check_counts(doc, "a mesh appended");
    CHECK(gltf_append_json(doc, "nodes", "{\"mesh\":1,\"extensions\":{\"EXT_mesh_gpu_instancing\":{\"attributes\":{\"TRANSLATION\":1}}}}") == 1,
          "a node");
    check_counts(doc, "an instanced node appended");
    CHECK(gltf_set_json(doc, "/nodes/0/extensions", "{\"EXT_mesh_gpu_instancing\":{\"attributes\":{\"SCALE\":3}}}") == 0, "ext");
    check_counts(doc, "an extension naming an accessor set");
    /* edits that must drop the cache */
    CHECK(gltf_copy_json(doc, "/meshes/1/primitives/0/indices", "/meshes/0/primitives/0/attributes/NORMAL") == 0, "copy");
    check_counts(doc, "a reference copied into a primitive");
    CHECK(gltf_remove_json(doc, "/meshes/0/primitives/0/attributes/NORMAL") == 0, "reference removed");
    check_counts(doc, "a primitive's reference removed");
    CHECK(gltf_set_json(doc, "/meshes/0/primitives/0/attributes/POSITION", "\"not an index\"") == 0, "odd value");
    check_counts(doc, "a reference set to a string");
    CHECK(gltf_set_json(doc, "/meshes/0/primitives/0/attributes/POSITION", "0") == 0, "back");
    check_counts(doc, "a reference set from a string");
    CHECK(gltf_remove_json(doc, "/accessors/1") == 0, "an accessor removed from the middle");
    check_counts(doc, "an accessor removed from the middle");
    CHECK(gltf_remove_json(doc, "/meshes/1") == 0, "a mesh removed");
    check_counts(doc, "a mesh removed");
    gltf_free(doc);
}

int main(void)
{
    RUN(test_counts_across_edits);
    return check_summary();
}
