/* fuzz_pipeline.c - libFuzzer harness for the whole main job on small inputs:
 * scene_load_memory -> per mesh of the default scene: weld -> certified
 * simplify ladder -> lodchain_write -> gltf_serialize (in memory), the same
 * calls `lodpipe IN -o OUT` makes, on one thread.
 *
 * Inputs whose default scene has more than FUZZ_MAX_TRIANGLES triangles are
 * skipped so that one run stays short. Besides crashes, sanitizer reports and
 * leaks, it aborts when a promise is broken by a level it writes:
 * - its certified bound exceeds its eps, or is not a number, or is not the
 *   recorded error;
 * - the level's sampled two-sided distance to the original (a lower bound of
 *   the true distance, the measure `lodpipe check` uses, coarser) exceeds the
 *   certified bound;
 * - the simplifier's invariant checker (on when bit 3 of the input's last
 *   byte is set) finds a broken invariant. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "config.h"
#include "fuzz_common.h"
#include "lodchain.h"
#include "measure.h"
#include "sha256.h"
#include "simplify.h"
#include "weld.h"

#define FUZZ_MAX_TRIANGLES 2000u
#define FUZZ_SAMPLES_PER_DIAGONAL 20.0

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static uint64_t scene_triangles(const scene *s)
{
    uint64_t total = 0;
    for (uint32_t m = 0; m < s->mesh_count; ++m)
        if (s->meshes[m].instance_count) total += s->meshes[m].triangle_count;
    return total;
}

static void broken(const char *what, uint32_t mesh, uint32_t level, double a, double b)
{
    fprintf(stderr, "fuzz_pipeline: mesh %u level %u: %s (%.17g vs %.17g)\n", mesh, level, what, a, b);
    abort();
}

/* Every written level's bound against its eps and against an independent
 * sampled measure of the level against the mesh's original triangles (the
 * scene model keeps the original vertex order, which weld and the levels
 * refer to, after lodchain_write reordered the document). */
static void check_levels(const scene *s, uint32_t m, const weld_result *w, const simplify_result *r,
                         const lodchain_summary *sum)
{
    float *p0 = NULL, *p1 = NULL;
    uint32_t *t0 = NULL, *t1 = NULL;
    measure_mesh original, level;
    lp_error err = {0, "", 0};
    const double diagonal = s->meshes[m].diagonal;
    if (lodchain_mesh_triangles(s, m, NULL, NULL, -1, &p0, &t0, &original, &err) == LP_OK)
        for (uint32_t k = 0; k < sum->level_count; ++k) {
            const uint32_t ladder = sum->levels[k].ladder_level;
            if (ladder < 1 || ladder > r->level_count) broken("written level is not in the ladder", m, k + 1, ladder, 0);
            const simplify_level *l = &r->levels[ladder - 1];
            if (!(l->bound <= l->eps)) broken("certified bound above eps", m, ladder, l->bound, l->eps);
            if (sum->levels[k].error != l->bound) broken("recorded error is not the bound", m, ladder, sum->levels[k].error, l->bound);
            free(p1);
            free(t1);
            p1 = NULL;
            t1 = NULL;
            if (!isfinite(diagonal) || !(diagonal > 0)) continue;
            if (lodchain_mesh_triangles(s, m, w, l, -1, &p1, &t1, &level, &err) != LP_OK) break;
            double measured = measure_two_sided(&original, &level, diagonal / FUZZ_SAMPLES_PER_DIAGONAL);
            if (measured > l->bound * (1 + 1e-9) + 1e-12 * diagonal)
                broken("sampled distance above the certified bound", m, ladder, measured, l->bound);
        }
    free(p0);
    free(t0);
    free(p1);
    free(t1);
}

/* The digest of everything scene_load decoded for mesh m. */
static void mesh_data_digest(const scene *s, uint32_t m, uint8_t digest[SHA256_BYTES])
{
    sha256_ctx h;
    sha256_init(&h);
    const scene_mesh *mesh = &s->meshes[m];
    for (uint32_t p = 0; p < mesh->primitive_count; ++p) {
        const scene_primitive *pr = &mesh->primitives[p];
        sha256_update(&h, &pr->vertex_count, sizeof pr->vertex_count);
        sha256_update(&h, &pr->triangle_count, sizeof pr->triangle_count);
        sha256_update(&h, &pr->stream_count, sizeof pr->stream_count);
        for (uint32_t a = 0; a < pr->stream_count; ++a)
            sha256_update(&h, pr->streams[a].values,
                          (size_t)pr->vertex_count * pr->streams[a].components * sizeof(float));
        if (pr->triangle_count) sha256_update(&h, pr->triangles, 3 * (size_t)pr->triangle_count * sizeof *pr->triangles);
    }
    sha256_final(&h, digest);
}

/* One mesh through weld -> simplify -> lodchain_write, as the CLI does: the
 * scene's decoded mesh is released once welded and read again before the
 * chain is written, and must come back as it was loaded. */
static int run_mesh(scene *s, uint32_t m, const simplify_options *opt, const lodchain_options *chain)
{
    const scene_mesh *mesh = &s->meshes[m];
    lp_error err = {0, "", 0};
    weld_result w;
    if (weld_build(mesh, 1, &w, &err) != LP_OK) return 1;
    uint8_t loaded[SHA256_BYTES], reloaded[SHA256_BYTES];
    mesh_data_digest(s, m, loaded);
    scene_release_mesh_data(s, m);
    int64_t *materials = malloc(((size_t)mesh->primitive_count + 1) * sizeof *materials);
    if (!materials) abort();
    for (uint32_t p = 0; p < mesh->primitive_count; ++p) materials[p] = mesh->primitives[p].material;
    simplify_result r;
    memset(&r, 0, sizeof r);
    int rc = simplify_mesh(&w, materials, opt, &r, &err);
    free(materials);
    if (rc == LP_PROMISE) {
        fprintf(stderr, "fuzz_pipeline: mesh %u: %s\n", m, err.msg);
        abort();
    }
    const int reread = scene_reload_mesh_data(s, m, &err) == LP_OK;
    if (reread) mesh_data_digest(s, m, reloaded);
    if (!reread || memcmp(loaded, reloaded, SHA256_BYTES) != 0) {
        fprintf(stderr, "fuzz_pipeline: mesh %u: read again, its data differs from the load's (%s)\n", m, err.msg);
        abort();
    }
    if (rc == LP_OK) {
        lodchain_summary sum;
        memset(&sum, 0, sizeof sum);
        rc = lodchain_write(s, m, &w, &r, chain, &sum, &err);
        if (rc == LP_OK) check_levels(s, m, &w, &r, &sum);
        lodchain_summary_free(&sum);
    }
    simplify_result_free(&r);
    weld_free(&w);
    return rc;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    scene s;
    if (fuzz_load(data, size, &s) != LP_OK) return 0;
    if (scene_triangles(&s) > FUZZ_MAX_TRIANGLES) {
        scene_free(&s);
        return 0;
    }
    /* The defaults of pipeline.toml, on one thread (placement: below). */
    lp_config config;
    config_defaults(&config);
    double fractions[SIMPLIFY_MAX_LEVELS];
    uint32_t levels = 0;
    for (; levels < config.lod.level_count && levels < SIMPLIFY_MAX_LEVELS; ++levels)
        fractions[levels] = config.lod.levels[levels] / 100.0;
    /* the input's last byte chooses the placement, so both kinds of collapse
     * are fuzzed: odd = lod.placement "optimal" on every level; and whether
     * levels begin with region rounds (bit 1: regions of 16 vertices, so
     * that these small meshes have several); bit 2: hubs from 7 faces around
     * a vertex (simplify.h: hub_faces), held with their neighbours, and no
     * collapse that would make one, at a size these small inputs reach;
     * bit 3: options.verify, the invariant checker (registrations both
     * ways, every changed face and original re-certified, every batch
     * reservation re-decided by walking the 2-ball), whose "broken" aborts;
     * bit 4: retry_due's patience from 3 faces (simplify.h: patient_faces),
     * so that these small inputs have vertices held back until a level's
     * last pass */
    const uint8_t last = size ? data[size - 1] : 0;
    const uint32_t full_edge = last & 1u ? (uint32_t)((1ull << levels) - 1u) : 0;
    const uint32_t regions = last & 2u ? 16 : 0;
    const uint32_t hub_faces = last & 4u ? 6 : 0;
    const int verify = (last & 8u) != 0;
    const uint32_t patient_faces = last & 16u ? 3 : 0;
    const simplify_options opt = {fractions, levels, 1, config.lod.flip_cos, verify, config.lod.strict_intersections,
                                  full_edge, regions, hub_faces, patient_faces};
    const lodchain_options chain = {{config.switching.pixel_error, config.switching.viewport_height,
                                     config.switching.fov_y},
                                    config.lod.min_reduction, 0, NULL, 1};
    int rc = LP_OK;
    for (uint32_t m = 0; m < s.mesh_count && rc == LP_OK; ++m)
        if (s.meshes[m].instance_count && s.meshes[m].triangle_count) rc = run_mesh(&s, m, &opt, &chain);
    if (rc == LP_OK) {
        gltf_out_file *files = NULL;
        size_t count = 0;
        char msg[512];
        if (gltf_serialize(s.doc, FUZZ_FOLDER "output.glb", &files, &count, msg, sizeof msg) == GLTF_OK) {
            gltf_free_files(files, count);
            free(files);
        }
    }
    scene_free(&s);
    return 0;
}
