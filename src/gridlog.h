/* gridlog.h - the commit's face-grid updates, applied in order on a helper
 * thread while the committing thread goes on.
 *
 * The simplifier commits a batch serially, and while it does, the other
 * cores have nothing to evaluate. About 40% of a commit was keeping the face
 * grid (facegrid.h) up to date, yet nothing in a commit reads the grid: only
 * the next batch's evaluation does. So the commit pushes each grid update
 * here, a helper thread applies them in push order, and gridlog_finish waits
 * until all are applied, before anyone queries the grid again.
 *
 * Promise: after gridlog_finish the grid is exactly what applying the same
 * updates inline, in the same order, would have made it (threaded or not),
 * and so is the order of every later query's reports (facegrid.h: it is
 * deterministic for a given sequence of inserts and removes).
 *
 * An update either removes a face, or says that a face moved from box old to
 * box new: a face that is present and whose two boxes lie in the same cells
 * (facegrid_same_cells) keeps its entries; any other is (re-)inserted.
 *
 * Memory: a fixed ring of updates (gridlog_init); a push waits while the ring
 * is full. Threads: one thread starts, pushes and finishes; nothing else may
 * touch the grid between gridlog_start and gridlog_finish. */
#ifndef LODPIPE_GRIDLOG_H
#define LODPIPE_GRIDLOG_H

#include <pthread.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#include "facegrid.h"

typedef struct gridlog_update {
    uint32_t face;
    uint32_t remove;                        /* 1: remove; 0: moved from old to new */
    double old_lo[3], old_hi[3], lo[3], hi[3];
} gridlog_update;

typedef struct gridlog {
    facegrid *grid;
    gridlog_update *ring;
    size_t mask;              /* ring size - 1 (a power of two) */
    atomic_size_t pushed;     /* updates pushed since gridlog_start */
    atomic_size_t applied;    /* updates applied (the applier's side) */
    atomic_int closed;        /* pushed is final */
    int out_of_memory;        /* an insert failed (the applier's side; read after finish) */
    int threaded;             /* a helper thread is applying */
    pthread_t thread;
} gridlog;

/* A ring of at least `capacity` updates (>= 1). Returns 0, or -1 when out of
 * memory (the log is then empty and safe to free). */
int gridlog_init(gridlog *l, size_t capacity);
void gridlog_free(gridlog *l);

/* Begins a run of updates to grid g: on a helper thread when `threaded` (and
 * one can be started), else each push applies its update at once. */
void gridlog_start(gridlog *l, facegrid *g, int threaded);

void gridlog_remove(gridlog *l, uint32_t face);
void gridlog_move(gridlog *l, uint32_t face, const double old_lo[3], const double old_hi[3], const double lo[3],
                  const double hi[3]);

/* Waits until every update pushed is applied. Returns 0, or -1 when an insert
 * ran out of memory (that face is then absent from the grid). */
int gridlog_finish(gridlog *l);

#endif
