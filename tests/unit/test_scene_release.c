/* test_scene_release.c - what lodpipe frees before it simplifies (scene.h
 * scene_release_mesh_data, gltf_io.h gltf_release_binary): the arrays go, the
 * records stay, and nothing reads or writes the released bytes afterwards
 * (gltf_get_view refuses, gltf_serialize fails); what the main job reads
 * again once the mesh is simplified (scene_reload_mesh_data) equals what the
 * load gave. ASan checks that scene_free after a release or a reload frees
 * nothing twice and leaks nothing. */
#include "check.h"
#include "scene.h"

#include <stdlib.h>
#include <string.h>

/* One triangle (float positions, uint16 indices) with material 0, its buffer
 * in a data: URI. */
static const char TRIANGLE_GLTF[] =
    "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
    "\"meshes\":[{\"name\":\"tri\",\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"material\":0}]}],"
    "\"materials\":[{\"name\":\"m\"}],"
    "\"buffers\":[{\"byteLength\":44,\"uri\":\"data:application/octet-stream;base64,"
    "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA=\"}],"
    "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36},{\"buffer\":0,\"byteOffset\":36,\"byteLength\":6}],"
    "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]},"
    "{\"bufferView\":1,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]}";

static int load_triangle(scene *s)
{
    lp_error err = {0, "", 0};
    int rc = scene_load_memory(TRIANGLE_GLTF, sizeof TRIANGLE_GLTF - 1, "triangle.gltf", NULL, s, &err);
    CHECK(rc == LP_OK, "load: %s", err.msg);
    return rc;
}

static void test_loaded_as_expected(void)
{
    scene s;
    if (load_triangle(&s)) return;
    const scene_primitive *p = &s.meshes[0].primitives[0];
    CHECK(s.mesh_count == 1 && s.meshes[0].primitive_count == 1, "one mesh, one primitive");
    CHECK(p->vertex_count == 3 && p->triangle_count == 1 && p->positions && p->triangles, "one triangle");
    CHECK(p->positions[3] == 1.0f && p->positions[7] == 1.0f, "positions read");
    CHECK(p->triangles[0] == 0 && p->triangles[1] == 1 && p->triangles[2] == 2, "indices read");
    gltf_view view;
    CHECK(gltf_get_view(s.doc, 0, &view) == 0 && view.byte_length == 36 && view.data, "view readable");
    scene_free(&s);
}

static void test_release_mesh_data(void)
{
    scene s;
    if (load_triangle(&s)) return;
    scene_release_mesh_data(&s, 0);
    const scene_mesh *m = &s.meshes[0];
    const scene_primitive *p = &m->primitives[0];
    CHECK(!p->streams && p->stream_count == 0 && !p->positions && p->vertex_count == 0, "streams released");
    CHECK(!p->triangles && p->triangle_count == 0, "triangles released");
    CHECK(strcmp(m->name, "tri") == 0 && p->material == 0 && p->mode == 4, "records kept");
    CHECK(m->triangle_count == 1 && m->instance_count == 1 && m->has_bbox && m->diagonal > 1.41 && m->diagonal < 1.42,
          "mesh summary kept: %llu triangles, diagonal %g", (unsigned long long)m->triangle_count, m->diagonal);
    scene_release_mesh_data(&s, 0); /* twice: nothing left to free */
    scene_release_mesh_data(&s, 7); /* out of range: nothing happens */
    scene_free(&s);
}

/* The triangle beside a primitive without POSITION (skipped, with a
 * warning), its index accessor one longer (4 indices: a warning from the
 * primitive that is read again). */
static int load_triangle_and_skipped(scene *s)
{
    char text[sizeof TRIANGLE_GLTF + 64];
    const char *at = strstr(TRIANGLE_GLTF, "]}],\"materials\"");
    snprintf(text, sizeof text, "%.*s,{\"attributes\":{\"NORMAL\":0}}%s", (int)(at - TRIANGLE_GLTF), TRIANGLE_GLTF,
             at);
    char *view = strstr(text, "\"byteOffset\":36,\"byteLength\":6}"), *count = strstr(text, "\"count\":3,\"type\":\"SCALAR\"");
    CHECK(view && count, "the text to change");
    if (!view || !count) return 1;
    view[strlen("\"byteOffset\":36,\"byteLength\":")] = '8';
    count[strlen("\"count\":")] = '4';
    lp_error err = {0, "", 0};
    int rc = scene_load_memory(text, strlen(text), "triangle.gltf", NULL, s, &err);
    CHECK(rc == LP_OK, "load: %s", err.msg);
    return rc;
}

static void test_reload_mesh_data(void)
{
    scene s;
    if (load_triangle_and_skipped(&s)) return;
    CHECK(s.meshes[0].primitive_count == 2 && s.meshes[0].primitives[1].skipped, "second primitive skipped");
    const uint32_t warnings = s.warning_count;
    CHECK(warnings == 2 && strstr(s.warnings[0], "not a multiple of 3") && strstr(s.warnings[1], "no POSITION"),
          "%u warnings: %s; %s", warnings, s.warnings[0], s.warnings[1]);
    float positions[9];
    uint32_t triangles[3];
    scene_primitive *p = &s.meshes[0].primitives[0];
    memcpy(positions, p->positions, sizeof positions);
    memcpy(triangles, p->triangles, sizeof triangles);
    scene_release_mesh_data(&s, 0);
    lp_error err = {0, "", 0};
    CHECK(scene_reload_mesh_data(&s, 0, &err) == LP_OK, "reload: %s", err.msg);
    CHECK(p->vertex_count == 3 && p->triangle_count == 1 && p->stream_count == 1 && p->positions && p->triangles,
          "one triangle again: %u vertices, %u triangles", p->vertex_count, p->triangle_count);
    CHECK(p->positions && memcmp(p->positions, positions, sizeof positions) == 0, "the same positions");
    CHECK(p->triangles && memcmp(p->triangles, triangles, sizeof triangles) == 0, "the same triangles");
    CHECK(p->streams && p->positions == p->streams[0].values && strcmp(p->streams[0].name, "POSITION") == 0,
          "positions are the POSITION stream");
    CHECK(p->material == 0 && p->mode == 4 && s.meshes[0].primitives[1].skipped && !s.meshes[0].primitives[1].streams,
          "records as loaded");
    CHECK(s.warning_count == warnings, "no warning repeated: %u, loaded with %u", s.warning_count, warnings);
    const float *held = p->positions;
    CHECK(scene_reload_mesh_data(&s, 0, &err) == LP_OK && p->positions == held, "held data left as it is");
    CHECK(scene_reload_mesh_data(&s, 7, &err) == LP_OK, "out of range: nothing happens");
    scene_free(&s);
}

static void test_release_binary(void)
{
    scene s;
    if (load_triangle(&s)) return;
    const size_t views = gltf_count(s.doc, GLTF_BUFFER_VIEWS), accessors = gltf_count(s.doc, GLTF_ACCESSORS);
    gltf_release_binary(s.doc);
    gltf_view view;
    CHECK(gltf_get_view(s.doc, 0, &view) == -1 && gltf_get_view(s.doc, 1, &view) == -1, "views refused");
    CHECK(gltf_count(s.doc, GLTF_BUFFER_VIEWS) == views && gltf_count(s.doc, GLTF_ACCESSORS) == accessors,
          "counts kept");
    CHECK(strcmp(gltf_name(s.doc, GLTF_MESHES, 0), "tri") == 0 && strcmp(s.meshes[0].name, "tri") == 0, "names kept");
    gltf_accessor acc;
    CHECK(gltf_get_accessor(s.doc, 0, &acc) == 0 && acc.count == 3 && acc.components == 3, "accessor records kept");
    gltf_primitive prim;
    CHECK(gltf_get_primitive(s.doc, 0, 0, &prim) == 0 && prim.indices == 1 && prim.attribute_count == 1,
          "primitive records kept");
    CHECK(s.meshes[0].primitives[0].positions[3] == 1.0f, "the scene's own copy is untouched");
    gltf_out_file *files = NULL;
    size_t file_count = 0;
    char msg[256] = "";
    CHECK(gltf_serialize(s.doc, "out.glb", &files, &file_count, msg, sizeof msg) == GLTF_IO && !files &&
              file_count == 0 && strstr(msg, "released"),
          "serialize refuses: %s", msg);
    gltf_release_binary(s.doc); /* twice */
    scene_free(&s);
}

int main(void)
{
    RUN(test_loaded_as_expected);
    RUN(test_release_mesh_data);
    RUN(test_reload_mesh_data);
    RUN(test_release_binary);
    return check_summary();
}
