/* rng.h - the unit tests' fixed-seed random numbers (splitmix64), so a test
 * that fails fails the same way every time. Define RNG_SEED before including. */
#ifndef LODPIPE_TEST_RNG_H
#define LODPIPE_TEST_RNG_H

#include <stdint.h>

#ifndef RNG_SEED
#error "define RNG_SEED before including rng.h"
#endif

static uint64_t rng_state = RNG_SEED;

static inline uint64_t rng_next(void)
{
    uint64_t z = (rng_state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* Uniform in [lo, hi). */
static inline double rng_uniform(double lo, double hi)
{
    return lo + (hi - lo) * (double)(rng_next() >> 11) * (1.0 / 9007199254740992.0);
}

#endif
