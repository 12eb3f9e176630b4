/* measure.c - see measure.h. */
#include "measure.h"

#include <float.h>
#include <math.h>

#include "bvh.h"
#include "geom.h"

/* How much a computed distance to a triangle set may exceed the true one.
 * geom.h: the answer for a thin triangle overestimates by up to ~sqrt(ulp *
 * |p - a| * longest edge), with |p - a| <= d + longest edge; and a sample
 * point, computed from float corners, lies a few ulps of the coordinates off
 * its triangle. Subtracting it keeps every sampled value a lower bound even
 * for slivers of huge extent (a fuzzed mesh with corners at 1e25 read
 * 3.4e16 where the true distance was at most 0.42). For ordinary meshes it
 * is ~1e-7 of the longest edge. */
typedef struct extent {
    double longest_edge; /* of its triangles */
    double magnitude;    /* its largest absolute coordinate */
} extent;

static extent extent_of(const measure_mesh *m)
{
    double longest2 = 0.0, largest = 0.0;
    for (uint32_t t = 0; t < m->triangle_count; ++t) {
        vec3d p[3];
        for (int k = 0; k < 3; ++k) p[k] = geom_vec3d_from_floats(m->positions + 3 * (size_t)m->triangles[3 * (size_t)t + k]);
        for (int k = 0; k < 3; ++k) {
            longest2 = fmax(longest2, geom_distance2(p[k], p[(k + 1) % 3]));
            largest = fmax(largest, fmax(fabs(p[k].x), fmax(fabs(p[k].y), fabs(p[k].z))));
        }
    }
    return (extent){sqrt(longest2), largest};
}

/* For samples of a measured against b: b's longest edge, and the larger
 * magnitude of both. */
static double overestimate(const extent *a, const extent *b, double d)
{
    return 4.0 * sqrt(DBL_EPSILON * (d + b->longest_edge) * b->longest_edge) +
           16.0 * DBL_EPSILON * fmax(a->magnitude, b->magnitude);
}

/* Whether the sample q certainly cannot raise `worst`: some triangle of the
 * tree lies within a radius r a little under worst. Then the exact closest
 * distance d has fl(sqrt(d^2)) <= worst (the 8 ulps of margin absorb the
 * rounding of r * r and of the square root), and the value kept, d less a
 * non-negative overestimate, is no larger, so skipping q changes no maximum
 * by a single bit. Most samples lie nearer than the largest distance found
 * so far: for them the exact closest-point query is replaced by a decision
 * that stops at the first triangle within r, tried first on the triangle
 * that answered the previous sample (*witness; neighbouring samples share
 * it), then by a traversal, nearest box first. Not tried below 1e-150, where
 * r * r would underflow and round upwards. */
static int within_worst(const bvh *tree, const double q[3], double worst, uint32_t *witness)
{
    if (!(worst > 1e-150)) return 0;
    const double r = worst * (1.0 - 8.0 * DBL_EPSILON);
    if (*witness < tree->triangle_count && bvh_triangle_distance2(tree, *witness, q) <= r * r) return 1;
    return bvh_any_within_filtered(tree, q, r, NULL, NULL, witness);
}

/* worst raised by the samples of a's triangle t farther from b (tree) */
static double sample_triangle(const measure_mesh *a, uint32_t t, const bvh *tree, const extent *a_extent,
                              const extent *b_extent, double spacing, double worst, uint32_t *witness)
{
    vec3d p[3];
    for (int k = 0; k < 3; ++k) p[k] = geom_vec3d_from_floats(a->positions + 3 * (size_t)a->triangles[3 * (size_t)t + k]);
    double longest = fmax(geom_distance(p[0], p[1]), fmax(geom_distance(p[1], p[2]), geom_distance(p[2], p[0])));
    int n = spacing > 0 ? (int)ceil(longest / spacing) : 1;
    if (n < 1) n = 1;
    if (n > 64) n = 64;
    for (int i = 0; i <= n; ++i)
        for (int j = 0; j <= n - i; ++j) {
            double u = (double)i / n, v = (double)j / n, w = 1.0 - u - v;
            double q[3] = {u * p[0].x + v * p[1].x + w * p[2].x, u * p[0].y + v * p[1].y + w * p[2].y,
                           u * p[0].z + v * p[1].z + w * p[2].z};
            bvh_hit hit;
            if (within_worst(tree, q, worst, witness)) continue;
            if (bvh_closest(tree, q, INFINITY, &hit)) {
                double d = sqrt(hit.distance2);
                d -= overestimate(a_extent, b_extent, d);
                if (d > worst) worst = d;
                *witness = hit.triangle;
            }
        }
    return worst;
}

/* max over a's samples of their distance to b (tree over b), less rounding */
static double sample_all(const measure_mesh *a, const extent *a_extent, const bvh *b_tree, const extent *b_extent,
                         double spacing)
{
    double worst = 0.0;
    uint32_t witness = UINT32_MAX; /* none yet */
    for (uint32_t t = 0; t < a->triangle_count; ++t)
        worst = sample_triangle(a, t, b_tree, a_extent, b_extent, spacing, worst, &witness);
    return worst;
}

static double one_sided(const measure_mesh *a, const extent *a_extent, const measure_mesh *b, const extent *b_extent,
                        double spacing)
{
    if (b->triangle_count == 0) return MEASURE_EMPTY;
    bvh tree;
    if (bvh_build(&tree, b->positions, b->vertex_count, b->triangles, b->triangle_count) != BVH_OK)
        return MEASURE_NO_MEMORY;
    double worst = sample_all(a, a_extent, &tree, b_extent, spacing);
    bvh_free(&tree);
    return worst;
}

double measure_one_sided(const measure_mesh *a, const measure_mesh *b, double spacing)
{
    const extent ea = extent_of(a), eb = extent_of(b);
    return one_sided(a, &ea, b, &eb, spacing);
}

double measure_two_sided(const measure_mesh *a, const measure_mesh *b, double spacing)
{
    const extent ea = extent_of(a), eb = extent_of(b);
    double ab = one_sided(a, &ea, b, &eb, spacing), ba = one_sided(b, &eb, a, &ea, spacing);
    if (ab == MEASURE_NO_MEMORY || ba == MEASURE_NO_MEMORY) return MEASURE_NO_MEMORY;
    if (ab < 0 || ba < 0) return MEASURE_EMPTY;
    return ab > ba ? ab : ba;
}

double measure_two_sided_with(const measure_mesh *a, const bvh *a_tree, const measure_mesh *b, double spacing)
{
    const extent ea = extent_of(a), eb = extent_of(b);
    double ab = one_sided(a, &ea, b, &eb, spacing);
    if (ab == MEASURE_NO_MEMORY) return MEASURE_NO_MEMORY;
    if (ab < 0 || a->triangle_count == 0) return MEASURE_EMPTY;
    double ba = sample_all(b, &eb, a_tree, &ea, spacing);
    return ab > ba ? ab : ba;
}
