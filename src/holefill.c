/* holefill.c - see holefill.h. */
#include "holefill.h"

#include <math.h>
#include <string.h>

typedef struct span {
    uint8_t lo, hi;
} span;

typedef struct walk {
    const holefill_problem *p;
    holefill *out;
    uint32_t count;
} walk;

static int joinable(const holefill_problem *p, uint32_t i, uint32_t j)
{
    return j == i + 1 || (i == 0 && j == p->n - 1) || p->allowed[i][j];
}

/* Triangulates the polygon spans still to do (the last one first): the span
 * lo .. hi is closed by the edge (lo, hi), and its triangle on that edge has
 * a third corner m with lo < m < hi, leaving the spans lo .. m and m .. hi. */
static void fill(walk *w, const holefill *partial, uint32_t done, const span *todo, uint32_t todo_count)
{
    if (todo_count == 0) {
        if (w->count < HOLEFILL_MAX) w->out[w->count++] = *partial;
        return;
    }
    const span s = todo[todo_count - 1];
    if (s.hi - s.lo < 2) { /* an edge: nothing to fill */
        fill(w, partial, done, todo, todo_count - 1);
        return;
    }
    const holefill_problem *p = w->p;
    for (uint32_t m = s.lo + 1u; m < s.hi; ++m) {
        const double c = p->cost[s.lo][m][s.hi];
        if (!joinable(p, s.lo, m) || !joinable(p, m, s.hi) || !(c < INFINITY)) continue;
        holefill next = *partial;
        next.cost += c;
        next.tri[done][0] = s.lo;
        next.tri[done][1] = (uint8_t)m;
        next.tri[done][2] = s.hi;
        span more[HOLEFILL_MAX_CORNERS];
        memcpy(more, todo, (todo_count - 1) * sizeof *more);
        more[todo_count - 1] = (span){(uint8_t)m, s.hi};
        more[todo_count] = (span){s.lo, (uint8_t)m};
        fill(w, &next, done + 1, more, todo_count + 1);
    }
}

/* Cheaper first; on equal cost, by triangle list: a total order, since two
 * triangulations with the same list are the same (listed once). */
static int cheaper_first(const holefill *x, const holefill *y)
{
    if (x->cost != y->cost) return x->cost < y->cost;
    return memcmp(x->tri, y->tri, sizeof x->tri) < 0;
}

static void sift_down(holefill *h, uint32_t i, uint32_t n)
{
    for (;;) {
        uint32_t best = i, l = 2 * i + 1, r = l + 1;
        if (l < n && cheaper_first(&h[l], &h[best])) best = l;
        if (r < n && cheaper_first(&h[r], &h[best])) best = r;
        if (best == i) return;
        const holefill t = h[i];
        h[i] = h[best];
        h[best] = t;
        i = best;
    }
}

uint32_t holefill_heap(const holefill_problem *p, holefill out[HOLEFILL_MAX])
{
    if (p->n < 3 || p->n > HOLEFILL_MAX_CORNERS) return 0;
    walk w = {p, out, 0};
    holefill start;
    memset(&start, 0, sizeof start);
    const span whole = {0, (uint8_t)(p->n - 1)};
    fill(&w, &start, 0, &whole, 1);
    for (uint32_t i = w.count / 2; i-- > 0;) sift_down(out, i, w.count);
    return w.count;
}

const holefill *holefill_pop(holefill *heap, uint32_t *count)
{
    const uint32_t n = --*count;
    const holefill t = heap[0];
    heap[0] = heap[n];
    heap[n] = t;
    sift_down(heap, 0, n);
    return &heap[n];
}

uint32_t holefill_all(const holefill_problem *p, holefill out[HOLEFILL_MAX])
{
    const uint32_t count = holefill_heap(p, out);
    /* each pop puts the cheapest left at the end: dearest first, reversed */
    for (uint32_t left = count; left > 1;) holefill_pop(out, &left);
    for (uint32_t i = 0, j = count ? count - 1 : 0; i < j; ++i, --j) {
        const holefill t = out[i];
        out[i] = out[j];
        out[j] = t;
    }
    return count;
}
