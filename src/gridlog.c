/* gridlog.c - grid updates applied in order on a helper thread (see
 * gridlog.h).
 *
 * A single-producer, single-consumer ring: the pusher writes slot
 * pushed & mask and then publishes pushed + 1 (release); the applier reads
 * slots below pushed (acquire) and publishes applied (release), which frees
 * their slots for the pusher. Either side that has nothing to do yields: the
 * other is running on the other core. */
#include "gridlog.h"

#include <sched.h>
#include <stdlib.h>
#include <string.h>

int gridlog_init(gridlog *l, size_t capacity)
{
    memset(l, 0, sizeof *l);
    size_t size = 1;
    while (size < capacity) size *= 2;
    l->ring = malloc(size * sizeof *l->ring);
    if (!l->ring) return -1;
    l->mask = size - 1;
    return 0;
}

void gridlog_free(gridlog *l)
{
    free(l->ring);
    memset(l, 0, sizeof *l);
}

static void apply(gridlog *l, const gridlog_update *u)
{
    if (u->remove) {
        facegrid_remove(l->grid, u->face);
        return;
    }
    if (facegrid_contains(l->grid, u->face) && facegrid_same_cells(l->grid, u->old_lo, u->old_hi, u->lo, u->hi))
        return;
    if (facegrid_insert(l->grid, u->face, u->lo, u->hi) != FACEGRID_OK) l->out_of_memory = 1;
}

static void *applier(void *p)
{
    gridlog *l = p;
    size_t done = atomic_load_explicit(&l->applied, memory_order_relaxed);
    for (;;) {
        /* closed before pushed: once closed is seen, pushed is final */
        const int closed = atomic_load_explicit(&l->closed, memory_order_acquire);
        const size_t ready = atomic_load_explicit(&l->pushed, memory_order_acquire);
        if (done < ready) {
            while (done < ready) apply(l, &l->ring[done++ & l->mask]);
            atomic_store_explicit(&l->applied, done, memory_order_release);
            continue;
        }
        if (closed) return NULL;
        sched_yield();
    }
}

void gridlog_start(gridlog *l, facegrid *g, int threaded)
{
    l->grid = g;
    l->out_of_memory = 0;
    atomic_init(&l->pushed, 0);
    atomic_init(&l->applied, 0);
    atomic_init(&l->closed, 0);
    l->threaded = threaded && pthread_create(&l->thread, NULL, applier, l) == 0;
}

static void push(gridlog *l, const gridlog_update *u)
{
    if (!l->threaded) {
        apply(l, u);
        return;
    }
    const size_t n = atomic_load_explicit(&l->pushed, memory_order_relaxed);
    while (n - atomic_load_explicit(&l->applied, memory_order_acquire) > l->mask) sched_yield(); /* ring full */
    l->ring[n & l->mask] = *u;
    atomic_store_explicit(&l->pushed, n + 1, memory_order_release);
}

void gridlog_remove(gridlog *l, uint32_t face)
{
    gridlog_update u = {.face = face, .remove = 1};
    push(l, &u);
}

void gridlog_move(gridlog *l, uint32_t face, const double old_lo[3], const double old_hi[3], const double lo[3],
                  const double hi[3])
{
    gridlog_update u = {.face = face, .remove = 0};
    memcpy(u.old_lo, old_lo, sizeof u.old_lo);
    memcpy(u.old_hi, old_hi, sizeof u.old_hi);
    memcpy(u.lo, lo, sizeof u.lo);
    memcpy(u.hi, hi, sizeof u.hi);
    push(l, &u);
}

int gridlog_finish(gridlog *l)
{
    if (l->threaded) {
        atomic_store_explicit(&l->closed, 1, memory_order_release);
        pthread_join(l->thread, NULL);
        l->threaded = 0;
    }
    return l->out_of_memory ? -1 : 0;
}
