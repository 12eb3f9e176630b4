/* test_gridlog.c - grid updates through the log: applied on a helper thread
 * through a tiny ring (so the pusher waits for the applier over and over),
 * the grid ends up exactly as when the same updates are applied inline, and
 * as when they are applied by hand: the same faces present, every query
 * reporting the same faces in the same order, and every face whose latest
 * box overlaps a query reported (the shadow boxes). */
#include "check.h"
#include "facegrid.h"
#include "gridlog.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define RNG_SEED 0x677269646c6f67ULL
#include "rng.h"

#define FACES 2000
#define QUERY_REPORTS (4 * FACES)

typedef struct {
    int present;
    double lo[3], hi[3];
} shadow_face;

typedef struct {
    uint32_t face[QUERY_REPORTS];
    uint32_t total;
} reports;

static int collect(void *context, uint32_t face)
{
    reports *r = context;
    if (r->total < QUERY_REPORTS) r->face[r->total] = face;
    r->total++;
    return 0;
}

static void random_box(double lo[3], double hi[3])
{
    for (int k = 0; k < 3; k++) {
        const double c = rng_uniform(-30, 30), size = rng_uniform(0, 3);
        lo[k] = c - size * rng_uniform(0, 1);
        hi[k] = lo[k] + size;
    }
}

static int overlaps(const double *alo, const double *ahi, const double *blo, const double *bhi)
{
    for (int k = 0; k < 3; k++)
        if (ahi[k] < blo[k] || bhi[k] < alo[k]) return 0;
    return 1;
}

/* Grids: [0] through a threaded log, [1] through an inline log, [2] by hand
 * (contains + same_cells + insert, as the simplifier did before the log). */
static void test_threaded_inline_and_by_hand_agree(void)
{
    static shadow_face shadow[FACES];
    static reports r[3];
    memset(shadow, 0, sizeof shadow);
    facegrid g[3];
    gridlog threaded, inline_log;
    for (int i = 0; i < 3; i++) CHECK(facegrid_init(&g[i], 1.25, FACES) == FACEGRID_OK, "init");
    CHECK(gridlog_init(&threaded, 3) == 0 && gridlog_init(&inline_log, 3) == 0, "log init");
    CHECK(threaded.mask == 3, "a ring of 4 for 3 asked: %zu", threaded.mask + 1);
    int problems = 0, queries = 0, kept = 0, ran_threaded = 0;
    unsigned long updates = 0;
    for (int batch = 0; batch < 60; batch++) {
        gridlog_start(&threaded, &g[0], 1);
        gridlog_start(&inline_log, &g[1], 0);
        ran_threaded += threaded.threaded;
        CHECK(!inline_log.threaded, "an inline log starts no thread");
        const int count = (int)(rng_next() % 600);
        for (int op = 0; op < count; op++, updates++) {
            const uint32_t f = (uint32_t)(rng_next() % FACES);
            if (shadow[f].present && rng_next() % 5 == 0) {
                gridlog_remove(&threaded, f);
                gridlog_remove(&inline_log, f);
                facegrid_remove(&g[2], f);
                shadow[f].present = 0;
                continue;
            }
            double lo[3], hi[3];
            if (rng_next() % 6 == 0) {
                random_box(lo, hi);
            } else { /* a small move: often the same cells (for an absent
                      * face, the same cells as the box it was removed with) */
                for (int k = 0; k < 3; k++) {
                    lo[k] = shadow[f].lo[k] + rng_uniform(-0.2, 0.2);
                    hi[k] = lo[k] + (shadow[f].hi[k] - shadow[f].lo[k]) * rng_uniform(0.8, 1.2);
                }
            }
            /* an absent face "moves" too (its old box is stale): it must be inserted */
            gridlog_move(&threaded, f, shadow[f].lo, shadow[f].hi, lo, hi);
            gridlog_move(&inline_log, f, shadow[f].lo, shadow[f].hi, lo, hi);
            if (facegrid_contains(&g[2], f) && facegrid_same_cells(&g[2], shadow[f].lo, shadow[f].hi, lo, hi)) kept++;
            else CHECK(facegrid_insert(&g[2], f, lo, hi) == FACEGRID_OK, "insert by hand");
            shadow[f].present = 1;
            memcpy(shadow[f].lo, lo, sizeof lo);
            memcpy(shadow[f].hi, hi, sizeof hi);
        }
        CHECK(gridlog_finish(&threaded) == 0 && gridlog_finish(&inline_log) == 0, "finish");
        for (uint32_t f = 0; f < FACES; f++)
            for (int i = 0; i < 3; i++)
                if (facegrid_contains(&g[i], f) != shadow[f].present) problems++;
        for (int q = 0; q < 20; q++, queries++) {
            double lo[3], hi[3];
            random_box(lo, hi);
            for (int i = 0; i < 3; i++) {
                r[i].total = 0;
                CHECK(facegrid_query(&g[i], lo, hi, collect, &r[i]) == 0, "query");
            }
            if (r[0].total != r[2].total || r[1].total != r[2].total ||
                memcmp(r[0].face, r[2].face, r[2].total * sizeof r[2].face[0]) ||
                memcmp(r[1].face, r[2].face, r[2].total * sizeof r[2].face[0]))
                problems++;
            static uint8_t seen[FACES];
            memset(seen, 0, sizeof seen);
            for (uint32_t k = 0; k < r[0].total && k < QUERY_REPORTS; k++) seen[r[0].face[k]] = 1;
            for (uint32_t f = 0; f < FACES; f++)
                if (shadow[f].present && overlaps(shadow[f].lo, shadow[f].hi, lo, hi) && !seen[f]) problems++;
        }
    }
    CHECK(problems == 0, "%d problems in %d queries after %lu updates", problems, queries, updates);
    CHECK(ran_threaded == 60, "the helper thread ran in %d of 60 batches", ran_threaded);
    CHECK(kept > 1000, "faces kept in their cells: %d", kept);
    gridlog_free(&threaded);
    gridlog_free(&inline_log);
    for (int i = 0; i < 3; i++) facegrid_free(&g[i]);
}

/* A run with nothing pushed finishes at once, threaded or not. */
static void test_empty_run(void)
{
    facegrid g;
    gridlog l;
    CHECK(facegrid_init(&g, 1.0, 8) == FACEGRID_OK, "init");
    CHECK(gridlog_init(&l, 1) == 0, "log init");
    for (int threaded = 0; threaded < 2; threaded++) {
        gridlog_start(&l, &g, threaded);
        CHECK(gridlog_finish(&l) == 0, "finish");
        CHECK(g.face_count == 0, "no faces");
    }
    gridlog_free(&l);
    facegrid_free(&g);
}

int main(void)
{
    RUN(test_threaded_inline_and_by_hand_agree);
    RUN(test_empty_run);
    return check_summary();
}
