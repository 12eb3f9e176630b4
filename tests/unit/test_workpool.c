/* test_workpool.c - jobs through the pool: many short jobs in a row (the
 * helpers poll, sleep and wake between them), each item of a job done once
 * whoever claims it, the helpers' writes visible after workpool_finish, and
 * a pool of one thread (no helpers) or one never given a job. */
#include "check.h"
#include "workpool.h"

#include <stdatomic.h>
#include <stdint.h>
#include <string.h>
#include <time.h>

#define ITEMS 64
#define JOBS 2000

typedef struct {
    atomic_uint next;
    uint32_t count;
    uint32_t done[ITEMS]; /* written by whoever claims the item */
    uint32_t by[ITEMS];
} counting_job;

static void count_items(void *p, uint32_t thread)
{
    counting_job *job = p;
    for (;;) {
        const uint32_t k = atomic_fetch_add_explicit(&job->next, 1, memory_order_relaxed);
        if (k >= job->count) return;
        job->done[k]++;
        job->by[k] = thread;
    }
}

static void run_jobs(uint32_t threads, int sleep_between)
{
    workpool pool;
    CHECK(workpool_init(&pool, threads) == 0, "init");
    uint32_t helped = 0, wrong = 0;
    for (uint32_t j = 0; j < JOBS; ++j) {
        counting_job job;
        memset(&job, 0, sizeof job);
        atomic_init(&job.next, 0);
        job.count = 1 + j % ITEMS;
        workpool_start(&pool, count_items, &job);
        count_items(&job, 0);
        workpool_finish(&pool);
        for (uint32_t k = 0; k < job.count; ++k) {
            wrong += job.done[k] != 1;
            wrong += job.by[k] >= threads;
            helped += job.by[k] != 0;
        }
        if (sleep_between && j % 100 == 0) {
            const struct timespec pause = {0, 5000000}; /* longer than the helpers poll */
            nanosleep(&pause, NULL);
        }
    }
    CHECK(wrong == 0, "%u items done other than once, or by no thread of the pool (%u threads)", wrong, threads);
    if (threads == 1) CHECK(helped == 0, "a pool of one thread has no helper, yet %u items were theirs", helped);
    workpool_free(&pool);
}

static void test_one_thread(void) { run_jobs(1, 0); }
static void test_two_threads(void) { run_jobs(2, 1); }
static void test_more_threads_than_cores(void) { run_jobs(5, 0); }

static void test_never_started(void)
{
    workpool pool;
    CHECK(workpool_init(&pool, 4) == 0, "init");
    CHECK(pool.started == 0, "no helper before the first job");
    workpool_free(&pool);
    workpool_free(&pool); /* zeroed: safe again */
}

int main(void)
{
    RUN(test_one_thread);
    RUN(test_two_threads);
    RUN(test_more_threads_than_cores);
    RUN(test_never_started);
    return check_summary();
}
