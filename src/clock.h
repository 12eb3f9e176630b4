/* clock.h - seconds on the monotonic clock, for the phase timings lodpipe
 * reports (simplify.json, batch progress). Only differences between two
 * readings mean anything. */
#ifndef LODPIPE_CLOCK_H
#define LODPIPE_CLOCK_H

#include <time.h>

static inline double lp_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

#endif
