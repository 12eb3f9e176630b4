/* threads.h - how many threads a "threads" option means: the number asked
 * for, or one per online core when it is 0 (at least one), never more than
 * the caller's fixed arrays hold. The simplifier, the morph measurement and
 * the batch scheduler resolve their option through it. */
#ifndef LODPIPE_THREADS_H
#define LODPIPE_THREADS_H

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

#endif
