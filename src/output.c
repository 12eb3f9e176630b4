/* output.c - see output.h. */
#include "output.h"
#include "stopsig.h"

#include <assert.h>
#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

static void folder_of(const char *path, char *out, size_t size)
{
    const char *slash = strrchr(path, '/');
    if (!slash) snprintf(out, size, ".");
    else if (slash == path) snprintf(out, size, "/");
    else snprintf(out, size, "%.*s", (int)(slash - path), path);
}

static int same_bytes(const char *path, const uint8_t *bytes, size_t size)
{
    struct stat st;
    if (stat(path, &st) != 0 || !S_ISREG(st.st_mode) || (size_t)st.st_size != size) return 0;
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    int same = 1;
    uint8_t buf[65536];
    size_t pos = 0, got;
    while (same && (got = fread(buf, 1, sizeof buf, f)) > 0) {
        if (pos + got > size || memcmp(buf, bytes + pos, got) != 0) same = 0;
        pos += got;
    }
    fclose(f);
    return same && pos == size;
}

/* Creates the folders of a relative name below base (for "Textures/x.png");
 * refuses names that climb out of base. */
static int make_parents(const char *base, const char *name, lp_error *err)
{
    if (name[0] == '/' || strstr(name, "..")) return lp_fail(err, LP_IO, "refusing to write outside the output folder: %s", name);
    char path[4096];
    for (const char *p = strchr(name, '/'); p; p = strchr(p + 1, '/')) {
        int len = snprintf(path, sizeof path, "%s/%.*s", base, (int)(p - name), name);
        if (len < 0 || (size_t)len >= sizeof path) return lp_fail(err, LP_IO, "path too long: %s", name);
        if (mkdir(path, 0777) != 0 && errno != EEXIST)
            return lp_fail(err, LP_IO, "cannot create folder %s (%s)", path, strerror(errno));
    }
    return LP_OK;
}

/* Writes bytes to fd, a new temp file for target, and closes it. */
static int fill_temp(int fd, const char *target, const uint8_t *bytes, size_t size, lp_error *err)
{
    mode_t mask = umask(0);
    umask(mask);
    fchmod(fd, 0666 & ~mask);
    size_t done = 0;
    while (done < size) {
        ssize_t n = write(fd, bytes + done, size - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            int e = n < 0 ? errno : ENOSPC;
            close(fd);
            return lp_fail(err, LP_IO, "cannot write %s (%s)", target, strerror(e));
        }
        done += (size_t)n;
    }
    if (fsync(fd) != 0 && errno != EINVAL) {
        int e = errno;
        close(fd);
        return lp_fail(err, LP_IO, "cannot write %s (%s)", target, strerror(e));
    }
    if (close(fd) != 0) return lp_fail(err, LP_IO, "cannot write %s (%s)", target, strerror(errno));
    return LP_OK;
}

/* Refuses a target the rename could not replace, before any is renamed:
 * rename(2) fails over a folder, and a failure between two renames would
 * leave the output half replaced. */
static int target_replaceable(const char *target, lp_error *err)
{
    struct stat st;
    if (lstat(target, &st) == 0 && S_ISDIR(st.st_mode)) return lp_fail(err, LP_IO, "cannot write %s (Is a directory)", target);
    return LP_OK;
}

int output_check_folder(const char *main_path, lp_error *err)
{
    char base[4096];
    folder_of(main_path, base, sizeof base);
    struct stat st;
    if (stat(base, &st) != 0) return lp_fail(err, LP_IO, "output folder %s does not exist", base);
    if (!S_ISDIR(st.st_mode)) return lp_fail(err, LP_IO, "output folder %s is not a folder", base);
    if (access(base, W_OK) != 0) return lp_fail(err, LP_IO, "output folder %s is not writable", base);
    return target_replaceable(main_path, err);
}

/* The set being written, for a signal that ends the process midway (Ctrl-C,
 * a batch stopping its jobs): its handler removes the temp files, so that no
 * "OUT.lodpipe-XXXXXX" is left behind, then ends the process by the same
 * signal. The handler reads temps[0 .. count); they change only with the stop
 * signals blocked (a temp is created and listed in one such step, so the
 * handler sees whole names of files this process made). One set at a time
 * per process, staged and committed while no other thread runs (output.h). */
struct output_set {
    char (*temps)[4200];   /* "" once renamed */
    char (*targets)[4200];
    size_t count, capacity;
    stopsig_saved before;
    sigset_t held_before;  /* the mask before output_commit held the signals */
    int held;
};

static output_set *volatile g_set;

static void remove_temps_and_die(int sig)
{
    const output_set *set = g_set;
    for (size_t i = 0; set && i < set->count; ++i)
        if (set->temps[i][0]) unlink(set->temps[i]);
    signal(sig, SIG_DFL);
    raise(sig);
}

int output_set_begin(output_set **out, lp_error *err)
{
    assert(!g_set); /* one set at a time: the handler knows one */
    output_set *set = calloc(1, sizeof *set);
    if (!set) return lp_no_memory(err, "out of memory");
    g_set = set;
    stopsig_catch(remove_temps_and_die, &set->before);
    *out = set;
    return LP_OK;
}

int output_stage(output_set *set, const char *target, const uint8_t *bytes, size_t size, lp_error *err)
{
    char temp[4200];
    if (target_replaceable(target, err)) return LP_IO;
    if (snprintf(temp, sizeof temp, "%s.lodpipe-XXXXXX", target) >= (int)sizeof temp)
        return lp_fail(err, LP_IO, "path too long: %s", target);
    sigset_t old;
    stopsig_block(&old);
    int rc = LP_OK, fd = -1;
    if (set->count == set->capacity) {
        const size_t capacity = set->capacity ? 2 * set->capacity : 8;
        char(*temps)[4200] = realloc(set->temps, capacity * sizeof *temps);
        if (temps) set->temps = temps;
        char(*targets)[4200] = temps ? realloc(set->targets, capacity * sizeof *targets) : NULL;
        if (targets) set->targets = targets, set->capacity = capacity;
        else rc = lp_no_memory(err, "out of memory");
    }
    if (!rc && (fd = mkstemp(temp)) < 0) rc = lp_fail(err, LP_IO, "cannot create a file beside %s (%s)", target, strerror(errno));
    if (!rc) {
        memcpy(set->targets[set->count], target, strlen(target) + 1);
        memcpy(set->temps[set->count], temp, strlen(temp) + 1);
        atomic_signal_fence(memory_order_seq_cst); /* listed whole before it is counted */
        set->count++;
    }
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    return rc ? rc : fill_temp(fd, target, bytes, size, err);
}

int output_commit(output_set *set, lp_error *err)
{
    for (size_t i = 0; i < set->count; ++i)
        if (set->temps[i][0] && target_replaceable(set->targets[i], err)) return LP_IO;
    /* held from the first rename on: a stop then takes effect after the
     * last one (output_set_end), never between two */
    if (!set->held) {
        stopsig_block(&set->held_before);
        set->held = 1;
    }
    for (size_t i = 0; i < set->count; ++i) {
        if (!set->temps[i][0]) continue;
        if (rename(set->temps[i], set->targets[i]) != 0)
            return lp_fail(err, LP_IO, "cannot write %s (%s)", set->targets[i], strerror(errno));
        set->temps[i][0] = 0;
    }
    return LP_OK;
}

void output_set_end(output_set *set)
{
    if (!set) return;
    sigset_t old;
    stopsig_block(&old); /* the handler must not read the set while it goes */
    for (size_t i = 0; i < set->count; ++i)
        if (set->temps[i][0]) unlink(set->temps[i]);
    stopsig_restore(&set->before);
    g_set = NULL;
    /* a stop that came meanwhile is taken now, by the disposition restored */
    pthread_sigmask(SIG_SETMASK, set->held ? &set->held_before : &old, NULL);
    free(set->temps);
    free(set->targets);
    free(set);
}

int output_write_all(const char *main_path, const gltf_out_file *files, size_t count, const output_file *also,
                     size_t also_count, const output_guard *guards, size_t guard_count, lp_error *err)
{
    char base[4096];
    folder_of(main_path, base, sizeof base);
    int rc = output_check_folder(main_path, err);
    if (rc) return rc;
    char (*targets)[4200] = calloc(count ? count : 1, sizeof *targets);
    if (!targets) return lp_no_memory(err, "out of memory");
    for (size_t i = 0; i < count && !rc; ++i) {
        if (i == 0) snprintf(targets[i], sizeof targets[i], "%s", main_path);
        else snprintf(targets[i], sizeof targets[i], "%s/%s", base, files[i].name);
        for (size_t g = 0; g < guard_count && !rc; ++g)
            if (output_same_path(targets[i], guards[g].path) && !same_bytes(targets[i], files[i].bytes, files[i].size))
                rc = lp_fail(err, LP_USAGE, "%s (written with the output) is %s; choose another output name", targets[i],
                             guards[g].why);
    }
    /* two of the files are one with other bytes: the later would silently
     * replace the earlier (an input's image named like the output's .bin;
     * images T.png and t.png written to an exFAT or Windows share) */
    for (size_t i = 0; i < count && !rc; ++i)
        for (size_t k = i + 1; k < count && !rc; ++k) {
            if (strcasecmp(targets[i], targets[k]) != 0 ||
                (files[i].size == files[k].size &&
                 (!files[i].size || memcmp(files[i].bytes, files[k].bytes, files[i].size) == 0)))
                continue;
            if (strcmp(targets[i], targets[k]) == 0)
                rc = lp_fail(err, LP_USAGE, "%s (written with the output) would be two files with other bytes (an input "
                                            "file named like one the output writes); choose another output name",
                             targets[i]);
            else if (output_folder_ignores_case(base))
                rc = lp_fail(err, LP_USAGE, "%s and %s (written with the output) are one file on this file system; rename one of them",
                             targets[i], targets[k]);
        }
    for (size_t i = 0; i < also_count && !rc; ++i) rc = output_check_folder(also[i].path, err);
    output_set *set = NULL;
    if (!rc) rc = output_set_begin(&set, err); /* before anything is written */
    /* the files beside the main one first, the main file last: a reader
     * never sees a main file whose buffers are missing */
    for (size_t i = 0; i < also_count && !rc; ++i) rc = output_stage(set, also[i].path, also[i].bytes, also[i].size, err);
    for (size_t k = 1; k <= count && !rc; ++k) {
        const size_t i = k % count;
        if (i > 0 && same_bytes(targets[i], files[i].bytes, files[i].size)) continue;
        if (i > 0) rc = make_parents(base, files[i].name, err);
        if (!rc) rc = output_stage(set, targets[i], files[i].bytes, files[i].size, err);
    }
    if (!rc) rc = output_commit(set, err);
    output_set_end(set);
    free(targets);
    return rc;
}

int output_folder_ignores_case(const char *folder)
{
    char lower[4200], upper[4200];
    const long pid = (long)getpid();
    const int nl = snprintf(lower, sizeof lower, "%s/.lodpipe-case-probe-%ld", folder, pid);
    const int nu = snprintf(upper, sizeof upper, "%s/.LODPIPE-CASE-PROBE-%ld", folder, pid);
    if (nl < 0 || nu < 0 || (size_t)nl >= sizeof lower || (size_t)nu >= sizeof upper) return 0;
    const int fd = open(lower, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd < 0) return 0;
    close(fd);
    const int blind = access(upper, F_OK) == 0;
    unlink(lower);
    return blind;
}

/* The real path of path's folder joined with its last name, in out; 0 when
 * the folder does not resolve. */
static int canonical_entry(const char *path, char *out, size_t size)
{
    char folder[4096], *real;
    folder_of(path, folder, sizeof folder);
    const char *slash = strrchr(path, '/');
    const char *name = slash ? slash + 1 : path;
    if (!*name || !(real = realpath(folder, NULL))) return 0;
    const int n = snprintf(out, size, "%s/%s", real, name);
    free(real);
    return n >= 0 && (size_t)n < size;
}

/* 1 when a and b are one entry of one folder but for ASCII case, on a file
 * system that ignores case: one file, which an identity check misses when
 * neither exists yet, or when the file system gives each name its own inode
 * number (a FUSE exFAT volume does). */
static int case_variants(const char *a, const char *b)
{
    const char *na = strrchr(a, '/'), *nb = strrchr(b, '/');
    if (strcasecmp(na ? na + 1 : a, nb ? nb + 1 : b) != 0) return 0; /* the common case, without a system call */
    char ca[8192], cb[8192], folder[8192];
    if (!canonical_entry(a, ca, sizeof ca) || !canonical_entry(b, cb, sizeof cb)) return 0;
    if (strcmp(ca, cb) == 0 || strcasecmp(ca, cb) != 0) return 0;
    folder_of(ca, folder, sizeof folder);
    return output_folder_ignores_case(folder);
}

int output_same_file(const char *a, const char *b)
{
    struct stat sa, sb;
    if (stat(a, &sa) != 0 || stat(b, &sb) != 0) return 0;
    return (sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino) || case_variants(a, b);
}

int output_same_path(const char *a, const char *b)
{
    struct stat sa, sb;
    const int ea = stat(a, &sa) == 0, eb = stat(b, &sb) == 0;
    if (ea && eb) return (sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino) || case_variants(a, b);
    if (ea || eb) return 0;
    char ca[8192], cb[8192];
    if (canonical_entry(a, ca, sizeof ca) && canonical_entry(b, cb, sizeof cb) && strcmp(ca, cb) == 0) return 1;
    return case_variants(a, b);
}
