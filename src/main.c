/* main.c - the lodpipe command line.
 *
 * Parses arguments, runs one command, prints errors as one line
 * "lodpipe: FILE: what is wrong" and exits with the documented code
 * (status.h). Commands live in their own small functions. */
#include <malloc.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "batch.h"
#include "clock.h"
#include "config.h"
#include "depfile.h"
#include "dracoout.h"
#include "jsonr.h"
#include "jsonw.h"
#include "lodchain.h"
#include "measure.h"
#include "output.h"
#include "scene.h"
#include "sha256.h"
#include "simplify.h"
#include "status.h"
#include "threads.h"
#include "version.h"
#include "weld.h"

static const char *const kModeNames[7] = {"POINTS", "LINES", "LINE_LOOP", "LINE_STRIP",
                                          "TRIANGLES", "TRIANGLE_STRIP", "TRIANGLE_FAN"};

typedef struct cli {
    const char *command;
    const char *output; /* -o */
    int json;
    const char *config_path;   /* --config */
    lp_config config;          /* defaults <- --config file <- flags */
    const char *operands[2];
    int operand_count;
    int force;
    int quiet;
    int allow_external_uris;
    const char *depfile;       /* --depfile: the main job's Make/Ninja dependency file */
    int jobs, jobs_given;      /* batch -j N (0: one per core) */
    uint32_t shard_index, shard_count; /* batch --shard K/N (1-based K; 0/0: everything) */
    double levels[SIMPLIFY_MAX_LEVELS]; /* config.lod.levels as fractions of the diagonal */
} cli;

static void usage(FILE *f)
{
    fputs("usage: lodpipe IN -o OUT [options]      the main job: certified LOD chains\n"
          "       lodpipe COMMAND [options] ARGS\n"
          "\n"
          "The main job simplifies every mesh of IN's default scene into levels whose\n"
          "two-sided Hausdorff distance to the original is certified, and writes them\n"
          "to OUT (.glb or .gltf) as MSFT_lod chains with switching distances.\n"
          "\n"
          "commands:\n"
          "  inspect FILE        per mesh: primitives, triangles, attributes, instancing\n"
          "                      nodes, bounding-box diagonal; LOD chains already present\n"
          "  convert IN OUT      load IN and write it to OUT unchanged (.glb or .gltf by\n"
          "                      OUT's extension); compressed geometry comes out decoded\n"
          "  check FILE          measure every LOD of FILE against its LOD0 (dense sampling,\n"
          "                      both directions); exit 3 if one exceeds its recorded error\n"
          "  simplify IN OUTDIR  the certified simplifier alone: for every mesh of the\n"
          "                      default scene, OUTDIR/mesh<K>_level<L>.obj (level 0 = the\n"
          "                      welded original, mesh space) and OUTDIR/simplify.json\n"
          "  batch SRC_DIR -o OUT_DIR [-j N] [--shard K/N] [--force] [--json]\n"
          "                      the main job on every .gltf/.glb under SRC_DIR, mirrored\n"
          "                      into OUT_DIR; unchanged files are skipped (cache in\n"
          "                      OUT_DIR/.lodpipe-cache.json); exit 5 if any file failed\n"
          "\n"
          "options:\n"
          "  -o OUT                 the main job's output (.glb or .gltf)\n"
          "  --config FILE          read settings from a pipeline.toml (flags override it)\n"
          "  --pixel-error P        screen error in pixels at the switching distance (1)\n"
          "  --viewport-height H    viewport height in pixels (1080)\n"
          "  --fov-y RADIANS        vertical field of view (0.7853981633974483)\n"
          "  --json                 print a machine-readable summary on stdout\n"
          "  --force                main job, convert: overwrite the input file if OUT names\n"
          "                         it; batch:\n"
          "                         rebuild every file, ignoring the cache\n"
          "  --allow-external-uris  accept uris that leave the input's folder\n"
          "  --quiet, -q            no warnings on stderr\n"
          "  --levels LIST          eps per level in percent of the mesh's bounding-box\n"
          "                         diagonal, increasing (default 1,3,7,15)\n"
          "  --placement MODE       half-edge (default: levels share the original vertices) or\n"
          "                         optimal (a level may place a kept vertex where its half-edge\n"
          "                         collapse fails; such a level has its own POSITION accessor)\n"
          "  --optimal-levels LIST  with --placement optimal: the level numbers (1-based) that\n"
          "                         may place vertices, e.g. 3,4 (default: every level)\n"
          "  --threads N            worker threads, 0..64 (0, the default: one per core); the result\n"
          "                         does not depend on it\n"
          "  --depfile FILE         main job: write a Make/Ninja rule OUT: IN, the files IN\n"
          "                         references and the --config file\n"
          "  -j N                   batch: files processed at once (0, the default: one per\n"
          "                         core; at most one per file to build); with run.threads 0,\n"
          "                         each job gets max(1, cores / jobs) threads\n"
          "  --shard K/N            batch: only the K-th of N disjoint parts (1 <= K <= N)\n"
          "  --draco                Draco-compress LOD0 and every level (KHR_draco_mesh_compression);\n"
          "                         the position quantization is added to the recorded errors;\n"
          "                         with convert: compress the meshes as they are\n"
          "  --help, -h             this text\n"
          "  --version              the version\n"
          "\n"
          "exit codes: 0 success, 1 usage error, 2 invalid input, 3 a promise could not\n"
          "be kept, 4 I/O error, 5 batch: some files failed. Errors are one line:\n"
          "\"lodpipe: FILE: what is wrong\". An option a command does not use is refused.\n",
          f);
}

static int usage_error(const char *msg)
{
    lp_say("%s (see lodpipe --help)", msg);
    return LP_USAGE;
}

static int report(const char *file, const lp_error *err)
{
    lp_say("%s: %s", file, err->msg);
    return err->code;
}

/* The load's warnings: the first 8 and a count of the rest, which `inspect`
 * lists (all it kept). */
static void print_warnings(const cli *c, const char *file, const scene *s)
{
    if (c->quiet) return;
    const int all = c->command && strcmp(c->command, "inspect") == 0;
    const uint32_t kept = s->warning_count < s->warning_capacity ? s->warning_count : s->warning_capacity;
    const uint32_t shown = all || kept < 8 ? kept : 8;
    for (uint32_t i = 0; i < shown; ++i) lp_say("%s: warning: %s", file, s->warnings[i]);
    if (s->warning_count > shown)
        lp_say(all ? "%s: warning: %u more warnings (not kept)" : "%s: warning: %u more warnings (lodpipe inspect lists them)",
               file, s->warning_count - shown);
}

static int load(const cli *c, const char *path, scene *s)
{
    scene_options opt;
    memset(&opt, 0, sizeof opt);
    opt.load.allow_external_uris = c->allow_external_uris;
    lp_error err = {0, "", 0};
    int rc = scene_load(path, &opt, s, &err);
    if (rc) return report(path, &err);
    print_warnings(c, path, s);
    return LP_OK;
}

/* A name as inspect prints it: on one line (lp_line's escapes). */
static const char *one_line(char *buf, size_t cap, const char *name)
{
    return lp_line(buf, cap, "%s", name ? name : "");
}

static int cmd_inspect(const cli *c)
{
    const char *path = c->operands[0];
    scene s;
    int rc = load(c, path, &s);
    if (rc) return rc;
    char name[1024];
    printf("file: %s\n", one_line(name, sizeof name, path));
    printf("scenes: %zu (default %lld), nodes: %u, meshes: %u, materials: %zu\n", gltf_count(s.doc, GLTF_SCENES),
           (long long)s.default_scene, s.node_count, s.mesh_count, gltf_count(s.doc, GLTF_MATERIALS));
    for (uint32_t m = 0; m < s.mesh_count; ++m) {
        const scene_mesh *mesh = &s.meshes[m];
        printf("mesh %u \"%s\": %u primitives, %llu triangles, bbox diagonal %.9g\n", m, one_line(name, sizeof name, mesh->name),
               mesh->primitive_count, (unsigned long long)mesh->triangle_count, mesh->diagonal);
        for (uint32_t p = 0; p < mesh->primitive_count; ++p) {
            const scene_primitive *pr = &mesh->primitives[p];
            printf("  primitive %u: %s, material %lld", p, kModeNames[pr->mode], (long long)pr->material);
            if (pr->skipped) {
                printf(", no POSITION (skipped)\n");
                continue;
            }
            printf(", %u vertices, %u triangles, attributes", pr->vertex_count, pr->triangle_count);
            for (uint32_t a = 0; a < pr->stream_count; ++a) printf(" %s", pr->streams[a].name);
            if (pr->target_count) printf(", %u morph targets", pr->target_count);
            printf("\n");
        }
        printf("  instanced by %u node%s%s", mesh->instance_count, mesh->instance_count == 1 ? "" : "s",
               mesh->instance_count ? ":" : "");
        for (uint32_t i = 0; i < mesh->instance_count; ++i) {
            const scene_node *n = &s.nodes[mesh->instances[i]];
            double stretch;
            lp_error ignored = {0, "", 0};
            if (scene_mesh_stretch(&s, mesh->instances[i], &stretch, &ignored)) stretch = NAN;
            printf(" %u \"%s\" (scale %.6g)", mesh->instances[i], one_line(name, sizeof name, n->name), stretch);
        }
        printf("\n");
    }
    uint32_t chains = 0;
    for (uint32_t i = 0; i < s.node_count; ++i) {
        const scene_node *n = &s.nodes[i];
        if (!n->lod_count) continue;
        printf("LOD chain on node %u \"%s\": mesh %lld", i, one_line(name, sizeof name, n->name), (long long)n->mesh);
        for (uint32_t l = 0; l < n->lod_count; ++l)
            printf(" -> node %lld (mesh %lld)", (long long)n->lod_ids[l], (long long)s.nodes[n->lod_ids[l]].mesh);
        printf("\n");
        chains++;
    }
    if (!chains) printf("LOD chains: none\n");
    scene_free(&s);
    return LP_OK;
}

/* The output format follows the name: .glb, or .gltf (JSON + .bin). */
static int output_name_ok(const char *out)
{
    size_t n = strlen(out);
    return (n > 4 && strcasecmp(out + n - 4, ".glb") == 0) || (n > 5 && strcasecmp(out + n - 5, ".gltf") == 0);
}

/* The output must be a .glb or .gltf, not the input (without --force), and
 * go to a folder that exists and may be written to. */
static int output_usable(const cli *c, const char *in, const char *out)
{
    if (!output_name_ok(out)) {
        lp_say("%s: the output name must end in .glb or .gltf", out);
        return LP_USAGE;
    }
    if (!c->force && output_same_file(in, out)) {
        lp_say("%s: refusing to overwrite the input (use --force)", out);
        return LP_USAGE;
    }
    lp_error err = {0, "", 0};
    if (output_check_folder(out, &err)) return report(out, &err); /* now, not after the work */
    if (c->depfile) {
        const char *named = output_same_path(c->depfile, out)  ? "output"
                            : output_same_path(c->depfile, in) ? "input"
                            : c->config_path && output_same_path(c->depfile, c->config_path) ? "--config file"
                                                                                             : NULL;
        if (named) {
            lp_say("%s: --depfile names the %s", c->depfile, named);
            return LP_USAGE;
        }
        if (output_check_folder(c->depfile, &err)) return report(c->depfile, &err);
    }
    return LP_OK;
}

/* The --depfile must not name a file the input reads (checked once they are
 * known, before the work). */
static int depfile_usable(const cli *c, const gltf_doc *doc)
{
    for (size_t i = 0; c->depfile && i < gltf_external_file_count(doc); ++i)
        if (output_same_path(c->depfile, gltf_external_file(doc, i))) {
            lp_say("%s: --depfile names %s, a file the input reads", c->depfile,
                    gltf_external_file(doc, i));
            return LP_USAGE;
        }
    return LP_OK;
}

/* Appends `,"outputs":[paths],"output_sha256":[hex]`: the files
 * output_write_all writes for `out` (the main file first, the others in its
 * folder) and the SHA-256 of each one's bytes. */
static void json_written_files(jsonw *j, const char *out, const gltf_out_file *files, size_t count)
{
    const char *slash = strrchr(out, '/');
    jsonw_raw(j, ",\"outputs\":[");
    jsonw_string(j, out);
    for (size_t i = 1; i < count; ++i) {
        jsonw path = {0};
        if (slash) jsonw_printf(&path, "%.*s/", (int)(slash - out), out);
        jsonw_raw(&path, files[i].name);
        jsonw_raw(j, ",");
        if (path.failed) j->failed = 1; /* a name left out would be a wrong report */
        else jsonw_string(j, path.text);
        jsonw_free(&path);
    }
    /* the hashes of the bytes this run writes, so a batch records what each
     * job wrote, not what it finds on disk later, when another job may have
     * replaced a shared file name (a.png and A.png on a case-insensitive
     * volume) */
    jsonw_raw(j, "],\"output_sha256\":[");
    for (size_t i = 0; i < count; ++i) {
        uint8_t digest[SHA256_BYTES];
        char hex[SHA256_HEX];
        sha256_bytes(files[i].bytes, files[i].size, digest);
        sha256_hex(digest, hex);
        jsonw_printf(j, "%s\"%s\"", i ? "," : "", hex);
    }
    jsonw_raw(j, "]");
}

/* The --json report's end: the outputs and the closing brace. Nonzero when
 * the report ran out of memory, here or before. */
static int finish_json_report(jsonw *j, const char *out, const gltf_out_file *files, size_t count)
{
    json_written_files(j, out, files, count);
    jsonw_raw(j, "}\n");
    return j->failed;
}

/* Serializes the document and writes every file all-or-nothing, with the
 * --depfile's text when `depfile` is not NULL. When `json_report` is not NULL (the
 * --json report, all but its outputs), the paths to be written and the
 * report's end are appended to it first: a report that runs out of memory
 * fails the run before any file is written, never after (exit 0 with a
 * wrong or empty report). No file the input `in` reads is
 * replaced (its .bin by a .gltf output's, say), unless --force names the
 * input itself as OUT (the whole input is replaced then), nor the --depfile
 * (in = NULL: no such guards). */
static int write_document(const cli *c, const char *in, const gltf_doc *doc, const char *out, const char *depfile,
                          jsonw *json_report)
{
    gltf_out_file *files = NULL;
    size_t count = 0;
    char msg[512];
    lp_error err = {0, "", 0};
    const size_t inputs = in ? gltf_external_file_count(doc) + 1 : 0;
    output_guard *guards = calloc(inputs + 3, sizeof *guards);
    size_t guard_count = 0;
    if (!guards) {
        lp_say("%s: out of memory", out);
        return LP_INVALID;
    }
    if (in && !(c->force && output_same_file(in, out))) {
        guards[guard_count++] = (output_guard){in, "the input"};
        for (size_t i = 0; i + 1 < inputs; ++i)
            guards[guard_count++] = (output_guard){gltf_external_file(doc, i), "a file the input reads"};
    }
    if (in && c->depfile) guards[guard_count++] = (output_guard){c->depfile, "the --depfile"};
    if (in && c->config_path) guards[guard_count++] = (output_guard){c->config_path, "the --config file"};
    const output_file also = {c ? c->depfile : NULL, (const uint8_t *)depfile, depfile ? strlen(depfile) : 0};
    int rc = gltf_serialize(doc, out, &files, &count, msg, sizeof msg);
    if (rc) {
        lp_fail(&err, rc, "%s", msg);
        rc = report(out, &err);
    } else if (json_report && finish_json_report(json_report, out, files, count) != 0) {
        lp_no_memory(&err, "out of memory for the --json report");
        rc = report(out, &err);
    } else if ((rc = output_write_all(out, files, count, &also, depfile ? 1 : 0, guards, guard_count, &err)) != 0) {
        rc = report(out, &err);
    }
    gltf_free_files(files, count);
    free(files);
    free(guards);
    return rc;
}

static dracoout_options draco_options_of(const cli *c)
{
    dracoout_options o = {c->config.draco.position_bits, c->config.draco.normal_bits, c->config.draco.texcoord_bits,
                          c->config.draco.color_bits,    c->config.draco.generic_bits, c->config.draco.speed,
                          c->config.draco.fallback};
    return o;
}

/* Does a node that uses mesh m carry an MSFT_lod chain? */
static int mesh_has_chain(const scene *s, uint32_t m)
{
    for (uint32_t n = 0; n < s->node_count; ++n)
        if (s->nodes[n].mesh == (int64_t)m && s->nodes[n].lod_count) return 1;
    return 0;
}

/* convert --draco: every mesh of the default scene compressed as it is. A
 * mesh that carries a chain is left uncompressed: its recorded errors (and
 * the check's allowance, LOD0's recorded error) are for its present geometry,
 * and quantizing it would make them false. */
static int draco_lod0_only(const cli *c, const char *in, scene *s)
{
    dracoout_options o = draco_options_of(c);
    dracoout_stats stats = {0};
    lp_error err = {0, "", 0};
    int rc = LP_OK;
    for (uint32_t m = 0; m < s->mesh_count && !rc; ++m) {
        if (!s->meshes[m].instance_count || !s->meshes[m].triangle_count) continue;
        if (mesh_has_chain(s, m)) {
            if (!c->quiet)
                lp_say("%s: warning: meshes[%u] has LOD chains; left uncompressed (their recorded errors are for its "
                       "present geometry: compress with the main job's --draco from the original)",
                       in, m);
            continue;
        }
        dracoout_plan plan;
        rc = dracoout_plan_mesh(s, m, NULL, NULL, 0, &o, o.position_bits, &plan, &err);
        if (!rc) rc = dracoout_write_mesh(s, m, NULL, &o, &plan, &stats, &err);
    }
    return rc ? report(in, &err) : LP_OK;
}

static int cmd_convert(const cli *c)
{
    const char *in = c->operands[0], *out = c->operands[1];
    int usage = output_usable(c, in, out);
    if (usage) return usage;
    scene s;
    int rc = load(c, in, &s);
    if (rc) return rc;
    if (c->config.draco.enabled) rc = draco_lod0_only(c, in, &s);
    if (!rc) rc = write_document(c, in, s.doc, out, NULL, NULL);
    scene_free(&s);
    return rc;
}

/* The simplifier's options from the effective configuration. */
static simplify_options simplify_options_of(const cli *c)
{
    uint32_t every = (uint32_t)((1ull << c->config.lod.level_count) - 1u);
    uint32_t full_edge = 0;
    if (c->config.lod.placement == 1) full_edge = c->config.lod.optimal_levels ? c->config.lod.optimal_levels & every : every;
    simplify_options opt = {c->levels, (uint32_t)c->config.lod.level_count, (uint32_t)c->config.run.threads,
                            c->config.lod.flip_cos, 0, c->config.lod.strict_intersections, full_edge, 0, 0, 0};
    const char *verify = getenv("LODPIPE_VERIFY");
    opt.verify = verify && strcmp(verify, "0") != 0;
    return opt;
}

/* Welds mesh m and runs the certified ladder on it; on failure nothing is
 * left to free. The mesh's geometry in the scene is freed once welded, so
 * that it is not held beside the simplifier's arrays (a caller that needs it
 * afterwards reads it again: scene_reload_mesh_data). */
static int weld_and_simplify(scene *s, uint32_t m, const simplify_options *opt, weld_result *w, simplify_result *r,
                             lp_error *err)
{
    const scene_mesh *mesh = &s->meshes[m];
    memset(r, 0, sizeof *r);
    const double weld_start = lp_seconds();
    int rc = weld_build(mesh, opt->threads, w, err);
    if (rc) return rc;
    const double weld_seconds = lp_seconds() - weld_start;
    weld_release_edge_opposite(w); /* nothing after the weld reads it */
    scene_release_mesh_data(s, m);
    int64_t *materials = malloc(((size_t)mesh->primitive_count + 1) * sizeof *materials);
    if (!materials) rc = lp_no_memory(err, "out of memory");
    for (uint32_t p = 0; materials && p < mesh->primitive_count; ++p) materials[p] = mesh->primitives[p].material;
    if (!rc) rc = simplify_mesh(w, materials, opt, r, err);
    if (!rc) r->seconds_weld = weld_seconds;
    free(materials);
    if (rc) weld_free(w);
    return rc;
}

/* Small meshes are welded and simplified ahead of the writer, several at
 * once, one thread each: a small mesh's simplifier has too little work per
 * batch to keep two cores busy (its helpers mostly wait to be woken), while
 * two meshes at once do. A run of consecutive meshes to simplify, each of at
 * most AHEAD_SMALL triangles and at most AHEAD_TRIANGLES in all (at most
 * AHEAD_MESHES of them), is done at once on the run's threads; a larger mesh
 * is done alone, with all of them (so no large mesh runs on one thread while
 * the others idle). The document is only read meanwhile; the chains are then
 * written in mesh order, one by one, so the output is the same bytes for any
 * thread count (the simplifier's result does not depend on its threads).
 * The bounds keep what is held at once to about one large mesh's worth. */
#define AHEAD_SMALL 65536
#define AHEAD_TRIANGLES 262144
#define AHEAD_MESHES 64

/* One mesh done ahead: its Draco budget (with --draco), weld and ladder. */
typedef struct mesh_ahead {
    uint32_t mesh;
    simplify_options opt;
    double reserved[SIMPLIFY_MAX_LEVELS]; /* opt.fractions with --draco: eps minus the quantization budget */
    int bits;                             /* Draco's position bits for it */
    weld_result w;
    simplify_result r;
    int rc, welded;
    lp_error err;
} mesh_ahead;

/* The meshes a command simplifies, one flag per mesh: `simplify` takes every
 * mesh of the default scene with triangles; the main job only those that a
 * node without MSFT_lod uses (lodchain_write leaves a node that has one as it
 * is, so a mesh with no such node would only gain unused level meshes).
 * NULL when out of memory. */
static uint8_t *meshes_to_simplify(const scene *s, int main_job)
{
    uint8_t *take = calloc((size_t)s->mesh_count + 1, 1);
    if (!take) return NULL;
    for (uint32_t n = 0; main_job && n < s->node_count; ++n)
        if (s->nodes[n].mesh >= 0 && s->nodes[n].mesh < (int64_t)s->mesh_count && !s->nodes[n].lod_count)
            take[s->nodes[n].mesh] = 1;
    for (uint32_t m = 0; m < s->mesh_count; ++m)
        take[m] = s->meshes[m].instance_count && s->meshes[m].triangle_count && (!main_job || take[m]);
    return take;
}

/* The meshes done ahead of the command's loop, which takes them in mesh
 * order: items[next, count) are done and not yet taken. */
typedef struct ahead_queue {
    scene *s;
    const cli *c;
    const dracoout_options *draco; /* NULL: no Draco budget (`simplify`) */
    const simplify_options *opt;
    uint8_t *take;                 /* meshes_to_simplify */
    mesh_ahead *items;             /* AHEAD_MESHES */
    uint32_t count, next;
} ahead_queue;

static void ahead_item(void *arg, uint32_t i)
{
    const ahead_queue *q = arg;
    mesh_ahead *a = &q->items[i];
    const scene_mesh *mesh = &q->s->meshes[a->mesh];
    /* (the items are reused from run to run: nothing of the last may stay) */
    memset(&a->w, 0, sizeof a->w);
    memset(&a->r, 0, sizeof a->r);
    a->err = (lp_error){0, "", 0};
    a->rc = LP_OK;
    a->bits = q->draco ? q->draco->position_bits : 0;
    double budget = 0;
    /* Draco: each level is simplified to eps - the quantization budget
     * (dracoout.h), and records eps itself afterwards */
    if (q->draco && q->c->config.draco.enabled && mesh->diagonal > 0) {
        a->rc = dracoout_budget(q->s, a->mesh, q->draco, q->c->levels[0] * mesh->diagonal,
                                a->opt.full_edge_levels != 0, &a->bits, &budget, &a->err);
        for (uint32_t k = 0; k < a->opt.level_count; ++k) a->reserved[k] = q->c->levels[k] - budget / mesh->diagonal;
        a->opt.fractions = a->reserved;
    }
    /* it lets the scene's copy of the mesh go; writing the chain reads it again */
    if (!a->rc) a->rc = weld_and_simplify(q->s, a->mesh, &a->opt, &a->w, &a->r, &a->err);
    a->welded = !a->rc;
}

/* Does the meshes to simplify from mesh `from` on into the queue's items: a
 * run of small ones as above, or one large one (none: none is left). */
static void run_ahead(ahead_queue *q, uint32_t from)
{
    const uint32_t threads = lp_threads(q->opt->threads, LP_TEAM_MAX);
    uint32_t count = 0;
    uint64_t triangles = 0;
    for (uint32_t m = from; m < q->s->mesh_count && count < AHEAD_MESHES; ++m) {
        if (!q->take[m]) continue;
        const uint64_t t = q->s->meshes[m].triangle_count;
        /* (count == 1 and triangles > AHEAD_SMALL: the first one is large, and alone) */
        if (count && (threads == 1 || t > AHEAD_SMALL || (count == 1 && triangles > AHEAD_SMALL) ||
                      triangles + t > AHEAD_TRIANGLES))
            break;
        q->items[count].mesh = m;
        q->items[count].opt = *q->opt;
        count++;
        triangles += t;
    }
    for (uint32_t i = 0; count > 1 && i < count; ++i) q->items[i].opt.threads = 1;
    lp_team_for(count > 1 ? threads : 1, count, ahead_item, q);
    q->count = count;
    q->next = 0;
}

/* Sets up the queue of a command (main_job: cmd_lod's meshes, else
 * `simplify`'s); nonzero when out of memory, with nothing to free. */
static int ahead_begin(ahead_queue *q, scene *s, const cli *c, const dracoout_options *draco,
                       const simplify_options *opt, int main_job)
{
    *q = (ahead_queue){s, c, draco, opt, meshes_to_simplify(s, main_job), calloc(AHEAD_MESHES, sizeof *q->items), 0, 0};
    if (q->take && q->items) return 0;
    free(q->take);
    free(q->items);
    q->take = NULL;
    q->items = NULL;
    return -1;
}

/* Mesh m done, the caller's from now on (its weld and result, when welded):
 * the next one in the queue, which is refilled when empty. NULL when m is not
 * the next mesh to simplify (a bug: the loop takes the meshes the queue does,
 * in its order). */
static mesh_ahead *ahead_take(ahead_queue *q, uint32_t m)
{
    if (q->next == q->count) run_ahead(q, m);
    if (q->next == q->count || q->items[q->next].mesh != m) return NULL;
    return &q->items[q->next++];
}

/* Frees the meshes done ahead and not taken (those after a mesh that
 * failed) and the queue. */
static void ahead_end(ahead_queue *q)
{
    for (uint32_t i = q->next; i < q->count; ++i)
        if (q->items[i].welded) {
            weld_free(&q->items[i].w);
            simplify_result_free(&q->items[i].r);
        }
    free(q->items);
    free(q->take);
}

/* Stages `size` bytes for path in the command's output set (output.h). */
static int stage_bytes(output_set *set, const char *path, const char *bytes, size_t size)
{
    lp_error err = {0, "", 0};
    int rc = output_stage(set, path, (const uint8_t *)bytes, size, &err);
    if (rc) report(path, &err);
    return rc;
}

/* The mesh's welded vertices as OBJ "v" lines, formatted once: every level
 * of a half-edge chain repeats them, and printf of 3 floats a line was most of
 * the time spent writing a large mesh's levels. Each coordinate is printed
 * with 17 significant digits: a reader that parses it as a double then gets
 * the float's exact value. %.9g is only enough for a reader that parses
 * floats: 100000.836 is 100000.8359375 read as a double, 6e-5 off, which a
 * measure of the certified bound (1e-7 of the diagonal) must not see.
 * The lines are formatted in chunks of OBJ_CHUNK vertices, on the run's
 * threads (the text does not depend on them): chunk c holds the lines of
 * vertices c * OBJ_CHUNK onwards, in order, and line[v] is where vertex v's
 * line starts in its chunk. */
#define OBJ_CHUNK 16384u

typedef struct obj_vertex_lines {
    const weld_result *w;
    uint32_t chunk_count;
    char **chunk_text;
    size_t *chunk_size;
    size_t *line; /* vertex_count offsets */
} obj_vertex_lines;

/* Closes a stream from open_memstream; nonzero when a write to it failed or
 * its buffer is gone (glibc's close reallocates the buffer to its final size
 * and, when that fails, leaves *buf NULL and returns 0). */
static int memstream_close(FILE *f, char *const *buf)
{
    int bad = ferror(f) != 0;
    bad |= fclose(f) != 0;
    return bad || !*buf;
}

static int format_vertex(FILE *f, const float *p)
{
    return fprintf(f, "v %.17g %.17g %.17g\n", (double)p[0], (double)p[1], (double)p[2]) < 0;
}

/* Formats chunk c (an lp_team_for item); its text stays NULL when that fails. */
static void format_chunk(void *arg, uint32_t c)
{
    obj_vertex_lines *l = arg;
    const uint32_t begin = c * OBJ_CHUNK, n = l->w->vertex_count;
    const uint32_t end = n - begin < OBJ_CHUNK ? n : begin + OBJ_CHUNK;
    FILE *f = open_memstream(&l->chunk_text[c], &l->chunk_size[c]);
    int bad = !f;
    for (uint32_t v = begin; v < end && !bad; ++v) {
        const long at = ftell(f);
        bad = at < 0 || format_vertex(f, l->w->positions + 3 * (size_t)v);
        l->line[v] = (size_t)at;
    }
    if (f && (memstream_close(f, &l->chunk_text[c]) || bad)) {
        free(l->chunk_text[c]);
        l->chunk_text[c] = NULL;
    }
}

static void obj_vertex_lines_free(obj_vertex_lines *l)
{
    for (uint32_t c = 0; l->chunk_text && c < l->chunk_count; ++c) free(l->chunk_text[c]);
    free(l->chunk_text);
    free(l->chunk_size);
    free(l->line);
}

static int obj_vertex_lines_init(obj_vertex_lines *l, const weld_result *w, uint32_t threads)
{
    l->w = w;
    l->chunk_count = w->vertex_count / OBJ_CHUNK + (w->vertex_count % OBJ_CHUNK != 0);
    const size_t chunks = (size_t)l->chunk_count + 1;
    l->chunk_text = calloc(chunks, sizeof *l->chunk_text);
    l->chunk_size = calloc(chunks, sizeof *l->chunk_size);
    l->line = malloc(((size_t)w->vertex_count + 1) * sizeof *l->line);
    int bad = !l->chunk_text || !l->chunk_size || !l->line;
    if (!bad) lp_team_for(threads, l->chunk_count, format_chunk, l);
    for (uint32_t c = 0; c < l->chunk_count && !bad; ++c) bad = !l->chunk_text[c];
    if (bad) {
        obj_vertex_lines_free(l);
        return LP_INVALID;
    }
    return LP_OK;
}

/* Writes vertex v's line; nonzero when the write fails. */
static int write_vertex_line(FILE *f, const obj_vertex_lines *l, uint32_t v)
{
    const uint32_t c = v / OBJ_CHUNK;
    const size_t end = (v + 1) % OBJ_CHUNK && v + 1 < l->w->vertex_count ? l->line[v + 1] : l->chunk_size[c];
    const size_t n = end - l->line[v];
    return fwrite(l->chunk_text[c] + l->line[v], 1, n, f) != n;
}

/* One level as OBJ, staged in set: the mesh's welded vertices (shared by all levels; at
 * `positions` when a level placed vertices, else the weld's) and the level's
 * faces: face_wedges (a level's, its back faces and the weld's dangling
 * triangles included), or face_vertices (level 0: the weld's triangles), then
 * the weld's backs and dangling triangles. A vertex at the weld's position
 * reuses its formatted line. */
static int write_obj(output_set *set, const char *path, const weld_result *w, const obj_vertex_lines *lines, const float *positions,
                     const uint32_t *face_vertices, uint32_t face_count, const uint32_t *face_wedges)
{
    char *buf = NULL;
    size_t size = 0;
    FILE *f = open_memstream(&buf, &size);
    int bad = !f;
    for (uint32_t c = 0; !positions && !bad && c < lines->chunk_count; ++c) /* every vertex where the weld put it */
        bad = fwrite(lines->chunk_text[c], 1, lines->chunk_size[c], f) != lines->chunk_size[c];
    for (uint32_t v = 0; positions && v < w->vertex_count && !bad; ++v) {
        const float *p = positions + 3 * (size_t)v;
        bad = memcmp(p, w->positions + 3 * (size_t)v, 3 * sizeof *p) != 0 ? format_vertex(f, p)
                                                                           : write_vertex_line(f, lines, v);
    }
    const uint32_t total = face_count + (face_vertices ? w->back_count + w->dangling_count : 0);
    for (uint32_t t = 0; t < total && !bad; ++t) {
        uint32_t corner[3];
        const uint32_t back = t - face_count, dangling = back - w->back_count;
        for (int k = 0; k < 3; ++k)
            corner[k] = !face_vertices     ? w->wedge_vertex[face_wedges[3 * (size_t)t + k]]
                        : t < face_count   ? face_vertices[3 * (size_t)t + k]
                        : back < w->back_count ? w->wedge_vertex[w->back_wedges[3 * (size_t)back + k]]
                                               : w->dangling_vertices[3 * (size_t)dangling + k];
        /* "f a b c\n", 1-based, formatted by hand (fprintf was most of the
         * time of writing a large level 0) */
        char line[40], *at = line;
        *at++ = 'f';
        for (int k = 0; k < 3; ++k) {
            char digits[12];
            int nd = 0;
            for (uint64_t x = (uint64_t)corner[k] + 1; x; x /= 10) digits[nd++] = (char)('0' + x % 10);
            *at++ = ' ';
            while (nd) *at++ = digits[--nd];
        }
        *at++ = '\n';
        bad = fwrite(line, 1, (size_t)(at - line), f) != (size_t)(at - line);
    }
    if (!f || memstream_close(f, &buf) || bad) {
        free(buf);
        lp_error e = {0, "", 0};
        lp_no_memory(&e, "out of memory formatting the OBJ");
        return report(path, &e);
    }
    int rc = stage_bytes(set, path, buf, size);
    free(buf);
    return rc;
}

static void json_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; ++s) {
        unsigned char ch = (unsigned char)*s;
        if (ch == '"' || ch == '\\') fprintf(f, "\\%c", ch);
        else if (ch < 0x20) fprintf(f, "\\u%04x", ch);
        else fputc(ch, f);
    }
    fputc('"', f);
}

static void json_stats(FILE *f, const simplify_stats *st)
{
    static const char *const names[SIMPLIFY_REJECT_COUNT] = {"kind", "link", "flip", "intersect", "cover", "face", "conflict"};
    fprintf(f, "\"candidates\":%llu,\"attempts\":%llu,\"commits\":%llu,\"passes\":%u,\"batches\":%u,\"rejected\":{",
            (unsigned long long)st->candidates, (unsigned long long)st->attempts, (unsigned long long)st->commits,
            st->passes, st->batches);
    for (int r = 0; r < SIMPLIFY_REJECT_COUNT; ++r)
        fprintf(f, "%s\"%s\":%llu", r ? "," : "", names[r], (unsigned long long)st->rejected[r]);
    fprintf(f, "},\"clusters\":{\"merges\":%llu,\"splits\":%llu,\"whole\":%u}", (unsigned long long)st->cluster_merges,
            (unsigned long long)st->cluster_splits, st->clusters_whole);
    fprintf(f, ",\"seconds_select\":%.6f,\"seconds_certify\":%.6f,\"seconds_commit\":%.6f", st->seconds_select,
            st->seconds_certify, st->seconds_commit);
    fprintf(f, ",\"removals\":%llu,\"seconds_removal\":%.6f", (unsigned long long)st->removals, st->seconds_removal);
    fprintf(f, ",\"verify_checks\":%llu", (unsigned long long)st->verify_checks);
    fprintf(f, ",\"regions\":{\"rounds\":%u,\"commits\":%llu,\"deferred\":%llu,\"seconds\":%.6f}", st->rounds,
            (unsigned long long)st->region_commits, (unsigned long long)st->deferred, st->seconds_regions);
}

/* The warning for mesh m's dangling zero-area triangles (weld.h), the same
 * from `simplify` and the main job. */
static void warn_dangling(const char *in, uint32_t m, uint32_t count)
{
    lp_say("%s: warning: meshes[%u]: %u zero-area triangles are segments or points that may lie off its surface; "
           "every level keeps them as they are (their vertices are never removed)", in, m, count);
}

/* The warning for mesh m's held vertices (simplify.h), the same from
 * `simplify` and the main job. */
static void warn_held(const char *in, uint32_t m, uint32_t count)
{
    lp_say("%s: warning: meshes[%u]: %u vertices are kept at every level: they have, or neighbour a vertex that has, "
           "more than %u triangles around it (a fan from one point)", in, m, count, SIMPLIFY_HUB_FACES);
}

/* The OBJ that `lodpipe simplify` writes for a mesh's level (0: the welded
 * original). */
static void level_obj_path(char *out, size_t size, const char *dir, uint32_t mesh, uint32_t level)
{
    snprintf(out, size, "%s/mesh%u_level%u.obj", dir, mesh, level);
}

static int cmd_simplify(const cli *c)
{
    const char *in = c->operands[0], *dir = c->operands[1];
    char first_obj[4200];
    level_obj_path(first_obj, sizeof first_obj, dir, 0, 0);
    lp_error err = {0, "", 0};
    if (output_check_folder(first_obj, &err)) return report(first_obj, &err);
    scene s;
    int rc = load(c, in, &s);
    if (rc) return rc;
    /* No glTF is written: the scene model holds every value this command
     * reads, so the document's binary data can go before the first weld. */
    gltf_release_binary(s.doc);
    simplify_options opt = simplify_options_of(c);
    char *json = NULL;
    size_t json_size = 0;
    FILE *j = open_memstream(&json, &json_size);
    /* every OBJ and the JSON appear together at the end, or none does */
    output_set *set = NULL;
    if (!j) lp_no_memory(&err, "out of memory");
    if (!j || output_set_begin(&set, &err)) {
        if (j) fclose(j);
        free(json);
        scene_free(&s);
        return report(dir, &err);
    }
    fprintf(j, "{\"file\":");
    json_string(j, in);
    fprintf(j, ",\"meshes\":[");
    int first = 1;
    char path[4096];
    ahead_queue ahead;
    if (ahead_begin(&ahead, &s, c, NULL, &opt, 0)) {
        lp_error e = {0, "", 0};
        lp_no_memory(&e, "out of memory");
        rc = report(in, &e);
    }
    for (uint32_t m = 0; m < s.mesh_count && !rc; ++m) {
        const scene_mesh *mesh = &s.meshes[m];
        if (!ahead.take[m]) continue;
        mesh_ahead *a = ahead_take(&ahead, m);
        if (!a) {
            lp_error e = {0, "", 0};
            lp_fail(&e, LP_PROMISE, "meshes[%u]: not simplified ahead (a bug)", m);
            rc = report(in, &e);
            break;
        }
        weld_result w = a->w;
        simplify_result r = a->r;
        a->welded = 0; /* w and r are this iteration's now */
        if ((rc = a->rc) != 0) {
            report(in, &a->err);
            break;
        }
        {
            obj_vertex_lines lines;
            rc = obj_vertex_lines_init(&lines, &w, lp_threads((uint32_t)c->config.run.threads, LP_TEAM_MAX));
            if (!rc) {
                level_obj_path(path, sizeof path, dir, m, 0);
                rc = write_obj(set, path, &w, &lines, NULL, w.triangle_vertices, w.triangle_count, NULL);
                for (uint32_t k = 0; k < r.level_count && !rc; ++k) {
                    level_obj_path(path, sizeof path, dir, m, k + 1);
                    rc = write_obj(set, path, &w, &lines, r.levels[k].positions, NULL, r.levels[k].triangle_count,
                                   r.levels[k].wedges);
                }
                obj_vertex_lines_free(&lines);
            } else {
                lp_error e = {0, "", 0};
                lp_no_memory(&e, "out of memory formatting the level OBJs");
                report(dir, &e);
            }
            fprintf(j, "%s{\"mesh\":%u,\"name\":", first ? "" : ",", m);
            json_string(j, mesh->name);
            fprintf(j, ",\"diagonal\":%.17g,\"triangles\":%u,\"weld\":{\"vertices\":%u,\"locked\":%u,\"degenerate_dropped\":%u,"
                       "\"degenerate_dangling\":%u,\"back_faces\":%u},\"seconds_weld\":%.6f,\"seconds_setup\":%.6f,\"held\":%u,\"levels\":[",
                    r.diagonal, weld_level0_triangles(&w), w.vertex_count, w.stats.vertices_by_kind[WELD_LOCKED],
                    w.stats.degenerate_triangles, w.stats.degenerate_dangling, w.back_count, r.seconds_weld,
                    r.seconds_setup, r.held_vertices);
            if (w.dangling_count && !c->quiet) warn_dangling(in, m, w.dangling_count);
            if (r.held_vertices && !c->quiet) warn_held(in, m, r.held_vertices);
            for (uint32_t k = 0; k < r.level_count; ++k) {
                const simplify_level *l = &r.levels[k];
                fprintf(j, "%s{\"level\":%u,\"fraction\":%.17g,\"eps\":%.17g,\"bound\":%.17g,\"triangles\":%u,\"seconds\":%.6f,",
                        k ? "," : "", k + 1, c->levels[k], l->eps, l->bound, l->triangle_count, l->stats.seconds);
                json_stats(j, &l->stats);
                fprintf(j, "}");
            }
            fprintf(j, "]}");
            first = 0;
            if (!c->quiet && isatty(STDERR_FILENO))
                for (uint32_t k = 0; k < r.level_count; ++k)
                    lp_say("%s: mesh %u level %u: %u -> %u triangles, bound %.4g%% of diagonal (%.2f s)",
                            in, m, k + 1, weld_level0_triangles(&w), r.levels[k].triangle_count,
                            r.diagonal > 0 ? 100.0 * r.levels[k].bound / r.diagonal : 0.0, r.levels[k].stats.seconds);
        }
        simplify_result_free(&r);
        weld_free(&w);
    }
    ahead_end(&ahead);
    fprintf(j, "]}\n");
    if (memstream_close(j, &json) && !rc) {
        lp_error e = {0, "", 0};
        lp_no_memory(&e, "out of memory formatting simplify.json");
        rc = report(dir, &e);
    }
    if (!rc) {
        snprintf(path, sizeof path, "%s/simplify.json", dir);
        rc = stage_bytes(set, path, json, json_size);
    }
    if (!rc && (rc = output_commit(set, &err)) != 0) report(dir, &err);
    output_set_end(set);
    free(json);
    scene_free(&s);
    return rc;
}

/* Appends `,"inputs":[paths]`: IN and every file it references. */
static void json_inputs(jsonw *j, const char *in, const gltf_doc *doc)
{
    jsonw_raw(j, ",\"inputs\":[");
    jsonw_string(j, in);
    for (size_t i = 0; i < gltf_external_file_count(doc); ++i) {
        jsonw_raw(j, ",");
        jsonw_string(j, gltf_external_file(doc, i));
    }
    jsonw_raw(j, "]");
}

/* --depfile's text, "OUT: IN referenced-files... [config]" (written with
 * the output, all or nothing), in *text; LP_OK, or the error reported. */
static int depfile_of(const cli *c, const char *in, const char *out, const gltf_doc *doc, char **text)
{
    size_t count = 0, external = gltf_external_file_count(doc);
    const char **deps = malloc((external + 2) * sizeof *deps);
    lp_error err = {0, "", 0};
    if (!deps) {
        lp_no_memory(&err, "out of memory");
        return report(c->depfile, &err);
    }
    deps[count++] = in;
    for (size_t i = 0; i < external; ++i) deps[count++] = gltf_external_file(doc, i);
    if (c->config_path) deps[count++] = c->config_path;
    *text = depfile_text(out, deps, count, &err);
    free(deps);
    return *text ? LP_OK : report(c->depfile, &err);
}

/* A mesh of the main job waiting for its Draco encoding. */
typedef struct draco_job {
    uint32_t mesh;
    dracoout_plan plan;
    lodchain_summary chain; /* the level meshes (morph_errors not kept) */
} draco_job;

/* Encodes every chain once all are written. LODPIPE_DRACO_REFERENCE=FILE (a
 * test hook) first writes the document as it is then: the same chains,
 * uncompressed, so a test can compare the decoded streams with exactly what
 * went into them. */
static int draco_encode_all(scene *s, const draco_job *jobs, uint32_t count, const dracoout_options *o, lp_error *err)
{
    const char *reference = getenv("LODPIPE_DRACO_REFERENCE");
    if (reference && *reference && write_document(NULL, NULL, s->doc, reference, NULL, NULL) != 0)
        return lp_fail(err, LP_IO, "cannot write the Draco reference %s", reference);
    dracoout_stats stats = {0};
    int rc = LP_OK;
    for (uint32_t i = 0; i < count && !rc; ++i)
        rc = dracoout_write_mesh(s, jobs[i].mesh, &jobs[i].chain, o, &jobs[i].plan, &stats, err);
    return rc;
}

/* The warning of a run that simplified meshes but kept no level of any: the
 * output is then the input rewritten, and silence would read as LOD work
 * done. Names the reason most of those meshes share: no extent (`flat` of
 * them, which also have a warning of their own), or no level that removed
 * lod.min_reduction of its triangles (the rest: zero-area triangles off the
 * surface no longer keep a mesh from its levels, weld.h). A tie names the
 * flat ones. */
static void say_no_level_kept(const char *in, uint32_t simplified, uint32_t flat, double min_reduction)
{
    const uint32_t small = simplified - flat;
    const int named_flat = flat >= small;
    const uint32_t top = named_flat ? flat : small;
    char reason[96];
    if (named_flat)
        snprintf(reason, sizeof reason, "no extent (bounding-box diagonal 0)");
    else
        snprintf(reason, sizeof reason, "no level removed %g %% of its triangles, lod.min_reduction",
                 100.0 * min_reduction);
    char share[48];
    if (top == simplified)
        snprintf(share, sizeof share, "%u mesh%s", simplified, simplified == 1 ? "" : "es");
    else
        snprintf(share, sizeof share, "%u of %u meshes", top, simplified);
    lp_say("%s: warning: no mesh kept a LOD level; the output has no new MSFT_lod chain (%s: %s)", in, share,
           reason);
}

/* The main job: every mesh of the default scene through the certified ladder
 * into an MSFT_lod chain, the document written to OUT all at once. */
static int cmd_lod(const cli *c)
{
    const char *in = c->operands[0], *out = c->output;
    int usage = output_usable(c, in, out);
    if (usage) return usage;
    scene s;
    int rc = load(c, in, &s);
    if (rc) return rc;
    if ((rc = depfile_usable(c, s.doc)) != 0) {
        scene_free(&s);
        return rc;
    }
    const int progress = !c->quiet && isatty(STDERR_FILENO);
    simplify_options opt = simplify_options_of(c);
    lodchain_options chain = {{c->config.switching.pixel_error, c->config.switching.viewport_height,
                               c->config.switching.fov_y},
                              c->config.lod.min_reduction, 0, NULL, (uint32_t)c->config.run.threads};
    const int draco = c->config.draco.enabled;
    const dracoout_options draco_opt = draco_options_of(c);
    draco_job *draco_jobs = calloc((size_t)s.mesh_count + 1, sizeof *draco_jobs);
    uint32_t draco_job_count = 0;
    ahead_queue ahead;
    if (!draco_jobs || ahead_begin(&ahead, &s, c, &draco_opt, &opt, 1)) {
        lp_say("%s: out of memory", in);
        free(draco_jobs); /* (a queue that failed has nothing to free) */
        scene_free(&s);
        return LP_INVALID;
    }
    jsonw j = {0};
    jsonw_raw(&j, "{\"input\":");
    jsonw_string(&j, in);
    jsonw_raw(&j, ",\"output\":");
    jsonw_string(&j, out);
    jsonw_raw(&j, ",\"meshes\":[");
    int first = 1;
    lp_error err = {0, "", 0};
    uint32_t scene_meshes = 0, simplified = 0, kept_any = 0, flat = 0;
    for (uint32_t m = 0; m < s.mesh_count; ++m) scene_meshes += s.meshes[m].instance_count && s.meshes[m].triangle_count;
    if (!scene_meshes && !c->quiet)
        lp_say("%s: warning: the default scene uses no mesh with triangles; nothing to simplify", in);
    for (uint32_t m = 0; m < s.mesh_count && !rc; ++m) {
        const scene_mesh *mesh = &s.meshes[m];
        if (!mesh->instance_count || !mesh->triangle_count) continue;
        if (!ahead.take[m]) { /* every node that uses it has MSFT_lod */
            if (!c->quiet)
                lp_say("%s: warning: meshes[%u]: every node that uses it already has MSFT_lod; left as it is%s", in, m,
                       draco ? ", uncompressed (--draco compresses the chains it makes)" : "");
            continue;
        }
        mesh_ahead *a = ahead_take(&ahead, m);
        if (!a) {
            rc = lp_fail(&err, LP_PROMISE, "meshes[%u]: not simplified ahead (a bug)", m);
            break;
        }
        weld_result w = a->w;
        simplify_result r = a->r;
        lodchain_summary sum;
        memset(&sum, 0, sizeof sum);
        dracoout_plan plan;
        const int bits = a->bits;
        const int welded = a->welded;
        a->welded = 0; /* w and r are this iteration's now */
        rc = a->rc;
        if (rc) err = a->err;
        if (!rc) rc = scene_reload_mesh_data(&s, m, &err);
        if (welded && w.dangling_count && !c->quiet) warn_dangling(in, m, w.dangling_count);
        if (welded && r.held_vertices && !c->quiet) warn_held(in, m, r.held_vertices);
        for (uint32_t k = 0; welded && draco && k < r.level_count; ++k) r.levels[k].eps = c->levels[k] * r.diagonal;
        if (!rc && draco) /* the quantization bound goes into the recorded errors */
            rc = dracoout_plan_mesh(&s, m, &w, &r, chain.min_reduction, &draco_opt, bits, &plan, &err);
        chain.added_error = draco ? plan.added_error : NULL;
        chain.keep_vertex_order = draco;
        if (!rc) rc = lodchain_write(&s, m, &w, &r, &chain, &sum, &err);
        if (!rc) {
            simplified++;
            kept_any += sum.level_count > 0;
            flat += !sum.level_count && !(r.diagonal > 0);
        }
        if (!rc && draco) { /* encoded once every chain is written (draco_encode_all) */
            draco_jobs[draco_job_count] = (draco_job){m, plan, sum};
            draco_jobs[draco_job_count++].chain.morph_errors = NULL;
        }
        if (welded) weld_free(&w);
        if (!draco) scene_release_mesh_data(&s, m); /* Draco encodes LOD0 from it at the end */
        if (rc) {
            lodchain_summary_free(&sum);
            simplify_result_free(&r);
            break;
        }
        if (progress)
            for (uint32_t k = 0; k < sum.level_count; ++k)
                lp_say("mesh %u \"%s\" level %u: %llu -> %u triangles, error %.4g%% (%.2f s)", m,
                        mesh->name, k + 1, (unsigned long long)mesh->triangle_count, sum.levels[k].triangles,
                        r.diagonal > 0 ? 100.0 * sum.levels[k].error / r.diagonal : 0.0,
                        r.levels[sum.levels[k].ladder_level - 1].stats.seconds);
        if (!c->quiet) {
            const uint32_t kept = sizeof sum.warnings / sizeof sum.warnings[0];
            for (uint32_t i = 0; i < sum.warning_count && i < kept; ++i) lp_say("%s: warning: %s", in, sum.warnings[i]);
            if (sum.warning_count > kept)
                lp_say("%s: warning: mesh %u: %u more warnings like these", in, m, sum.warning_count - kept);
        }
        jsonw_printf(&j, "%s{\"mesh\":%u,\"name\":", first ? "" : ",", m);
        jsonw_string(&j, mesh->name);
        jsonw_printf(&j, ",\"triangles\":%llu,\"diagonal\":", (unsigned long long)mesh->triangle_count);
        jsonw_number(&j, r.diagonal);
        jsonw_printf(&j, ",\"nodes\":%u,", sum.nodes);
        if (draco) {
            jsonw_printf(&j, "\"draco\":{\"position_bits\":%d,\"raised\":%s,\"lod0_error\":", plan.position_bits,
                         plan.position_bits > plan.configured_bits ? "true" : "false");
            jsonw_number(&j, plan.added_error[0]);
            jsonw_raw(&j, "},");
            if (!c->quiet && plan.position_bits > plan.configured_bits)
                lp_say("%s: warning: meshes[%u] \"%s\": Draco position bits raised from %d to %d so that every "
                                "level's error plus quantization stays within its eps",
                        in, m, mesh->name, plan.configured_bits, plan.position_bits);
        }
        jsonw_raw(&j, "\"levels\":[");
        for (uint32_t k = 0; k < sum.level_count; ++k) {
            const lodchain_level *l = &sum.levels[k];
            jsonw_printf(&j, "%s{\"level\":%u,\"mesh\":%lld,\"triangles\":%u,\"eps\":", k ? "," : "", k + 1,
                         (long long)l->mesh, l->triangles);
            jsonw_number(&j, l->eps);
            jsonw_raw(&j, ",\"error\":");
            jsonw_number(&j, l->error);
            jsonw_raw(&j, ",\"error_fraction\":");
            jsonw_number(&j, r.diagonal > 0 ? l->error / r.diagonal : 0.0);
            jsonw_raw(&j, ",\"seconds\":");
            jsonw_number(&j, r.levels[l->ladder_level - 1].stats.seconds);
            jsonw_raw(&j, "}");
        }
        jsonw_raw(&j, "]}");
        first = 0;
        lodchain_summary_free(&sum);
        simplify_result_free(&r);
    }
    jsonw_raw(&j, "]");
    ahead_end(&ahead);
    if (!rc && draco) rc = draco_encode_all(&s, draco_jobs, draco_job_count, &draco_opt, &err);
    free(draco_jobs);
    /* an edit of the document that ran out of memory may show up as another
     * failure ("cannot set ..."); say what it was */
    if (rc && gltf_out_of_memory(s.doc)) lp_no_memory(&err, "out of memory");
    if (!rc && c->json && j.failed) rc = lp_no_memory(&err, "out of memory for the --json report");
    if (rc) {
        report(in, &err);
        jsonw_free(&j);
        scene_free(&s);
        return rc;
    }
    json_inputs(&j, in, s.doc);
    char *depfile = NULL;
    if (c->depfile) rc = depfile_of(c, in, out, s.doc, &depfile);
    if (!rc) rc = write_document(c, in, s.doc, out, depfile, c->json ? &j : NULL);
    free(depfile);
    if (!rc && simplified && !kept_any && !c->quiet) say_no_level_kept(in, simplified, flat, chain.min_reduction);
    if (!rc && c->json) fputs(j.text, stdout); /* complete: write_document checked it before writing */
    jsonw_free(&j);
    scene_free(&s);
    return rc;
}

/* One entry of a node's extras.lodpipe.levels: the LOD node it describes and
 * its recorded error. */
typedef struct chain_record {
    double node, error;
} chain_record;

typedef enum chain_records_state { RECORDS_NONE, RECORDS_READ, RECORDS_MALFORMED, RECORDS_OUT_OF_MEMORY } chain_records_state;

/* Reads node n's extras.lodpipe.levels into records (malloc'd). RECORDS_NONE:
 * no extras.lodpipe (or extras not an object), nothing recorded;
 * RECORDS_MALFORMED, with the reason in `why`: extras.lodpipe is there but is
 * not an object whose `levels` is an array of objects, each with a
 * non-negative integer `node` (no node twice) and a finite non-negative
 * `error`. A gate must not pass a certificate it cannot read.
 * RECORDS_OUT_OF_MEMORY: they could not be read for want of memory. */
static chain_records_state read_chain_records(const gltf_doc *doc, uint32_t n, chain_record **records, uint32_t *count,
                                              char *why, size_t why_size)
{
    *records = NULL;
    *count = 0;
    char pointer[64];
    snprintf(pointer, sizeof pointer, "/nodes/%u/extras/lodpipe", n);
    char *text = gltf_get_json(doc, pointer);
    if (!text) return gltf_out_of_memory(doc) ? RECORDS_OUT_OF_MEMORY : RECORDS_NONE;
    jsonr r;
    chain_records_state state = RECORDS_MALFORMED;
    snprintf(why, why_size, "extras.lodpipe.levels is not an array");
    const int parsed = jsonr_parse(&r, text, strlen(text));
    if (parsed != 0) {
        snprintf(why, why_size, "extras.lodpipe cannot be read");
        free(text);
        return parsed == -2 ? RECORDS_OUT_OF_MEMORY : RECORDS_MALFORMED;
    }
    const uint32_t levels = r.tokens[0].type == JSONR_OBJECT ? jsonr_member(&r, 0, "levels") : JSONR_NONE;
    if (levels != JSONR_NONE && r.tokens[levels].type == JSONR_ARRAY) {
        const uint32_t size = jsonr_size(&r, levels);
        chain_record *out = calloc(size ? size : 1, sizeof *out);
        uint32_t k = 0;
        for (; out && k < size; ++k) {
            const uint32_t entry = jsonr_element(&r, levels, k);
            const uint32_t node = jsonr_member(&r, entry, "node"), error = jsonr_member(&r, entry, "error");
            out[k].node = jsonr_number(&r, node, -1);
            out[k].error = jsonr_number(&r, error, -1);
            if (!(out[k].node >= 0 && out[k].node <= 4294967295.0 && out[k].node == floor(out[k].node))) {
                snprintf(why, why_size, "extras.lodpipe.levels[%u].node is not a node index", k);
                break;
            }
            if (!(out[k].error >= 0 && isfinite(out[k].error))) {
                snprintf(why, why_size, "extras.lodpipe.levels[%u].error is not a finite non-negative number", k);
                break;
            }
            uint32_t same = 0;
            while (same < k && out[same].node != out[k].node) same++;
            if (same < k) {
                snprintf(why, why_size, "extras.lodpipe.levels[%u] and [%u] describe the same node", same, k);
                break;
            }
        }
        if (!out) state = RECORDS_OUT_OF_MEMORY;
        if (out && k == size) {
            state = RECORDS_READ;
            *records = out;
            *count = size;
        } else {
            free(out);
        }
    }
    jsonr_free(&r);
    free(text);
    return state;
}

/* The recorded error of LOD node `node`, looked up by node (not by position:
 * a chain edited by hand may list its levels in another order), or -1. */
static double recorded_error(const chain_record *records, uint32_t count, int64_t node)
{
    for (uint32_t k = 0; k < count; ++k)
        if (records[k].node == (double)node) return records[k].error;
    return -1;
}

/* Was any primitive of mesh m Draco-compressed in the file (decoded on
 * load)? LOD0's recorded error is its quantization then; a plain LOD0 should
 * record 0. */
static int mesh_has_draco(const scene *s, uint32_t m)
{
    for (size_t p = 0; p < gltf_primitive_count(s->doc, m); ++p) {
        gltf_primitive g;
        if (gltf_get_primitive(s->doc, m, p, &g) == 0 && g.was_draco) return 1;
    }
    return 0;
}

/* The longest chain `check` measures (lodpipe writes at most 16 levels). */
#define CHECK_MAX_LEVELS 64

/* lodpipe check FILE: measures every LOD against its LOD0 by dense sampling
 * and compares with the recorded error; exit 3 when a measured distance
 * exceeds its record. */
static int cmd_check(const cli *c)
{
    const char *in = c->operands[0];
    scene s;
    int rc = load(c, in, &s);
    if (rc) return rc;
    int failed = 0, chains = 0;
    lp_error err = {0, "", 0};
    printf("%-6s %-6s %-6s %-10s %-14s %-14s %-14s %s\n", "node", "level", "mesh", "triangles", "recorded", "allowed",
           "measured", "ok");
    for (uint32_t n = 0; n < s.node_count && !rc; ++n) {
        const scene_node *node = &s.nodes[n];
        if (!node->lod_count) continue;
        chains++;
        if (node->mesh < 0) { /* a chain without its finest level */
            printf("%-6u %-6u %-6s %-10s %-14s %-14s %-14s %s\n", n, 0, "-", "-", "-", "-", "-",
                   "NO: the node has MSFT_lod but no mesh");
            failed = 1;
            continue;
        }
        const scene_mesh *base = &s.meshes[node->mesh];
        float *bp = NULL, *lp = NULL;
        uint32_t *bt = NULL, *lt = NULL;
        measure_mesh a, b;
        bvh a_tree;
        memset(&a_tree, 0, sizeof a_tree);
        if (lodchain_mesh_triangles(&s, (uint32_t)node->mesh, NULL, NULL, -1, &bp, &bt, &a, &err) ||
            bvh_build(&a_tree, a.positions, a.vertex_count, a.triangles, a.triangle_count) != BVH_OK)
            rc = LP_INVALID;
        const double spacing = base->diagonal / 400.0;
        chain_record *records = NULL;
        uint32_t record_count = 0;
        char malformed[160];
        const chain_records_state state =
            read_chain_records(s.doc, n, &records, &record_count, malformed, sizeof malformed);
        if (state == RECORDS_OUT_OF_MEMORY) rc = LP_INVALID;
        /* LOD0's own recorded error (Draco: its quantization, else 0): the
         * errors are against the original surface, so a level and the file's
         * LOD0 are within the sum of both (triangle inequality). The original
         * is not in the file, so this one cannot be measured: shown in the
         * `allowed` column, and a warning when a plain LOD0 claims one. */
        double lod0_error = recorded_error(records, record_count, n);
        if (lod0_error < 0) lod0_error = 0;
        if (lod0_error > 0 && !c->quiet && !mesh_has_draco(&s, (uint32_t)node->mesh))
            lp_say("%s: warning: nodes[%u]: LOD0 records an error of %.8g but is not Draco-compressed; it is added to "
                   "every level's allowance",
                   in, n, lod0_error);
        /* MSFT_lod lists levels from finest to coarsest, each shown in the
         * node's place: fewer triangles and no smaller recorded error than
         * the level before, and the node's own transform */
        uint32_t previous_triangles = a.triangle_count;
        double previous_error = lod0_error, local[16], lod_local[16];
        scene_local_transform(&s, n, local);
        for (uint32_t k = 0; k < node->lod_count && !rc; ++k) {
            /* each measurement samples the whole level: a hostile chain that
             * lists one node 100k times must not cost 100k of them */
            char skipped[96];
            uint32_t same = 0;
            while (same < k && node->lod_ids[same] != node->lod_ids[k]) same++;
            if (k == CHECK_MAX_LEVELS)
                snprintf(skipped, sizeof skipped, "NO: %u levels beyond the %d this check measures", node->lod_count - k,
                         CHECK_MAX_LEVELS);
            else if (same < k)
                snprintf(skipped, sizeof skipped, "NO: the same LOD node as level %u", same + 1);
            if (k == CHECK_MAX_LEVELS || same < k) {
                printf("%-6u %-6u %-6s %-10s %-14s %-14s %-14s %s\n", n, k + 1, "-", "-", "-", "-", "-", skipped);
                failed = 1;
                if (k == CHECK_MAX_LEVELS) break;
                continue;
            }
            const scene_node *lod = &s.nodes[node->lod_ids[k]];
            const double recorded = recorded_error(records, record_count, node->lod_ids[k]);
            const int have = recorded >= 0;
            if (lod->mesh < 0) {
                printf("%-6u %-6u %-6s %-10s %-14s %-14s %-14s %s\n", n, k + 1, "-", "-", "-", "-", "-",
                       "NO: the level has no mesh");
                failed = 1;
                continue;
            }
            free(lp);
            free(lt);
            lp = NULL;
            lt = NULL;
            if (lodchain_mesh_triangles(&s, (uint32_t)lod->mesh, NULL, NULL, -1, &lp, &lt, &b, &err)) {
                rc = LP_INVALID;
                break;
            }
            double measured = measure_two_sided_with(&a, &a_tree, &b, spacing);
            if (measured == MEASURE_NO_MEMORY) {
                rc = LP_INVALID;
                break;
            }
            const double allowed = recorded + lod0_error;
            int ok = have && measured >= 0 && measured <= allowed * (1 + 1e-9) + 1e-12 * base->diagonal;
            scene_local_transform(&s, (uint32_t)node->lod_ids[k], lod_local);
            const char *order = b.triangle_count >= previous_triangles ? "NO: not fewer triangles than the level before"
                                : have && recorded < previous_error   ? "NO: a smaller recorded error than the level before"
                                : memcmp(local, lod_local, sizeof local) != 0 ? "NO: the LOD node's transform is not its node's"
                                                                              : NULL;
            const int unreadable = state == RECORDS_MALFORMED;
            if ((have && !ok) || order || unreadable) failed = 1;
            previous_triangles = b.triangle_count;
            if (have) previous_error = recorded;
            char rec[32] = "-", allow[32] = "-", got[32] = "-", why[192];
            if (have) snprintf(rec, sizeof rec, "%.8g", recorded);
            if (have) snprintf(allow, sizeof allow, "%.8g", allowed);
            if (measured >= 0) snprintf(got, sizeof got, "%.8g", measured);
            snprintf(why, sizeof why, "NO: %s", malformed);
            /* no triangles on one side: nothing within any distance of the other */
            const char *verdict = unreadable ? why
                                  : have && !ok && measured < 0
                                      ? (a.triangle_count ? "NO: the level has no triangles" : "NO: LOD0 has no triangles")
                                  : have && !ok ? "NO: exceeds the allowed error"
                                  : order       ? order
                                  : !have       ? "not recorded"
                                                : "yes";
            printf("%-6u %-6u %-6lld %-10u %-14s %-14s %-14s %s\n", n, k + 1, (long long)lod->mesh, b.triangle_count,
                   rec, allow, got, verdict);
        }
        free(records);
        bvh_free(&a_tree);
        free(bp);
        free(bt);
        free(lp);
        free(lt);
    }
    if (rc) lp_say("%s: out of memory", in);
    else if (!chains) printf("no LOD chains\n");
    scene_free(&s);
    if (rc) return rc;
    if (failed) {
        lp_say("%s: a level fails its check (a row marked NO)", in);
        return LP_PROMISE;
    }
    return LP_OK;
}

/* A whole number at the start of text, decimal digits only (no sign, no
 * space), at most max; *end after its digits. 0, or -1 when there are no
 * digits or the number is above max, however many digits it has: sscanf's
 * %u wrapped a value >= 2^32 (4294967297 read as 1) and skipped leading
 * white space. */
static int parse_digits(const char *text, const char **end, unsigned max, unsigned *out)
{
    const char *p = text;
    unsigned long long v = 0;
    if (*p < '0' || *p > '9') return -1;
    for (; *p >= '0' && *p <= '9'; ++p)
        if (v <= max) v = v * 10 + (unsigned)(*p - '0'); /* stays above max once it is */
    *end = p;
    if (v > max) return -1;
    *out = (unsigned)v;
    return 0;
}

/* -j N (0..256) and --shard K/N (1 <= K <= N <= 65536). */
static int parse_batch_value(cli *c, const char *flag, const char *value)
{
    char msg[300];
    unsigned k = 0, n = 0;
    const char *end = value;
    if (strcmp(flag, "-j") == 0) {
        if (parse_digits(value, &end, 256, &k) == 0 && *end == 0) {
            c->jobs = (int)k;
            c->jobs_given = 1;
            return LP_OK;
        }
        snprintf(msg, sizeof msg, "-j %.100s: must be a whole number in 0..256 (0: one per core)", value);
        return usage_error(msg);
    }
    if (parse_digits(value, &end, 65536, &k) == 0 && *end == '/' && parse_digits(end + 1, &end, 65536, &n) == 0 &&
        *end == 0 && k >= 1 && k <= n) {
        c->shard_index = k;
        c->shard_count = n;
        return LP_OK;
    }
    snprintf(msg, sizeof msg, "--shard %.100s: must be K/N with 1 <= K <= N <= 65536", value);
    return usage_error(msg);
}

/* The batch command: the options it shares with the main job reach every
 * file through the effective configuration (batch.h). */
static int cmd_batch(const cli *c)
{
    batch_options opt;
    memset(&opt, 0, sizeof opt);
    opt.source_dir = c->operands[0];
    opt.output_dir = c->output;
    opt.jobs = c->jobs;
    opt.shard_index = c->shard_index;
    opt.shard_count = c->shard_count;
    opt.force = c->force;
    opt.json = c->json;
    opt.quiet = c->quiet;
    opt.allow_external_uris = c->allow_external_uris;
    opt.config = &c->config;
    return batch_run(&opt);
}

/* A path option given once: a second -o, --config or --depfile is more
 * likely a mistake than an override (which of two outputs was meant?). */
static int set_once(const char **slot, const char *flag, const char *value)
{
    if (*slot) {
        char msg[300];
        snprintf(msg, sizeof msg, "%s given twice (%.100s, %.100s)", flag, *slot, value);
        return usage_error(msg);
    }
    *slot = value;
    return LP_OK;
}

/* Does option `a` take the next argument as its value? */
static int flag_takes_value(const char *a)
{
    return config_flag(a) == 1 || strcmp(a, "-o") == 0 || strcmp(a, "--config") == 0 || strcmp(a, "--depfile") == 0 ||
           strcmp(a, "-j") == 0 || strcmp(a, "--shard") == 0;
}

/* The first option on the command line that is not in `allowed` (NULL-ended),
 * or NULL: a command refuses what it would silently ignore (`check --json`
 * printing a table, `simplify --draco` compressing nothing). */
static const char *inapplicable_flag(int argc, char **argv, const char *const *allowed)
{
    for (int i = 1; i < argc; ++i) {
        const char *a = argv[i];
        if (a[0] != '-' || !a[1]) continue;
        size_t k = 0;
        while (allowed[k] && strcmp(allowed[k], a) != 0) k++;
        if (!allowed[k]) return a;
        if (flag_takes_value(a)) i++;
    }
    return NULL;
}

/* Reads the command line: the command, its operands, the tool's own flags,
 * and the configuration (defaults, then --config FILE, then config flags in
 * the order given). */
static int parse(int argc, char **argv, cli *c)
{
    memset(c, 0, sizeof *c);
    const char **config_args = calloc((size_t)argc + 1, sizeof *config_args);
    if (!config_args) {
        lp_say("the command line: out of memory");
        return LP_INVALID;
    }
    size_t config_argc = 0;
    int rc = LP_OK;
    for (int i = 1; i < argc && !rc; ++i) {
        const char *a = argv[i];
        int kind = config_flag(a);
        if (flag_takes_value(a) && i + 1 >= argc) {
            char msg[300];
            snprintf(msg, sizeof msg, "%s needs a value", a);
            rc = usage_error(msg);
            break;
        }
        if (kind) {
            config_args[config_argc++] = a;
            config_args[config_argc++] = kind == 1 ? argv[++i] : "true";
        } else if (strcmp(a, "-o") == 0) {
            rc = set_once(&c->output, a, argv[++i]);
        } else if (strcmp(a, "--config") == 0) {
            rc = set_once(&c->config_path, a, argv[++i]);
        } else if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            free(config_args);
            exit(LP_OK);
        } else if (strcmp(a, "--version") == 0) {
            printf("lodpipe %s (source %s)\n", LODPIPE_VERSION, LODPIPE_SOURCE_ID);
            free(config_args);
            exit(LP_OK);
        } else if (strcmp(a, "--force") == 0) {
            c->force = 1;
        } else if (strcmp(a, "--quiet") == 0 || strcmp(a, "-q") == 0) {
            c->quiet = 1;
        } else if (strcmp(a, "--json") == 0) {
            c->json = 1;
        } else if (strcmp(a, "--allow-external-uris") == 0) {
            c->allow_external_uris = 1;
        } else if (strcmp(a, "--depfile") == 0) {
            rc = set_once(&c->depfile, a, argv[++i]);
        } else if (strcmp(a, "-j") == 0 || strcmp(a, "--shard") == 0) {
            rc = parse_batch_value(c, a, argv[++i]);
        } else if (a[0] == '-' && a[1]) {
            char msg[300];
            snprintf(msg, sizeof msg, "unknown option %.200s", a);
            rc = usage_error(msg);
        } else if (!c->command) {
            c->command = a;
        } else if (c->operand_count < 2) {
            c->operands[c->operand_count++] = a;
        } else {
            rc = usage_error("too many arguments");
        }
    }
    lp_error err = {0, "", 0};
    config_defaults(&c->config);
    if (!rc && c->config_path && (rc = config_load(&c->config, c->config_path, &err)) != 0)
        lp_say("%s", err.msg);
    for (size_t k = 0; !rc && k < config_argc; k += 2)
        if ((rc = config_set(&c->config, config_args[k], config_args[k + 1], &err)) != 0)
            lp_say("%s", err.msg);
    /* a rule between keys holds for the settings in effect; the error names
     * the config file when the file breaks it on its own (the flags did not
     * mend it), else the command line (the message names key and flag) */
    if (!rc && (rc = config_check(&c->config, &err)) != 0) {
        const config_rule rule = config_broken_rule(&c->config, NULL);
        lp_config file_only;
        lp_error ignored = {0, "", 0};
        config_defaults(&file_only);
        const int file_alone = c->config_path && config_load(&file_only, c->config_path, &ignored) == 0 &&
                               config_breaks(&file_only, rule);
        /* the file's line that sets the last of the rule's keys, as for a bad key */
        const uint32_t line = file_alone ? config_rule_line(c->config_path, rule) : 0;
        if (line) lp_say("%s:%u: %s", c->config_path, (unsigned)line, err.msg);
        else if (file_alone || !c->config_path) lp_say("%s: %s", file_alone ? c->config_path : "the command line", err.msg);
        else lp_say("the command line (with %s): %s", c->config_path, err.msg);
    }
    free(config_args);
    if (rc) return rc;
    for (size_t k = 0; k < c->config.lod.level_count && k < SIMPLIFY_MAX_LEVELS; ++k)
        c->levels[k] = c->config.lod.levels[k] / 100.0;
    return LP_OK;
}

int main(int argc, char **argv)
{
    /* A file-size limit (ulimit -f) must become a write error we report, not a kill. */
    signal(SIGXFSZ, SIG_IGN);
    /* Large blocks always straight from mmap, so that freeing one gives its
     * pages back. By default glibc raises this threshold (up to 32 MB) each
     * time such a block is freed, and then serves the next large arrays from
     * the heap, where the pages of a freed scratch array (the BVH build's, a
     * grid's old pool) stay resident: on the 1.1M-triangle benchmark mesh
     * that added ~5 % to the peak RSS. Setting it turns the adjustment off. */
    mallopt(M_MMAP_THRESHOLD, 128 * 1024);
    cli c;
    int rc = parse(argc, argv, &c);
    if (rc) return rc;
    if (!c.command) return usage_error("no command given");
    const int batch = strcmp(c.command, "batch") == 0;
    if (!batch && (c.jobs_given || c.shard_count)) return usage_error("-j and --shard belong to the batch command");
    if (c.depfile && (batch || !c.output)) return usage_error("--depfile belongs to the main job: lodpipe IN -o OUT --depfile FILE");
    if (batch) {
        if (c.operand_count != 1 || !c.output) return usage_error("batch needs SRC_DIR and -o OUT_DIR");
        return cmd_batch(&c);
    }
    /* the commands that take operands only (-o is the main job's and batch's:
     * refused with the other options a command does not use) */
#define LOADING_FLAGS "--quiet", "-q", "--allow-external-uris"
    static const char *const kReadOnly[] = {LOADING_FLAGS, NULL};
    static const char *const kConvert[] = {LOADING_FLAGS, "--force", "--draco", "--config", NULL};
    static const char *const kSimplify[] = {LOADING_FLAGS, "--config", "--levels", "--placement", "--optimal-levels",
                                            "--threads", NULL};
#undef LOADING_FLAGS
    static const struct {
        const char *name;
        int operands;
        const char *usage;
        int (*run)(const cli *);
        const char *const *flags; /* the options it uses */
    } kCommands[] = {
        {"inspect", 1, "inspect needs exactly one FILE", cmd_inspect, kReadOnly},
        {"convert", 2, "convert needs IN and OUT", cmd_convert, kConvert},
        {"check", 1, "check needs exactly one FILE", cmd_check, kReadOnly},
        {"simplify", 2, "simplify needs IN and OUTDIR", cmd_simplify, kSimplify},
    };
    for (size_t k = 0; k < sizeof kCommands / sizeof kCommands[0]; ++k) {
        if (strcmp(c.command, kCommands[k].name) != 0) continue;
        const char *unused = inapplicable_flag(argc, argv, kCommands[k].flags);
        if (unused) {
            char msg[300];
            snprintf(msg, sizeof msg, "%.100s does not apply to %s", unused, kCommands[k].name);
            return usage_error(msg);
        }
        if (c.operand_count != kCommands[k].operands) return usage_error(kCommands[k].usage);
        return kCommands[k].run(&c);
    }
    if (c.output) { /* the main job: lodpipe IN -o OUT */
        if (c.operand_count != 0) return usage_error("the main job takes one input: lodpipe IN -o OUT");
        c.operands[0] = c.command;
        return cmd_lod(&c);
    }
    char msg[300];
    /* `lodpipe scene.glb` is the main job without its -o, not an unknown command */
    if (output_name_ok(c.command) || access(c.command, F_OK) == 0)
        snprintf(msg, sizeof msg, "no output given: lodpipe %.200s -o OUT", c.command);
    else
        snprintf(msg, sizeof msg, "unknown command %.200s", c.command);
    return usage_error(msg);
}
