/* test_facegrid.c - the face grid against brute force over stored boxes:
 * random inserts, moves and removes, random queries (every present face whose
 * box overlaps the query is reported, exactly once; absent faces never), the
 * big-face list (wide, huge, non-finite and inverted boxes), growth of every
 * pool, steady state without allocation, clear, early stop, and determinism
 * of the report order. */
#include "check.h"
#include "facegrid.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define RNG_SEED 0x66616365677269ULL
#include "rng.h"

static uint32_t rng_below(uint32_t n)
{
    return (uint32_t)(rng_next() % n);
}

/* ---- brute force ---------------------------------------------------------- */

#define FACES 3000

typedef struct {
    int present;
    double lo[3], hi[3];
} shadow_face;

static shadow_face shadow[FACES];

/* Reports collected by a query. */
typedef struct {
    uint32_t count[FACES];
    uint32_t order[4 * FACES];
    uint32_t total;
    uint32_t stop_after; /* 0: never stop */
} collector;

static int collect(void *context, uint32_t face)
{
    collector *c = context;
    if (face < FACES) c->count[face]++;
    if (c->total < 4 * FACES) c->order[c->total] = face;
    c->total++;
    return c->stop_after && c->total >= c->stop_after ? 7 : 0;
}

static int boxes_overlap(const double *alo, const double *ahi, const double *blo, const double *bhi)
{
    for (int k = 0; k < 3; k++)
        if (ahi[k] < blo[k] || bhi[k] < alo[k]) return 0;
    return 1;
}

static int box_is_ordinary(const double *lo, const double *hi)
{
    for (int k = 0; k < 3; k++)
        if (!isfinite(lo[k]) || !isfinite(hi[k]) || !(lo[k] <= hi[k])) return 0;
    return 1;
}

static void random_box(double lo[3], double hi[3])
{
    int kind = (int)rng_below(100);
    for (int k = 0; k < 3; k++) {
        double c = rng_uniform(-50, 50);
        double size = kind < 70 ? rng_uniform(0, 2) : kind < 90 ? rng_uniform(0, 20) : rng_uniform(0, 150);
        if (kind == 95) size = 0; /* a point */
        lo[k] = c - size * rng_uniform(0, 1);
        hi[k] = lo[k] + size;
    }
    if (kind == 96) lo[rng_below(3)] = NAN;
    if (kind == 97) hi[rng_below(3)] = INFINITY;
    if (kind == 98) {
        int k = (int)rng_below(3);
        lo[k] = 1e300;
        hi[k] = 1e300;
    }
    if (kind == 99) { /* inverted */
        int k = (int)rng_below(3);
        double t = lo[k];
        lo[k] = hi[k] + 1;
        hi[k] = t;
    }
}

/* Runs one query and checks it against the shadow boxes. Returns the
 * number of problems. */
static int check_query(const facegrid *g, const double lo[3], const double hi[3])
{
    static collector c;
    memset(&c, 0, sizeof c);
    int r = facegrid_query(g, lo, hi, collect, &c);
    int problems = 0;
    CHECK(r == 0, "query returned %d", r);
    int any_nan = 0, inverted = 0;
    for (int k = 0; k < 3; k++) {
        any_nan |= isnan(lo[k]) || isnan(hi[k]);
        inverted |= lo[k] > hi[k];
    }
    for (uint32_t f = 0; f < FACES; f++) {
        if (c.count[f] > 1) {
            problems++;
            if (problems < 5) CHECK(0, "face %u reported %u times", f, c.count[f]);
        }
        if (!shadow[f].present) {
            if (c.count[f]) {
                problems++;
                if (problems < 5) CHECK(0, "absent face %u reported", f);
            }
            continue;
        }
        int must = any_nan || !box_is_ordinary(shadow[f].lo, shadow[f].hi) ||
                   (!inverted && boxes_overlap(shadow[f].lo, shadow[f].hi, lo, hi));
        if (must && !c.count[f]) {
            problems++;
            if (problems < 5) CHECK(0, "overlapping face %u not reported", f);
        }
    }
    return problems;
}

/* ---- tests ---------------------------------------------------------------- */

static void test_random_against_brute_force(void)
{
    facegrid g;
    memset(shadow, 0, sizeof shadow);
    CHECK(facegrid_init(&g, 1.5, FACES) == FACEGRID_OK, "init");
    int problems = 0, queries = 0;
    for (int round = 0; round < 40; round++) {
        for (int op = 0; op < 400; op++) {
            uint32_t f = rng_below(FACES);
            if (rng_below(4) == 0) {
                facegrid_remove(&g, f);
                shadow[f].present = 0;
            } else {
                double lo[3], hi[3];
                random_box(lo, hi);
                CHECK(facegrid_insert(&g, f, lo, hi) == FACEGRID_OK, "insert");
                shadow[f].present = 1;
                memcpy(shadow[f].lo, lo, sizeof lo);
                memcpy(shadow[f].hi, hi, sizeof hi);
            }
        }
        uint32_t present = 0;
        for (uint32_t f = 0; f < FACES; f++) {
            present += shadow[f].present;
            if (facegrid_contains(&g, f) != shadow[f].present) problems++;
        }
        CHECK(g.face_count == present, "face_count %u, expected %u", g.face_count, present);
        for (int q = 0; q < 30; q++) {
            double lo[3], hi[3];
            random_box(lo, hi);
            if (q == 0)
                for (int k = 0; k < 3; k++) {
                    lo[k] = -INFINITY;
                    hi[k] = INFINITY;
                }
            problems += check_query(&g, lo, hi);
            queries++;
        }
    }
    CHECK(problems == 0, "%d problems in %d queries", problems, queries);
    facegrid_free(&g);
}

/* The simplifier keeps a changed face's entries when facegrid_same_cells
 * says its new box lies in the same cells: queries must then still report
 * every face whose NEW box overlaps them. Faces are moved by small jitters
 * (mostly the same cells) and sometimes to a fresh random box. */
static void test_same_cells_moves(void)
{
    facegrid g;
    memset(shadow, 0, sizeof shadow);
    CHECK(facegrid_init(&g, 1.5, FACES) == FACEGRID_OK, "init");
    for (uint32_t f = 0; f < FACES; f++) {
        random_box(shadow[f].lo, shadow[f].hi);
        CHECK(facegrid_insert(&g, f, shadow[f].lo, shadow[f].hi) == FACEGRID_OK, "insert");
        shadow[f].present = 1;
    }
    int problems = 0, kept = 0, moved = 0;
    for (int round = 0; round < 40; round++) {
        for (int op = 0; op < 400; op++) {
            uint32_t f = rng_below(FACES);
            double lo[3], hi[3];
            if (rng_below(8) == 0) {
                random_box(lo, hi);
            } else {
                for (int k = 0; k < 3; k++) {
                    lo[k] = shadow[f].lo[k] + rng_uniform(-0.3, 0.3);
                    hi[k] = shadow[f].hi[k] + rng_uniform(-0.3, 0.3);
                }
            }
            if (facegrid_same_cells(&g, shadow[f].lo, shadow[f].hi, lo, hi)) {
                kept++;
            } else {
                CHECK(facegrid_insert(&g, f, lo, hi) == FACEGRID_OK, "move");
                moved++;
            }
            memcpy(shadow[f].lo, lo, sizeof lo);
            memcpy(shadow[f].hi, hi, sizeof hi);
        }
        for (int q = 0; q < 30; q++) {
            double lo[3], hi[3];
            random_box(lo, hi);
            problems += check_query(&g, lo, hi);
        }
    }
    CHECK(problems == 0, "%d problems after %d kept and %d moved faces", problems, kept, moved);
    CHECK(kept > 1000 && moved > 1000, "both paths exercised: %d kept, %d moved", kept, moved);
    const double lo[3] = {0.1, 0.1, 0.1}, hi[3] = {1.4, 1.4, 1.4}, hi_next[3] = {1.6, 1.4, 1.4};
    const double lo_nan[3] = {NAN, 0.1, 0.1};
    CHECK(facegrid_same_cells(&g, lo, hi, lo, hi) == 1, "a box has its own cells");
    CHECK(facegrid_same_cells(&g, lo, hi, lo, hi_next) == 0, "a box reaching the next cell");
    CHECK(facegrid_same_cells(&g, lo_nan, hi, lo_nan, hi) == 0, "the big list is never the same cells");
    facegrid_free(&g);
}

static void test_big_faces(void)
{
    facegrid g;
    memset(shadow, 0, sizeof shadow);
    CHECK(facegrid_init(&g, 1.0, FACES) == FACEGRID_OK, "init");
    double lo[3] = {0, 0, 0}, hi[3] = {20, 20, 20}; /* 21^3 = 9261 cells > 4096 */
    CHECK(facegrid_insert(&g, 5, lo, hi) == FACEGRID_OK, "wide");
    double lo2[3] = {0, 0, 0}, hi2[3] = {15, 15, 15}; /* 16^3 = 4096 cells: not big */
    CHECK(facegrid_insert(&g, 6, lo2, hi2) == FACEGRID_OK, "just small enough");
    double lo3[3] = {1e300, 0, 0}, hi3[3] = {1e300, 1, 1};
    CHECK(facegrid_insert(&g, 7, lo3, hi3) == FACEGRID_OK, "huge coordinate");
    double lo4[3] = {NAN, 0, 0}, hi4[3] = {1, 1, 1};
    CHECK(facegrid_insert(&g, 8, lo4, hi4) == FACEGRID_OK, "NaN");
    uint32_t big = 0;
    for (uint32_t e = g.cells[0].head; e != FACEGRID_NONE; e = g.entries[e].next_in_cell) big++;
    CHECK(big == 3, "big list has %u entries, expected 3", big);
    CHECK(g.entry_used == 3 + 4096, "entries used %u", g.entry_used);

    /* a query far from everything still reports the big faces, once each */
    static collector c;
    memset(&c, 0, sizeof c);
    double qlo[3] = {-100, -100, -100}, qhi[3] = {-99, -99, -99};
    facegrid_query(&g, qlo, qhi, collect, &c);
    CHECK(c.total == 3 && c.count[5] == 1 && c.count[7] == 1 && c.count[8] == 1,
          "far query: %u reports", c.total);
    /* a query inside the wide box reports 5, 6 once each */
    memset(&c, 0, sizeof c);
    double q2lo[3] = {3, 3, 3}, q2hi[3] = {9, 9, 9};
    facegrid_query(&g, q2lo, q2hi, collect, &c);
    CHECK(c.count[5] == 1 && c.count[6] == 1 && c.total == 4, "inside query: %u reports", c.total);
    /* an inverted query box reports only the big list */
    memset(&c, 0, sizeof c);
    double q3lo[3] = {3, 3, 3}, q3hi[3] = {2, 9, 9};
    facegrid_query(&g, q3lo, q3hi, collect, &c);
    CHECK(c.total == 3 && c.count[6] == 0, "inverted query: %u reports", c.total);

    facegrid_remove(&g, 5);
    facegrid_remove(&g, 7);
    memset(&c, 0, sizeof c);
    facegrid_query(&g, qlo, qhi, collect, &c);
    CHECK(c.total == 1 && c.count[8] == 1, "after removal: %u reports", c.total);
    facegrid_free(&g);
}

static void test_growth_and_steady_state(void)
{
    enum { N = 20000 };
    facegrid g;
    CHECK(facegrid_init(&g, 0.25, N) == FACEGRID_OK, "init");
    size_t initial = facegrid_memory(&g);
    double (*lo)[3] = malloc(N * sizeof *lo), (*hi)[3] = malloc(N * sizeof *hi);
    for (uint32_t f = 0; f < N; f++) {
        for (int k = 0; k < 3; k++) {
            lo[f][k] = rng_uniform(-30, 30);
            hi[f][k] = lo[f][k] + rng_uniform(0, 0.6);
        }
        CHECK(facegrid_insert(&g, f, lo[f], hi[f]) == FACEGRID_OK, "insert %u", f);
    }
    size_t grown = facegrid_memory(&g);
    CHECK(grown > initial, "memory grew: %zu -> %zu", initial, grown);
    CHECK(g.cell_count * 2 <= g.table_mask + 1, "load %u / %u", g.cell_count, g.table_mask + 1);
    uint32_t entry_capacity = g.entry_capacity, cell_capacity = g.cell_capacity;
    /* remove and re-insert everything in another order: no growth */
    for (int pass = 0; pass < 3; pass++) {
        for (uint32_t i = 0; i < N; i++) {
            uint32_t f = (i * 7919u + (uint32_t)pass) % N;
            facegrid_remove(&g, f);
            CHECK(facegrid_insert(&g, f, lo[f], hi[f]) == FACEGRID_OK, "reinsert");
        }
    }
    CHECK(g.entry_capacity == entry_capacity && g.cell_capacity == cell_capacity &&
              facegrid_memory(&g) == grown,
          "steady state allocated: %zu -> %zu", grown, facegrid_memory(&g));
    /* spot-check queries against brute force */
    int problems = 0;
    for (int q = 0; q < 200; q++) {
        double qlo[3], qhi[3];
        for (int k = 0; k < 3; k++) {
            qlo[k] = rng_uniform(-32, 32);
            qhi[k] = qlo[k] + rng_uniform(0, q < 100 ? 1 : 40);
        }
        static collector c;
        memset(&c, 0, sizeof c);
        facegrid_query(&g, qlo, qhi, collect, &c);
        /* brute force on faces < FACES only (the collector's size) */
        for (uint32_t f = 0; f < FACES; f++) {
            int must = boxes_overlap(lo[f], hi[f], qlo, qhi);
            if ((must && c.count[f] != 1) || c.count[f] > 1) problems++;
        }
    }
    CHECK(problems == 0, "%d problems", problems);
    /* clear: nothing left, allocations kept, usable again */
    facegrid_clear(&g);
    CHECK(g.face_count == 0 && facegrid_memory(&g) == grown, "clear");
    static collector c;
    memset(&c, 0, sizeof c);
    double all_lo[3] = {-INFINITY, -INFINITY, -INFINITY}, all_hi[3] = {INFINITY, INFINITY, INFINITY};
    facegrid_query(&g, all_lo, all_hi, collect, &c);
    CHECK(c.total == 0, "%u reports after clear", c.total);
    CHECK(facegrid_insert(&g, 3, lo[3], hi[3]) == FACEGRID_OK, "insert after clear");
    facegrid_query(&g, all_lo, all_hi, collect, &c);
    CHECK(c.total == 1 && c.count[3] == 1, "%u reports after reinsert", c.total);
    free(lo);
    free(hi);
    facegrid_free(&g);
    CHECK(facegrid_memory(&g) == 0, "freed");
}

static void test_early_stop(void)
{
    facegrid g;
    CHECK(facegrid_init(&g, 1.0, 100) == FACEGRID_OK, "init");
    for (uint32_t f = 0; f < 100; f++) {
        double lo[3] = {f * 0.1, 0, 0}, hi[3] = {f * 0.1 + 0.5, 0.5, 0.5};
        facegrid_insert(&g, f, lo, hi);
    }
    static collector c;
    memset(&c, 0, sizeof c);
    c.stop_after = 5;
    double qlo[3] = {0, 0, 0}, qhi[3] = {10, 1, 1};
    int r = facegrid_query(&g, qlo, qhi, collect, &c);
    CHECK(r == 7 && c.total == 5, "stopped: r=%d after %u", r, c.total);
    facegrid_free(&g);
}

/* Runs the same random sequence on a fresh grid and returns a hash of the
 * report order of a series of queries. */
static uint64_t run_sequence(uint64_t seed, uint32_t capacity)
{
    uint64_t saved = rng_state;
    rng_state = seed;
    facegrid g;
    facegrid_init(&g, 0.75, capacity);
    uint64_t h = 1469598103934665603ULL;
    static collector c;
    for (int op = 0; op < 5000; op++) {
        uint32_t f = rng_below(1000);
        if (rng_below(3) == 0) {
            facegrid_remove(&g, f);
        } else {
            double lo[3], hi[3];
            random_box(lo, hi);
            facegrid_insert(&g, f, lo, hi);
        }
        if (op % 100 == 0) {
            double lo[3], hi[3];
            random_box(lo, hi);
            memset(&c, 0, sizeof c);
            facegrid_query(&g, lo, hi, collect, &c);
            for (uint32_t i = 0; i < c.total && i < 4 * FACES; i++) h = (h ^ c.order[i]) * 1099511628211ULL;
            h = (h ^ c.total) * 1099511628211ULL;
        }
    }
    facegrid_free(&g);
    rng_state = saved;
    return h;
}

static void test_determinism(void)
{
    uint64_t a = run_sequence(42, 1000), b = run_sequence(42, 1000), c = run_sequence(42, 3000);
    CHECK(a == b, "same sequence, different order");
    CHECK(a == c, "capacity changed the order");
    CHECK(a != run_sequence(43, 1000), "hash is not trivial");
}

static void test_invalid_arguments(void)
{
    facegrid g;
    CHECK(facegrid_init(&g, 0.0, 10) == FACEGRID_ERROR_INVALID_ARGUMENT, "zero cell");
    facegrid_free(&g);
    CHECK(facegrid_init(&g, NAN, 10) == FACEGRID_ERROR_INVALID_ARGUMENT, "NaN cell");
    facegrid_free(&g);
    CHECK(facegrid_init(&g, 1e-320, 10) == FACEGRID_ERROR_INVALID_ARGUMENT, "cell too small to invert");
    CHECK(facegrid_init(&g, 1.0, FACEGRID_MAX_FACES + 1) == FACEGRID_ERROR_INVALID_ARGUMENT, "too many faces");
    CHECK(facegrid_memory(&g) == 0, "nothing allocated for too many faces");
    facegrid_free(&g);
    CHECK(facegrid_init(&g, 1.0, 10) == FACEGRID_OK, "init");
    double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    CHECK(facegrid_insert(&g, 10, lo, hi) == FACEGRID_ERROR_INVALID_ARGUMENT, "face out of range");
    facegrid_remove(&g, 10);
    facegrid_remove(&g, 3);
    CHECK(g.face_count == 0, "removing absent faces");
    /* moving a face: insert twice */
    CHECK(facegrid_insert(&g, 3, lo, hi) == FACEGRID_OK, "insert");
    double lo2[3] = {5, 5, 5}, hi2[3] = {5.5, 5.5, 5.5};
    CHECK(facegrid_insert(&g, 3, lo2, hi2) == FACEGRID_OK, "move");
    CHECK(g.face_count == 1, "moved face counted once");
    static collector c;
    memset(&c, 0, sizeof c);
    facegrid_query(&g, lo, lo, collect, &c);
    CHECK(c.total == 0, "old place empty");
    facegrid_query(&g, hi2, hi2, collect, &c);
    CHECK(c.total == 1 && c.count[3] == 1, "new place");
    /* negative coordinates and cell boundaries */
    double lo3[3] = {-1, -1, -1}, hi3[3] = {-1, -1, -1};
    facegrid_insert(&g, 4, lo3, hi3);
    memset(&c, 0, sizeof c);
    facegrid_query(&g, hi3, hi3, collect, &c);
    CHECK(c.count[4] == 1, "point box at a cell corner");
    facegrid_free(&g);
}

/* A grid reset after heavy use (larger pools and table than a fresh one)
 * reports the same faces in the same order as a freshly made grid with the
 * same inserts: what the simplifier's rebuilt grids rely on for the same
 * output. */
static void test_reset_same_as_init(void)
{
    facegrid used, fresh;
    CHECK(facegrid_init(&used, 0.25, FACES) == FACEGRID_OK, "init");
    for (uint32_t f = 0; f < FACES; ++f) {
        double lo[3], hi[3];
        random_box(lo, hi);
        CHECK(facegrid_insert(&used, f, lo, hi) == FACEGRID_OK, "insert");
    }
    const uint32_t n = FACES / 3;
    CHECK(facegrid_reset(&used, 1.5, n) == FACEGRID_OK, "reset");
    CHECK(facegrid_init(&fresh, 1.5, n) == FACEGRID_OK, "init");
    CHECK(used.face_count == 0 && used.cell_count == 1 && used.face_capacity == n, "reset empties the grid");
    for (uint32_t f = 0; f < n; ++f) {
        random_box(shadow[f].lo, shadow[f].hi);
        CHECK(facegrid_insert(&used, f, shadow[f].lo, shadow[f].hi) == FACEGRID_OK, "insert after reset");
        CHECK(facegrid_insert(&fresh, f, shadow[f].lo, shadow[f].hi) == FACEGRID_OK, "insert fresh");
    }
    CHECK(facegrid_insert(&used, n, shadow[0].lo, shadow[0].hi) == FACEGRID_ERROR_INVALID_ARGUMENT,
          "face_capacity is the reset's");
    static collector a, b;
    int differ = 0;
    for (int q = 0; q < 200; ++q) {
        double lo[3], hi[3];
        random_box(lo, hi);
        memset(&a, 0, sizeof a);
        memset(&b, 0, sizeof b);
        facegrid_query(&used, lo, hi, collect, &a);
        facegrid_query(&fresh, lo, hi, collect, &b);
        differ += a.total != b.total || memcmp(a.order, b.order, (a.total < 4 * FACES ? a.total : 4 * FACES) *
                                                                     sizeof a.order[0]) != 0;
    }
    CHECK(differ == 0, "%d of 200 queries differ between a reset grid and a fresh one", differ);
    facegrid_free(&used);
    facegrid_free(&fresh);
}

int main(void)
{
    RUN(test_random_against_brute_force);
    RUN(test_same_cells_moves);
    RUN(test_big_faces);
    RUN(test_growth_and_steady_state);
    RUN(test_early_stop);
    RUN(test_determinism);
    RUN(test_invalid_arguments);
    RUN(test_reset_same_as_init);
    return check_summary();
}
