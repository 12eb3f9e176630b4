/* threads.h - how many threads a "threads" option means: the number asked
 * for, or one per online core when it is 0 (at least one), never more than
 * the caller's fixed arrays hold. The simplifier, the morph measurement and
 * the batch scheduler resolve their option through it.
 *
 * And the two short-lived forms of threads the set-up and the measurements
 * use (the simplifier's loop has a pool that lives for a mesh: workpool.h):
 * one piece of work beside the caller (lp_beside), and a team that shares
 * numbered items through a counter (lp_team_for). Neither fails: work that finds no
 * thread runs on the caller. */
#ifndef LODPIPE_THREADS_H
#define LODPIPE_THREADS_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <unistd.h>

static inline uint32_t lp_threads(uint32_t requested, uint32_t cap)
{
    uint32_t n = requested;
    if (!n) {
        const long cores = sysconf(_SC_NPROCESSORS_ONLN);
        n = cores > 0 ? (uint32_t)(cores < (long)UINT32_MAX ? cores : (long)UINT32_MAX) : 1;
    }
    return n > cap ? cap : n;
}

/* Work beside the caller: fn(arg) runs on a thread of its own when `wanted`
 * and one starts, else on the caller before lp_beside_start returns. */
typedef struct lp_beside {
    pthread_t thread;
    int running;
} lp_beside;

static inline void lp_beside_start(lp_beside *b, int wanted, void *(*fn)(void *), void *arg)
{
    b->running = wanted && pthread_create(&b->thread, NULL, fn, arg) == 0;
    if (!b->running) fn(arg);
}

/* Waits for the work lp_beside_start began (at once when it ran on the
 * caller); everything it wrote is then visible. */
static inline void lp_beside_join(lp_beside *b)
{
    if (b->running) pthread_join(b->thread, NULL);
    b->running = 0;
}

#define LP_TEAM_MAX 64

/* A team's shared state: the next item to claim. */
typedef struct lp_team {
    void (*item)(void *arg, uint32_t i);
    void *arg;
    uint32_t count;
    atomic_uint next;
} lp_team;

static inline void *lp_team_member(void *p)
{
    lp_team *team = p;
    for (uint32_t i; (i = atomic_fetch_add_explicit(&team->next, 1u, memory_order_relaxed)) < team->count;)
        team->item(team->arg, i);
    return NULL;
}

/* item(arg, i) once for every i < count, by a team: the caller and up to
 * threads - 1 (at most LP_TEAM_MAX - 1, and fewer than count) threads of
 * their own, as many as start, each claiming the next item until none is
 * left. Returns when all items are done; what they wrote is then visible.
 * Items must write apart from each other, and what each computes must not
 * depend on which thread runs it. */
static inline void lp_team_for(uint32_t threads, uint32_t count, void (*item)(void *arg, uint32_t i), void *arg)
{
    lp_team team = {item, arg, count, 0};
    atomic_init(&team.next, 0u);
    pthread_t helper[LP_TEAM_MAX];
    uint32_t started = 0;
    if (threads > LP_TEAM_MAX) threads = LP_TEAM_MAX;
    while (started + 1 < threads && started + 1 < count && pthread_create(&helper[started], NULL, lp_team_member, &team) == 0)
        started++;
    lp_team_member(&team);
    for (uint32_t t = 0; t < started; ++t) pthread_join(helper[t], NULL);
}

#endif
