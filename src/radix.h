/* radix.h - a stable least-significant-digit radix sort of 64-bit keys,
 * optionally carrying a 32-bit value with each: for the orders the pipeline
 * needs on millions of items (the simplifier's regions, the loader's
 * duplicate triangles), where glibc's qsort calls a comparison function at
 * every step and copies through a merge buffer.
 *
 * Promise. radix_sort_u64 sorts key[0 .. n) ascending, moving value[i] with
 * key[i] when value is not NULL; equal keys keep their order. It sorts on the
 * 16-bit digits up to max_key's highest bit, so every key must be <= max_key.
 * Returns 0, or -1 when its scratch (8 bytes a key, 4 a value, 512 KiB of
 * counts) cannot be allocated; the arrays are then unchanged. */
#ifndef LODPIPE_RADIX_H
#define LODPIPE_RADIX_H

#include <stddef.h>
#include <stdint.h>

int radix_sort_u64(uint64_t *key, uint32_t *value, size_t n, uint64_t max_key);

/* Scratch that one caller keeps across sorts (all zero to start): a caller
 * that sorts again and again then reuses memory whose pages are in already
 * instead of faulting fresh ones in at every sort. */
typedef struct radix_scratch {
    uint64_t *key;
    uint32_t *value;
    size_t *count;
    size_t key_cap, value_cap;
} radix_scratch;

/* radix_sort_u64 with its scratch in *scratch (grown when too small). */
int radix_sort_u64_with(uint64_t *key, uint32_t *value, size_t n, uint64_t max_key, radix_scratch *scratch);

void radix_scratch_free(radix_scratch *scratch);

#endif
