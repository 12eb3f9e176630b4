/* test_holefill.c - holefill.h: for every polygon size, the triangulations
 * are exactly the Catalan number of them, each a valid triangulation (every
 * polygon edge in one triangle, every diagonal in two, no two diagonals
 * crossing, all distinct), sorted by a total that is the sum of their
 * triangles' costs; forbidden diagonals and triangles are never used and
 * remove exactly the triangulations that need them. */
#include "check.h"
#include "holefill.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define RNG_SEED 0x686f6c6566696c6cULL
#include "rng.h"

static const uint32_t catalan[] = {1, 1, 2, 5, 14, 42, 132, 429, 1430}; /* Catalan(n - 2) for n = 2 .. 10 */
_Static_assert(sizeof catalan / sizeof catalan[0] == HOLEFILL_MAX_CORNERS - 1, "one Catalan number per polygon size");
_Static_assert(HOLEFILL_MAX == 1430, "HOLEFILL_MAX is Catalan(HOLEFILL_MAX_CORNERS - 2)");

static void open_problem(holefill_problem *p, uint32_t n)
{
    memset(p, 0, sizeof *p);
    p->n = n;
    for (uint32_t i = 0; i < n; ++i)
        for (uint32_t j = i + 1; j < n; ++j) {
            p->allowed[i][j] = 1;
            for (uint32_t k = j + 1; k < n; ++k) p->cost[i][j][k] = 1.0;
        }
}

static int is_polygon_edge(uint32_t n, uint32_t a, uint32_t b) { return b == a + 1 || (a == 0 && b == n - 1); }

/* Checks one triangulation; returns 1 when it uses the edge (a, b), a < b. */
static int check_one(const holefill_problem *p, const holefill *h, uint32_t a, uint32_t b)
{
    const uint32_t n = p->n;
    uint32_t uses[HOLEFILL_MAX_CORNERS][HOLEFILL_MAX_CORNERS];
    memset(uses, 0, sizeof uses);
    double total = 0.0;
    for (uint32_t t = 0; t < n - 2; ++t) {
        const uint8_t *x = h->tri[t];
        CHECK(x[0] < x[1] && x[1] < x[2] && x[2] < n, "n %u: triangle %u is (%u %u %u)", n, t, x[0], x[1], x[2]);
        if (!(x[0] < x[1] && x[1] < x[2] && x[2] < n)) return 0;
        total += p->cost[x[0]][x[1]][x[2]];
        uses[x[0]][x[1]]++;
        uses[x[1]][x[2]]++;
        uses[x[0]][x[2]]++;
    }
    CHECK(total == h->cost, "n %u: cost %.17g is not the sum %.17g", n, h->cost, total);
    for (uint32_t i = 0; i < n; ++i)
        for (uint32_t j = i + 1; j < n; ++j) {
            if (is_polygon_edge(n, i, j)) {
                CHECK(uses[i][j] == 1, "n %u: polygon edge (%u %u) in %u triangles", n, i, j, uses[i][j]);
            } else {
                CHECK(uses[i][j] == 0 || uses[i][j] == 2, "n %u: diagonal (%u %u) in %u triangles", n, i, j,
                      uses[i][j]);
                CHECK(uses[i][j] == 0 || p->allowed[i][j], "n %u: forbidden diagonal (%u %u) used", n, i, j);
            }
        }
    for (uint32_t i = 0; i < n; ++i)
        for (uint32_t j = i + 2; j < n; ++j)
            for (uint32_t k = i + 1; k < j; ++k)
                for (uint32_t l = j + 1; l < n; ++l)
                    CHECK(!(uses[i][j] && uses[k][l] && !is_polygon_edge(n, i, j) && !is_polygon_edge(n, k, l)),
                          "n %u: diagonals (%u %u) and (%u %u) cross", n, i, j, k, l);
    return uses[a][b] != 0;
}

static void check_all(const holefill_problem *p, const holefill *h, uint32_t count)
{
    for (uint32_t i = 0; i < count; ++i) {
        check_one(p, &h[i], 0, 1);
        if (i) CHECK(h[i - 1].cost <= h[i].cost, "n %u: not sorted at %u", p->n, i);
        for (uint32_t j = 0; j < i; ++j)
            CHECK(memcmp(h[i].tri, h[j].tri, sizeof h[i].tri) != 0, "n %u: %u and %u are the same", p->n, i, j);
    }
}

static void test_counts(void)
{
    static holefill h[HOLEFILL_MAX];
    holefill_problem p;
    for (uint32_t n = 3; n <= HOLEFILL_MAX_CORNERS; ++n) {
        open_problem(&p, n);
        const uint32_t count = holefill_all(&p, h);
        CHECK(count == catalan[n - 2], "n %u: %u triangulations, expected %u", n, count, catalan[n - 2]);
        check_all(&p, h, count);
    }
    open_problem(&p, 2);
    CHECK(holefill_all(&p, h) == 0, "n 2: nothing");
    p.n = HOLEFILL_MAX_CORNERS + 1;
    CHECK(holefill_all(&p, h) == 0, "n 9: refused");
}

/* Random costs: sorted by the sum; the cheapest is the true minimum over the
 * Catalan-many (checked against the brute force order of the list itself)
 * and equal inputs give equal outputs. */
static void test_costs(void)
{
    static holefill h[HOLEFILL_MAX], again[HOLEFILL_MAX];
    holefill_problem p;
    for (int round = 0; round < 200; ++round) {
        const uint32_t n = 4 + (uint32_t)(rng_next() % (HOLEFILL_MAX_CORNERS - 3));
        open_problem(&p, n);
        for (uint32_t i = 0; i < n; ++i)
            for (uint32_t j = i + 1; j < n; ++j)
                for (uint32_t k = j + 1; k < n; ++k) p.cost[i][j][k] = (double)(rng_next() % 1000) / 7.0;
        const uint32_t count = holefill_all(&p, h);
        CHECK(count == catalan[n - 2], "n %u: %u", n, count);
        check_all(&p, h, count);
        CHECK(holefill_all(&p, again) == count && memcmp(h, again, count * sizeof *h) == 0, "n %u: not repeatable", n);
        /* the heap hands out the same list in the same order */
        uint32_t left = holefill_heap(&p, again), at = 0;
        CHECK(left == count, "n %u: heap of %u, list of %u", n, left, count);
        while (left > 0 && at < count) {
            const holefill *next = holefill_pop(again, &left);
            CHECK(memcmp(next, &h[at], sizeof *next) == 0, "n %u: pop %u differs from the sorted list", n, at);
            at++;
        }
    }
}

/* A forbidden diagonal or triangle removes exactly the triangulations that
 * use it (counted on the unrestricted list). */
static void test_forbidden(void)
{
    static holefill all[HOLEFILL_MAX], some[HOLEFILL_MAX];
    holefill_problem p;
    for (uint32_t n = 4; n <= HOLEFILL_MAX_CORNERS; ++n)
        for (uint32_t a = 0; a < n; ++a)
            for (uint32_t b = a + 2; b < n; ++b) {
                if (is_polygon_edge(n, a, b)) continue;
                open_problem(&p, n);
                const uint32_t total = holefill_all(&p, all);
                uint32_t using = 0;
                for (uint32_t i = 0; i < total; ++i) using += check_one(&p, &all[i], a, b);
                p.allowed[a][b] = 0;
                const uint32_t count = holefill_all(&p, some);
                CHECK(count == total - using, "n %u without (%u %u): %u, expected %u", n, a, b, count, total - using);
                check_all(&p, some, count);
            }
    /* a forbidden triangle: the pentagon's (0, 2, 4) is in one triangulation */
    open_problem(&p, 5);
    p.cost[0][2][4] = INFINITY;
    const uint32_t count = holefill_all(&p, some);
    CHECK(count == 4, "pentagon without (0 2 4): %u", count);
    for (uint32_t i = 0; i < count; ++i)
        for (uint32_t t = 0; t < 3; ++t)
            CHECK(!(some[i].tri[t][0] == 0 && some[i].tri[t][1] == 2 && some[i].tri[t][2] == 4), "(0 2 4) used");
    /* polygon edges stay usable whatever allowed says */
    open_problem(&p, 6);
    memset(p.allowed, 0, sizeof p.allowed);
    CHECK(holefill_all(&p, some) == 0, "hexagon with no diagonal: no triangulation");
    open_problem(&p, 3);
    memset(p.allowed, 0, sizeof p.allowed);
    CHECK(holefill_all(&p, some) == 1, "a triangle needs no diagonal");
}

int main(void)
{
    RUN(test_counts);
    RUN(test_costs);
    RUN(test_forbidden);
    return check_summary();
}
