/* measure.c - see measure.h. */
#include "measure.h"

#include <math.h>

#include "bvh.h"
#include "geom.h"

static double sample_triangle(const measure_mesh *a, uint32_t t, const bvh *tree, double spacing, double worst)
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
            if (bvh_closest(tree, q, INFINITY, &hit)) {
                double d = sqrt(hit.distance2);
                if (d > worst) worst = d;
            }
        }
    return worst;
}

double measure_one_sided(const measure_mesh *a, const measure_mesh *b, double spacing)
{
    if (b->triangle_count == 0) return -1.0;
    bvh tree;
    if (bvh_build(&tree, b->positions, b->vertex_count, b->triangles, b->triangle_count) != BVH_OK) return -1.0;
    double worst = 0.0;
    for (uint32_t t = 0; t < a->triangle_count; ++t) worst = sample_triangle(a, t, &tree, spacing, worst);
    bvh_free(&tree);
    return worst;
}

double measure_two_sided(const measure_mesh *a, const measure_mesh *b, double spacing)
{
    double ab = measure_one_sided(a, b, spacing), ba = measure_one_sided(b, a, spacing);
    if (ab < 0 || ba < 0) return -1.0;
    return ab > ba ? ab : ba;
}

double measure_two_sided_with(const measure_mesh *a, const bvh *a_tree, const measure_mesh *b, double spacing)
{
    double ab = measure_one_sided(a, b, spacing);
    if (ab < 0 || a->triangle_count == 0) return -1.0;
    double ba = 0.0;
    for (uint32_t t = 0; t < b->triangle_count; ++t) ba = sample_triangle(b, t, a_tree, spacing, ba);
    return ab > ba ? ab : ba;
}
