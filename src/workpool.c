/* workpool.c - helper threads parked between jobs (see workpool.h).
 *
 * Everything a job's hand-over needs goes under one mutex: a helper enters
 * a job only while it is open (and counts itself in busy), and the caller
 * closes it and waits for busy to reach zero, so a helper that wakes after
 * the close never touches a job its caller has moved on from. generation
 * and busy are atomics only so that the polling before a sleep may read
 * them without the lock; every decision is taken again under it. */
#include "workpool.h"

#include <sched.h>
#include <string.h>

#include "clock.h"

/* Measured on a 2-core VM: waking a sleeping thread took longer than
 * evaluating a candidate, so in the late passes (batches of 2-4 expensive
 * candidates) the caller had evaluated most of them before the helper came.
 * Polling bridges the gap between two batches; it burns the idle core, which
 * costs where the other core's work is small (a scene of 500 meshes of 96
 * triangles, --threads 2: user + sys 5.1 s without a pool, 9.1 s polling
 * 2 ms, 7.2 s polling 0.2 ms, 6.4 s polling 0.05 ms; its wall time 5.1, 5.0,
 * 4.5, 4.8 s), while the 1.1M-triangle chain's levels 2-4 took about the same
 * with each (0.29-0.33 / 0.12-0.15 / 0.05-0.07 s, against 0.39-0.42 / 0.18-
 * 0.19 / 0.10-0.11 s without the pool). */
#define WORKPOOL_SPIN_SECONDS 0.00005

/* Polls (yielding the core) until *value differs from `from`, for at most
 * WORKPOOL_SPIN_SECONDS. */
static void spin_while_equal(atomic_uint_fast64_t *value, uint64_t from)
{
    const double until = lp_seconds() + WORKPOOL_SPIN_SECONDS;
    while (atomic_load_explicit(value, memory_order_relaxed) == from && lp_seconds() < until) sched_yield();
}

static void spin_while_busy(atomic_uint *busy)
{
    const double until = lp_seconds() + WORKPOOL_SPIN_SECONDS;
    while (atomic_load_explicit(busy, memory_order_relaxed) != 0 && lp_seconds() < until) sched_yield();
}

static void *helper(void *p)
{
    const workpool_arg *a = p;
    workpool *pool = a->pool;
    uint64_t seen = 0;
    pthread_mutex_lock(&pool->lock);
    for (;;) {
        while (!pool->quit && (!pool->open || atomic_load_explicit(&pool->generation, memory_order_relaxed) == seen)) {
            pthread_mutex_unlock(&pool->lock);
            spin_while_equal(&pool->generation, seen);
            pthread_mutex_lock(&pool->lock);
            if (pool->quit || (pool->open && atomic_load_explicit(&pool->generation, memory_order_relaxed) != seen))
                break;
            pool->parked++;
            pthread_cond_wait(&pool->wake, &pool->lock);
            pool->parked--;
        }
        if (pool->quit) break;
        seen = atomic_load_explicit(&pool->generation, memory_order_relaxed);
        const workpool_fn fn = pool->fn;
        void *job = pool->job;
        atomic_fetch_add_explicit(&pool->busy, 1, memory_order_relaxed);
        pthread_mutex_unlock(&pool->lock);
        fn(job, a->thread);
        pthread_mutex_lock(&pool->lock);
        if (atomic_fetch_sub_explicit(&pool->busy, 1, memory_order_relaxed) == 1 && pool->waiting)
            pthread_cond_signal(&pool->idle);
    }
    pthread_mutex_unlock(&pool->lock);
    return NULL;
}

int workpool_init(workpool *p, uint32_t threads)
{
    memset(p, 0, sizeof *p);
    p->threads = threads > WORKPOOL_MAX_THREADS ? WORKPOOL_MAX_THREADS : threads;
    atomic_init(&p->generation, 0);
    atomic_init(&p->busy, 0);
    if (pthread_mutex_init(&p->lock, NULL)) return -1;
    if (pthread_cond_init(&p->wake, NULL)) {
        pthread_mutex_destroy(&p->lock);
        return -1;
    }
    if (pthread_cond_init(&p->idle, NULL)) {
        pthread_cond_destroy(&p->wake);
        pthread_mutex_destroy(&p->lock);
        return -1;
    }
    p->ready = 1;
    return 0;
}

void workpool_start(workpool *p, workpool_fn fn, void *job)
{
    if (p->threads < 2) return;
    pthread_mutex_lock(&p->lock);
    p->fn = fn;
    p->job = job;
    const uint64_t generation = atomic_load_explicit(&p->generation, memory_order_relaxed) + 1;
    atomic_store_explicit(&p->generation, generation, memory_order_relaxed);
    p->open = 1;
    const int parked = p->parked != 0;
    pthread_mutex_unlock(&p->lock);
    /* the helpers start at the first job: a pool that never gets one (a
     * mesh with nothing to remove) costs no thread */
    if (!p->started && generation == 1) {
        for (uint32_t t = 1; t < p->threads; ++t) {
            p->args[t] = (workpool_arg){p, t};
            if (pthread_create(&p->tid[t], NULL, helper, &p->args[t]) != 0) break;
            p->started = t;
        }
        return; /* a new helper finds the job open */
    }
    if (parked) pthread_cond_broadcast(&p->wake);
}

void workpool_finish(workpool *p)
{
    if (p->threads < 2) return;
    pthread_mutex_lock(&p->lock);
    p->open = 0;
    if (atomic_load_explicit(&p->busy, memory_order_relaxed)) {
        pthread_mutex_unlock(&p->lock);
        spin_while_busy(&p->busy);
        pthread_mutex_lock(&p->lock);
    }
    p->waiting = 1;
    while (atomic_load_explicit(&p->busy, memory_order_relaxed)) pthread_cond_wait(&p->idle, &p->lock);
    p->waiting = 0;
    pthread_mutex_unlock(&p->lock);
}

void workpool_free(workpool *p)
{
    if (!p->ready) return;
    pthread_mutex_lock(&p->lock);
    p->quit = 1;
    pthread_mutex_unlock(&p->lock);
    pthread_cond_broadcast(&p->wake);
    for (uint32_t t = 1; t <= p->started; ++t) pthread_join(p->tid[t], NULL);
    pthread_cond_destroy(&p->idle);
    pthread_cond_destroy(&p->wake);
    pthread_mutex_destroy(&p->lock);
    memset(p, 0, sizeof *p);
}
