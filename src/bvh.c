/* bvh.c - static BVH with exact double-precision distance queries (see bvh.h).
 *
 * Build: top-down, binned surface-area heuristic on triangle-box centres
 * (Wald, "On fast Construction of SAH-based Bounding Volume Hierarchies",
 * 2007), one axis per node (the widest spread of centres), with an object
 * median split when binning cannot separate the triangles or the depth cap
 * comes near. Queries: depth-first, nearer child first, pruning by box
 * distance with the safety argument given in bvh.h. */
#include "bvh.h"

#include "geom.h"
#include "threads.h"

#include <assert.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

enum {
    LEAF_MAX_TRIANGLES = 4,
    LEAF_MIN_TRIANGLES = 2,   /* splits leave >= 2 per side: nodes < triangles */
    SAH_BIN_COUNT = 16
};

/* A node's computed box distance is multiplied by this before it is compared
 * with the bound. The computed point-triangle value and the computed box
 * distance each carry at most ~5 ulps of relative rounding, in opposite
 * directions at worst; 1e-14 (~90 ulps) covers both with room to spare. */
static const double BOX_DISTANCE_SHRINK = 1.0 - 1e-14;

/* ---- build ---------------------------------------------------------------- */

/* A triangle as the builder sees it; sorted in place while splitting. Its
 * centre is recomputed from the box when needed (ref_centre) rather than
 * stored: 12 bytes less a triangle while the build holds one per triangle. */
typedef struct {
    float lo[3], hi[3];
    uint32_t triangle;
} build_ref;

/* The box centre along axis, halves first (lo + hi could overflow near
 * FLT_MAX); float arithmetic, so the same value every time it is asked. */
static inline float ref_centre(const build_ref *ref, int axis)
{
    return 0.5f * ref->lo[axis] + 0.5f * ref->hi[axis];
}

/* What a range of refs spans: the union of their boxes (the node box) and
 * the box of their centres (what splitting looks at). Four lanes a box, the
 * fourth a copy of the third (z), so that the unions below are whole 4-wide
 * min/max operations a compiler turns into single SIMD instructions (the
 * build spends most of its time in them); only lanes 0 to 2 are read. */
typedef struct {
    float lo[4], hi[4];
    float centre_lo[4], centre_hi[4];
} range_bounds;

typedef struct {
    build_ref *refs;
    bvh_node *nodes;
    uint32_t node_count;
    uint32_t depth;
} builder;

static unsigned ceil_log2(uint32_t n)
{
    unsigned bits = 0;
    while (((uint64_t)1 << bits) < n) bits++;
    return bits;
}

static void bounds_reset(range_bounds *r)
{
    for (int lane = 0; lane < 4; lane++) {
        r->lo[lane] = r->centre_lo[lane] = INFINITY;
        r->hi[lane] = r->centre_hi[lane] = -INFINITY;
    }
}

/* Ternaries rather than ifs so that compilers emit minps / maxps; the ref's
 * box is copied into four-lane locals first (z twice) so that nothing it
 * reads can alias what it writes. Each lane's centre is ref_centre's value. */
static inline void bounds_add_ref(range_bounds *restrict r, const build_ref *restrict ref)
{
    const float lo[4] = {ref->lo[0], ref->lo[1], ref->lo[2], ref->lo[2]};
    const float hi[4] = {ref->hi[0], ref->hi[1], ref->hi[2], ref->hi[2]};
    float centre[4];
    for (int lane = 0; lane < 4; lane++) centre[lane] = 0.5f * lo[lane] + 0.5f * hi[lane];
    for (int lane = 0; lane < 4; lane++) r->lo[lane] = lo[lane] < r->lo[lane] ? lo[lane] : r->lo[lane];
    for (int lane = 0; lane < 4; lane++) r->hi[lane] = hi[lane] > r->hi[lane] ? hi[lane] : r->hi[lane];
    for (int lane = 0; lane < 4; lane++)
        r->centre_lo[lane] = centre[lane] < r->centre_lo[lane] ? centre[lane] : r->centre_lo[lane];
    for (int lane = 0; lane < 4; lane++)
        r->centre_hi[lane] = centre[lane] > r->centre_hi[lane] ? centre[lane] : r->centre_hi[lane];
}

static inline void bounds_add_bounds(range_bounds *restrict r, const range_bounds *restrict other)
{
    for (int lane = 0; lane < 4; lane++) r->lo[lane] = other->lo[lane] < r->lo[lane] ? other->lo[lane] : r->lo[lane];
    for (int lane = 0; lane < 4; lane++) r->hi[lane] = other->hi[lane] > r->hi[lane] ? other->hi[lane] : r->hi[lane];
    for (int lane = 0; lane < 4; lane++)
        r->centre_lo[lane] = other->centre_lo[lane] < r->centre_lo[lane] ? other->centre_lo[lane] : r->centre_lo[lane];
    for (int lane = 0; lane < 4; lane++)
        r->centre_hi[lane] = other->centre_hi[lane] > r->centre_hi[lane] ? other->centre_hi[lane] : r->centre_hi[lane];
}

static void bounds_of_refs(range_bounds *r, const build_ref *refs, uint32_t count)
{
    bounds_reset(r);
    for (uint32_t i = 0; i < count; i++) bounds_add_ref(r, &refs[i]);
}

/* Half the surface area of the node box; only ratios matter to the SAH.
 * Computed in double so that huge coordinates do not overflow. */
static double half_area(const range_bounds *r)
{
    double dx = (double)r->hi[0] - r->lo[0];
    double dy = (double)r->hi[1] - r->lo[1];
    double dz = (double)r->hi[2] - r->lo[2];
    if (!(dx >= 0.0)) return 0.0;   /* empty */
    return dx * dy + dy * dz + dz * dx;
}

/* Checks the input and fills one build_ref per triangle. */
static bvh_result make_refs(build_ref *refs, const float *positions, size_t vertex_count,
                            const uint32_t *indices, uint32_t triangle_count)
{
    for (uint32_t t = 0; t < triangle_count; t++) {
        build_ref *ref = &refs[t];
        for (int axis = 0; axis < 3; axis++) {
            ref->lo[axis] = INFINITY;
            ref->hi[axis] = -INFINITY;
        }
        for (int corner = 0; corner < 3; corner++) {
            uint32_t v = indices[3 * (size_t)t + corner];
            if (v >= vertex_count) return BVH_ERROR_INDEX_OUT_OF_RANGE;
            const float *xyz = positions + 3 * (size_t)v;
            for (int axis = 0; axis < 3; axis++) {
                if (!isfinite(xyz[axis])) return BVH_ERROR_NONFINITE_POSITION;
                if (xyz[axis] < ref->lo[axis]) ref->lo[axis] = xyz[axis];
                if (xyz[axis] > ref->hi[axis]) ref->hi[axis] = xyz[axis];
            }
        }
        ref->triangle = t;
    }
    return BVH_OK;
}

static void swap_refs(build_ref *a, build_ref *b)
{
    build_ref tmp = *a;
    *a = *b;
    *b = tmp;
}

/* Rearranges refs[0 .. count) so that refs[nth] has the centre it would have
 * in sorted order along `axis`, smaller-or-equal ones before it and larger-or-
 * equal after (quickselect, Hoare partition, median-of-three pivot: expected
 * O(count), and balanced even when many centres are equal). */
static void select_nth_by_centre(build_ref *refs, uint32_t count, uint32_t nth, int axis)
{
    uint32_t left = 0, right = count - 1;
    while (left < right) {
        uint32_t mid = left + (right - left) / 2;
        /* Order refs[left], refs[mid], refs[right]; the median goes to mid.
         * This also puts a sentinel at each end for the scans below. */
        if (ref_centre(&refs[mid], axis) < ref_centre(&refs[left], axis)) swap_refs(&refs[mid], &refs[left]);
        if (ref_centre(&refs[right], axis) < ref_centre(&refs[left], axis)) swap_refs(&refs[right], &refs[left]);
        if (ref_centre(&refs[right], axis) < ref_centre(&refs[mid], axis)) swap_refs(&refs[right], &refs[mid]);
        float pivot = ref_centre(&refs[mid], axis);

        uint32_t i = left, j = right;
        for (;;) {
            while (ref_centre(&refs[i], axis) < pivot) i++;
            while (ref_centre(&refs[j], axis) > pivot) j--;
            if (i >= j) break;
            swap_refs(&refs[i], &refs[j]);
            i++;
            j--;
        }
        /* Now refs[left .. j] <= pivot <= refs[j+1 .. right], left <= j < right. */
        if (nth <= j) right = j;
        else left = j + 1;
    }
}

static int centre_bin(float centre, float centre_min, float bin_scale)
{
    int bin = (int)((centre - centre_min) * bin_scale);
    if (bin < 0) bin = 0;
    if (bin > SAH_BIN_COUNT - 1) bin = SAH_BIN_COUNT - 1;
    return bin;
}

/* Looks for the best SAH split of refs[0 .. count) along `axis` that leaves
 * at least LEAF_MIN_TRIANGLES on each side. On success partitions the refs,
 * writes both sides' bounds (from the bins: no second pass) and returns the
 * left count; returns 0 with the refs untouched when no bin boundary gives
 * such a split. */
static uint32_t split_by_sah(build_ref *refs, uint32_t count, int axis,
                             const range_bounds *all, range_bounds *left_bounds,
                             range_bounds *right_bounds)
{
    float centre_min = all->centre_lo[axis];
    /* Scale so that the largest centre lands in the last bin, not past it. */
    float bin_scale = (float)SAH_BIN_COUNT * (1.0f - 1e-6f) / (all->centre_hi[axis] - centre_min);
    if (!(bin_scale > 0.0f) || !isfinite(bin_scale)) return 0;

    uint32_t bin_count[SAH_BIN_COUNT] = {0};
    range_bounds bin[SAH_BIN_COUNT];
    for (int b = 0; b < SAH_BIN_COUNT; b++) bounds_reset(&bin[b]);
    for (uint32_t i = 0; i < count; i++) {
        int b = centre_bin(ref_centre(&refs[i], axis), centre_min, bin_scale);
        bin_count[b]++;
        bounds_add_ref(&bin[b], &refs[i]);
    }

    /* Suffix unions: suffix[b] covers bins b .. last. */
    range_bounds suffix[SAH_BIN_COUNT];
    uint32_t suffix_count[SAH_BIN_COUNT];
    suffix[SAH_BIN_COUNT - 1] = bin[SAH_BIN_COUNT - 1];
    suffix_count[SAH_BIN_COUNT - 1] = bin_count[SAH_BIN_COUNT - 1];
    for (int b = SAH_BIN_COUNT - 2; b > 0; b--) {
        suffix[b] = suffix[b + 1];
        if (bin_count[b]) bounds_add_bounds(&suffix[b], &bin[b]); /* an empty bin's union changes nothing */
        suffix_count[b] = suffix_count[b + 1] + bin_count[b];
    }

    int best_split = 0;   /* left = bins < best_split; 0 = none found */
    double best_cost = INFINITY;
    range_bounds prefix, best_prefix;
    bounds_reset(&prefix);
    bounds_reset(&best_prefix);
    uint32_t prefix_count = 0;
    for (int b = 1; b < SAH_BIN_COUNT; b++) {
        /* past an empty bin both sides are those of the boundary before,
         * whose equal cost the strict test below would keep: most bins of
         * the many small nodes are empty */
        if (bin_count[b - 1] == 0) continue;
        bounds_add_bounds(&prefix, &bin[b - 1]);
        prefix_count += bin_count[b - 1];
        if (prefix_count < LEAF_MIN_TRIANGLES || suffix_count[b] < LEAF_MIN_TRIANGLES) continue;
        double cost = half_area(&prefix) * prefix_count + half_area(&suffix[b]) * suffix_count[b];
        if (cost < best_cost) {   /* strict: the first best split wins, deterministically */
            best_cost = cost;
            best_split = b;
            best_prefix = prefix;
        }
    }
    if (best_split == 0) return 0;

    uint32_t i = 0, j = count;
    while (i < j) {
        if (centre_bin(ref_centre(&refs[i], axis), centre_min, bin_scale) < best_split) {
            i++;
        } else {
            j--;
            swap_refs(&refs[i], &refs[j]);
        }
    }
    *left_bounds = best_prefix;
    *right_bounds = suffix[best_split];
    return i;
}

/* How a node over refs[0 .. count) (spanning `bounds`, at `depth`) splits:
 * returns the left count (the refs are reordered so that the left part comes
 * first) and both parts' bounds. */
static uint32_t split_range(build_ref *refs, uint32_t count, uint32_t depth, const range_bounds *bounds,
                            range_bounds *left_bounds, range_bounds *right_bounds)
{
    int axis = 0;
    for (int a = 1; a < 3; a++)
        if ((double)bounds->centre_hi[a] - bounds->centre_lo[a] >
            (double)bounds->centre_hi[axis] - bounds->centre_lo[axis])
            axis = a;

    /* SAH unless the median is needed to keep every leaf within
     * BVH_MAX_DEPTH: a median split reaches leaves within ceil_log2(count)
     * more levels, SAH guarantees nothing. */
    uint32_t left_count = 0;
    if (depth + ceil_log2(count) + 1 < BVH_MAX_DEPTH)
        left_count = split_by_sah(refs, count, axis, bounds, left_bounds, right_bounds);
    if (left_count == 0) {
        left_count = count / 2;
        /* When every centre is the same point any halving will do. */
        if (bounds->centre_hi[axis] > bounds->centre_lo[axis])
            select_nth_by_centre(refs, count, left_count, axis);
        bounds_of_refs(left_bounds, refs, left_count);
        bounds_of_refs(right_bounds, refs + left_count, count - left_count);
    }
    assert(left_count >= LEAF_MIN_TRIANGLES && count - left_count >= LEAF_MIN_TRIANGLES);
    return left_count;
}

/* The node box is the exact float union of its triangles' vertex boxes: no
 * rounding is involved, so nothing needs widening (see bvh.h). */
static void set_box(bvh_node *node, const range_bounds *bounds)
{
    for (int axis = 0; axis < 3; axis++) {
        node->lo[axis] = bounds->lo[axis];
        node->hi[axis] = bounds->hi[axis];
    }
}

/* Builds the subtree over refs[first .. first + count), which span `bounds`,
 * at `depth`; returns its root's node index. Nodes are laid out depth first,
 * so a left child always directly follows its parent. */
static uint32_t build_node(builder *b, uint32_t first, uint32_t count, uint32_t depth,
                           const range_bounds *bounds)
{
    uint32_t index = b->node_count++;
    if (depth > b->depth) b->depth = depth;
    set_box(&b->nodes[index], bounds);
    if (count <= LEAF_MAX_TRIANGLES) {
        b->nodes[index].offset = first;
        b->nodes[index].count = count;
        return index;
    }
    range_bounds left_bounds, right_bounds;
    const uint32_t left_count = split_range(b->refs + first, count, depth, bounds, &left_bounds, &right_bounds);
    build_node(b, first, left_count, depth + 1, &left_bounds);
    uint32_t right = build_node(b, first + left_count, count - left_count, depth + 1,
                                &right_bounds);
    b->nodes[index].offset = right;
    b->nodes[index].count = 0;
    return index;
}

/* The right subtree of the root, built on a second thread. */
typedef struct subtree_job {
    builder b;
    uint32_t first, count;
    range_bounds bounds;
} subtree_job;

static void *build_subtree(void *p)
{
    subtree_job *job = p;
    build_node(&job->b, job->first, job->count, 1, &job->bounds);
    return NULL;
}

/* Builds the whole tree into b (refs made, nodes allocated). With threads > 1
 * the root's two subtrees are built at once, into the same arrays: refs are
 * split by then, the left subtree's nodes start at 1, the right one's at
 * left_count (the left one has fewer nodes than triangles, so they cannot
 * meet); then the right block moves down behind the left one and its child
 * indices with it. The result is the sequential layout exactly. */
static void build_tree(builder *b, uint32_t n, unsigned threads)
{
    range_bounds everything;
    bounds_of_refs(&everything, b->refs, n);
    if (threads < 2 || n <= 4096) { /* small trees: a thread costs more than it saves */
        build_node(b, 0, n, 0, &everything);
        return;
    }
    range_bounds left_bounds;
    subtree_job right = {.b = {b->refs, b->nodes, 0, 1}};
    const uint32_t left_count = split_range(b->refs, n, 0, &everything, &left_bounds, &right.bounds);
    right.b.node_count = left_count;
    right.first = left_count;
    right.count = n - left_count;
    lp_beside beside;
    lp_beside_start(&beside, 1, build_subtree, &right);
    b->node_count = 1;
    b->depth = 0;
    build_node(b, 0, left_count, 1, &left_bounds);
    lp_beside_join(&beside);
    const uint32_t right_root = b->node_count, shift = left_count - right_root;
    const uint32_t right_nodes = right.b.node_count - left_count;
    for (uint32_t i = left_count; i < right.b.node_count; i++)
        if (b->nodes[i].count == 0) b->nodes[i].offset -= shift;
    memmove(b->nodes + right_root, b->nodes + left_count, sizeof *b->nodes * (size_t)right_nodes);
    set_box(&b->nodes[0], &everything);
    b->nodes[0].offset = right_root;
    b->nodes[0].count = 0;
    b->node_count = right_root + right_nodes;
    if (right.b.depth > b->depth) b->depth = right.b.depth;
}

bvh_result bvh_build(bvh *tree, const float *positions, size_t vertex_count,
                     const uint32_t *indices, size_t triangle_count)
{
    return bvh_build_threads(tree, positions, vertex_count, indices, triangle_count, 1);
}

bvh_result bvh_build_threads(bvh *tree, const float *positions, size_t vertex_count,
                             const uint32_t *indices, size_t triangle_count, unsigned threads)
{
    memset(tree, 0, sizeof *tree);
    if (triangle_count > BVH_MAX_TRIANGLES) return BVH_ERROR_TOO_MANY_TRIANGLES;
    if (triangle_count == 0) return BVH_OK;
    if (!indices || (!positions && vertex_count > 0)) return BVH_ERROR_INVALID_ARGUMENT;
    uint32_t n = (uint32_t)triangle_count;

    /* With >= 2 triangles per leaf there are at most n / 2 leaves, so fewer
     * than n nodes; the array is trimmed to the real count at the end. */
    builder b = {0};
    b.refs = malloc(sizeof *b.refs * (size_t)n);
    b.nodes = malloc(sizeof *b.nodes * (size_t)n);
    tree->triangle_order = malloc(sizeof *tree->triangle_order * (size_t)n);
    if (!b.refs || !b.nodes || !tree->triangle_order) {
        free(b.refs);
        free(b.nodes);
        bvh_free(tree);
        return BVH_ERROR_OUT_OF_MEMORY;
    }

    bvh_result result = make_refs(b.refs, positions, vertex_count, indices, n);
    if (result != BVH_OK) {
        free(b.refs);
        free(b.nodes);
        bvh_free(tree);
        return result;
    }

    build_tree(&b, n, threads);
    assert(b.node_count <= n && b.depth <= BVH_MAX_DEPTH);
    for (uint32_t i = 0; i < n; i++) tree->triangle_order[i] = b.refs[i].triangle;
    free(b.refs);

    bvh_node *trimmed = realloc(b.nodes, sizeof *b.nodes * (size_t)b.node_count);
    tree->nodes = trimmed ? trimmed : b.nodes;   /* a failed shrink keeps the old block */
    tree->node_count = b.node_count;
    tree->triangle_count = n;
    tree->depth = b.depth;
    tree->positions = positions;
    tree->indices = indices;
    tree->vertex_count = vertex_count;
    return BVH_OK;
}

void bvh_free(bvh *tree)
{
    free(tree->nodes);
    free(tree->triangle_order);
    memset(tree, 0, sizeof *tree);
}

const char *bvh_result_string(bvh_result result)
{
    switch (result) {
    case BVH_OK: return "ok";
    case BVH_ERROR_OUT_OF_MEMORY: return "out of memory";
    case BVH_ERROR_INDEX_OUT_OF_RANGE: return "triangle index out of range";
    case BVH_ERROR_NONFINITE_POSITION: return "vertex position is NaN or infinite";
    case BVH_ERROR_TOO_MANY_TRIANGLES: return "too many triangles";
    case BVH_ERROR_INVALID_ARGUMENT: return "invalid argument";
    }
    return "unknown bvh result";
}

size_t bvh_memory_bytes(const bvh *tree)
{
    return sizeof(bvh_node) * (size_t)tree->node_count +
           sizeof(uint32_t) * (size_t)tree->triangle_count;
}

/* ---- queries -------------------------------------------------------------- */

/* How far x lies outside [lo, hi] (0 inside), in double, up to the sign,
 * for lo <= hi (a box of finite floats) and finite x: x minus x clamped to
 * the box. The clamp is one max and one min, which compilers emit without
 * branches (the side of a box a query point lies on is hardly predictable);
 * the value is x - lo = -(lo - x) exactly (rounding is symmetric) when
 * x < lo, x - hi when x > hi and 0 inside, so its square is bit for bit the
 * square of the distance to the box along that axis, as before. */
static inline double gap_outside(double x, double lo, double hi)
{
    double clamped = x > lo ? x : lo;
    clamped = clamped < hi ? clamped : hi;
    return x - clamped;
}

/* Squared distance from p to the node's box, computed in double (0 inside). */
static double box_distance2(const bvh_node *node, const double p[3])
{
    double d2 = 0.0;
    for (int axis = 0; axis < 3; axis++) {
        const double gap = gap_outside(p[axis], node->lo[axis], node->hi[axis]);
        d2 += gap * gap;
    }
    return d2;
}

/* May a node at computed box distance `box_d2` hold a triangle whose computed
 * distance is <= bound2? A positive test, so NaN never admits a node. */
static int node_may_reach(double box_d2, double bound2)
{
    return box_d2 * BOX_DISTANCE_SHRINK <= bound2;
}

/* d2(p, triangle) exactly as bvh.h defines it. */
static double triangle_distance2(const bvh *tree, uint32_t triangle, const vec3d *p,
                                 vec3d *closest)
{
    const uint32_t *corner = tree->indices + 3 * (size_t)triangle;
    vec3d a = geom_vec3d_from_floats(tree->positions + 3 * (size_t)corner[0]);
    vec3d b = geom_vec3d_from_floats(tree->positions + 3 * (size_t)corner[1]);
    vec3d c = geom_vec3d_from_floats(tree->positions + 3 * (size_t)corner[2]);
    return geom_point_triangle_distance2(p, &a, &b, &c, closest);
}

/* Squared distance from p to the float box of the triangle's corners: a
 * lower bound of d2(p, triangle) by the argument of bvh.h, as a node's box is
 * (the node box holds this one, which holds the computed closest point). */
static double triangle_box_distance2(const bvh *tree, uint32_t triangle, const double p[3])
{
    const uint32_t *corner = tree->indices + 3 * (size_t)triangle;
    const float *a = tree->positions + 3 * (size_t)corner[0], *b = tree->positions + 3 * (size_t)corner[1],
                *c = tree->positions + 3 * (size_t)corner[2];
    double d2 = 0.0;
    for (int axis = 0; axis < 3; axis++) {
        float lo = a[axis] < b[axis] ? a[axis] : b[axis], hi = a[axis] < b[axis] ? b[axis] : a[axis];
        lo = c[axis] < lo ? c[axis] : lo;
        hi = c[axis] > hi ? c[axis] : hi;
        const double gap = gap_outside(p[axis], lo, hi);
        d2 += gap * gap;
    }
    return d2;
}

static int query_point_valid(const double p[3])
{
    return isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]);
}

typedef struct {
    uint32_t node;
    double box_d2;
} stack_entry;

/* How a traversal ended. */
enum { TRAVERSE_NONE = 0, TRAVERSE_CLOSEST = 1, TRAVERSE_WITHIN = 2 };

/* The traversal shared by all queries: visits leaves nearest box first and
 * prunes against the best distance so far (initially bound2). It stops at
 * the first new best with d2 <= stop2 (TRAVERSE_WITHIN: a decision query
 * passes stop2 = bound2, so that is the first triangle within bound2);
 * otherwise it ends with the exact closest (TRAVERSE_CLOSEST). Either way
 * that triangle goes to *hit.
 *
 * Stack bound: entries are the unvisited far siblings of the nodes on the
 * current root-to-node path, at most one per level, so BVH_MAX_DEPTH
 * entries suffice. */
static int traverse(const bvh *tree, const double p[3], double bound2, double stop2,
                    bvh_triangle_filter filter, void *context, bvh_hit *hit)
{
    if (tree->triangle_count == 0 || !query_point_valid(p) || !(bound2 >= 0.0)) return TRAVERSE_NONE;

    const bvh_node *nodes = tree->nodes;
    vec3d point = geom_vec3d_from_doubles(p);
    uint32_t best_triangle = UINT32_MAX;   /* none yet; every real number is lower */
    double best_d2 = bound2;
    vec3d best_point = point;
    int ended = TRAVERSE_CLOSEST;

    stack_entry stack[BVH_MAX_DEPTH];
    unsigned top = 0;
    uint32_t current = 0;
    if (!node_may_reach(box_distance2(&nodes[0], p), best_d2)) return TRAVERSE_NONE;

    for (;;) {
        const bvh_node *node = &nodes[current];
        if (node->count > 0) {
            for (uint32_t i = 0; i < node->count; i++) {
                uint32_t triangle = tree->triangle_order[node->offset + i];
                if (!node_may_reach(triangle_box_distance2(tree, triangle, p), best_d2)) continue;
                if (filter && !filter(context, triangle)) continue;
                vec3d q;
                double d2 = triangle_distance2(tree, triangle, &point, &q);
                if (d2 < best_d2 || (d2 == best_d2 && triangle < best_triangle)) {
                    best_d2 = d2;
                    best_triangle = triangle;
                    best_point = q;
                    if (d2 <= stop2) {
                        ended = TRAVERSE_WITHIN;
                        goto finished;
                    }
                }
            }
        } else {
            uint32_t near = current + 1, far = node->offset;
            double near_d2 = box_distance2(&nodes[near], p);
            double far_d2 = box_distance2(&nodes[far], p);
            if (far_d2 < near_d2) {
                uint32_t swap_node = near; near = far; far = swap_node;
                double swap_d2 = near_d2; near_d2 = far_d2; far_d2 = swap_d2;
            }
            if (node_may_reach(far_d2, best_d2)) {
                assert(top < BVH_MAX_DEPTH);
                stack[top].node = far;
                stack[top].box_d2 = far_d2;
                top++;
            }
            if (node_may_reach(near_d2, best_d2)) {
                current = near;
                continue;
            }
        }

        /* Next pending subtree that can still beat (or tie) the best. */
        for (;;) {
            if (top == 0) goto finished;
            top--;
            if (node_may_reach(stack[top].box_d2, best_d2)) break;
        }
        current = stack[top].node;
    }

finished:
    if (best_triangle == UINT32_MAX) return TRAVERSE_NONE;
    hit->triangle = best_triangle;
    hit->distance2 = best_d2;
    hit->point[0] = best_point.x;
    hit->point[1] = best_point.y;
    hit->point[2] = best_point.z;
    return ended;
}

/* r^2 for a radius; NaN (rejected by traverse) for negative or NaN r. */
static double radius_squared(double r)
{
    return r >= 0.0 ? r * r : NAN;
}

double bvh_triangle_distance2(const bvh *tree, uint32_t triangle, const double p[3])
{
    assert(triangle < tree->triangle_count);
    vec3d point = geom_vec3d_from_doubles(p), closest;
    return triangle_distance2(tree, triangle, &point, &closest);
}

int bvh_closest(const bvh *tree, const double p[3], double max_dist, bvh_hit *hit)
{
    return bvh_closest_filtered(tree, p, max_dist, NULL, NULL, hit);
}

int bvh_closest_filtered(const bvh *tree, const double p[3], double max_dist,
                         bvh_triangle_filter filter, void *context, bvh_hit *hit)
{
    bvh_hit found;
    if (!traverse(tree, p, radius_squared(max_dist), -INFINITY, filter, context, &found)) return 0;
    if (hit) *hit = found;
    return 1;
}

int bvh_closest_unless_within(const bvh *tree, const double p[3], double max_dist, double enough,
                              bvh_triangle_filter filter, void *context, bvh_hit *hit)
{
    /* NaN (a negative or NaN enough) never stops the traversal early */
    return traverse(tree, p, radius_squared(max_dist), radius_squared(enough), filter, context, hit);
}

int bvh_any_within(const bvh *tree, const double p[3], double r)
{
    return bvh_any_within_filtered(tree, p, r, NULL, NULL, NULL);
}

int bvh_any_within_filtered(const bvh *tree, const double p[3], double r,
                            bvh_triangle_filter filter, void *context,
                            uint32_t *witness)
{
    const double r2 = radius_squared(r);
    bvh_hit found;
    if (!traverse(tree, p, r2, r2, filter, context, &found)) return 0;
    if (witness) *witness = found.triangle;
    return 1;
}

void bvh_visit_near(const bvh *tree, const double p[3], double r, bvh_triangle_visit visit, void *context)
{
    const double r2 = radius_squared(r);
    if (tree->triangle_count == 0 || !query_point_valid(p) || !(r2 >= 0.0)) return;
    uint32_t stack[BVH_MAX_DEPTH];
    unsigned top = 0;
    uint32_t current = 0;
    if (!node_may_reach(box_distance2(&tree->nodes[0], p), r2)) return;
    for (;;) {
        const bvh_node *node = &tree->nodes[current];
        if (node->count > 0) {
            for (uint32_t i = 0; i < node->count; i++) {
                const uint32_t triangle = tree->triangle_order[node->offset + i];
                if (node_may_reach(triangle_box_distance2(tree, triangle, p), r2)) visit(context, triangle);
            }
        } else {
            const uint32_t near = current + 1, far = node->offset;
            if (node_may_reach(box_distance2(&tree->nodes[far], p), r2)) {
                assert(top < BVH_MAX_DEPTH);
                stack[top++] = far;
            }
            if (node_may_reach(box_distance2(&tree->nodes[near], p), r2)) {
                current = near;
                continue;
            }
        }
        if (top == 0) return;
        current = stack[--top];
    }
}
