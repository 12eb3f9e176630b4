/* test_keymap.c - keymap.h against a plain array as the reference: inserts,
 * repeated keys, growth, clearing by generation and the generation wrap. */
#include "check.h"
#include "keymap.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define RNG_SEED 0x6b65796d61702121ULL
#include "rng.h"

enum { UNIVERSE = 5000 };

static void test_against_array(void)
{
    keymap m;
    memset(&m, 0, sizeof m);
    static uint32_t ref[UNIVERSE];
    static uint8_t present[UNIVERSE];
    CHECK(keymap_find(&m, 7) == NULL, "empty map finds nothing");
    for (int round = 0; round < 50; ++round) {
        keymap_clear(&m);
        memset(present, 0, sizeof present);
        uint32_t n = (uint32_t)(rng_next() % 3000), live = 0;
        for (uint32_t i = 0; i < n; ++i) {
            uint32_t k = (uint32_t)(rng_next() % UNIVERSE), v = (uint32_t)rng_next();
            int r = keymap_insert(&m, k, v);
            CHECK(r == (present[k] ? 0 : 1), "insert %u: %d (present %d)", k, r, present[k]);
            if (!present[k]) {
                present[k] = 1;
                ref[k] = v;
                live++;
            }
        }
        CHECK(m.count == live, "count %u == %u", m.count, live);
        int wrong = 0;
        for (uint32_t k = 0; k < UNIVERSE; ++k) {
            uint32_t *at = keymap_find(&m, k);
            wrong += present[k] ? !(at && *at == ref[k]) : at != NULL;
        }
        CHECK(wrong == 0, "round %d: %d keys wrong", round, wrong);
    }
    /* the generation counter wraps: old entries must not come back */
    keymap_clear(&m);
    CHECK(keymap_insert(&m, 42, 1) == 1, "insert 42");
    m.current = UINT32_MAX;
    CHECK(keymap_insert(&m, 43, 2) == 1, "insert 43 at the last generation");
    keymap_clear(&m);
    CHECK(m.current == 1 && keymap_find(&m, 42) == NULL && keymap_find(&m, 43) == NULL, "wrap forgets everything");
    CHECK(keymap_insert(&m, 43, 3) == 1 && *keymap_find(&m, 43) == 3, "usable after the wrap");
    keymap_free(&m);
}

int main(void)
{
    RUN(test_against_array);
    return check_summary();
}
