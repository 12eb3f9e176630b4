/* facegrid.c - dynamic uniform spatial hash of faces (see facegrid.h).
 *
 * Layout: a pool of 16-byte entries (one per face and cell), each in two
 * lists: the cell's doubly linked list (so removal is O(1) per entry; the
 * first entry's back link names the cell, so an entry needs no cell field)
 * and the face's singly linked chain (so removal finds them). Cells are records in a flat
 * array, found by key through an open-addressing table of cell indices with
 * linear probing; cell records are never deleted before facegrid_clear, so
 * the table needs no tombstones. Every insert reserves all the entries, cells
 * and table slots it may need before it changes anything, so running out of
 * memory leaves the grid as it was. */
#include "facegrid.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geom.h"

#define BIG_CELL 0u
/* Cell coordinates of inserted faces stay within +-2^52 (where doubles are
 * still integers exactly); query ranges are clamped to +-2^62. */
#define CELL_LIMIT 4503599627370496.0
#define QUERY_LIMIT 4611686018427387904.0
#define MAX_POOL ((uint32_t)1 << 30)
#define MAX_CELLS ((uint32_t)1 << 29)
/* An entry's `face` field: the face in the low bits (faces are below
 * FACEGRID_MAX_FACES), and above it one bit per axis saying whether the
 * cell is the face's lowest on that axis (what the exactly-once rule of
 * report_cell needs), so no per-face record of the first cell is kept. */
#define FACE_MASK (FACEGRID_MAX_FACES - 1u)
#define FIRST_ON_AXIS(k) ((uint32_t)FACEGRID_MAX_FACES << (k))
/* prev_in_cell of a cell's first entry: this bit and the cell index (entry
 * indices are below MAX_POOL, so they never have it). */
#define CELL_HEAD ((uint32_t)1 << 31)

/* ---- hashing -------------------------------------------------------------- */

static uint64_t hash_key(const int64_t key[3])
{
    uint64_t h = (uint64_t)key[0] * 0x9e3779b97f4a7c15ULL;
    h ^= (uint64_t)key[1] * 0xc2b2ae3d27d4eb4fULL;
    h ^= (uint64_t)key[2] * 0x165667b19e3779f9ULL;
    h ^= h >> 31;
    h *= 0xbf58476d1ce4e5b9ULL;
    h ^= h >> 27;
    h *= 0x94d049bb133111ebULL;
    return h ^ (h >> 31);
}

static int same_key(const int64_t a[3], const int64_t b[3])
{
    return a[0] == b[0] && a[1] == b[1] && a[2] == b[2];
}

/* The cell with this key, or FACEGRID_NONE. */
static uint32_t find_cell(const facegrid *g, const int64_t key[3])
{
    uint32_t slot = (uint32_t)hash_key(key) & g->table_mask;
    for (;;) {
        uint32_t cell = g->table[slot];
        if (cell == FACEGRID_NONE || same_key(g->cells[cell].key, key)) return cell;
        slot = (slot + 1) & g->table_mask;
    }
}

static void table_put(uint32_t *table, uint32_t mask, uint64_t hash, uint32_t cell)
{
    uint32_t slot = (uint32_t)hash & mask;
    while (table[slot] != FACEGRID_NONE) slot = (slot + 1) & mask;
    table[slot] = cell;
}

/* ---- reserving room ------------------------------------------------------- */

/* Room for `more` cells beyond cell_count, with the table at load <= 1/2. */
static int reserve_cells(facegrid *g, uint64_t more)
{
    uint64_t need = (uint64_t)g->cell_count + more;
    if (need > MAX_CELLS) return -1;
    if (need > g->cell_capacity) {
        uint64_t capacity = g->cell_capacity ? g->cell_capacity : 64;
        while (capacity < need) capacity *= 2;
        facegrid_cell *cells = realloc(g->cells, (size_t)capacity * sizeof *cells);
        if (!cells) return -1;
        g->cells = cells;
        g->cell_capacity = (uint32_t)capacity;
    }
    uint64_t size = (uint64_t)g->table_mask + 1;
    if (need * 2 > size) {
        while (need * 2 > size) size *= 2;
        uint32_t *table = malloc((size_t)size * sizeof *table);
        if (!table) return -1;
        memset(table, 0xff, (size_t)size * sizeof *table);
        uint32_t mask = (uint32_t)(size - 1);
        for (uint32_t c = 1; c < g->cell_count; c++) table_put(table, mask, hash_key(g->cells[c].key), c);
        free(g->table);
        g->table = table;
        g->table_mask = mask;
    }
    return 0;
}

/* Room for `more` entries without growing again. */
static int reserve_entries(facegrid *g, uint64_t more)
{
    if (more <= g->entry_free_count) return 0;
    uint64_t need = (uint64_t)g->entry_used + (more - g->entry_free_count);
    if (need > MAX_POOL) return -1;
    if (need > g->entry_capacity) {
        uint64_t capacity = g->entry_capacity ? g->entry_capacity : 256;
        while (capacity < need) capacity *= 2;
        facegrid_entry *entries = realloc(g->entries, (size_t)capacity * sizeof *entries);
        if (!entries) return -1;
        g->entries = entries;
        g->entry_capacity = (uint32_t)capacity;
    }
    return 0;
}

/* ---- entries and cells ---------------------------------------------------- */

/* Takes an entry (room reserved) and links it at the front of `cell` and of
 * face's chain; `first_axes` are FIRST_ON_AXIS bits. */
static void add_entry(facegrid *g, uint32_t face, uint32_t cell, uint32_t first_axes)
{
    uint32_t e;
    if (g->entry_free != FACEGRID_NONE) {
        e = g->entry_free;
        g->entry_free = g->entries[e].next_of_face;
        g->entry_free_count--;
    } else {
        e = g->entry_used++;
    }
    facegrid_entry *entry = &g->entries[e];
    entry->face = face | first_axes;
    entry->prev_in_cell = CELL_HEAD | cell;
    entry->next_in_cell = g->cells[cell].head;
    if (entry->next_in_cell != FACEGRID_NONE) g->entries[entry->next_in_cell].prev_in_cell = e;
    g->cells[cell].head = e;
    entry->next_of_face = g->face_head[face];
    g->face_head[face] = e;
}

/* The cell with this key, created (room reserved) when new. */
static uint32_t get_cell(facegrid *g, const int64_t key[3])
{
    uint64_t hash = hash_key(key);
    uint32_t slot = (uint32_t)hash & g->table_mask;
    for (;;) {
        uint32_t cell = g->table[slot];
        if (cell == FACEGRID_NONE) break;
        if (same_key(g->cells[cell].key, key)) return cell;
        slot = (slot + 1) & g->table_mask;
    }
    uint32_t cell = g->cell_count++;
    memcpy(g->cells[cell].key, key, sizeof g->cells[cell].key);
    g->cells[cell].head = FACEGRID_NONE;
    g->cells[cell].pad = 0;
    g->table[slot] = cell;
    return cell;
}

/* ---- public --------------------------------------------------------------- */

facegrid_result facegrid_init(facegrid *g, double cell_size, uint32_t face_capacity)
{
    if (!g) return FACEGRID_ERROR_INVALID_ARGUMENT;
    memset(g, 0, sizeof *g);
    return facegrid_reset(g, cell_size, face_capacity);
}

facegrid_result facegrid_reset(facegrid *g, double cell_size, uint32_t face_capacity)
{
    if (!g) return FACEGRID_ERROR_INVALID_ARGUMENT;
    if (!(cell_size > 0) || !isfinite(cell_size) || !isfinite(1.0 / cell_size) ||
        face_capacity > FACEGRID_MAX_FACES) {
        facegrid_free(g);
        return FACEGRID_ERROR_INVALID_ARGUMENT;
    }
    g->cell_size = cell_size;
    g->inverse_cell_size = 1.0 / cell_size;
    g->face_capacity = face_capacity;
    if (!g->face_head || face_capacity > g->face_allocated) {
        free(g->face_head);
        g->face_allocated = face_capacity ? face_capacity : 1;
        g->face_head = malloc((size_t)g->face_allocated * sizeof *g->face_head);
    }
    if (!g->table) {
        g->table = malloc(128 * sizeof *g->table);
        g->table_mask = 127;
    }
    if (!g->cells) g->cell_count = 0;
    if (!g->face_head || !g->table || (!g->cells && reserve_cells(g, 1) != 0)) {
        facegrid_free(g);
        return FACEGRID_ERROR_OUT_OF_MEMORY;
    }
    facegrid_clear(g);
    return FACEGRID_OK;
}

void facegrid_clear(facegrid *g)
{
    if (!g || !g->face_head) return;
    memset(g->face_head, 0xff, (size_t)g->face_capacity * sizeof *g->face_head);
    memset(g->table, 0xff, ((size_t)g->table_mask + 1) * sizeof *g->table);
    g->face_count = 0;
    g->entry_used = 0;
    g->entry_free = FACEGRID_NONE;
    g->entry_free_count = 0;
    g->cell_count = 1; /* the big list */
    memset(&g->cells[BIG_CELL], 0, sizeof g->cells[BIG_CELL]);
    g->cells[BIG_CELL].head = FACEGRID_NONE;
}

void facegrid_free(facegrid *g)
{
    if (!g) return;
    free(g->face_head);
    free(g->entries);
    free(g->cells);
    free(g->table);
    memset(g, 0, sizeof *g);
    g->entry_free = FACEGRID_NONE;
}

size_t facegrid_memory(const facegrid *g)
{
    if (!g || !g->face_head) return 0;
    return (size_t)g->face_allocated * sizeof *g->face_head +
           (size_t)g->entry_capacity * sizeof *g->entries +
           (size_t)g->cell_capacity * sizeof *g->cells +
           ((size_t)g->table_mask + 1) * sizeof *g->table;
}

int facegrid_contains(const facegrid *g, uint32_t face)
{
    return g && face < g->face_capacity && g->face_head[face] != FACEGRID_NONE;
}

void facegrid_remove(facegrid *g, uint32_t face)
{
    if (!facegrid_contains(g, face)) return;
    uint32_t e = g->face_head[face];
    while (e != FACEGRID_NONE) {
        facegrid_entry *entry = &g->entries[e];
        uint32_t next = entry->next_of_face;
        if (entry->prev_in_cell & CELL_HEAD)
            g->cells[entry->prev_in_cell & ~CELL_HEAD].head = entry->next_in_cell;
        else
            g->entries[entry->prev_in_cell].next_in_cell = entry->next_in_cell;
        if (entry->next_in_cell != FACEGRID_NONE)
            g->entries[entry->next_in_cell].prev_in_cell = entry->prev_in_cell;
        entry->face = FACEGRID_NONE;
        entry->next_of_face = g->entry_free;
        g->entry_free = e;
        g->entry_free_count++;
        e = next;
    }
    g->face_head[face] = FACEGRID_NONE;
    g->face_count--;
}

/* One axis of an inserted box's cell range, or 0 when the face belongs in
 * the big list on that axis (inverted, non-finite or too far): |floor(x)| <=
 * 2^52 exactly when |x| <= 2^52 (an integer), which also turns away NaN and
 * infinite bounds. */
static inline int axis_cells(const facegrid *g, double lo, double hi, int64_t *c0, int64_t *c1)
{
    const double x = lo * g->inverse_cell_size, y = hi * g->inverse_cell_size;
    if (!(lo <= hi) || !(fabs(x) <= CELL_LIMIT) || !(fabs(y) <= CELL_LIMIT)) return 0;
    *c0 = (int64_t)geom_floor(x);
    *c1 = (int64_t)geom_floor(y);
    return 1;
}

/* The cell range of an inserted box, or 0 when the face belongs in the big
 * list (non-finite, inverted, too far, or too many cells). */
static int insert_range(const facegrid *g, const double lo[3], const double hi[3], int64_t c0[3],
                        int64_t c1[3], uint64_t *cell_total)
{
    double total = 1;
    for (int k = 0; k < 3; k++) {
        if (!axis_cells(g, lo[k], hi[k], &c0[k], &c1[k])) return 0;
        total *= (double)(c1[k] - c0[k] + 1);
    }
    if (total > FACEGRID_MAX_CELLS_PER_FACE) return 0;
    *cell_total = (uint64_t)total;
    return 1;
}

/* insert_range of both boxes, compared axis by axis so that most calls stop
 * early (it runs on every move of a face, most of which stay in their
 * cells): equal ranges have equal totals, so b's cap is a's. */
int facegrid_same_cells(const facegrid *g, const double lo_a[3], const double hi_a[3], const double lo_b[3],
                        const double hi_b[3])
{
    if (!g) return 0;
    double total = 1;
    for (int k = 0; k < 3; k++) {
        int64_t a0, a1, b0, b1;
        if (!axis_cells(g, lo_a[k], hi_a[k], &a0, &a1) || !axis_cells(g, lo_b[k], hi_b[k], &b0, &b1) || a0 != b0 ||
            a1 != b1)
            return 0;
        total *= (double)(a1 - a0 + 1);
    }
    return total <= FACEGRID_MAX_CELLS_PER_FACE;
}

facegrid_result facegrid_insert(facegrid *g, uint32_t face, const double lo[3], const double hi[3])
{
    if (!g || !g->face_head || face >= g->face_capacity || !lo || !hi)
        return FACEGRID_ERROR_INVALID_ARGUMENT;
    facegrid_remove(g, face);

    int64_t c0[3], c1[3];
    uint64_t total = 0;
    int small = insert_range(g, lo, hi, c0, c1, &total);
    if (!small) {
        if (reserve_entries(g, 1) != 0) return FACEGRID_ERROR_OUT_OF_MEMORY;
        add_entry(g, face, BIG_CELL, 0);
        g->face_count++;
        return FACEGRID_OK;
    }
    if (reserve_entries(g, total) != 0 || reserve_cells(g, total) != 0)
        return FACEGRID_ERROR_OUT_OF_MEMORY;

    int64_t key[3];
    for (key[0] = c0[0]; key[0] <= c1[0]; key[0]++)
        for (key[1] = c0[1]; key[1] <= c1[1]; key[1]++)
            for (key[2] = c0[2]; key[2] <= c1[2]; key[2]++) {
                uint32_t first = 0;
                for (int k = 0; k < 3; k++)
                    if (key[k] == c0[k]) first |= FIRST_ON_AXIS(k);
                add_entry(g, face, get_cell(g, key), first);
            }
    g->face_count++;
    return FACEGRID_OK;
}

/* Query cell coordinate of x (not NaN), clamped to +-2^62 so that the
 * range loops never overflow. */
static int64_t query_coordinate(const facegrid *g, double x)
{
    double c = geom_floor(x * g->inverse_cell_size);
    if (c < -QUERY_LIMIT) c = -QUERY_LIMIT;
    if (c > QUERY_LIMIT) c = QUERY_LIMIT;
    return (int64_t)c;
}

/* Reports the entries of one cell (inside the query range [q0, q1]) whose
 * face has here its first cell in common with the range: on every axis the
 * cell is max(the face's lowest cell, q0). Both are <= the cell's key, so
 * that max equals the key exactly when one of them does: the entry's
 * FIRST_ON_AXIS bit, or key == q0. */
static int report_cell(const facegrid *g, uint32_t cell, const int64_t q0[3],
                       facegrid_callback callback, void *context)
{
    const int64_t *key = g->cells[cell].key;
    uint32_t at_query_low = 0;
    for (int k = 0; k < 3; k++)
        if (key[k] == q0[k]) at_query_low |= FIRST_ON_AXIS(k);
    const uint32_t all_axes = FIRST_ON_AXIS(0) | FIRST_ON_AXIS(1) | FIRST_ON_AXIS(2);
    for (uint32_t e = g->cells[cell].head; e != FACEGRID_NONE; e = g->entries[e].next_in_cell) {
        uint32_t face = g->entries[e].face;
        if (((face | at_query_low) & all_axes) != all_axes) continue;
        int r = callback(context, face & FACE_MASK);
        if (r) return r;
    }
    return 0;
}

int facegrid_query(const facegrid *g, const double lo[3], const double hi[3],
                   facegrid_callback callback, void *context)
{
    if (!g || !g->face_head || !callback || !lo || !hi) return 0;

    for (uint32_t e = g->cells[BIG_CELL].head; e != FACEGRID_NONE; e = g->entries[e].next_in_cell) {
        int r = callback(context, g->entries[e].face & FACE_MASK);
        if (r) return r;
    }

    /* a NaN bound: the whole space */
    int any_nan = 0;
    for (int k = 0; k < 3; k++) any_nan |= isnan(lo[k]) || isnan(hi[k]);
    int64_t q0[3], q1[3];
    double count = 1;
    for (int k = 0; k < 3; k++) {
        q0[k] = any_nan ? -(int64_t)QUERY_LIMIT : query_coordinate(g, lo[k]);
        q1[k] = any_nan ? (int64_t)QUERY_LIMIT : query_coordinate(g, hi[k]);
        if (q0[k] > q1[k]) return 0;
        count *= (double)q1[k] - (double)q0[k] + 1; /* in double: the span can exceed int64 */
    }

    if (count <= (double)g->cell_count) {
        int64_t key[3];
        for (key[0] = q0[0]; key[0] <= q1[0]; key[0]++)
            for (key[1] = q0[1]; key[1] <= q1[1]; key[1]++)
                for (key[2] = q0[2]; key[2] <= q1[2]; key[2]++) {
                    uint32_t cell = find_cell(g, key);
                    if (cell == FACEGRID_NONE) continue;
                    int r = report_cell(g, cell, q0, callback, context);
                    if (r) return r;
                }
        return 0;
    }
    /* a query wider than the set of cells: scan the cells instead */
    for (uint32_t cell = 1; cell < g->cell_count; cell++) {
        const int64_t *key = g->cells[cell].key;
        if (key[0] < q0[0] || key[0] > q1[0] || key[1] < q0[1] || key[1] > q1[1] ||
            key[2] < q0[2] || key[2] > q1[2])
            continue;
        int r = report_cell(g, cell, q0, callback, context);
        if (r) return r;
    }
    return 0;
}
