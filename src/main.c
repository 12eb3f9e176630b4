/* main.c - the lodpipe command line.
 *
 * Parses arguments, runs one command, prints errors as one line
 * "lodpipe: FILE: what is wrong" and exits with the documented code
 * (status.h). Commands live in their own small functions. */
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "output.h"
#include "scene.h"
#include "status.h"
#include "version.h"

static const char *const kModeNames[7] = {"POINTS", "LINES", "LINE_LOOP", "LINE_STRIP",
                                          "TRIANGLES", "TRIANGLE_STRIP", "TRIANGLE_FAN"};

typedef struct cli {
    const char *command;
    const char *operands[2];
    int operand_count;
    int force;
    int quiet;
    int allow_external_uris;
} cli;

static void usage(FILE *f)
{
    fputs("usage: lodpipe COMMAND [options] ARGS\n"
          "\n"
          "commands:\n"
          "  inspect FILE        per mesh: primitives, triangles, attributes, instancing\n"
          "                      nodes, bounding-box diagonal; LOD chains already present\n"
          "  convert IN OUT      load IN and write it to OUT unchanged (.glb or .gltf by\n"
          "                      OUT's extension); compressed geometry comes out decoded\n"
          "\n"
          "options:\n"
          "  --force                overwrite the input file if OUT names it\n"
          "  --allow-external-uris  accept uris that leave the input's folder\n"
          "  --quiet                no warnings on stderr\n"
          "  --help                 this text\n"
          "  --version              the version\n"
          "\n"
          "exit codes: 0 success, 1 usage error, 2 invalid input, 3 a promise could not\n"
          "be kept, 4 I/O error. Errors are one line: \"lodpipe: FILE: what is wrong\".\n",
          f);
}

static int usage_error(const char *msg)
{
    fprintf(stderr, "lodpipe: %s (see lodpipe --help)\n", msg);
    return LP_USAGE;
}

static int report(const char *file, const lp_error *err)
{
    fprintf(stderr, "lodpipe: %s: %s\n", file, err->msg);
    return err->code;
}

static void print_warnings(const cli *c, const char *file, const scene *s)
{
    if (c->quiet) return;
    uint32_t shown = s->warning_count < 8 ? s->warning_count : 8;
    for (uint32_t i = 0; i < shown; ++i) fprintf(stderr, "lodpipe: %s: warning: %s\n", file, s->warnings[i]);
    if (s->warning_count > shown)
        fprintf(stderr, "lodpipe: %s: warning: %u more warnings\n", file, s->warning_count - shown);
}

static int load(const cli *c, const char *path, scene *s)
{
    scene_options opt;
    memset(&opt, 0, sizeof opt);
    opt.load.allow_external_uris = c->allow_external_uris;
    lp_error err = {0, ""};
    int rc = scene_load(path, &opt, s, &err);
    if (rc) return report(path, &err);
    print_warnings(c, path, s);
    return LP_OK;
}

static int cmd_inspect(const cli *c)
{
    const char *path = c->operands[0];
    scene s;
    int rc = load(c, path, &s);
    if (rc) return rc;
    printf("file: %s\n", path);
    printf("scenes: %zu (default %lld), nodes: %u, meshes: %u, materials: %zu\n", gltf_count(s.doc, GLTF_SCENES),
           (long long)s.default_scene, s.node_count, s.mesh_count, gltf_count(s.doc, GLTF_MATERIALS));
    for (uint32_t m = 0; m < s.mesh_count; ++m) {
        const scene_mesh *mesh = &s.meshes[m];
        printf("mesh %u \"%s\": %u primitives, %llu triangles, bbox diagonal %.9g\n", m, mesh->name,
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
        printf("  instanced by %u node%s:", mesh->instance_count, mesh->instance_count == 1 ? "" : "s");
        for (uint32_t i = 0; i < mesh->instance_count; ++i) {
            const scene_node *n = &s.nodes[mesh->instances[i]];
            printf(" %u \"%s\" (scale %.6g)", mesh->instances[i], n->name, scene_max_scale(n->world));
        }
        printf("\n");
    }
    uint32_t chains = 0;
    for (uint32_t i = 0; i < s.node_count; ++i) {
        const scene_node *n = &s.nodes[i];
        if (!n->lod_count) continue;
        printf("LOD chain on node %u \"%s\": mesh %lld", i, n->name, (long long)n->mesh);
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

static int cmd_convert(const cli *c)
{
    const char *in = c->operands[0], *out = c->operands[1];
    if (!output_name_ok(out)) {
        fprintf(stderr, "lodpipe: %s: the output name must end in .glb or .gltf\n", out);
        return LP_USAGE;
    }
    if (!c->force && output_same_file(in, out)) {
        fprintf(stderr, "lodpipe: %s: refusing to overwrite the input (use --force)\n", out);
        return LP_USAGE;
    }
    scene s;
    int rc = load(c, in, &s);
    if (rc) return rc;
    gltf_out_file *files = NULL;
    size_t count = 0;
    char msg[512];
    lp_error err = {0, ""};
    rc = gltf_serialize(s.doc, out, &files, &count, msg, sizeof msg);
    if (rc) {
        lp_fail(&err, rc, "%s", msg);
        rc = report(out, &err);
    } else if ((rc = output_write_all(out, files, count, &err)) != 0) {
        rc = report(out, &err);
    }
    gltf_free_files(files, count);
    free(files);
    scene_free(&s);
    return rc;
}

static int parse(int argc, char **argv, cli *c)
{
    memset(c, 0, sizeof *c);
    for (int i = 1; i < argc; ++i) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            exit(LP_OK);
        } else if (strcmp(a, "--version") == 0) {
            printf("lodpipe %s\n", LODPIPE_VERSION);
            exit(LP_OK);
        } else if (strcmp(a, "--force") == 0) {
            c->force = 1;
        } else if (strcmp(a, "--quiet") == 0 || strcmp(a, "-q") == 0) {
            c->quiet = 1;
        } else if (strcmp(a, "--allow-external-uris") == 0) {
            c->allow_external_uris = 1;
        } else if (a[0] == '-' && a[1]) {
            char msg[300];
            snprintf(msg, sizeof msg, "unknown option %.200s", a);
            return usage_error(msg);
        } else if (!c->command) {
            c->command = a;
        } else if (c->operand_count < 2) {
            c->operands[c->operand_count++] = a;
        } else {
            return usage_error("too many arguments");
        }
    }
    return LP_OK;
}

int main(int argc, char **argv)
{
    /* A file-size limit (ulimit -f) must become a write error we report, not a kill. */
    signal(SIGXFSZ, SIG_IGN);
    cli c;
    int rc = parse(argc, argv, &c);
    if (rc) return rc;
    if (!c.command) return usage_error("no command given");
    if (strcmp(c.command, "inspect") == 0) {
        if (c.operand_count != 1) return usage_error("inspect needs exactly one FILE");
        return cmd_inspect(&c);
    }
    if (strcmp(c.command, "convert") == 0) {
        if (c.operand_count != 2) return usage_error("convert needs IN and OUT");
        return cmd_convert(&c);
    }
    char msg[300];
    snprintf(msg, sizeof msg, "unknown command %.200s", c.command);
    return usage_error(msg);
}
