/* test_radix.c - radix.h against qsort on random keys: the same order and
 * equal keys in their first order (stability, through the carried values),
 * for maxima that take one to four passes, and the edge cases (no key, one
 * key). */
#include "check.h"
#include "radix.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RNG_SEED 0x7261646978736f72ULL
#include "rng.h"

typedef struct pair {
    uint64_t key;
    uint32_t value;
} pair;

/* by key, then by value: with values numbered in input order, the stable order */
static int by_key_then_value(const void *a, const void *b)
{
    const pair *x = a, *y = b;
    if (x->key != y->key) return x->key < y->key ? -1 : 1;
    return x->value < y->value ? -1 : x->value > y->value;
}

static radix_scratch kept; /* shared by every sort of test_kept_scratch */
static int use_kept;

static void check_against_qsort(size_t n, uint64_t max_key, int with_values)
{
    uint64_t *key = malloc((n + 1) * sizeof *key);
    uint32_t *value = malloc((n + 1) * sizeof *value);
    pair *ref = malloc((n + 1) * sizeof *ref);
    if (!key || !value || !ref) abort();
    for (size_t i = 0; i < n; ++i) {
        key[i] = max_key == UINT64_MAX ? rng_next() : rng_next() % (max_key + 1);
        value[i] = (uint32_t)i;
        ref[i] = (pair){key[i], (uint32_t)i};
    }
    CHECK((use_kept ? radix_sort_u64_with(key, with_values ? value : NULL, n, max_key, &kept)
                    : radix_sort_u64(key, with_values ? value : NULL, n, max_key)) == 0,
          "n %zu: sort failed", n);
    qsort(ref, n, sizeof *ref, by_key_then_value);
    size_t bad = 0;
    for (size_t i = 0; i < n; ++i) bad += key[i] != ref[i].key || (with_values && value[i] != ref[i].value);
    CHECK(bad == 0, "n %zu, max_key %llu, values %d: %zu positions differ from qsort's stable order", n,
          (unsigned long long)max_key, with_values, bad);
    free(key);
    free(value);
    free(ref);
}

static void test_orders(void)
{
    static const uint64_t maxima[] = {1, 255, 65535, 65536, 1000003, (1ull << 40) + 17, UINT64_MAX >> 1, UINT64_MAX};
    for (size_t m = 0; m < sizeof maxima / sizeof *maxima; ++m)
        for (int values = 0; values <= 1; ++values) {
            check_against_qsort(0, maxima[m], values);
            check_against_qsort(1, maxima[m], values);
            check_against_qsort(1000, maxima[m], values);
            check_against_qsort(100000, maxima[m], values);
        }
}

/* the same orders with one scratch kept across sorts of growing and
 * shrinking sizes, with and without values (radix_sort_u64_with) */
static void test_kept_scratch(void)
{
    use_kept = 1;
    test_orders();
    check_against_qsort(300000, 1000003, 1);
    check_against_qsort(50, 1000003, 1);
    use_kept = 0;
    radix_scratch_free(&kept);
    CHECK(kept.key == NULL && kept.value == NULL && kept.count == NULL, "freed scratch is empty");
}

int main(void)
{
    RUN(test_orders);
    RUN(test_kept_scratch);
    return check_summary();
}
