/* batch.c - see batch.h.
 *
 * Why one process per file. Each file runs as its own `lodpipe IN -o OUT
 * --json` child (posix_spawn of this very binary, /proc/self/exe), whose JSON
 * summary the batch reads back, instead of running the pipeline on threads
 * inside this process:
 * - isolation: a file that makes the job exit, abort or run out of memory
 *   ends only its own process; the batch reports it and goes on;
 * - memory: every file's allocations go back to the system when its job
 *   ends, so a long batch does not fragment or grow;
 * - identity: a batch output IS a single-file run's output, by construction,
 *   not by keeping two code paths in step;
 * - the single-file pipeline already uses worker threads per mesh
 *   (run.threads), so cores are shared by giving each of the -j jobs
 *   cores / jobs threads (when run.threads is 0) rather than by nesting pools.
 * The cost, one exec per file (a few milliseconds), is small against a
 * simplification. The configuration reaches the jobs as a canonical
 * pipeline.toml (config_write) in OUT_DIR, so every key, from a file or a
 * flag, applies to every file; switches that are not configuration keys
 * (--allow-external-uris, --quiet) are passed on explicitly in job_argv.
 *
 * The cache key (batch.h) needs the list of files a glTF references; the
 * batch does not parse glTF itself: the job lists them ("inputs" in its JSON),
 * and the manifest keeps that list. The list is a function of the input's
 * bytes, so when the input is unchanged, re-hashing the recorded list is
 * exactly re-hashing what the job would read. */
#include "batch.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "clock.h"
#include "jsonr.h"
#include "jsonw.h"
#include "output.h"
#include "sha256.h"
#include "status.h"
#include "stopsig.h"
#include "threads.h"
#include "version.h"

extern char **environ;

#define MANIFEST_NAME ".lodpipe-cache.json"
#define MANIFEST_FORMAT 1
#define CAPTURE_LIMIT (4u << 20) /* bytes kept of a job's stdout or stderr */
#define MAX_SCAN_DEPTH 256

/* A file a job read or wrote: `name` relative to SRC_DIR (inputs) or OUT_DIR
 * (outputs), or, when `as_opened`, the path exactly as the job opened it (an
 * input outside SRC_DIR, allowed by --allow-external-uris). */
typedef struct file_ref {
    char *name;
    int as_opened;
    char sha256[SHA256_HEX];
} file_ref;

typedef struct file_refs {
    file_ref *items;
    size_t count;
} file_refs;

/* What the manifest says about one file, or what its job just produced. */
typedef struct record {
    int present;
    char key[SHA256_HEX];
    uint32_t meshes;
    uint64_t triangles_in, triangles_out;
    double seconds;
    file_refs inputs, outputs;
} record;

typedef enum job_state { JOB_SKIPPED_SHARD, JOB_PENDING, JOB_RUNNING, JOB_CACHED, JOB_BUILT, JOB_FAILED } job_state;

typedef struct capture {
    char *bytes;
    size_t size, capacity;
    int fd;            /* -1 once at end of file */
    int out_of_memory; /* bytes were dropped for want of memory */
} capture;

typedef struct job {
    char *rel;    /* path below SRC_DIR */
    char *source; /* SRC_DIR/rel */
    char *output; /* OUT_DIR/rel */
    job_state state;
    record old;   /* from the manifest */
    record now;   /* this run's result (built or cached) */
    int exit_code;
    char *error;  /* first line of a failed job's message */
    pid_t pid;
    capture out, err;
    double started;
    struct timespec launched; /* coarse wall clock just before its inputs were hashed to launch it */
    file_refs before;         /* inputs hashed before the launch (changed_input) */
} job;

typedef struct batch {
    const batch_options *opt;
    char *source_dir, *output_dir; /* without trailing slashes */
    char self[4096];               /* the binary every job runs */
    char config_path[4200];        /* the jobs' pipeline.toml, removed at the end */
    uint8_t key_prefix[SHA256_BYTES]; /* version + configuration + switches */
    job *jobs;
    size_t job_count, job_capacity;
    size_t selected, to_build, finished_builds;
    int jobs_at_once, threads_per_job;
    int progress; /* stderr is a terminal and not quiet */
    int progress_shown;
    double start;
    struct stat output_stat;
    int case_blind; /* OUT_DIR's file system takes a.glb and A.glb for one name (output.h) */
    char *source_real, *output_real; /* real paths of SRC_DIR and OUT_DIR, as place_of gives paths */
} batch;

static char *join_path(const char *dir, const char *name)
{
    size_t a = strlen(dir), b = strlen(name);
    char *p = malloc(a + b + 2);
    if (!p) return NULL;
    memcpy(p, dir, a);
    p[a] = '/';
    memcpy(p + a + 1, name, b + 1);
    return p;
}

static char *strip_slashes(const char *path)
{
    char *p = strdup(path);
    if (!p) return NULL;
    size_t n = strlen(p);
    while (n > 1 && p[n - 1] == '/') p[--n] = 0;
    return p;
}

static void refs_free(file_refs *r)
{
    for (size_t i = 0; i < r->count; ++i) free(r->items[i].name);
    free(r->items);
    memset(r, 0, sizeof *r);
}

static void record_free(record *r)
{
    refs_free(&r->inputs);
    refs_free(&r->outputs);
    memset(r, 0, sizeof *r);
}

static char *resolve_ref(const char *base, const file_ref *f)
{
    return f->as_opened ? strdup(f->name) : join_path(base, f->name);
}

/* ---- progress and messages ---------------------------------------------------- */

static void clear_progress(batch *b)
{
    if (b->progress_shown) {
        fputs("\r\033[K", stderr);
        b->progress_shown = 0;
    }
}

static void show_progress(batch *b, const char *current)
{
    if (!b->progress) return;
    size_t done = 0;
    for (size_t i = 0; i < b->job_count; ++i)
        done += b->jobs[i].state == JOB_CACHED || b->jobs[i].state == JOB_BUILT || b->jobs[i].state == JOB_FAILED;
    char eta[32] = "--:--";
    double elapsed = lp_seconds() - b->start;
    if (b->finished_builds > 0) {
        double left = elapsed / (double)b->finished_builds * (double)(b->to_build - b->finished_builds);
        long s = (long)(left + 0.5);
        snprintf(eta, sizeof eta, "%ld:%02ld", s / 60, s % 60);
    }
    char shown[256];
    const char *name = lp_line(shown, sizeof shown, "%s", current ? current : "");
    size_t len = strlen(name);
    fprintf(stderr, "\r\033[Klodpipe batch: %zu/%zu files, ETA %s  %s%s", done, b->selected, eta, len > 50 ? "..." : "",
            len > 50 ? name + len - 50 : name);
    fflush(stderr);
    b->progress_shown = 1;
}

/* Relays a job's stderr text as it is (its lines already name the file). */
static void relay(batch *b, const capture *c)
{
    if (!c->size) return;
    clear_progress(b);
    fwrite(c->bytes, 1, c->size, stderr);
    if (c->bytes[c->size - 1] != '\n') fputc('\n', stderr);
}

/* ---- the file list ------------------------------------------------------------- */

static int has_gltf_extension(const char *name)
{
    size_t n = strlen(name);
    return (n > 5 && strcasecmp(name + n - 5, ".gltf") == 0) || (n > 4 && strcasecmp(name + n - 4, ".glb") == 0);
}

static int add_job(batch *b, const char *rel)
{
    if (b->job_count == b->job_capacity) {
        size_t cap = b->job_capacity ? 2 * b->job_capacity : 64;
        job *j = realloc(b->jobs, cap * sizeof *j);
        if (!j) return -1;
        b->jobs = j;
        b->job_capacity = cap;
    }
    job *j = &b->jobs[b->job_count];
    memset(j, 0, sizeof *j);
    j->rel = strdup(rel);
    j->source = join_path(b->source_dir, rel);
    j->output = join_path(b->output_dir, rel);
    j->out.fd = j->err.fd = -1;
    if (!j->rel || !j->source || !j->output) {
        free(j->rel);
        free(j->source);
        free(j->output);
        return -1;
    }
    b->job_count++;
    return 0;
}

/* Collects every glTF file below SRC_DIR/rel_dir (rel_dir "" = the top). */
static int scan(batch *b, const char *rel_dir, int depth, lp_error *err)
{
    char *dir_path = rel_dir[0] ? join_path(b->source_dir, rel_dir) : strdup(b->source_dir);
    if (!dir_path) return lp_no_memory(err, "%s: out of memory", b->source_dir);
    DIR *d = opendir(dir_path);
    if (!d) {
        int rc = errno == ENOMEM ? lp_no_memory(err, "%s: out of memory", dir_path)
                                 : lp_fail(err, LP_IO, "%s: cannot read the folder (%s)", dir_path, strerror(errno));
        free(dir_path);
        return rc;
    }
    int rc = LP_OK;
    struct dirent *e;
    while (!rc && (e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.') continue;
        char *rel = rel_dir[0] ? join_path(rel_dir, e->d_name) : strdup(e->d_name);
        char *full = rel ? join_path(b->source_dir, rel) : NULL;
        struct stat st;
        if (!rel || !full) {
            rc = lp_no_memory(err, "%s: out of memory", b->source_dir);
        } else if (lstat(full, &st) == 0) {
            if (S_ISDIR(st.st_mode)) {
                int is_output = st.st_dev == b->output_stat.st_dev && st.st_ino == b->output_stat.st_ino;
                if (!is_output && depth < MAX_SCAN_DEPTH) rc = scan(b, rel, depth + 1, err);
            } else if (has_gltf_extension(e->d_name) && stat(full, &st) == 0 && S_ISREG(st.st_mode)) {
                if (add_job(b, rel)) rc = lp_no_memory(err, "%s: out of memory", b->source_dir);
            }
        }
        free(rel);
        free(full);
    }
    closedir(d);
    free(dir_path);
    return rc;
}

static int by_relative_path(const void *a, const void *b)
{
    return strcmp(((const job *)a)->rel, ((const job *)b)->rel);
}

uint32_t batch_shard_of(const char *relative_path, uint32_t shard_count)
{
    if (shard_count <= 1) return 0;
    uint8_t d[SHA256_BYTES];
    sha256_bytes(relative_path, strlen(relative_path), d);
    uint64_t x = 0;
    for (int i = 0; i < 8; ++i) x = x << 8 | d[i];
    return (uint32_t)(x % shard_count);
}

/* ---- the manifest ---------------------------------------------------------------- */

static int read_refs(const jsonr *r, uint32_t array, file_refs *out)
{
    uint32_t n = jsonr_size(r, array);
    if (r->count == 0 || array == JSONR_NONE || r->tokens[array].type != JSONR_ARRAY) return -1;
    out->items = calloc(n ? n : 1, sizeof *out->items);
    if (!out->items) return -1;
    for (uint32_t i = 0; i < n; ++i) {
        uint32_t item = jsonr_element(r, array, i);
        uint32_t name = jsonr_member(r, item, "path"), opened = jsonr_member(r, item, "opened");
        char *hash = jsonr_string(r, jsonr_member(r, item, "sha256"));
        file_ref *f = &out->items[out->count];
        f->as_opened = name == JSONR_NONE;
        f->name = jsonr_string(r, f->as_opened ? opened : name);
        int ok = f->name && hash && strlen(hash) == SHA256_HEX - 1;
        if (ok) memcpy(f->sha256, hash, SHA256_HEX);
        free(hash);
        if (!ok) {
            free(f->name);
            return -1;
        }
        out->count++;
    }
    return 0;
}

/* An entry's count `name`: 0 when it is a whole number in 0..max, else -1. A
 * hand-edited or damaged entry (a negative or huge count) is a cache miss,
 * not a number the summary wraps. */
static int read_count(const jsonr *r, uint32_t item, const char *name, double max, uint64_t *out)
{
    double v = jsonr_number(r, jsonr_member(r, item, name), -1);
    if (!(v >= 0 && v <= max) || v != (double)(uint64_t)v) return -1;
    *out = (uint64_t)v;
    return 0;
}

/* An entry's numbers: meshes fit their uint32_t, triangle counts stay exact
 * doubles (2^53, far beyond the 2 GiB input limit), seconds finite and >= 0.
 * 0, or -1 for an entry the cache must not trust. */
static int read_counts(const jsonr *r, uint32_t item, record *o)
{
    uint64_t meshes = 0;
    double seconds = jsonr_number(r, jsonr_member(r, item, "seconds"), -1);
    const double exact = 9007199254740992.0; /* 2^53 */
    if (read_count(r, item, "meshes", 4294967295.0, &meshes) || read_count(r, item, "triangles_in", exact, &o->triangles_in) ||
        read_count(r, item, "triangles_out", exact, &o->triangles_out) || !(seconds >= 0 && seconds <= 1e9))
        return -1;
    o->meshes = (uint32_t)meshes;
    o->seconds = seconds;
    return 0;
}

/* Reads the manifest's entries into the jobs' `old` records. A missing file
 * is an empty cache; a damaged one too (with a warning): the cache only ever
 * saves work, it never decides an output. */
static void load_manifest(batch *b)
{
    char *path = join_path(b->output_dir, MANIFEST_NAME);
    FILE *f = path ? fopen(path, "rb") : NULL;
    if (!f) {
        free(path);
        return;
    }
    char *text = NULL;
    size_t size = 0, cap = 0, got;
    char buf[65536];
    while ((got = fread(buf, 1, sizeof buf, f)) > 0) {
        if (size + got + 1 > cap) {
            cap = 2 * (size + got + 1);
            char *t = realloc(text, cap);
            if (!t) break;
            text = t;
        }
        memcpy(text + size, buf, got);
        size += got;
    }
    fclose(f);
    jsonr r;
    int ok = text && jsonr_parse(&r, text, size) == 0;
    if (ok) {
        uint32_t entries = jsonr_member(&r, 0, "entries");
        ok = jsonr_number(&r, jsonr_member(&r, 0, "format"), 0) == MANIFEST_FORMAT && entries != JSONR_NONE;
        for (uint32_t e = 0; ok && e < jsonr_size(&r, entries); ++e) {
            uint32_t item = jsonr_element(&r, entries, e);
            char *source = jsonr_string(&r, jsonr_member(&r, item, "source"));
            char *key = jsonr_string(&r, jsonr_member(&r, item, "key"));
            job probe = {.rel = source};
            job *j = source && b->job_count ? bsearch(&probe, b->jobs, b->job_count, sizeof *b->jobs, by_relative_path) : NULL;
            if (j && key && strlen(key) == SHA256_HEX - 1 && !j->old.present) {
                record *o = &j->old;
                memcpy(o->key, key, SHA256_HEX);
                if (read_counts(&r, item, o) == 0 &&
                    read_refs(&r, jsonr_member(&r, item, "inputs"), &o->inputs) == 0 &&
                    read_refs(&r, jsonr_member(&r, item, "outputs"), &o->outputs) == 0)
                    o->present = 1;
                else
                    record_free(o);
            }
            free(source);
            free(key);
        }
        jsonr_free(&r);
    }
    if (!ok && !b->opt->quiet) lp_say("%s: warning: not a lodpipe cache manifest; rebuilding everything", path);
    free(text);
    free(path);
}

static void json_refs(jsonw *w, const char *name, const file_refs *refs)
{
    jsonw_printf(w, ",\"%s\":[", name);
    for (size_t i = 0; i < refs->count; ++i) {
        jsonw_raw(w, i ? ",{" : "{");
        jsonw_raw(w, refs->items[i].as_opened ? "\"opened\":" : "\"path\":");
        jsonw_string(w, refs->items[i].name);
        jsonw_printf(w, ",\"sha256\":\"%s\"}", refs->items[i].sha256);
    }
    jsonw_raw(w, "]");
}

/* Writes the manifest: this run's built and cached files, plus the old
 * entries of files outside the shard. */
static int write_manifest(batch *b, lp_error *err)
{
    jsonw w = {0};
    jsonw_printf(&w, "{\"format\":%d,\"version\":", MANIFEST_FORMAT);
    jsonw_string(&w, LODPIPE_VERSION);
    jsonw_raw(&w, ",\"entries\":[");
    int first = 1;
    for (size_t i = 0; i < b->job_count; ++i) {
        const job *j = &b->jobs[i];
        const record *r = j->state == JOB_SKIPPED_SHARD ? &j->old : &j->now;
        if (!r->present || (j->state != JOB_SKIPPED_SHARD && j->state != JOB_BUILT && j->state != JOB_CACHED)) continue;
        jsonw_raw(&w, first ? "\n{\"source\":" : ",\n{\"source\":");
        jsonw_string(&w, j->rel);
        jsonw_printf(&w, ",\"key\":\"%s\",\"meshes\":%u,\"triangles_in\":%llu,\"triangles_out\":%llu,\"seconds\":", r->key,
                     r->meshes, (unsigned long long)r->triangles_in, (unsigned long long)r->triangles_out);
        jsonw_number(&w, r->seconds);
        json_refs(&w, "inputs", &r->inputs);
        json_refs(&w, "outputs", &r->outputs);
        jsonw_raw(&w, "}");
        first = 0;
    }
    jsonw_raw(&w, "\n]}\n");
    if (w.failed) {
        jsonw_free(&w);
        return lp_no_memory(err, "%s: out of memory writing the cache manifest", b->output_dir);
    }
    char *path = join_path(b->output_dir, MANIFEST_NAME);
    gltf_out_file f = {(char *)MANIFEST_NAME, (uint8_t *)w.text, w.length};
    int rc = path ? output_write_all(path, &f, 1, NULL, 0, NULL, 0, err)
                  : lp_no_memory(err, "%s: out of memory writing the cache manifest", b->output_dir);
    if (rc && path) { /* output.c's messages leave the file to the caller, as report() in main.c does */
        char msg[sizeof err->msg];
        const int out_of_memory = err->out_of_memory;
        snprintf(msg, sizeof msg, "%s", err->msg);
        lp_fail(err, rc, "%s: %s", path, msg);
        err->out_of_memory = out_of_memory;
    }
    free(path);
    jsonw_free(&w);
    return rc;
}

/* ---- the cache key -------------------------------------------------------------- */

/* Version, configuration (without run.threads) and switches: what every key
 * of this run starts with. */
static int compute_key_prefix(batch *b)
{
    lp_config config = *b->opt->config;
    config.run.threads = 0;
    size_t n = config_write(&config, CONFIG_TOML, NULL, 0);
    char *text = malloc(n + 1);
    if (!text) return -1;
    config_write(&config, CONFIG_TOML, text, n + 1);
    sha256_ctx ctx;
    sha256_init(&ctx);
    const char *head = "lodpipe batch cache key 2\nversion " LODPIPE_VERSION "\nsource " LODPIPE_SOURCE_ID "\n";
    sha256_update(&ctx, head, strlen(head));
    sha256_update(&ctx, text, n);
    const char *uris = b->opt->allow_external_uris ? "allow_external_uris true\n" : "allow_external_uris false\n";
    sha256_update(&ctx, uris, strlen(uris));
    sha256_final(&ctx, b->key_prefix);
    free(text);
    return 0;
}

/* Reading back what a job read and wrote: the failures are told apart, so
 * that the batch running out of memory says so (exit 2) instead of blaming
 * the job. */
enum { READBACK_OK = 0, READBACK_UNREADABLE = -1, READBACK_NO_MEMORY = -2 };

/* sha256_file_hex's result as a READBACK_* value (fopen allocates). */
static int hash_result(int rc)
{
    return !rc ? READBACK_OK : errno == ENOMEM ? READBACK_NO_MEMORY : READBACK_UNREADABLE;
}

/* Hashes every input of r as it is now (refreshing r's hashes) and derives
 * the key. Returns READBACK_OK, READBACK_UNREADABLE when an input cannot be
 * read, or READBACK_NO_MEMORY. */
static int compute_key(const batch *b, const char *rel, record *r)
{
    sha256_ctx ctx;
    sha256_init(&ctx);
    sha256_update(&ctx, b->key_prefix, sizeof b->key_prefix);
    sha256_update(&ctx, "source ", 7);
    sha256_update(&ctx, rel, strlen(rel) + 1);
    for (size_t i = 0; i < r->inputs.count; ++i) {
        file_ref *f = &r->inputs.items[i];
        char *path = resolve_ref(b->source_dir, f);
        int rc = !path ? READBACK_NO_MEMORY : hash_result(sha256_file_hex(path, f->sha256));
        free(path);
        if (rc) return rc;
        sha256_update(&ctx, f->as_opened ? "opened " : "input ", f->as_opened ? 7 : 6);
        sha256_update(&ctx, f->name, strlen(f->name) + 1);
        sha256_update(&ctx, f->sha256, SHA256_HEX - 1);
    }
    uint8_t d[SHA256_BYTES];
    sha256_final(&ctx, d);
    sha256_hex(d, r->key);
    return 0;
}

/* The recorded outputs are all there with the recorded bytes. */
static int outputs_intact(const batch *b, const record *r)
{
    if (!r->outputs.count) return 0;
    for (size_t i = 0; i < r->outputs.count; ++i) {
        char hex[SHA256_HEX];
        char *path = resolve_ref(b->output_dir, &r->outputs.items[i]);
        int rc = path ? sha256_file_hex(path, hex) : -1;
        free(path);
        if (rc || strcmp(hex, r->outputs.items[i].sha256) != 0) return 0;
    }
    return 1;
}

static int copy_refs(const file_refs *from, file_refs *to)
{
    to->items = calloc(from->count ? from->count : 1, sizeof *to->items);
    if (!to->items) return -1;
    for (size_t i = 0; i < from->count; ++i) {
        to->items[i] = from->items[i];
        to->items[i].name = strdup(from->items[i].name);
        if (!to->items[i].name) return -1;
        to->count++;
    }
    return 0;
}

/* Decides whether the job's recorded result still holds: the key over its
 * current input bytes matches, and its outputs are intact. */
static int still_cached(const batch *b, job *j)
{
    if (!j->old.present) return 0;
    record probe = {0};
    int ok = copy_refs(&j->old.inputs, &probe.inputs) == 0 && compute_key(b, j->rel, &probe) == 0 &&
             strcmp(probe.key, j->old.key) == 0 && outputs_intact(b, &j->old);
    record_free(&probe);
    if (!ok) return 0;
    j->now = j->old;
    memset(&j->old, 0, sizeof j->old);
    return 1;
}

/* ---- inputs that change while their job runs ------------------------------------- */

/* The key is over the inputs' bytes as hashed after the job, but the job built
 * from the bytes it read at its start: a file replaced in between would pair
 * its new bytes with the old output, and be "cached" from then on. So before
 * the launch the batch notes the time and hashes the inputs it knows of (the
 * file itself and, from the manifest, what it referenced last time); after
 * the job, an input whose hash differs from that, or, for an input not hashed
 * before, whose change time (ctime, which no program can set back) is not
 * before the launch, changed while the job ran, and the file is not recorded
 * (changed_input). The clock is the coarse
 * one the kernel stamps files with, read before the hashing, so any change
 * after it is seen; a change in the same tick just before it costs only a
 * rebuild. */
static void hash_before_launch(const batch *b, job *j)
{
    clock_gettime(CLOCK_REALTIME_COARSE, &j->launched);
    file_refs *r = &j->before;
    if (j->old.present) {
        if (copy_refs(&j->old.inputs, r) != 0) refs_free(r);
    } else if ((r->items = calloc(1, sizeof *r->items)) != NULL && (r->items[0].name = strdup(j->rel)) != NULL) {
        r->count = 1;
    }
    for (size_t i = 0; i < r->count; ++i) {
        char *path = resolve_ref(b->source_dir, &r->items[i]);
        if (!path || sha256_file_hex(path, r->items[i].sha256) != 0) r->items[i].sha256[0] = 0; /* unknown */
        free(path);
    }
}

/* The first input of a built job (its hashes taken after the job) that
 * changed since hash_before_launch, or NULL. Called after the hashing, so a
 * change during it shows in the change time. */
static const file_ref *changed_input(const batch *b, const job *j)
{
    for (size_t i = 0; i < j->now.inputs.count; ++i) {
        const file_ref *f = &j->now.inputs.items[i];
        int hashed_before = 0;
        for (size_t k = 0; k < j->before.count && !hashed_before; ++k) {
            const file_ref *g = &j->before.items[k];
            if (!g->sha256[0] || g->as_opened != f->as_opened || strcmp(g->name, f->name) != 0) continue;
            if (strcmp(g->sha256, f->sha256) != 0) return f;
            hashed_before = 1;
        }
        /* the same bytes before the launch and after the job: what the job
         * read (a change and its undoing in between aside). Only an input
         * first seen now needs the change time, which a file server's clock
         * could put ahead of ours (then the file is rebuilt, never stale). */
        if (hashed_before) continue;
        char *path = resolve_ref(b->source_dir, f);
        struct stat st;
        int changed = !path || stat(path, &st) != 0 || st.st_ctim.tv_sec > j->launched.tv_sec ||
                      (st.st_ctim.tv_sec == j->launched.tv_sec && st.st_ctim.tv_nsec >= j->launched.tv_nsec);
        free(path);
        if (changed) return f;
    }
    return NULL;
}

/* ---- running one job --------------------------------------------------------------- */

/* Creates the folders above `path` (below OUT_DIR). */
static int make_parent_folders(const char *path)
{
    char *p = strdup(path);
    if (!p) return -1;
    int rc = 0;
    for (char *s = strchr(p + 1, '/'); s && !rc; s = strchr(s + 1, '/')) {
        *s = 0;
        if (mkdir(p, 0777) != 0 && errno != EEXIST) rc = -1;
        *s = '/';
    }
    free(p);
    return rc;
}

static int start_job(batch *b, job *j)
{
    int out_pipe[2] = {-1, -1}, err_pipe[2] = {-1, -1};
    if (make_parent_folders(j->output) != 0) {
        j->exit_code = errno == ENOMEM ? LP_INVALID : LP_IO;
        if (errno == ENOMEM) lp_say("%s: out of memory creating its output folder", j->output);
        else lp_say("%s: cannot create its output folder (%s)", j->output, strerror(errno));
        return -1;
    }
    if (pipe(out_pipe) || pipe(err_pipe)) {
        j->exit_code = LP_IO;
        lp_say("%s: cannot start its job (%s)", j->source, strerror(errno));
        for (int k = 0; k < 2; ++k) {
            if (out_pipe[k] >= 0) close(out_pipe[k]);
            if (err_pipe[k] >= 0) close(err_pipe[k]);
        }
        return -1;
    }
    hash_before_launch(b, j);
    for (int k = 0; k < 2; ++k) {
        fcntl(out_pipe[k], F_SETFD, FD_CLOEXEC);
        fcntl(err_pipe[k], F_SETFD, FD_CLOEXEC);
    }
    char *argv[12];
    int n = 0;
    argv[n++] = b->self;
    argv[n++] = j->source;
    argv[n++] = "-o";
    argv[n++] = j->output;
    argv[n++] = "--config";
    argv[n++] = b->config_path;
    argv[n++] = "--json";
    if (b->opt->allow_external_uris) argv[n++] = "--allow-external-uris";
    if (b->opt->quiet) argv[n++] = "--quiet";
    argv[n] = NULL;
    /* (the file actions allocate: a job whose output did not go to the
     * pipes would print into the batch's own and leave no summary) */
    posix_spawn_file_actions_t actions;
    int rc = posix_spawn_file_actions_init(&actions);
    if (!rc) {
        rc = posix_spawn_file_actions_adddup2(&actions, out_pipe[1], STDOUT_FILENO);
        if (!rc) rc = posix_spawn_file_actions_adddup2(&actions, err_pipe[1], STDERR_FILENO);
        /* SIGTERM is how the batch stops a job: the job must not inherit it
         * ignored (stopsig leaves an ignored signal ignored) */
        posix_spawnattr_t attr;
        if (!rc) rc = posix_spawnattr_init(&attr);
        if (!rc) {
            sigset_t term;
            sigemptyset(&term);
            sigaddset(&term, SIGTERM);
            posix_spawnattr_setsigdefault(&attr, &term);
            posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGDEF);
            rc = posix_spawn(&j->pid, b->self, &actions, &attr, argv, environ);
            posix_spawnattr_destroy(&attr);
        }
        posix_spawn_file_actions_destroy(&actions);
    }
    close(out_pipe[1]);
    close(err_pipe[1]);
    if (rc != 0) {
        close(out_pipe[0]);
        close(err_pipe[0]);
        j->exit_code = rc == ENOMEM ? LP_INVALID : LP_IO;
        if (rc == ENOMEM) lp_say("%s: out of memory starting its job", j->source);
        else lp_say("%s: cannot start %s (%s)", j->source, b->self, strerror(rc));
        return -1;
    }
    fcntl(out_pipe[0], F_SETFL, O_NONBLOCK);
    fcntl(err_pipe[0], F_SETFL, O_NONBLOCK);
    j->out.fd = out_pipe[0];
    j->err.fd = err_pipe[0];
    j->started = lp_seconds();
    j->state = JOB_RUNNING;
    return 0;
}

/* Reads what is available; closes the descriptor at end of file. Bytes past
 * CAPTURE_LIMIT are read and dropped, so a chatty job never blocks. */
static void drain(capture *c)
{
    char buf[65536];
    for (;;) {
        ssize_t n = read(c->fd, buf, sizeof buf);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
        if (n <= 0) {
            close(c->fd);
            c->fd = -1;
            return;
        }
        size_t keep = c->size >= CAPTURE_LIMIT ? 0 : (size_t)n < CAPTURE_LIMIT - c->size ? (size_t)n : CAPTURE_LIMIT - c->size;
        if (keep && c->size + keep + 1 > c->capacity) {
            size_t cap = 2 * (c->size + keep + 1);
            char *p = realloc(c->bytes, cap);
            if (!p) {
                keep = 0;
                c->out_of_memory = 1;
            } else {
                c->bytes = p;
                c->capacity = cap;
            }
        }
        if (keep) {
            memcpy(c->bytes + c->size, buf, keep);
            c->size += keep;
            c->bytes[c->size] = 0;
        }
    }
}

/* A path the job printed, as a file_ref relative to base when below it. */
static int ref_from_path(const char *base, char *path, file_ref *f)
{
    size_t n = strlen(base);
    if (strncmp(path, base, n) == 0 && path[n] == '/' && path[n + 1]) {
        f->name = strdup(path + n + 1);
        free(path);
        if (!f->name) return -1;
    } else {
        f->name = path;
        f->as_opened = 1;
    }
    return 0;
}

static int refs_from_json(const jsonr *r, uint32_t array, const char *base, file_refs *out)
{
    uint32_t n = jsonr_size(r, array);
    if (!n) return READBACK_UNREADABLE;
    out->items = calloc(n, sizeof *out->items);
    if (!out->items) return READBACK_NO_MEMORY;
    for (uint32_t i = 0; i < n; ++i) {
        const uint32_t element = jsonr_element(r, array, i);
        if (r->tokens[element].type != JSONR_STRING) return READBACK_UNREADABLE;
        char *path = jsonr_string(r, element);
        if (!path || ref_from_path(base, path, &out->items[out->count])) return READBACK_NO_MEMORY;
        out->count++;
    }
    return READBACK_OK;
}

/* The hashes the job reported of the bytes it wrote, one per output: not the
 * files' hashes now, which could be another job's bytes when two jobs wrote
 * one file (fail_clashes must see that they differ). */
static int output_hashes_from_json(const jsonr *r, uint32_t array, file_refs *outputs)
{
    if (array == JSONR_NONE || r->tokens[array].type != JSONR_ARRAY || jsonr_size(r, array) != outputs->count)
        return READBACK_UNREADABLE;
    for (size_t i = 0; i < outputs->count; ++i) {
        const uint32_t element = jsonr_element(r, array, (uint32_t)i);
        if (r->tokens[element].type != JSONR_STRING) return READBACK_UNREADABLE;
        char *hex = jsonr_string(r, element);
        if (!hex) return READBACK_NO_MEMORY;
        const int ok = strlen(hex) == SHA256_HEX - 1 && strspn(hex, "0123456789abcdef") == SHA256_HEX - 1;
        if (ok) memcpy(outputs->items[i].sha256, hex, SHA256_HEX);
        free(hex);
        if (!ok) return READBACK_UNREADABLE;
    }
    return READBACK_OK;
}

/* Reads a finished job's --json summary into j->now: counts, the files it
 * read (hashed now) and wrote (with the hashes it reported) and the key.
 * Returns a READBACK_* value. */
static int read_job_summary(const batch *b, job *j)
{
    jsonr r;
    if (j->out.out_of_memory) return READBACK_NO_MEMORY;
    if (!j->out.bytes) return READBACK_UNREADABLE;
    int rc = jsonr_parse(&r, j->out.bytes, j->out.size);
    if (rc) return rc == -2 ? READBACK_NO_MEMORY : READBACK_UNREADABLE;
    record *now = &j->now;
    uint32_t meshes = jsonr_member(&r, 0, "meshes");
    now->meshes = jsonr_size(&r, meshes);
    for (uint32_t m = 0; m < now->meshes; ++m) {
        uint32_t mesh = jsonr_element(&r, meshes, m);
        now->triangles_in += (uint64_t)jsonr_number(&r, jsonr_member(&r, mesh, "triangles"), 0);
        uint32_t levels = jsonr_member(&r, mesh, "levels");
        for (uint32_t k = 0; k < jsonr_size(&r, levels); ++k)
            now->triangles_out += (uint64_t)jsonr_number(&r, jsonr_member(&r, jsonr_element(&r, levels, k), "triangles"), 0);
    }
    rc = refs_from_json(&r, jsonr_member(&r, 0, "inputs"), b->source_dir, &now->inputs);
    if (!rc) rc = refs_from_json(&r, jsonr_member(&r, 0, "outputs"), b->output_dir, &now->outputs);
    if (!rc) rc = output_hashes_from_json(&r, jsonr_member(&r, 0, "output_sha256"), &now->outputs);
    if (!rc) rc = compute_key(b, j->rel, now);
    jsonr_free(&r);
    now->present = !rc;
    return rc;
}

/* The job's failure line for the summary: its last stderr line that is not
 * a warning (a job reports its error last, after the warnings of loading);
 * else `fallback`, the batch's own line (the job was killed, or its summary
 * could not be read back) when there is one; else its last line. */
static void note_error(job *j, const char *fallback)
{
    const char *text = j->err.size ? j->err.bytes : fallback, *pick = NULL, *last = NULL;
    static const char kWarning[] = ": warning: ";
    for (const char *line = text; *line; line += strcspn(line, "\n"), line += *line == '\n') {
        const size_t len = strcspn(line, "\n");
        if (!len) continue;
        last = line;
        int warning = 0;
        for (size_t k = 0; !warning && k + sizeof kWarning - 1 <= len; ++k)
            warning = memcmp(line + k, kWarning, sizeof kWarning - 1) == 0;
        if (!warning) pick = line;
    }
    text = pick ? pick : fallback[0] ? fallback : last ? last : text;
    size_t n = strcspn(text, "\n");
    j->error = malloc(n + 1);
    if (j->error) {
        memcpy(j->error, text, n);
        j->error[n] = 0;
    }
}

static void finish_job(batch *b, job *j, int status)
{
    j->now.seconds = lp_seconds() - j->started;
    b->finished_builds++;
    char message[700];
    message[0] = 0;
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
        const int summary = read_job_summary(b, j);
        if (summary == READBACK_OK) {
            j->state = JOB_BUILT;
            if (!b->opt->quiet) relay(b, &j->err);
            const file_ref *changed = changed_input(b, j);
            if (changed) { /* built from bytes the batch cannot name: not recorded */
                j->now.present = 0;
                if (!b->opt->quiet) {
                    clear_progress(b);
                    char *path = resolve_ref(b->source_dir, changed);
                    lp_say("%s: warning: changed while its job ran; %s is built but not cached (the next run builds it again)",
                           path ? path : changed->name, j->rel);
                    free(path);
                }
            }
            return;
        }
        record_free(&j->now);
        if (summary == READBACK_NO_MEMORY) {
            j->exit_code = LP_INVALID;
            lp_line(message, sizeof message, "lodpipe: %s: out of memory reading the job's summary back", j->source);
        } else {
            j->exit_code = LP_IO;
            lp_line(message, sizeof message, "lodpipe: %s: the job's summary or files could not be read back", j->source);
        }
    } else if (WIFEXITED(status)) {
        j->exit_code = WEXITSTATUS(status);
        if (!j->err.size) lp_line(message, sizeof message, "lodpipe: %s: the job failed with exit code %d", j->source, j->exit_code);
    } else {
        int sig = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
        j->exit_code = 128 + sig;
        lp_line(message, sizeof message, "lodpipe: %s: the job was killed by signal %d (%s)", j->source, sig, strsignal(sig));
    }
    j->state = JOB_FAILED;
    relay(b, &j->err);
    if (message[0]) {
        clear_progress(b);
        fprintf(stderr, "%s\n", message);
    }
    note_error(j, message);
}

/* ---- outputs that two files would both write ------------------------------------ */

/* Two files of one folder can write the same output: a.gltf and a.GLTF both
 * write a.bin (a .gltf writes <OUT stem>.bin; with draco.fallback every output
 * also writes <stem>.fallback.bin, which a.fallback.gltf's .bin is too), and
 * two inputs can bring different textures of the same name. One of the two
 * outputs is then silently wrong and the cache never settles. So every name a
 * job writes is a claim; claims are sorted by name, and a name claimed by two
 * jobs fails the later job in file order (deterministic), unless both claims
 * know the same bytes (a texture the two share: output.c leaves an identical
 * file alone). Before the launch a job's names are its outputs when cached,
 * else those its run will write (OUT, the buffers) and the textures its last
 * run wrote (from the manifest); after the jobs, the outputs each one wrote.
 * Two different names can be one file: a folder of OUT_DIR that is a symlink
 * to another, or a case-insensitive file system (a.glb and A.glb). So claims
 * are compared by the file a name reaches (claim_files), not by the name. */
typedef struct claim {
    char *name;              /* relative to OUT_DIR */
    const char *file;        /* the smallest name that reaches the same file (claim_files) */
    int in_source;           /* it reaches a file inside SRC_DIR, outside OUT_DIR (claim_files) */
    char sha256[SHA256_HEX]; /* "" when the bytes are not known before the job */
    size_t job;
} claim;

typedef struct claims {
    claim *items;
    size_t count, capacity;
    int failed; /* out of memory */
} claims;

static void claim_add(claims *c, size_t job, char *name, const char *sha256)
{
    if (!name || c->failed) {
        free(name);
        c->failed = 1;
        return;
    }
    if (c->count == c->capacity) {
        size_t cap = c->capacity ? 2 * c->capacity : 64;
        claim *p = realloc(c->items, cap * sizeof *p);
        if (!p) {
            free(name);
            c->failed = 1;
            return;
        }
        c->items = p;
        c->capacity = cap;
    }
    claim *k = &c->items[c->count++];
    k->name = name;
    k->file = name;
    k->in_source = 0;
    k->job = job;
    snprintf(k->sha256, sizeof k->sha256, "%s", sha256 ? sha256 : ""); /* a copy: fail_job frees the record */
}

static void claim_refs(claims *c, size_t job, const file_refs *r)
{
    for (size_t i = 0; i < r->count; ++i)
        if (!r->items[i].as_opened) claim_add(c, job, strdup(r->items[i].name), r->items[i].sha256);
}

/* The file name written beside OUT: its stem (the name up to the last dot, as
 * gltf_serialize takes it) + suffix. */
static char *beside(const char *rel, const char *suffix)
{
    const char *base = strrchr(rel, '/');
    base = base ? base + 1 : rel;
    const char *dot = strrchr(base, '.');
    size_t stem = dot && dot > base ? (size_t)(dot - rel) : strlen(rel), n = strlen(suffix);
    char *p = malloc(stem + n + 1);
    if (!p) return NULL;
    memcpy(p, rel, stem);
    memcpy(p + stem, suffix, n + 1);
    return p;
}

/* Claims what the job will write, as far as known before it runs. */
static void claim_planned(const batch *b, claims *c, size_t i)
{
    const job *j = &b->jobs[i];
    size_t n = strlen(j->rel);
    claim_add(c, i, strdup(j->rel), NULL);
    if (n > 5 && strcasecmp(j->rel + n - 5, ".gltf") == 0) claim_add(c, i, beside(j->rel, ".bin"), NULL);
    if (b->opt->config->draco.enabled && b->opt->config->draco.fallback) claim_add(c, i, beside(j->rel, ".fallback.bin"), NULL);
    if (j->old.present) claim_refs(c, i, &j->old.outputs);
}

static int by_claim(const void *a, const void *b)
{
    const claim *x = a, *y = b;
    int d = strcmp(x->file, y->file);
    return d ? d : x->job < y->job ? -1 : x->job > y->job;
}

static void fold_case(char *s)
{
    for (; *s; ++s)
        if (*s >= 'A' && *s <= 'Z') *s = (char)(*s - 'A' + 'a');
}

/* Where OUT_DIR/name lands, as a string two names share when they are one
 * file: the real path of its deepest folder that exists (a symlinked folder
 * resolves), then the rest as written; in ASCII lower case when OUT_DIR's file
 * system ignores case (a.glb and A.glb; other letters' cases are not folded).
 * A folder made by the run (a symlink inside it, OUT_DIR/A when OUT_DIR/a is
 * made) resolves only after the run; the check after the jobs sees it. NULL
 * when memory ran out. */
static char *place_of(const batch *b, const char *name, int fold)
{
    char *path = join_path(b->output_dir, name), *place = NULL;
    if (!path) return NULL;
    for (size_t end = strlen(path), start; end > 0; end = start - 1) {
        for (start = end; start > 0 && path[start - 1] != '/';) --start;
        if (start == 0) break;
        path[start - 1] = 0;
        char *real = realpath(start > 1 ? path : "/", NULL);
        const int found = real != NULL, no_memory = !real && errno == ENOMEM;
        path[start - 1] = '/';
        if (found) place = join_path(real, path + start);
        free(real);
        if (found || no_memory) {
            free(path);
            path = NULL;
            break;
        }
    }
    if (path) { /* no folder of it resolves: as written */
        place = path;
        path = NULL;
    }
    if (place && fold && b->case_blind) fold_case(place);
    return place;
}

/* A folder's real path as place_of gives paths; NULL when it does not
 * resolve (errno says why). */
static char *real_folder(const batch *b, const char *dir)
{
    char *real = realpath(dir, NULL);
    if (real && b->case_blind) fold_case(real);
    return real;
}

typedef struct placed {
    char *place;
    const char *name;
    size_t claim;
} placed;

/* 1 when path is inside folder (both as place_of gives them). */
static int path_inside(const char *path, const char *folder)
{
    const size_t n = strlen(folder);
    return strncmp(path, folder, n) == 0 && (path[n] == '/' || (n && folder[n - 1] == '/'));
}

static int by_place(const void *a, const void *b)
{
    const placed *x = a, *y = b;
    int d = strcmp(x->place, y->place);
    return d ? d : strcmp(x->name, y->name);
}

/* Sets every claim's file, the smallest of the names that reach the same
 * place, and whether that place is a source's (a folder of OUT_DIR that links
 * into SRC_DIR: the output would replace a source file). -1 when memory ran
 * out. */
static int claim_files(const batch *b, claims *c)
{
    placed *p = c->count ? malloc(c->count * sizeof *p) : NULL;
    if (c->count && !p) return -1;
    size_t n = 0;
    for (; n < c->count; ++n) {
        p[n] = (placed){place_of(b, c->items[n].name, 1), c->items[n].name, n};
        if (!p[n].place) break;
        c->items[n].in_source = path_inside(p[n].place, b->source_real) && !path_inside(p[n].place, b->output_real);
    }
    const int rc = n < c->count ? -1 : 0;
    if (!rc && n) qsort(p, n, sizeof *p, by_place);
    for (size_t i = 0, first = 0; !rc && i < n; ++i) {
        if (strcmp(p[i].place, p[first].place) != 0) first = i;
        c->items[p[i].claim].file = p[first].name;
    }
    for (size_t i = 0; i < n; ++i) free(p[i].place);
    free(p);
    return rc;
}

/* Marks a job failed by the batch itself, with its one-line error. */
static void fail_job(batch *b, job *j, int code, const char *message)
{
    if (j->state == JOB_PENDING && b->to_build) b->to_build--;
    j->state = JOB_FAILED;
    j->exit_code = code;
    record_free(&j->now);
    clear_progress(b);
    fprintf(stderr, "%s\n", message);
    free(j->error);
    j->error = strdup(message);
}

/* Fails every selected job that claims a name an earlier job claims with
 * other (or unknown) bytes; after the run (`after`), the earlier job too when
 * the later one's bytes replaced its file. Returns -1 when memory ran out. */
static int fail_clashes(batch *b, claims *c, int after)
{
    if (c->failed || claim_files(b, c)) return -1;
    if (c->count) qsort(c->items, c->count, sizeof *c->items, by_claim);
    for (size_t k = 0; k < c->count; ++k) {
        const claim *q = &c->items[k];
        job *j = &b->jobs[q->job];
        if (!q->in_source || j->state == JOB_SKIPPED_SHARD || j->state == JOB_FAILED) continue;
        char message[1400], *target = join_path(b->output_dir, q->name), *place = place_of(b, q->name, 0);
        lp_line(message, sizeof message, "lodpipe: %s: writes %s, which is %s in the source folder; not %s (a folder of OUT_DIR links into SRC_DIR)",
                j->source, target ? target : q->name, place ? place : "a file", after ? "recorded" : "built");
        fail_job(b, j, LP_USAGE, message);
        free(target);
        free(place);
    }
    for (size_t k = 0; k < c->count; ++k) {
        const claim *q = &c->items[k];
        for (size_t e = k; e-- > 0 && strcmp(c->items[e].file, q->file) == 0;) {
            const claim *p = &c->items[e];
            if (p->job == q->job || (p->sha256[0] && strcmp(p->sha256, q->sha256) == 0)) continue;
            job *first = &b->jobs[p->job], *later = &b->jobs[q->job];
            char message[1400], same[700] = "", *target = join_path(b->output_dir, q->name),
                                *other = join_path(b->output_dir, p->name);
            const char *t = target ? target : q->name, *o = other ? other : p->name;
            if (strcmp(p->name, q->name) != 0) lp_line(same, sizeof same, ", which is %s on this file system,", o);
            if (later->state != JOB_SKIPPED_SHARD && later->state != JOB_FAILED) {
                lp_line(message, sizeof message, "lodpipe: %s: writes %s%s as %s does; not %s (rename one of them)",
                        later->source, t, same[0] ? same : ",", first->source, after ? "recorded" : "built");
                fail_job(b, later, LP_USAGE, message);
            }
            char hex[SHA256_HEX];
            if (after && (first->state == JOB_BUILT || first->state == JOB_CACHED) &&
                (!target || sha256_file_hex(target, hex) != 0 || strcmp(hex, p->sha256) != 0)) {
                lp_line(message, sizeof message, "lodpipe: %s: its %s was replaced by the one %s writes; not recorded (rename one of them)",
                        first->source, o, later->source);
                fail_job(b, first, LP_USAGE, message);
            }
            free(target);
            free(other);
            break;
        }
    }
    return 0;
}

static void claims_free(claims *c)
{
    for (size_t i = 0; i < c->count; ++i) free(c->items[i].name);
    free(c->items);
}

/* Before the launch: what every file will write, selected or not (a clash
 * with a file of another shard fails the later file in its own shard). */
static int check_planned_outputs(batch *b)
{
    claims c = {0};
    for (size_t i = 0; i < b->job_count; ++i) {
        if (b->jobs[i].state == JOB_CACHED) claim_refs(&c, i, &b->jobs[i].now.outputs);
        else claim_planned(b, &c, i);
    }
    int rc = fail_clashes(b, &c, 0);
    claims_free(&c);
    return rc;
}

/* After the jobs: the outputs recorded for every file, with their bytes. */
static int check_written_outputs(batch *b)
{
    claims c = {0};
    for (size_t i = 0; i < b->job_count; ++i) {
        const job *j = &b->jobs[i];
        if (j->state == JOB_BUILT || j->state == JOB_CACHED) claim_refs(&c, i, &j->now.outputs);
        else if (j->state == JOB_SKIPPED_SHARD && j->old.present) claim_refs(&c, i, &j->old.outputs);
    }
    int rc = fail_clashes(b, &c, 1);
    claims_free(&c);
    return rc;
}

/* ---- the run -------------------------------------------------------------------- */

/* The jobs' pipeline.toml: the effective configuration, with the threads
 * each job gets when the configuration leaves them to lodpipe. */
static int write_job_config(batch *b, lp_error *err)
{
    lp_config config = *b->opt->config;
    if (config.run.threads == 0) config.run.threads = b->threads_per_job;
    size_t n = config_write(&config, CONFIG_TOML, NULL, 0);
    char *text = malloc(n + 1);
    if (!text) return lp_no_memory(err, "%s: out of memory", b->output_dir);
    config_write(&config, CONFIG_TOML, text, n + 1);
    snprintf(b->config_path, sizeof b->config_path, "%s/.lodpipe-batch-XXXXXX.toml", b->output_dir);
    int fd = mkstemps(b->config_path, 5);
    int rc = LP_OK;
    if (fd < 0) {
        rc = lp_fail(err, LP_IO, "%s: cannot write the jobs' configuration (%s)", b->output_dir, strerror(errno));
        b->config_path[0] = 0;
    } else {
        size_t done = 0;
        while (done < n) {
            ssize_t w = write(fd, text + done, n - done);
            if (w < 0 && errno == EINTR) continue;
            if (w <= 0) break;
            done += (size_t)w;
        }
        if (close(fd) != 0 || done != n) { /* a full disk: no empty temp file left in OUT_DIR */
            rc = lp_fail(err, LP_IO, "%s: cannot write (%s)", b->config_path, strerror(errno));
            unlink(b->config_path);
            b->config_path[0] = 0;
        }
    }
    free(text);
    return rc;
}

/* A batch told to stop (SIGINT, SIGTERM, SIGHUP): the signal, 0 while none.
 * run_jobs starts nothing more, passes SIGTERM to the running jobs (which
 * remove their temp files) and waits for them; batch_run then removes the
 * jobs' configuration, records what was built, and ends by the same signal. */
static volatile sig_atomic_t g_stop;

static void note_stop(int sig) { g_stop = sig; }

/* Runs every pending job, at most jobs_at_once at a time. */
static void run_jobs(batch *b)
{
    size_t next = 0, running = 0;
    struct pollfd *fds = calloc(2 * (size_t)b->jobs_at_once + 1, sizeof *fds);
    size_t *owner = calloc(2 * (size_t)b->jobs_at_once + 1, sizeof *owner);
    if (!fds || !owner) {
        free(fds);
        free(owner);
        for (size_t i = 0; i < b->job_count; ++i)
            if (b->jobs[i].state == JOB_PENDING) {
                b->jobs[i].state = JOB_FAILED;
                b->jobs[i].exit_code = LP_INVALID;
            }
        lp_say("%s: out of memory", b->source_dir);
        return;
    }
    const char *current = NULL;
    int stopping = 0;
    for (;;) {
        while (!g_stop && running < (size_t)b->jobs_at_once && next < b->job_count) {
            job *j = &b->jobs[next++];
            if (j->state != JOB_PENDING) continue;
            if (start_job(b, j) == 0) {
                running++;
                current = j->rel;
            } else {
                j->state = JOB_FAILED;
                b->finished_builds++;
                note_error(j, "lodpipe: the job could not start");
            }
        }
        if (g_stop && !stopping) {
            stopping = 1;
            for (size_t i = 0; i < b->job_count; ++i) {
                job *j = &b->jobs[i];
                if (j->state == JOB_RUNNING) kill(j->pid, SIGTERM);
                else if (j->state == JOB_PENDING) {
                    j->state = JOB_FAILED;
                    j->exit_code = 128 + (int)g_stop;
                    note_error(j, "lodpipe: not built: the batch was stopped");
                }
            }
        }
        if (!running) break;
        show_progress(b, current);
        size_t nfds = 0;
        for (size_t i = 0; i < b->job_count; ++i) {
            job *j = &b->jobs[i];
            if (j->state != JOB_RUNNING) continue;
            if (j->out.fd >= 0) {
                fds[nfds] = (struct pollfd){j->out.fd, POLLIN, 0};
                owner[nfds++] = i;
            }
            if (j->err.fd >= 0) {
                fds[nfds] = (struct pollfd){j->err.fd, POLLIN, 0};
                owner[nfds++] = i;
            }
        }
        /* a timeout, so that a stop arriving just before poll is seen */
        if (nfds && poll(fds, nfds, 500) > 0) {
            for (size_t k = 0; k < nfds; ++k) {
                if (!fds[k].revents) continue;
                job *j = &b->jobs[owner[k]];
                drain(fds[k].fd == j->out.fd ? &j->out : &j->err);
            }
        }
        for (size_t i = 0; i < b->job_count; ++i) {
            job *j = &b->jobs[i];
            if (j->state != JOB_RUNNING || j->out.fd >= 0 || j->err.fd >= 0) continue;
            int status = 0;
            while (waitpid(j->pid, &status, 0) < 0 && errno == EINTR) {}
            running--;
            finish_job(b, j, status);
        }
    }
    clear_progress(b);
    free(fds);
    free(owner);
}

/* ---- the summary ------------------------------------------------------------------- */

typedef struct totals {
    size_t files, built, cached, failed;
    uint64_t meshes, triangles_in, triangles_out;
    double job_seconds;
} totals;

static totals count_totals(const batch *b)
{
    totals t = {0};
    for (size_t i = 0; i < b->job_count; ++i) {
        const job *j = &b->jobs[i];
        if (j->state == JOB_SKIPPED_SHARD) continue;
        t.files++;
        if (j->state == JOB_FAILED) {
            t.failed++;
            continue;
        }
        if (j->state == JOB_BUILT) {
            t.built++;
            t.job_seconds += j->now.seconds;
        } else {
            t.cached++;
        }
        t.meshes += j->now.meshes;
        t.triangles_in += j->now.triangles_in;
        t.triangles_out += j->now.triangles_out;
    }
    return t;
}

static const char *state_name(job_state s)
{
    return s == JOB_BUILT ? "built" : s == JOB_CACHED ? "cached" : "failed";
}

static void print_json(const batch *b, const totals *t, double wall)
{
    jsonw w = {0};
    jsonw_raw(&w, "{\"source\":");
    jsonw_string(&w, b->source_dir);
    jsonw_raw(&w, ",\"output\":");
    jsonw_string(&w, b->output_dir);
    jsonw_printf(&w, ",\"jobs\":%d,\"threads_per_job\":%d,\"shard\":", b->jobs_at_once, b->threads_per_job);
    if (b->opt->shard_count) jsonw_printf(&w, "{\"index\":%u,\"count\":%u}", b->opt->shard_index, b->opt->shard_count);
    else jsonw_raw(&w, "null");
    jsonw_printf(&w, ",\"files\":%zu,\"built\":%zu,\"cached\":%zu,\"failed\":%zu,\"meshes\":%llu,\"triangles_in\":%llu,"
                     "\"triangles_out\":%llu,\"seconds\":",
                 t->files, t->built, t->cached, t->failed, (unsigned long long)t->meshes,
                 (unsigned long long)t->triangles_in, (unsigned long long)t->triangles_out);
    jsonw_number(&w, wall);
    jsonw_raw(&w, ",\"files_per_second\":");
    jsonw_number(&w, wall > 0 ? (double)t->files / wall : 0);
    jsonw_raw(&w, ",\"triangles_per_second\":");
    jsonw_number(&w, wall > 0 ? (double)t->triangles_in / wall : 0);
    jsonw_raw(&w, ",\"results\":[");
    int first = 1;
    for (size_t i = 0; i < b->job_count; ++i) {
        const job *j = &b->jobs[i];
        if (j->state == JOB_SKIPPED_SHARD) continue;
        jsonw_raw(&w, first ? "{\"file\":" : ",{\"file\":");
        jsonw_string(&w, j->rel);
        jsonw_printf(&w, ",\"status\":\"%s\",\"exit\":%d,\"meshes\":%u,\"triangles_in\":%llu,\"triangles_out\":%llu,\"seconds\":",
                     state_name(j->state), j->state == JOB_FAILED ? j->exit_code : 0, j->now.meshes,
                     (unsigned long long)j->now.triangles_in, (unsigned long long)j->now.triangles_out);
        jsonw_number(&w, j->now.seconds);
        if (j->state == JOB_FAILED) {
            jsonw_raw(&w, ",\"error\":");
            jsonw_string(&w, j->error ? j->error : "");
        }
        jsonw_raw(&w, "}");
        first = 0;
    }
    jsonw_raw(&w, "]}\n");
    fputs(w.failed ? "{}\n" : w.text, stdout);
    jsonw_free(&w);
}

static void print_table(const batch *b, const totals *t, double wall)
{
    printf("lodpipe batch: %s -> %s", b->source_dir, b->output_dir);
    if (b->opt->shard_count) printf(" (shard %u/%u)", b->opt->shard_index, b->opt->shard_count);
    printf(", -j %d, %d thread%s per job\n", b->jobs_at_once, b->threads_per_job, b->threads_per_job == 1 ? "" : "s");
    printf("%-8s %8s %8s %14s %14s %10s\n", "", "files", "meshes", "triangles in", "triangles out", "seconds");
    uint64_t m[2] = {0, 0}, in[2] = {0, 0}, out[2] = {0, 0};
    double s[2] = {0, 0};
    for (size_t i = 0; i < b->job_count; ++i) {
        const job *j = &b->jobs[i];
        if (j->state != JOB_BUILT && j->state != JOB_CACHED) continue;
        int k = j->state == JOB_CACHED;
        m[k] += j->now.meshes;
        in[k] += j->now.triangles_in;
        out[k] += j->now.triangles_out;
        s[k] += j->state == JOB_BUILT ? j->now.seconds : 0;
    }
    printf("%-8s %8zu %8llu %14llu %14llu %10.2f\n", "built", t->built, (unsigned long long)m[0], (unsigned long long)in[0],
           (unsigned long long)out[0], s[0]);
    printf("%-8s %8zu %8llu %14llu %14llu %10s\n", "cached", t->cached, (unsigned long long)m[1], (unsigned long long)in[1],
           (unsigned long long)out[1], "-");
    printf("%-8s %8zu %8s %14s %14s %10s\n", "failed", t->failed, "-", "-", "-", "-");
    printf("%-8s %8zu %8llu %14llu %14llu %10.2f\n", "total", t->files, (unsigned long long)t->meshes,
           (unsigned long long)t->triangles_in, (unsigned long long)t->triangles_out, wall);
    printf("wall %.2f s: %.2f files/s, %.0f triangles/s\n", wall, wall > 0 ? (double)t->files / wall : 0.0,
           wall > 0 ? (double)t->triangles_in / wall : 0.0);
    for (size_t i = 0; i < b->job_count; ++i)
        if (b->jobs[i].state == JOB_FAILED) { /* a name's control characters escaped, as on stderr */
            char line[4 * 4096 + 64]; /* an escaped byte takes up to 4 */
            printf("%s\n", lp_line(line, sizeof line, "failed: %s (exit %d)", b->jobs[i].rel, b->jobs[i].exit_code));
        }
}

/* ---- setup ----------------------------------------------------------------------- */

static int make_folders(const char *path)
{
    if (make_parent_folders(path) != 0) return -1;
    return mkdir(path, 0777) != 0 && errno != EEXIST ? -1 : 0;
}

/* 1 when folder (as stat gave it) is an ancestor of path: the job for
 * SRC_DIR/R writes OUT_DIR/R, which for OUT_DIR = SRC_DIR/.. and R = "src/x"
 * is SRC_DIR/src/x, another job's source. -1 when memory ran out (the
 * answer is not known, and a "no" could let an output replace a source). */
static int folder_contains(const struct stat *folder, const char *path)
{
    char *real = realpath(path, NULL);
    if (!real) return errno == ENOMEM ? -1 : 0;
    int found = 0;
    for (char *slash; !found && (slash = strrchr(real, '/')) != NULL;) {
        slash[slash == real] = 0; /* "/a" -> "/", "/a/b" -> "/a" */
        struct stat st;
        found = stat(real, &st) == 0 && st.st_dev == folder->st_dev && st.st_ino == folder->st_ino;
        if (slash == real) break;
    }
    free(real);
    return found;
}

static int prepare(batch *b, lp_error *err)
{
    struct stat src;
    if (stat(b->source_dir, &src) != 0 || !S_ISDIR(src.st_mode))
        return lp_fail(err, LP_IO, "%s: not a readable folder", b->source_dir);
    if (make_folders(b->output_dir) != 0 || stat(b->output_dir, &b->output_stat) != 0 || !S_ISDIR(b->output_stat.st_mode))
        return errno == ENOMEM ? lp_no_memory(err, "%s: out of memory", b->output_dir)
                               : lp_fail(err, LP_IO, "%s: cannot create the output folder (%s)", b->output_dir, strerror(errno));
    if (src.st_dev == b->output_stat.st_dev && src.st_ino == b->output_stat.st_ino)
        return lp_fail(err, LP_USAGE, "%s: the output folder must differ from the source folder", b->output_dir);
    /* the manifest is written after every job: a path it cannot take (a
     * folder there) is reported now, not after all the work */
    char *manifest = join_path(b->output_dir, MANIFEST_NAME);
    struct stat st;
    int rc = LP_OK;
    if (!manifest) rc = lp_no_memory(err, "%s: out of memory", b->output_dir);
    else if (lstat(manifest, &st) == 0 && S_ISDIR(st.st_mode))
        rc = lp_fail(err, LP_IO, "%s: cannot write the cache manifest (Is a directory)", manifest);
    else if (access(b->output_dir, W_OK) != 0)
        rc = lp_fail(err, LP_IO, "%s: cannot write the cache manifest (%s)", manifest, strerror(errno));
    free(manifest);
    if (rc) return rc;
    b->case_blind = output_folder_ignores_case(b->output_dir);
    const char *unresolved = !(b->source_real = real_folder(b, b->source_dir)) ? b->source_dir
                             : !(b->output_real = real_folder(b, b->output_dir)) ? b->output_dir
                                                                                 : NULL;
    if (unresolved)
        return errno == ENOMEM ? lp_no_memory(err, "%s: out of memory", unresolved)
                               : lp_fail(err, LP_IO, "%s: cannot resolve the folder (%s)", unresolved, strerror(errno));
    const int inside = folder_contains(&b->output_stat, b->source_dir);
    if (inside < 0) return lp_no_memory(err, "%s: out of memory", b->output_dir);
    if (inside)
        return lp_fail(err, LP_USAGE,
                       "%s: the output folder must not contain the source folder (an output could replace a source)",
                       b->output_dir);
    ssize_t n = readlink("/proc/self/exe", b->self, sizeof b->self - 1);
    if (n <= 0 || (size_t)n >= sizeof b->self - 1) return lp_fail(err, LP_IO, "cannot find the lodpipe binary (/proc/self/exe)");
    b->self[n] = 0;
    rc = scan(b, "", 0, err);
    if (rc) return rc;
    if (b->job_count) qsort(b->jobs, b->job_count, sizeof *b->jobs, by_relative_path); /* jobs is NULL when none */
    if (compute_key_prefix(b)) return lp_no_memory(err, "%s: out of memory", b->output_dir);
    return LP_OK;
}

/* Marks each job as outside the shard, cached or pending. */
static void select_jobs(batch *b)
{
    for (size_t i = 0; i < b->job_count; ++i) {
        job *j = &b->jobs[i];
        if (b->opt->shard_count && batch_shard_of(j->rel, b->opt->shard_count) != b->opt->shard_index - 1) {
            j->state = JOB_SKIPPED_SHARD;
            continue;
        }
        b->selected++;
        if (!b->opt->force && still_cached(b, j)) {
            j->state = JOB_CACHED;
        } else {
            j->state = JOB_PENDING;
            b->to_build++;
        }
    }
}

static void free_batch(batch *b)
{
    for (size_t i = 0; i < b->job_count; ++i) {
        job *j = &b->jobs[i];
        free(j->rel);
        free(j->source);
        free(j->output);
        free(j->error);
        free(j->out.bytes);
        free(j->err.bytes);
        record_free(&j->old);
        record_free(&j->now);
        refs_free(&j->before);
    }
    free(b->jobs);
    free(b->source_dir);
    free(b->output_dir);
    free(b->source_real);
    free(b->output_real);
}

int batch_run(const batch_options *options)
{
    batch b;
    memset(&b, 0, sizeof b);
    b.opt = options;
    b.start = lp_seconds();
    b.source_dir = strip_slashes(options->source_dir);
    b.output_dir = strip_slashes(options->output_dir);
    lp_error err = {0, "", 0};
    int rc = b.source_dir && b.output_dir ? prepare(&b, &err)
                                          : lp_no_memory(&err, "%s: out of memory", options->source_dir);
    if (rc) {
        lp_say("%s", err.msg);
        free_batch(&b);
        return rc;
    }
    b.progress = !options->quiet && isatty(STDERR_FILENO);
    load_manifest(&b);
    select_jobs(&b);
    if (check_planned_outputs(&b) != 0) {
        lp_say("%s: out of memory", b.output_dir);
        free_batch(&b);
        return LP_INVALID;
    }
    const int cores = (int)lp_threads(0, 256);
    b.jobs_at_once = options->jobs > 0 ? options->jobs : cores;
    if (b.to_build && (size_t)b.jobs_at_once > b.to_build) b.jobs_at_once = (int)b.to_build;
    b.threads_per_job = options->config->run.threads ? options->config->run.threads
                                                      : (cores / b.jobs_at_once > 1 ? cores / b.jobs_at_once : 1);
    stopsig_saved before;
    stopsig_catch(note_stop, &before);
    if (b.to_build) {
        rc = write_job_config(&b, &err);
        if (rc) {
            lp_say("%s", err.msg);
            free_batch(&b);
            stopsig_restore(&before);
            return rc;
        }
        run_jobs(&b);
        unlink(b.config_path);
        /* unchecked outputs are not recorded: the next run builds them again */
        if (check_written_outputs(&b) != 0) rc = lp_no_memory(&err, "%s: out of memory checking the jobs' outputs", b.output_dir);
    }
    double wall = lp_seconds() - b.start;
    totals t = count_totals(&b);
    if (!rc) rc = write_manifest(&b, &err);
    if (rc) lp_say("%s", err.msg);
    if (options->json) print_json(&b, &t, wall);
    else print_table(&b, &t, wall);
    fflush(stdout);
    free_batch(&b);
    stopsig_restore(&before);
    if (g_stop) raise(g_stop); /* stopped: end the way the signal would have */
    if (t.failed) return LP_SOME_FAILED;
    return rc;
}
