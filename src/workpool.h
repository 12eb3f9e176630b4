/* workpool.h - helper threads started once and woken per job.
 *
 * The simplifier hands its second core many short jobs: a batch of a few
 * candidates in a late pass, a region round, a pass's candidate collection.
 * Starting a thread per job cost about as much as evaluating ten small
 * candidates, so small batches ran on one core. A pool starts its helpers at
 * its first job and parks them on a condition variable between jobs: a job
 * then costs a wake-up, not a thread.
 *
 * Promise: between workpool_start and workpool_finish, each helper thread
 * (numbers 1 .. threads - 1) runs fn(job, its number) at most once, and only
 * one that wakes before workpool_finish closes the job: any subset of them
 * may run it, none included (a helper that wakes late, or that could not be
 * started, skips it). So a job must be such that its caller, running its own
 * share as thread 0 before workpool_finish, finishes whatever no helper
 * took (they claim work from a shared counter). workpool_finish returns once
 * every helper that entered the job has returned from fn; everything they
 * wrote is then visible to the caller, and everything the caller wrote
 * before workpool_start is visible to them.
 *
 * A helper that finishes a job, and a caller that waits for one, poll for a
 * short while (WORKPOOL_SPIN_SECONDS) before they sleep: the next job or the
 * helper's end usually comes sooner than a sleeping thread wakes.
 *
 * Threads: one thread owns the pool and starts, finishes and frees it; one
 * job at a time. */
#ifndef LODPIPE_WORKPOOL_H
#define LODPIPE_WORKPOOL_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>

#define WORKPOOL_MAX_THREADS 64

typedef void (*workpool_fn)(void *job, uint32_t thread);

typedef struct workpool workpool;

typedef struct workpool_arg {
    workpool *pool;
    uint32_t thread;
} workpool_arg;

struct workpool {
    pthread_mutex_t lock;
    pthread_cond_t wake; /* a job opened, or quit */
    pthread_cond_t idle; /* the last helper left the job */
    workpool_fn fn;
    void *job;
    atomic_uint_fast64_t generation; /* jobs started (written under the lock) */
    int open;                        /* the current job may still be entered */
    int quit;
    atomic_uint busy;  /* helpers inside the current job (written under the lock) */
    uint32_t parked;   /* helpers waiting on wake */
    int waiting;       /* the caller waits on idle */
    uint32_t threads;    /* asked for, the caller included */
    uint32_t started;    /* helpers 1 .. started run (0 until the first job) */
    int ready;           /* the lock and conditions are initialized */
    pthread_t tid[WORKPOOL_MAX_THREADS];
    workpool_arg args[WORKPOOL_MAX_THREADS];
};

/* A pool of `threads` threads counting the caller (at most
 * WORKPOOL_MAX_THREADS); none is started yet. Returns 0, or -1. */
int workpool_init(workpool *p, uint32_t threads);

/* Opens a job: wakes the helpers (started at the first job; a pool of one
 * thread has none). */
void workpool_start(workpool *p, workpool_fn fn, void *job);

/* Closes the job to helpers not yet in it and waits for those in it. */
void workpool_finish(workpool *p);

/* Stops and joins the helpers. Safe on a zeroed pool. */
void workpool_free(workpool *p);

#endif
