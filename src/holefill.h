/* holefill.h - the triangulations of a small polygon, cheapest first: the
 * ways to fill the hole a removed vertex leaves (DESIGN.md §3, Cohen et al.'s
 * vertex removal).
 *
 * A polygon of n corners 0 .. n-1 (3 <= n <= HOLEFILL_MAX_CORNERS), each
 * consecutive pair and (n-1, 0) an edge, has Catalan(n - 2) triangulations:
 * n - 2 triangles whose other edges (diagonals) do not cross. The caller
 * says which diagonals are allowed and what each triangle costs.
 *
 * Promise. holefill_all returns every triangulation whose diagonals are all
 * allowed and whose triangles all have a finite cost, each once, sorted by
 * total cost (the sum of its triangles') and, on equal cost, by its triangle
 * list, so the order is fully determined by the inputs. Each triangle is
 * (i, j, k) with i < j < k: in the polygon's order, so wound as the polygon.
 * Triangles are listed in a fixed order for a given triangulation. */
#ifndef LODPIPE_HOLEFILL_H
#define LODPIPE_HOLEFILL_H

#include <stdint.h>

#define HOLEFILL_MAX_CORNERS 10
#define HOLEFILL_MAX 1430 /* Catalan(8): the triangulations of a decagon */

typedef struct holefill {
    double cost;
    uint8_t tri[HOLEFILL_MAX_CORNERS - 2][3];
} holefill;

typedef struct holefill_problem {
    uint32_t n;
    /* allowed[i][j], i < j: corners i and j may be joined (edges of the
     * polygon are always allowed, whatever is set here) */
    uint8_t allowed[HOLEFILL_MAX_CORNERS][HOLEFILL_MAX_CORNERS];
    /* cost[i][j][k], i < j < k: the triangle's cost, INFINITY to forbid it */
    double cost[HOLEFILL_MAX_CORNERS][HOLEFILL_MAX_CORNERS][HOLEFILL_MAX_CORNERS];
} holefill_problem;

/* Writes the triangulations to out (room for HOLEFILL_MAX) and returns how
 * many; 0 when n is out of range or none is allowed. */
uint32_t holefill_all(const holefill_problem *p, holefill out[HOLEFILL_MAX]);

/* The same triangulations, in a heap: holefill_pop then hands them out in
 * holefill_all's order, one at a time, for callers that stop after the
 * first few (a decagon has 1,430, and sorting them all was 8 % of a whole
 * simplification's instructions). holefill_heap returns the count;
 * holefill_pop takes the next (*count > 0), decrements *count and returns
 * where it now lies (valid until the next pop). */
uint32_t holefill_heap(const holefill_problem *p, holefill out[HOLEFILL_MAX]);
const holefill *holefill_pop(holefill *heap, uint32_t *count);

#endif
