/* keymap.h - a small map from uint32 keys to uint32 values, emptied in O(1).
 *
 * For per-candidate bookkeeping ("have I seen face f, and where did I put
 * it?") whose size is that of a neighbourhood, not of the mesh: open
 * addressing with linear probing, load <= 1/2, grown by doubling; an entry
 * belongs to the map only while its generation is the map's current one, so
 * keymap_clear costs nothing until the generation counter wraps. Memory: 12
 * bytes per slot, slots = the largest size reached, times 2 to 4. */
#ifndef LODPIPE_KEYMAP_H
#define LODPIPE_KEYMAP_H

#include <stdint.h>

typedef struct keymap {
    uint32_t *key, *value, *generation;
    uint32_t mask;    /* slots - 1 (0 before the first insert) */
    uint32_t count;
    uint32_t current; /* generation of the live entries */
} keymap;

/* The map's hash, also an order for keys that nothing else orders: a
 * bijection of 32-bit integers (so distinct keys never tie) that scatters
 * neighbouring keys over the whole range (the lowbias32 mixer). */
static inline uint32_t keymap_hash(uint32_t k)
{
    k ^= k >> 16;
    k *= 0x7feb352dU;
    k ^= k >> 15;
    k *= 0x846ca68bU;
    return k ^ (k >> 16);
}

/* Empties the map (keeps its memory). */
void keymap_clear(keymap *m);
/* The value of key k, or NULL when k is absent. */
uint32_t *keymap_find(const keymap *m, uint32_t k);
/* Inserts k -> v when k is absent (an existing value is left alone). Returns
 * 1 inserted, 0 already present, -1 out of memory. */
int keymap_insert(keymap *m, uint32_t k, uint32_t v);
void keymap_free(keymap *m);

#endif
