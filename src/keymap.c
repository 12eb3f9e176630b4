/* keymap.c - see keymap.h. */
#include "keymap.h"

#include <stdlib.h>
#include <string.h>

void keymap_clear(keymap *m)
{
    m->count = 0;
    if (++m->current == 0) { /* wrapped: forget every old generation */
        if (m->generation) memset(m->generation, 0, ((size_t)m->mask + 1) * sizeof *m->generation);
        m->current = 1;
    }
}

uint32_t *keymap_find(const keymap *m, uint32_t k)
{
    if (!m->key) return NULL;
    for (uint32_t i = keymap_hash(k) & m->mask;; i = (i + 1) & m->mask) {
        if (m->generation[i] != m->current) return NULL;
        if (m->key[i] == k) return &m->value[i];
    }
}

static int grow(keymap *m)
{
    const uint32_t old_slots = m->key ? m->mask + 1 : 0, slots = old_slots ? 2 * old_slots : 256;
    uint32_t *key = malloc((size_t)slots * sizeof *key), *value = malloc((size_t)slots * sizeof *value),
             *generation = calloc(slots, sizeof *generation);
    if (!key || !value || !generation || slots == 0) {
        free(key);
        free(value);
        free(generation);
        return -1;
    }
    const uint32_t live = m->current ? m->current : 1;
    for (uint32_t j = 0; j < old_slots; ++j) {
        if (m->generation[j] != m->current) continue;
        uint32_t i = keymap_hash(m->key[j]) & (slots - 1);
        while (generation[i] == live) i = (i + 1) & (slots - 1);
        key[i] = m->key[j];
        value[i] = m->value[j];
        generation[i] = live;
    }
    free(m->key);
    free(m->value);
    free(m->generation);
    m->key = key;
    m->value = value;
    m->generation = generation;
    m->mask = slots - 1;
    m->current = live;
    return 0;
}

int keymap_insert(keymap *m, uint32_t k, uint32_t v)
{
    if (m->current == 0) m->current = 1;
    if ((!m->key || 2 * ((size_t)m->count + 1) > (size_t)m->mask + 1) && grow(m)) return -1;
    for (uint32_t i = keymap_hash(k) & m->mask;; i = (i + 1) & m->mask) {
        if (m->generation[i] != m->current) {
            m->key[i] = k;
            m->value[i] = v;
            m->generation[i] = m->current;
            m->count++;
            return 1;
        }
        if (m->key[i] == k) return 0;
    }
}

void keymap_free(keymap *m)
{
    free(m->key);
    free(m->value);
    free(m->generation);
    memset(m, 0, sizeof *m);
}
