/* facegrid.h - a dynamic uniform spatial hash of faces by bounding box, for
 * the simplifier's self-intersection guard (DESIGN.md §5): "which faces of
 * the current mesh are near this new face?" while faces come and go.
 *
 * Space is cut into cubes of side cell_size; cell (i, j, k) holds the points
 * whose coordinates x satisfy floor(x * (1 / cell_size)) == i (and so on),
 * computed in double, with int64 cell coordinates. A face is entered in every
 * cell its closed box [lo, hi] overlaps. A face whose box spans more than
 * FACEGRID_MAX_CELLS_PER_FACE cells, or has a non-finite or inverted bound, or
 * lies beyond +-2^52 cells, goes into one "big faces" list instead, which
 * every query reports.
 *
 * Promise of a query with box [lo, hi]: every face present (inserted and not
 * removed since) whose inserted box overlaps [lo, hi] (closed boxes) is
 * reported, EXACTLY ONCE (a face in several cells is reported only from the
 * first cell, in x, then y, then z order, that it shares with the query; no
 * scratch memory needed). Faces whose cells merely touch the query's cells
 * are reported too (the grid is coarse), and big faces are always reported.
 * A removed face is never reported. Both sides use the same rounding of
 * coordinates to cells, and floor(x * s) is monotone in x, so a point in both
 * boxes lies in a cell of both: no overlap is missed. A query box with a NaN
 * bound reports every face; infinite bounds are fine; an inverted box (some
 * lo > hi) reports only the big faces.
 *
 * Order of reports: deterministic for a given sequence of inserts and removes
 * (it does not depend on addresses or on threads), otherwise unspecified.
 *
 * Memory: per face slot 4 bytes (face_capacity fixed at init or reset); a 16-byte
 * entry per (face, cell) pair, pooled with a free list and grown by doubling;
 * a 32-byte record per cell ever used and a 4-byte hash slot per cell at load
 * <= 1/2. Cells are not forgotten when they empty (so the table never needs
 * deletions); facegrid_clear forgets them. After the pools have grown to the
 * working size, insert and remove do not allocate.
 *
 * Threads: queries only read, so any number of threads may query at once
 * while no thread inserts, removes or clears. */
#ifndef LODPIPE_FACEGRID_H
#define LODPIPE_FACEGRID_H

#include <stddef.h>
#include <stdint.h>

/* A face whose box spans more cells than this goes into the big list. */
#define FACEGRID_MAX_CELLS_PER_FACE 4096

/* Face ids are below this (2^29; an entry keeps three flag bits above it). */
#define FACEGRID_MAX_FACES ((uint32_t)1 << 29)

#define FACEGRID_NONE UINT32_MAX

typedef enum {
    FACEGRID_OK = 0,
    FACEGRID_ERROR_OUT_OF_MEMORY,
    FACEGRID_ERROR_INVALID_ARGUMENT /* bad cell size, face id >= capacity, NULL */
} facegrid_result;

typedef struct {
    uint32_t face;          /* the face (low 29 bits), and bit 29 + k: the cell is
                               the face's lowest on axis k */
    uint32_t next_in_cell;  /* FACEGRID_NONE at the end */
    uint32_t prev_in_cell;  /* previous entry; for the cell's first entry
                               bit 31 + the cell's index (cell 0 is the big list) */
    uint32_t next_of_face;  /* the face's next entry; the free list's link */
} facegrid_entry;

typedef struct {
    int64_t key[3];         /* cell coordinates (unused for the big list) */
    uint32_t head;          /* first entry, FACEGRID_NONE when empty */
    uint32_t pad;
} facegrid_cell;

/* Read-only for users; fields are documented for tests and debugging. */
typedef struct {
    double cell_size;
    double inverse_cell_size;
    uint32_t face_capacity;
    uint32_t face_allocated;        /* face_head's length (>= face_capacity) */
    uint32_t face_count;            /* faces present */
    uint32_t *face_head;            /* first entry of each face, or FACEGRID_NONE */
    facegrid_entry *entries;
    uint32_t entry_used;            /* high-water mark of the pool */
    uint32_t entry_capacity;
    uint32_t entry_free;            /* free list head, or FACEGRID_NONE */
    uint32_t entry_free_count;      /* entries on the free list */
    facegrid_cell *cells;           /* cells[0] is the big list */
    uint32_t cell_count;
    uint32_t cell_capacity;
    uint32_t *table;                /* open addressing (linear probing): cell index or NONE */
    uint32_t table_mask;            /* table size - 1 (a power of two) */
} facegrid;

/* Prepares an empty grid for faces 0 .. face_capacity - 1 (face_capacity
 * <= FACEGRID_MAX_FACES) with cubic cells of side cell_size (finite, > 0). On failure the grid is empty and safe to
 * facegrid_free. */
facegrid_result facegrid_init(facegrid *g, double cell_size, uint32_t face_capacity);

/* facegrid_init for a grid that is initialised already (or all zero), with
 * the same result, except that the allocations stay where they are large
 * enough: a grid rebuilt again and again then writes to memory it has used
 * before instead of faulting fresh pages in (and its hash table keeps its
 * size, which changes no query's reports: cells are numbered in the order
 * they are made, whatever the table's size). On failure the grid is empty
 * and safe to facegrid_free. */
facegrid_result facegrid_reset(facegrid *g, double cell_size, uint32_t face_capacity);

/* Enters face (< face_capacity) with the box [lo, hi]. A face already present
 * is first removed (so insert also moves a face). On out of memory the face
 * is absent and the grid otherwise unchanged. */
facegrid_result facegrid_insert(facegrid *g, uint32_t face, const double lo[3], const double hi[3]);

/* 1 when a face entered with the box [lo_a, hi_a] would be entered in
 * exactly the same cells with [lo_b, hi_b] (neither going to the big list):
 * its entries would not change, so moving it is not needed. 0 otherwise. */
int facegrid_same_cells(const facegrid *g, const double lo_a[3], const double hi_a[3], const double lo_b[3],
                        const double hi_b[3]);

/* Removes every entry of face; nothing happens if it is absent or out of
 * range. Never allocates. */
void facegrid_remove(facegrid *g, uint32_t face);

/* 1 when face is present. */
int facegrid_contains(const facegrid *g, uint32_t face);

/* Called once per reported face; a non-zero return stops the query, which
 * then returns that value. */
typedef int (*facegrid_callback)(void *context, uint32_t face);

/* Reports the faces near [lo, hi] (see the promise above). Returns 0, or the
 * first non-zero callback value. Read-only: thread-safe against other
 * queries. */
int facegrid_query(const facegrid *g, const double lo[3], const double hi[3],
                   facegrid_callback callback, void *context);

/* Removes every face and forgets every cell; keeps the allocations. */
void facegrid_clear(facegrid *g);

/* Frees everything; the grid is left empty (init again to reuse). */
void facegrid_free(facegrid *g);

/* Bytes allocated by the grid. */
size_t facegrid_memory(const facegrid *g);

#endif
