/* failmalloc.c - an LD_PRELOAD library that makes one allocation fail, for
 * tests/oom.test.mjs: every path that runs out of memory must end in a
 * one-line error and no output (or in the same output, when the program
 * could do without the memory), never in a crash.
 *
 * Counting starts when main starts (the C++ runtime's own start-up is not
 * lodpipe's to handle). The allocations malloc, calloc, realloc,
 * aligned_alloc, posix_memalign and memalign are numbered from 1 across all
 * threads; C++'s operator new comes through malloc (not under
 * AddressSanitizer, whose operator new is its own: there only the C
 * allocations are counted).
 *
 *   FAIL_AT=N          allocation N fails (0 or unset: none)
 *   FAIL_LEN=K         ... and the K - 1 after it (default 1)
 *   FAIL_COUNT_FILE=F  writes the number of allocations to F when main returns
 *   FAIL_MAIN_ONLY=1   the program's children (batch jobs) run without this
 *                      library: LD_PRELOAD leaves the environment before main
 *
 * Built by `make test` as build/failmalloc.so (tests only; never linked into
 * lodpipe). */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef void *(*malloc_fn)(size_t);
typedef void *(*calloc_fn)(size_t, size_t);
typedef void *(*realloc_fn)(void *, size_t);
typedef void *(*aligned_fn)(size_t, size_t);
typedef int (*posix_memalign_fn)(void **, size_t, size_t);
typedef void (*free_fn)(void *);

static malloc_fn real_malloc;
static calloc_fn real_calloc;
static realloc_fn real_realloc;
static aligned_fn real_aligned_alloc, real_memalign;
static posix_memalign_fn real_posix_memalign;
static free_fn real_free;

static atomic_long allocations;
static atomic_int counting;
static long fail_first, fail_count = 1;

/* dlsym may allocate (calloc) before the real functions are known: such
 * early blocks come from here and are never freed. */
static _Alignas(16) char early[16384];
static size_t early_used;

static void *early_block(size_t n)
{
    n = (n + 15) & ~(size_t)15;
    if (early_used + n > sizeof early) return NULL;
    void *p = early + early_used;
    early_used += n;
    return p;
}

static int is_early(const void *p) { return (const char *)p >= early && (const char *)p < early + sizeof early; }

static void resolve(void)
{
    static int resolving;
    if (real_malloc || resolving) return;
    resolving = 1;
    real_calloc = (calloc_fn)dlsym(RTLD_NEXT, "calloc");
    real_realloc = (realloc_fn)dlsym(RTLD_NEXT, "realloc");
    real_aligned_alloc = (aligned_fn)dlsym(RTLD_NEXT, "aligned_alloc");
    real_memalign = (aligned_fn)dlsym(RTLD_NEXT, "memalign");
    real_posix_memalign = (posix_memalign_fn)dlsym(RTLD_NEXT, "posix_memalign");
    real_free = (free_fn)dlsym(RTLD_NEXT, "free");
    real_malloc = (malloc_fn)dlsym(RTLD_NEXT, "malloc");
    resolving = 0;
}

/* 1 when this allocation is to fail. */
static int fail_now(void)
{
    if (!atomic_load(&counting)) return 0;
    const long n = atomic_fetch_add(&allocations, 1) + 1;
    return fail_first > 0 && n >= fail_first && n < fail_first + fail_count;
}

void *malloc(size_t n)
{
    resolve();
    if (!real_malloc) return early_block(n);
    if (fail_now()) return errno = ENOMEM, NULL;
    return real_malloc(n);
}

void *calloc(size_t a, size_t b)
{
    resolve();
    if (!real_calloc) return early_block(a * b); /* static storage: already zero */
    if (fail_now()) return errno = ENOMEM, NULL;
    return real_calloc(a, b);
}

void *realloc(void *p, size_t n)
{
    resolve();
    if (is_early(p)) { /* its size is unknown: copy what the early store holds from p on, at most n */
        const size_t room = (size_t)(early + sizeof early - (char *)p);
        void *q = malloc(n);
        if (q) memcpy(q, p, n < room ? n : room);
        return q;
    }
    if (fail_now()) return errno = ENOMEM, NULL;
    return real_realloc(p, n);
}

void free(void *p)
{
    if (!p || is_early(p)) return;
    resolve();
    real_free(p);
}

void *aligned_alloc(size_t a, size_t n)
{
    resolve();
    if (fail_now()) return errno = ENOMEM, NULL;
    return real_aligned_alloc(a, n);
}

void *memalign(size_t a, size_t n)
{
    resolve();
    if (fail_now()) return errno = ENOMEM, NULL;
    return real_memalign(a, n);
}

int posix_memalign(void **out, size_t a, size_t n)
{
    resolve();
    if (fail_now()) return ENOMEM;
    return real_posix_memalign(out, a, n);
}

/* main runs inside wrapped_main, so counting covers exactly lodpipe's own run. */
typedef int (*main_fn)(int, char **, char **);
static main_fn program_main;

static int wrapped_main(int argc, char **argv, char **envp)
{
    const char *at = getenv("FAIL_AT"), *len = getenv("FAIL_LEN");
    fail_first = at ? atol(at) : 0;
    fail_count = len ? atol(len) : 1;
    const char *main_only = getenv("FAIL_MAIN_ONLY");
    if (main_only && strcmp(main_only, "1") == 0) unsetenv("LD_PRELOAD");
    atomic_store(&counting, 1);
    const int rc = program_main(argc, argv, envp);
    atomic_store(&counting, 0);
    const char *count_file = getenv("FAIL_COUNT_FILE");
    FILE *f = count_file ? fopen(count_file, "w") : NULL;
    if (f) {
        fprintf(f, "%ld\n", atomic_load(&allocations));
        fclose(f);
    }
    return rc;
}

typedef int (*start_fn)(main_fn, int, char **, void (*)(void), void (*)(void), void (*)(void), void *);

int __libc_start_main(main_fn m, int argc, char **argv, void (*init)(void), void (*fini)(void), void (*rtld_fini)(void),
                      void *stack_end)
{
    start_fn real_start = (start_fn)dlsym(RTLD_NEXT, "__libc_start_main");
    program_main = m;
    return real_start(wrapped_main, argc, argv, init, fini, rtld_fini, stack_end);
}
