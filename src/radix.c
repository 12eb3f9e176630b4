/* radix.c - see radix.h. */
#include "radix.h"

#include <stdlib.h>
#include <string.h>

#define DIGIT_BITS 16
#define DIGITS (1u << DIGIT_BITS)

int radix_sort_u64(uint64_t *key, uint32_t *value, size_t n, uint64_t max_key)
{
    if (n < 2 || max_key == 0) return 0;
    uint64_t *tmp_key = malloc(n * sizeof *tmp_key);
    uint32_t *tmp_value = value ? malloc(n * sizeof *tmp_value) : NULL;
    size_t *count = malloc(DIGITS * sizeof *count);
    if (!tmp_key || (value && !tmp_value) || !count) {
        free(tmp_key);
        free(tmp_value);
        free(count);
        return -1;
    }
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
    free(tmp_key);
    free(tmp_value);
    free(count);
    return 0;
}
