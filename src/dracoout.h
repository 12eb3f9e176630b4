/* dracoout.h - Draco compression of a mesh's LOD chain
 * (KHR_draco_mesh_compression, issue 5), with the position quantization
 * inside the recorded bound.
 *
 * What is bounded. Draco quantizes a float POSITION on a grid: with origin o
 * (per axis), range r (one for all axes) and b bits, the step is
 * D = r / (2^b - 1) and a value x is stored as the nearest grid index
 * q = floor((x - o) / D + 1/2), decoded as o + q * D. In exact arithmetic a
 * coordinate moves by at most D / 2; Draco computes in float32, which adds at
 * most a few float roundings of values of size r and |o| (derivation in
 * dracoout.c). So every decoded vertex lies within
 *     Q = sqrt(sum over axes of (D / 2 + 2^-20 * (r + |o_axis|))^2)
 * of the exact one, and since a point of a triangle is a convex combination
 * of its corners, every point of a decoded triangle lies within Q of the same
 * point of the exact triangle and back: the two-sided Hausdorff distance
 * between a decoded primitive and the exact one is at most Q. lodpipe sets
 * the grid itself (explicit quantization: o = the per-axis minimum and r =
 * the largest extent of the float vertices that the primitives of the level
 * use, one grid for all of them so that a position two primitives share
 * decodes to one point in both: no crack along a material seam, no back
 * lifted off its front), so Q is known before encoding. Integer positions
 * (KHR_mesh_quantization) are stored losslessly: Q = 0.
 *
 * The chain's errors (all against the ORIGINAL, uncompressed LOD0 surface):
 * level k's decoded triangles are within Q_k (the Q of the level's grid)
 * of the exact level, which is
 * within its certified bound B_k of the original, so the recorded error is
 * B_k + Q_k (triangle inequality); LOD0's recorded error is Q_0, its own
 * quantization. A level k and the decoded LOD0 of the file are then within
 * B_k + Q_k + Q_0 of each other (what `lodpipe check` allows).
 *
 * The simplifier certifies each level close to its eps (B_k is often within
 * 1e-4 of eps_k), closer than float32 can resolve a grid over the mesh, so no
 * number of bits could fit the quantization afterwards. Hence the budget:
 * with Draco each level is simplified to eps_k - Q_0 (dracoout_budget), and
 * since Q_k <= Q_0, B_k + Q_k <= eps_k. The recorded eps stays eps_k.
 * Position bits are chosen per mesh: those of the budget, raised one at a time
 * (up to Draco's 30) while some kept level still has B_k + Q_k > eps_k (only
 * rounding can cause that); when even 30 bits cannot fit, LP_PROMISE. */
#ifndef LODPIPE_DRACOOUT_H
#define LODPIPE_DRACOOUT_H

#include <stdint.h>

#include "lodchain.h"
#include "scene.h"
#include "simplify.h"
#include "status.h"
#include "weld.h"

#define DRACOOUT_MAX_BITS 30 /* AttributeQuantizationTransform's limit */

typedef struct dracoout_options {
    int position_bits, normal_bits, texcoord_bits, color_bits, generic_bits; /* 1..30 (normal 2..30) */
    int speed;    /* 0 (smallest) .. 10 (fastest) */
    int fallback; /* 1: also an uncompressed fallback, from the DECODED data, in a separate buffer */
} dracoout_options;

/* One primitive's position grid. */
typedef struct dracoout_grid {
    float origin[3];
    float range;  /* > 0 (1 when every vertex is the same point) */
    int bits;
    double axis_bound[3]; /* a decoded coordinate is within this of the exact one */
    double bound;         /* Q: Euclidean length of axis_bound */
} dracoout_grid;

/* The grid Draco gets for positions whose per-axis minimum and maximum are lo
 * and hi (float values) at `bits`, and its bound. */
void dracoout_grid_of(const double lo[3], const double hi[3], int bits, dracoout_grid *g);

typedef struct dracoout_plan {
    int position_bits; /* chosen for the mesh, >= the configured bits */
    int configured_bits;
    /* per ladder level: [0] LOD0, [k] ladder level k (1-based): the Q of
     * the level's grid at position_bits. What lodchain_options's
     * added_error takes. */
    double added_error[SIMPLIFY_MAX_LEVELS + 1];
    /* per ladder level: the box of its one position grid (the float
     * positions its quantized primitives use; empty when none is) */
    double grid_lo[SIMPLIFY_MAX_LEVELS + 1][3], grid_hi[SIMPLIFY_MAX_LEVELS + 1][3];
} dracoout_plan;

/* The budget the simplifier must leave for the quantization, so that a
 * level's certified bound plus its quantization bound fits its eps: Q_0, the
 * largest grid bound over LOD0's primitives, bounds every level's Q too (a
 * level uses a subset of LOD0's vertices, so its grid's range is no larger).
 * *bits is the configured position bits, raised while Q_0 > smallest_eps / 4
 * (so the levels keep most of their eps); *budget is Q_0 at *bits. Returns
 * LP_PROMISE when even DRACOOUT_MAX_BITS leaves Q_0 > smallest_eps / 2 (float32
 * cannot resolve the mesh at that eps, e.g. far from the origin). `placing`:
 * some level may place vertices (full-edge placement); such a level writes
 * float positions even where LOD0's are integers (stored losslessly, Q 0),
 * so Q_0 is then taken as if every primitive's positions were floats. */
int dracoout_budget(const scene *s, uint32_t m, const dracoout_options *o, double smallest_eps, int placing,
                    int *bits, double *budget, lp_error *err);

/* Picks mesh m's position bits and the quantization bound of LOD0 and every
 * ladder level (those lodchain will keep must fit their eps). Returns LP_OK,
 * or LP_PROMISE when even DRACOOUT_MAX_BITS cannot fit a level (the message
 * names the mesh, the level, its bound and eps). w and r may be NULL (LOD0
 * alone: `convert --draco`). */
int dracoout_plan_mesh(const scene *s, uint32_t m, const weld_result *w, const simplify_result *r,
                       double min_reduction, const dracoout_options *o, int start_bits, dracoout_plan *plan,
                       lp_error *err);

typedef struct dracoout_stats {
    uint32_t primitives;         /* encoded */
    uint32_t sequential;         /* of which with sequential connectivity (morph targets, or edgebreaker lost a face) */
    uint64_t stream_bytes;       /* Draco bytes written */
} dracoout_stats;

/* Replaces every triangle primitive of mesh m (LOD0) and of chain's level
 * meshes (chain may be NULL: LOD0 alone) by a KHR_draco_mesh_compression
 * primitive: all attributes in the stream (positions on the plan's grid,
 * the other floats at the configured bits, integers losslessly), only the
 * vertices the primitive's triangles use, morph targets as plain accessors in
 * the stream's vertex order (such primitives use sequential connectivity,
 * which keeps the order). Accessors only this primitive used are rewritten in
 * place (same numbers), shared ones are left alone and new ones added. Each
 * stream is decoded again at once: its face count must be the input's and,
 * where the order is kept, every decoded position within its grid's bound,
 * else LP_PROMISE. With o->fallback the accessors also get the decoded data,
 * in a second buffer; without it the extension is required. */
int dracoout_write_mesh(scene *s, uint32_t m, const lodchain_summary *chain, const dracoout_options *o,
                        const dracoout_plan *plan, dracoout_stats *stats, lp_error *err);

#endif
