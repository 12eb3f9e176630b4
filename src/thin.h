/* thin.h - where the original is "thin", so that the simplifier's
 * self-intersection test (DESIGN.md §5) runs only there.
 *
 * Space is cut into cubes of side `radius` (the simplifier uses 2 eps of the
 * level). A cube is thin when, among the original triangles touching it and
 * its 26 neighbours (everything within `radius` of any point of the cube):
 *   - the surface is not one coherent sheet: |sum of area-weighted normals|
 *     is below half the area (two sheets facing each other or away, a thin
 *     plate or tube, a fold: all give about 0; scan noise on one sheet stays
 *     near 1);
 *   - or there is more than one connected component or material (a part or
 *     a decal lying on another surface faces the same way as it);
 *   - or a vertex the caller marks special (border, non-manifold) or a
 *     non-finite triangle lies there.
 * Everything else is one coherent sheet, where a collapse whose faces stay
 * within eps of it has no other part of the surface to run into. This is the
 * design's heuristic for WHERE to test, not part of the certified bound; the
 * simplifier's strict mode tests everywhere. A triangle spanning more than
 * 64 cubes makes everything thin (low-poly input: test everywhere).
 *
 * Memory: a 64-byte record per occupied cube and per cube next to a thin
 * one, hashed at load <= 1/2, and a 4-byte union-find entry per vertex while
 * building. */
#ifndef LODPIPE_THIN_H
#define LODPIPE_THIN_H

#include <stdint.h>

typedef struct thin_cube thin_cube;

typedef struct thin_map {
    double inv_cell;
    int all_thin;     /* too many cubes per triangle, or radius not usable */
    uint32_t mask;    /* hash capacity - 1 */
    uint32_t *slot;   /* hash: cube index or UINT32_MAX */
    thin_cube *cubes;
    uint32_t count, capacity;
} thin_map;

/* Builds the map over the original triangles (positions xyz per vertex,
 * triangles 3 per triangle, material per triangle, special per vertex may be
 * NULL). Returns 0, or -1 when out of memory. */
int thin_map_build(thin_map *m, double radius, const float *positions, uint32_t vertex_count,
                   const uint32_t *triangles, uint32_t triangle_count, const int32_t *material,
                   const uint8_t *special);
void thin_map_free(thin_map *m);

/* 1 when some cube overlapping the box [lo, hi] grown by one cube on every
 * side is thin, or the grown box spans more than THIN_MAX_QUERY_CUBES cubes,
 * or a bound is not finite. Cubes with no original triangle are skipped: a
 * surface within eps of the original crosses such a cube only next to
 * occupied cubes, which the growth brings in. */
#define THIN_MAX_QUERY_CUBES 125
int thin_map_box(const thin_map *m, const double lo[3], const double hi[3]);

#endif
