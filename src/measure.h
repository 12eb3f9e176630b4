/* measure.h - an independent measurement of the distance between two
 * triangle sets: dense sampling of each side, exact closest-point queries
 * against the other side's BVH. It certifies nothing: a sampled maximum is a
 * LOWER bound of the true one-sided Hausdorff distance, which is exactly what a
 * check needs (a sampled value above a recorded bound proves the bound false).
 * It stays one despite rounding: each computed distance is reduced by what
 * geom.h allows it to overestimate (thin triangles, the sample point's own
 * rounding), about 1e-7 of the longest edge for ordinary meshes.
 * Cost: a sample that lies within the largest distance found so far cannot
 * raise the maximum and is settled by a decision query (bvh_any_within)
 * instead of an exact closest point: the same maximum, to the bit.
 * Used by `lodpipe check`, independently of the certificate's code paths. */
#ifndef LODPIPE_MEASURE_H
#define LODPIPE_MEASURE_H

#include <stdint.h>

typedef struct measure_mesh {
    const float *positions; /* xyz per vertex */
    uint32_t vertex_count;
    const uint32_t *triangles; /* 3 per triangle */
    uint32_t triangle_count;
} measure_mesh;

/* What the measures return when they cannot measure: a side is empty, or a
 * side's BVH cannot be built (out of memory). */
#define MEASURE_EMPTY (-1.0)
#define MEASURE_NO_MEMORY (-2.0)

/* max over sample points p of A of d(p, B); samples: every vertex and a
 * barycentric grid on each triangle with spacing at most `spacing`
 * (at most 64 x 64 per triangle). MEASURE_EMPTY when B is empty,
 * MEASURE_NO_MEMORY when its BVH cannot be built. */
double measure_one_sided(const measure_mesh *a, const measure_mesh *b, double spacing);

/* max of both directions (MEASURE_EMPTY, MEASURE_NO_MEMORY as above). */
double measure_two_sided(const measure_mesh *a, const measure_mesh *b, double spacing);

/* The same with the BVH of `a` built once for several b (a_tree over a). */
#include "bvh.h"
double measure_two_sided_with(const measure_mesh *a, const bvh *a_tree, const measure_mesh *b, double spacing);

#endif
