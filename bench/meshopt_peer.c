/* meshopt_peer.c - the meshoptimizer side of `make bench` (bench/run.py).
 *
 * Loads a glTF file with the project's own loader (scene.h) and welds mesh K
 * by position (weld.h), so meshoptimizer starts from exactly the indexed
 * triangle mesh lodpipe starts from: positions = weld_result.positions,
 * indices = weld_result.triangle_vertices. Only positions are given to
 * meshopt_simplify (no attributes), like lodpipe's position certificate.
 *
 *   meshopt_peer info FILE MESH
 *       JSON: triangles, vertices, diagonal, meshopt scale.
 *   meshopt_peer simplify FILE MESH T1[,T2,...] OUT.obj [--error E]
 *       A chain: level 1 = meshopt_simplify(original, target T1 triangles),
 *       level 2 = meshopt_simplify(level 1, T2), ...; writes the LAST level
 *       as OBJ (only the vertices it uses, "v %.17g" of each float: exact for a
 *       reader that parses doubles, "f" 1-based) and prints
 *       JSON with each level's triangle count and meshopt's result_error.
 *       target_error is 1.0 (the count decides) unless --error E gives E as a
 *       fraction of the bbox DIAGONAL (converted to meshopt's extent-relative
 *       units, see below).
 *   meshopt_peer chain FILE MESH [--errors e1,e2,..] [--targets t1,t2,..]
 *                      [--reps N] [--out DIR]
 *       Times the whole chain (each level from the previous, as lodpipe does)
 *       N times (default 3) with CLOCK_MONOTONIC and prints the median and
 *       every run. --errors: fractions of the bbox diagonal (default
 *       0.01,0.03,0.07,0.15), target count 0, so meshoptimizer stops at its
 *       own error estimate; --targets: triangle counts with target_error 1.0
 *       (the count decides). Both may be given (both chains are timed, in
 *       alternation). --out DIR writes DIR/errors_level<L>.obj and
 *       DIR/targets_level<L>.obj (once, outside the timing).
 *       Also reports load and weld time and the peak RSS (getrusage).
 *
 * meshoptimizer 0.18's target_error is "relative to mesh extents": its
 * meshopt_simplifyScale is the largest bbox extent, not the diagonal. An eps
 * that is a fraction f of the diagonal D is passed as f * D / scale.
 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#include <meshoptimizer.h>

#include "scene.h"
#include "weld.h"

#define MAX_LEVELS 32
#define MAX_REPS 99

typedef struct peer_mesh {
    scene s;
    weld_result w;
    double diagonal;
    float scale; /* meshopt_simplifyScale */
    double load_seconds, weld_seconds;
} peer_mesh;

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void die(const char *fmt, const char *arg)
{
    fprintf(stderr, "meshopt_peer: ");
    fprintf(stderr, fmt, arg);
    fprintf(stderr, "\n");
    exit(1);
}

static void *xmalloc(size_t n)
{
    void *p = malloc(n ? n : 1);
    if (!p) die("%s", "out of memory");
    return p;
}

static long peak_rss_kb(void)
{
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0) return -1;
    return ru.ru_maxrss; /* kilobytes on Linux */
}

static void load_mesh(const char *path, const char *mesh_arg, peer_mesh *pm)
{
    char *end;
    errno = 0;
    unsigned long k = strtoul(mesh_arg, &end, 10);
    if (errno || *end || end == mesh_arg) die("bad mesh index '%s'", mesh_arg);

    memset(pm, 0, sizeof *pm);
    scene_options opt;
    memset(&opt, 0, sizeof opt);
    lp_error err;
    memset(&err, 0, sizeof err);
    double t0 = now_seconds();
    if (scene_load(path, &opt, &pm->s, &err) != LP_OK) {
        fprintf(stderr, "meshopt_peer: %s: %s\n", path, err.msg);
        exit(1);
    }
    double t1 = now_seconds();
    if (k >= pm->s.mesh_count) die("mesh index %s out of range", mesh_arg);
    if (weld_build(&pm->s.meshes[k], 1, &pm->w, &err) != LP_OK) {
        fprintf(stderr, "meshopt_peer: %s: %s\n", path, err.msg);
        exit(1);
    }
    double t2 = now_seconds();
    pm->load_seconds = t1 - t0;
    pm->weld_seconds = t2 - t1;
    pm->diagonal = pm->s.meshes[k].diagonal;
    pm->scale = meshopt_simplifyScale(pm->w.positions, pm->w.vertex_count, 3 * sizeof(float));
    if (pm->w.triangle_count == 0) die("mesh %s has no triangles", mesh_arg);
}

static void free_mesh(peer_mesh *pm)
{
    weld_free(&pm->w);
    scene_free(&pm->s);
}

/* Parses "a,b,c" into out[]; returns the count. */
static int parse_list(const char *text, double *out, int max)
{
    int n = 0;
    const char *p = text;
    while (*p) {
        char *end;
        errno = 0;
        double v = strtod(p, &end);
        if (errno || end == p || !(v >= 0) || n == max) die("bad list '%s'", text);
        out[n++] = v;
        if (*end == ',') end++;
        else if (*end) die("bad list '%s'", text);
        p = end;
    }
    if (n == 0) die("empty list '%s'", text);
    return n;
}

/* One chain: level i from level i-1. levels[i] receives the index buffer
 * (capacity: the input index count each), counts[i] its index count.
 * target_tris[i] (or 0) and target_err[i] (meshopt units) per level. */
static void run_chain(const peer_mesh *pm, int n, const double *target_tris,
                      const float *target_err, unsigned **levels, size_t *counts,
                      float *result_err)
{
    const unsigned *src = pm->w.triangle_vertices;
    size_t src_count = 3 * (size_t)pm->w.triangle_count;
    for (int i = 0; i < n; i++) {
        size_t target = 3 * (size_t)target_tris[i];
        counts[i] = meshopt_simplify(levels[i], src, src_count, pm->w.positions,
                                     pm->w.vertex_count, 3 * sizeof(float), target,
                                     target_err[i], 0, &result_err[i]);
        src = levels[i];
        src_count = counts[i];
    }
}

static void write_obj(const char *path, const peer_mesh *pm, const unsigned *idx, size_t count)
{
    FILE *f = fopen(path, "w");
    if (!f) die("cannot write %s", path);
    uint32_t *remap = xmalloc(sizeof(uint32_t) * pm->w.vertex_count);
    for (uint32_t v = 0; v < pm->w.vertex_count; v++) remap[v] = UINT32_MAX;
    uint32_t used = 0;
    for (size_t i = 0; i < count; i++) {
        unsigned v = idx[i];
        if (remap[v] == UINT32_MAX) {
            remap[v] = used++;
            const float *p = pm->w.positions + 3 * (size_t)v;
            fprintf(f, "v %.17g %.17g %.17g\n", (double)p[0], (double)p[1], (double)p[2]);
        }
    }
    for (size_t i = 0; i + 2 < count; i += 3)
        fprintf(f, "f %u %u %u\n", remap[idx[i]] + 1, remap[idx[i + 1]] + 1, remap[idx[i + 2]] + 1);
    free(remap);
    if (fclose(f) != 0) die("cannot write %s", path);
}

static unsigned **alloc_levels(const peer_mesh *pm, int n)
{
    unsigned **levels = xmalloc(sizeof(unsigned *) * (size_t)n);
    for (int i = 0; i < n; i++)
        levels[i] = xmalloc(sizeof(unsigned) * 3 * (size_t)pm->w.triangle_count);
    return levels;
}

static void free_levels(unsigned **levels, int n)
{
    for (int i = 0; i < n; i++) free(levels[i]);
    free(levels);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(const double *v, int n)
{
    double tmp[MAX_REPS];
    memcpy(tmp, v, sizeof(double) * (size_t)n);
    qsort(tmp, (size_t)n, sizeof(double), cmp_double);
    return n % 2 ? tmp[n / 2] : 0.5 * (tmp[n / 2 - 1] + tmp[n / 2]);
}

static void print_mesh_json(const peer_mesh *pm)
{
    printf("\"triangles\":%u,\"vertices\":%u,\"diagonal\":%.9g,\"meshopt_scale\":%.9g,"
           "\"load_seconds\":%.6f,\"weld_seconds\":%.6f",
           pm->w.triangle_count, pm->w.vertex_count, pm->diagonal, (double)pm->scale,
           pm->load_seconds, pm->weld_seconds);
}

static int cmd_info(int argc, char **argv)
{
    if (argc != 4) die("%s", "usage: meshopt_peer info FILE MESH");
    peer_mesh pm;
    load_mesh(argv[2], argv[3], &pm);
    printf("{");
    print_mesh_json(&pm);
    printf(",\"meshopt_version\":%d}\n", MESHOPTIMIZER_VERSION);
    free_mesh(&pm);
    return 0;
}

static int cmd_simplify(int argc, char **argv)
{
    if (argc != 6 && argc != 8)
        die("%s", "usage: meshopt_peer simplify FILE MESH T1[,T2..] OUT.obj [--error E]");
    double err_frac = -1;
    if (argc == 8) {
        if (strcmp(argv[6], "--error")) die("unknown option %s", argv[6]);
        err_frac = strtod(argv[7], NULL);
        if (!(err_frac >= 0)) die("bad --error %s", argv[7]);
    }
    peer_mesh pm;
    load_mesh(argv[2], argv[3], &pm);
    double targets[MAX_LEVELS];
    int n = parse_list(argv[4], targets, MAX_LEVELS);
    float terr[MAX_LEVELS], rerr[MAX_LEVELS];
    for (int i = 0; i < n; i++)
        terr[i] = err_frac < 0 ? 1.0f : (float)(err_frac * pm.diagonal / pm.scale);
    unsigned **levels = alloc_levels(&pm, n);
    size_t counts[MAX_LEVELS];
    double t0 = now_seconds();
    run_chain(&pm, n, targets, terr, levels, counts, rerr);
    double t1 = now_seconds();
    write_obj(argv[5], &pm, levels[n - 1], counts[n - 1]);
    printf("{");
    print_mesh_json(&pm);
    printf(",\"simplify_seconds\":%.6f,\"levels\":[", t1 - t0);
    for (int i = 0; i < n; i++)
        printf("%s{\"target\":%.0f,\"triangles\":%zu,\"result_error_rel_diag\":%.9g}", i ? "," : "",
               targets[i], counts[i] / 3, (double)rerr[i] * pm.scale / pm.diagonal);
    printf("],\"out\":\"%s\"}\n", argv[5]);
    free_levels(levels, n);
    free_mesh(&pm);
    return 0;
}

typedef struct chain_spec {
    const char *name;
    int n;
    double targets[MAX_LEVELS];
    float terr[MAX_LEVELS];
    double input[MAX_LEVELS]; /* what was asked: fraction of diagonal or triangle count */
    double seconds[MAX_REPS];
    size_t counts[MAX_LEVELS];
    float rerr[MAX_LEVELS];
} chain_spec;

static void print_chain(const chain_spec *c, int reps, const peer_mesh *pm)
{
    printf("\"%s\":{\"median_seconds\":%.6f,\"runs\":[", c->name, median(c->seconds, reps));
    for (int r = 0; r < reps; r++) printf("%s%.6f", r ? "," : "", c->seconds[r]);
    printf("],\"levels\":[");
    for (int i = 0; i < c->n; i++) {
        printf("%s{", i ? "," : "");
        if (c->targets[i] > 0)
            printf("\"target_triangles\":%.0f,", c->targets[i]);
        else
            printf("\"target_error_rel_diag\":%.9g,\"target_error_meshopt\":%.9g,", c->input[i],
                   (double)c->terr[i]);
        printf("\"triangles\":%zu,\"result_error_rel_diag\":%.9g}", c->counts[i] / 3,
               (double)c->rerr[i] * pm->scale / pm->diagonal);
    }
    printf("]}");
}

static int cmd_chain(int argc, char **argv)
{
    if (argc < 4) die("%s", "usage: meshopt_peer chain FILE MESH [--errors ..] [--targets ..] [--reps N] [--out DIR]");
    const char *errors = NULL, *targets = NULL, *outdir = NULL;
    int reps = 3;
    for (int i = 4; i < argc; i++) {
        if (i + 1 >= argc) die("option %s needs a value", argv[i]);
        if (!strcmp(argv[i], "--errors")) errors = argv[++i];
        else if (!strcmp(argv[i], "--targets")) targets = argv[++i];
        else if (!strcmp(argv[i], "--out")) outdir = argv[++i];
        else if (!strcmp(argv[i], "--reps")) {
            reps = atoi(argv[++i]);
            if (reps < 1 || reps > MAX_REPS) die("bad --reps %s", argv[i]);
        } else die("unknown option %s", argv[i]);
    }
    if (!errors && !targets) errors = "0.01,0.03,0.07,0.15";

    peer_mesh pm;
    load_mesh(argv[2], argv[3], &pm);

    chain_spec specs[2];
    int nspec = 0;
    memset(specs, 0, sizeof specs);
    if (errors) {
        chain_spec *c = &specs[nspec++];
        c->name = "by_error";
        c->n = parse_list(errors, c->input, MAX_LEVELS);
        for (int i = 0; i < c->n; i++) {
            c->targets[i] = 0;
            c->terr[i] = (float)(c->input[i] * pm.diagonal / pm.scale);
        }
    }
    if (targets) {
        chain_spec *c = &specs[nspec++];
        c->name = "by_count";
        c->n = parse_list(targets, c->input, MAX_LEVELS);
        for (int i = 0; i < c->n; i++) {
            c->targets[i] = c->input[i];
            c->terr[i] = 1.0f;
        }
    }
    int nmax = 0;
    for (int s = 0; s < nspec; s++) nmax = specs[s].n > nmax ? specs[s].n : nmax;
    unsigned **levels = alloc_levels(&pm, nmax);

    /* Alternate the chains rep by rep so machine noise hits both alike. */
    for (int r = 0; r < reps; r++) {
        for (int s = 0; s < nspec; s++) {
            chain_spec *c = &specs[s];
            double t0 = now_seconds();
            run_chain(&pm, c->n, c->targets, c->terr, levels, c->counts, c->rerr);
            c->seconds[r] = now_seconds() - t0;
        }
    }
    if (outdir) {
        char path[4096];
        for (int s = 0; s < nspec; s++) {
            chain_spec *c = &specs[s];
            run_chain(&pm, c->n, c->targets, c->terr, levels, c->counts, c->rerr);
            for (int i = 0; i < c->n; i++) {
                snprintf(path, sizeof path, "%s/%s_level%d.obj", outdir,
                         strcmp(c->name, "by_error") ? "targets" : "errors", i + 1);
                write_obj(path, &pm, levels[i], c->counts[i]);
            }
        }
    }
    printf("{");
    print_mesh_json(&pm);
    printf(",\"meshopt_version\":%d,\"reps\":%d,", MESHOPTIMIZER_VERSION, reps);
    for (int s = 0; s < nspec; s++) {
        if (s) printf(",");
        print_chain(&specs[s], reps, &pm);
    }
    printf(",\"peak_rss_kb\":%ld}\n", peak_rss_kb());
    free_levels(levels, nmax);
    free_mesh(&pm);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc < 2) die("%s", "usage: meshopt_peer info|simplify|chain ...");
    if (!strcmp(argv[1], "info")) return cmd_info(argc, argv);
    if (!strcmp(argv[1], "simplify")) return cmd_simplify(argc, argv);
    if (!strcmp(argv[1], "chain")) return cmd_chain(argc, argv);
    die("unknown mode %s", argv[1]);
    return 1;
}
