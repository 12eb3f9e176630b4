/* bvh.h - a static bounding volume hierarchy over a triangle set, answering
 * exact double-precision distance queries.
 *
 * The certificate (DESIGN.md §4) asks two questions of the original mesh O:
 * "which triangle is closest to this point, and how far is it?" and "is any
 * triangle within this distance?". Both must be exact, not approximate: a
 * pruned subtree must never hide a triangle the brute-force loop would have
 * picked. This module answers them.
 *
 * What is computed. For a point p (double) and triangle t, d2(p, t) is
 * geom_point_triangle_distance2 evaluated on t's float32 vertices converted to
 * double (exactly). Every query below is defined in terms of these values, so
 * it agrees bit for bit with a loop over all triangles calling that function.
 *
 * Why pruning is safe. Node boxes are float boxes containing their
 * triangles' float vertices exactly (float min/max needs no rounding; see
 * geom_box_round_outward for boxes that come from doubles). The closest point
 * geom.c computes is clamped into its triangle's vertex box, hence lies in
 * every ancestor box, so the true distance to a node box is a lower bound of
 * every computed distance below it up to ~10 ulps of relative rounding. A
 * node is skipped only when its computed box distance, shrunk by a relative
 * 1e-14, still exceeds the current bound; ties are never skipped. A leaf's
 * triangle is skipped by the same test on its own vertex box.
 *
 * Data. The tree borrows the caller's positions and indices (no copy): they
 * must stay alive and unchanged while the tree is used. Nodes are one flat
 * array of 32-byte records in depth-first order (left child = next node),
 * leaves hold 2 to 4 triangles (1 only when the whole set is one triangle),
 * and one array maps leaf slots to triangle numbers. Memory: 4 bytes per
 * triangle for that map plus 32 bytes per node; with 0.6 to 0.7 nodes per
 * triangle that is ~24 to 26 bytes per triangle (measured on 1.1M-triangle
 * meshes; bvh_memory_bytes reports the exact figure). The build peaks at 64
 * bytes per triangle (28 of scratch, 32 for the node array before it is
 * trimmed, 4 for the map) and frees the scratch before returning.
 *
 * Build: binned SAH on triangle-box centres along the widest axis (16 bins),
 * median split when binning finds nothing useful, O(n log n): ~0.4 s for 1.1M
 * triangles on one core at -O2. Depth is capped at BVH_MAX_DEPTH so queries
 * use a fixed-size stack on the C stack. bvh_build_threads builds the root's
 * two subtrees on two threads: the same tree, about 0.1 s sooner there.
 *
 * Threads: a built tree is never modified by a query; any number of threads
 * may query one tree at once (filters must then be thread-safe themselves). */
#ifndef LODPIPE_BVH_H
#define LODPIPE_BVH_H

#include <stddef.h>
#include <stdint.h>

/* No leaf is deeper than this (root = depth 0); queries keep a stack this
 * long on the C stack (16 bytes an entry). */
#define BVH_MAX_DEPTH 64

/* Largest number of triangles accepted by bvh_build. */
#define BVH_MAX_TRIANGLES ((size_t)1 << 30)

typedef enum {
    BVH_OK = 0,
    BVH_ERROR_OUT_OF_MEMORY,
    BVH_ERROR_INDEX_OUT_OF_RANGE,   /* an index >= vertex_count */
    BVH_ERROR_NONFINITE_POSITION,   /* a used vertex has a NaN or infinite coordinate */
    BVH_ERROR_TOO_MANY_TRIANGLES,   /* more than BVH_MAX_TRIANGLES */
    BVH_ERROR_INVALID_ARGUMENT      /* a NULL pointer with a non-zero count */
} bvh_result;

/* One node. Inner node: count == 0, the left child is the next node in the
 * array and `offset` is the right child's index. Leaf: `count` triangles,
 * whose numbers are triangle_order[offset .. offset + count - 1]. */
typedef struct {
    float lo[3], hi[3];
    uint32_t offset;
    uint32_t count;
} bvh_node;

/* A built tree. Read-only for users; fields are documented for tests and
 * debugging, not as an interface to write to. */
typedef struct {
    bvh_node *nodes;             /* node_count nodes, root at 0 */
    uint32_t *triangle_order;    /* triangle_count entries */
    uint32_t node_count;
    uint32_t triangle_count;
    uint32_t depth;              /* depth of the deepest leaf, <= BVH_MAX_DEPTH */
    const float *positions;      /* borrowed: xyz per vertex */
    const uint32_t *indices;     /* borrowed: 3 per triangle */
    size_t vertex_count;
} bvh;

/* Builds the tree over triangle_count triangles: triangle t has the vertices
 * indices[3t], indices[3t+1], indices[3t+2], vertex v is at positions[3v ..
 * 3v+2]. Degenerate triangles are fine. Zero triangles give an empty tree on
 * which every query finds nothing.
 *
 * Returns BVH_OK, or an error (every index is checked against vertex_count
 * and every used vertex must be finite) after which *tree is empty but safe
 * to pass to bvh_free. The result depends only on the input, never on timing
 * or memory addresses. */
bvh_result bvh_build(bvh *tree, const float *positions, size_t vertex_count,
                     const uint32_t *indices, size_t triangle_count);

/* bvh_build with the root's two subtrees built at once when threads > 1
 * (and the set is large enough to be worth a thread): the same tree, node
 * for node, as with one thread. */
bvh_result bvh_build_threads(bvh *tree, const float *positions, size_t vertex_count,
                             const uint32_t *indices, size_t triangle_count, unsigned threads);

/* Frees what bvh_build allocated (not the borrowed arrays) and empties *tree.
 * Safe on an empty or failed tree, and twice. */
void bvh_free(bvh *tree);

/* Human-readable name of a result code. */
const char *bvh_result_string(bvh_result result);

/* Bytes the tree owns (nodes and triangle map), excluding the borrowed arrays. */
size_t bvh_memory_bytes(const bvh *tree);

/* d2(p, triangle) exactly as the queries below compute it, for one triangle
 * (triangle < triangle_count): a caller that already knows a likely answer
 * can test it without a traversal and rely on the same value. */
double bvh_triangle_distance2(const bvh *tree, uint32_t triangle, const double p[3]);

/* Decides whether triangle `triangle` takes part in a query; non-zero = yes.
 * Called with the caller's context, possibly several times per triangle,
 * never for triangles a query can rule out by their boxes. */
typedef int (*bvh_triangle_filter)(void *context, uint32_t triangle);

/* The answer of a closest-triangle query. */
typedef struct {
    uint32_t triangle;     /* input triangle number */
    double distance2;      /* d2(p, triangle) as defined above */
    double point[3];       /* the closest point on it that distance2 measures to */
} bvh_hit;

/* Exact closest triangle: among the triangles with d2(p, t) <= max_dist^2
 * (max_dist^2 computed in double; max_dist may be INFINITY), the one with the
 * smallest d2, ties going to the lowest triangle number. Writes it to *hit
 * (when hit is not NULL) and returns 1; returns 0 (and leaves *hit alone) when there is none, when
 * max_dist is negative or NaN, or when p is not finite. */
int bvh_closest(const bvh *tree, const double p[3], double max_dist, bvh_hit *hit);

/* bvh_closest restricted to the triangles `filter` accepts (NULL filter
 * accepts all): the same exact minimum and tie rule, over that subset. */
int bvh_closest_filtered(const bvh *tree, const double p[3], double max_dist,
                         bvh_triangle_filter filter, void *context, bvh_hit *hit);

/* bvh_closest_filtered that may stop early: returns 2 (with *hit) as soon as
 * it meets a triangle with d2(p, t) <= enough^2, which is then within
 * max_dist but not necessarily the closest; otherwise it returns what
 * bvh_closest_filtered would (1 with the exact closest, or 0). For a caller
 * that only needs the closest when it is farther than `enough`. A negative
 * or NaN enough never stops early. */
int bvh_closest_unless_within(const bvh *tree, const double p[3], double max_dist, double enough,
                              bvh_triangle_filter filter, void *context, bvh_hit *hit);

/* Decision query: 1 iff some triangle has d2(p, t) <= r^2 (r^2 computed in
 * double), else 0; stops at the first one found. 0 for negative or NaN r and
 * for non-finite p. */
int bvh_any_within(const bvh *tree, const double p[3], double r);

/* bvh_any_within restricted to the triangles `filter` accepts (NULL accepts
 * all). When it returns 1 and witness is not NULL, *witness is a triangle
 * that satisfied the test: the first one met in a deterministic traversal,
 * not necessarily the closest or the lowest-numbered. */
int bvh_any_within_filtered(const bvh *tree, const double p[3], double r,
                            bvh_triangle_filter filter, void *context,
                            uint32_t *witness);

/* Called by bvh_visit_near for each triangle it meets. */
typedef void (*bvh_triangle_visit)(void *context, uint32_t triangle);

/* Calls visit(context, t) once for every triangle t whose vertex box lies
 * within r of p (computed box distance, shrunk as the queries shrink it): a
 * superset of the triangles with d2(p, t) <= r^2, in a fixed order (the
 * tree's). For a caller that needs every triangle near a point, not only the
 * closest. Nothing is visited for negative or NaN r or non-finite p. */
void bvh_visit_near(const bvh *tree, const double p[3], double r, bvh_triangle_visit visit, void *context);

#endif
