/* radix.c - see radix.h. */
#include "radix.h"

#include <stdlib.h>
#include <string.h>

#define DIGIT_BITS 16
#define DIGITS (1u << DIGIT_BITS)

int radix_sort_u64(uint64_t *key, uint32_t *value, size_t n, uint64_t max_key)
{
    radix_scratch scratch = {0};
    const int rc = radix_sort_u64_with(key, value, n, max_key, &scratch);
    radix_scratch_free(&scratch);
    return rc;
}

void radix_scratch_free(radix_scratch *scratch)
{
    free(scratch->key);
    free(scratch->value);
    free(scratch->count);
    memset(scratch, 0, sizeof *scratch);
}

/* Grows *data to hold n items of elem bytes (its contents are not kept). */
static int room(void **data, size_t *cap, size_t n, size_t elem)
{
    if (*data && *cap >= n) return 0;
    void *p = malloc(n * elem);
    if (!p) return -1;
    free(*data);
    *data = p;
    *cap = n;
    return 0;
}

int radix_sort_u64_with(uint64_t *key, uint32_t *value, size_t n, uint64_t max_key, radix_scratch *scratch)
{
    if (n < 2 || max_key == 0) return 0;
    size_t count_cap = scratch->count ? DIGITS : 0;
    if (room((void **)&scratch->key, &scratch->key_cap, n, sizeof *scratch->key) ||
        (value && room((void **)&scratch->value, &scratch->value_cap, n, sizeof *scratch->value)) ||
        room((void **)&scratch->count, &count_cap, DIGITS, sizeof *scratch->count))
        return -1;
    uint64_t *tmp_key = scratch->key;
    uint32_t *tmp_value = value ? scratch->value : NULL;
    size_t *count = scratch->count;
    uint64_t *from_key = key, *to_key = tmp_key;
    uint32_t *from_value = value, *to_value = tmp_value;
    for (unsigned shift = 0; shift < 64 && (max_key >> shift) != 0; shift += DIGIT_BITS) {
        memset(count, 0, DIGITS * sizeof *count);
        for (size_t i = 0; i < n; ++i) count[(from_key[i] >> shift) & (DIGITS - 1)]++;
        size_t at = 0;
        for (size_t d = 0; d < DIGITS; ++d) {
            const size_t c = count[d];
            count[d] = at;
            at += c;
        }
        for (size_t i = 0; i < n; ++i) {
            const size_t to = count[(from_key[i] >> shift) & (DIGITS - 1)]++;
            to_key[to] = from_key[i];
            if (value) to_value[to] = from_value[i];
        }
        uint64_t *k = from_key;
        from_key = to_key;
        to_key = k;
        uint32_t *v = from_value;
        from_value = to_value;
        to_value = v;
    }
    if (from_key != key) { /* an odd number of passes: the result is in the scratch */
        memcpy(key, from_key, n * sizeof *key);
        if (value) memcpy(value, from_value, n * sizeof *value);
    }
    return 0;
}
