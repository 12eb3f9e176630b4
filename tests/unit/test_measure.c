/* test_measure.c - measure.h stays what `lodpipe check` needs: a lower bound
 * of the true two-sided distance that still finds real distances.
 * - a mesh against itself reads (nearly) zero, also for slivers whose corners
 *   lie at 1e25, where geom.h's closest point overestimates by ~1e16 (the
 *   mesh of a fuzz_pipeline input that made `lodpipe check` call a correct
 *   level wrong: 3.4e16 measured against a true distance of at most 0.42);
 * - a square against the same square lifted by h reads h, less at most
 *   1e-7 (2 + h) (what rounding could add), in both
 *   directions and through measure_two_sided_with;
 * - a tent (one vertex of a grid raised) reads the raise exactly where the
 *   samples reach the apex;
 * - skipping the samples that lie within the largest distance found so far
 *   changes nothing: on random bumpy grids both directions equal, to the bit,
 *   a reference that queries the exact closest point for every sample. */
#include "bvh.h"
#include "check.h"
#include "geom.h"
#include "measure.h"
#define RNG_SEED 0x6d656173ULL
#include "rng.h"

#include <float.h>
#include <math.h>
#include <stdint.h>

/* Three triangles of that input: each joins two corners of the unit-sized
 * part with one 1.4e25 away, long and thin. */
static const float SLIVER_POSITIONS[] = {
    0.0f, 0.6363636255264282f, 0.0f,
    0.09090909361839294f, 0.6363636255264282f, 0.0011897783260792494f,
    1.725559417575795e-10f, -1.4707101179776283e-31f, -1.4335386788950379e+25f,
    0.0f, -1.4342925976925433e-31f, -1.4693093989091884e-31f,
    -9.671406556917033e+24f, -1.4679086798407486e-31f, -1.4335386788950379e+25f,
    -1.471760539729523e-31f, -0.0007237520767375827f, -1.472460899263743e-31f,
};
static const uint32_t SLIVER_TRIANGLES[] = {0, 1, 2, 0, 2, 3, 2, 5, 4};

static void test_slivers_against_themselves(void)
{
    const measure_mesh a = {SLIVER_POSITIONS, 6, SLIVER_TRIANGLES, 3};
    for (double spacing = 1e23; spacing <= 1e26; spacing *= 10) {
        double d = measure_two_sided(&a, &a, spacing);
        CHECK(d >= 0.0 && d <= 1e-3, "spacing %g: a mesh against itself measured %.17g", spacing, d);
    }
}

static void test_lifted_square(void)
{
    for (double h = 1e-4; h <= 10.0; h *= 10) {
        const float z = (float)h;
        const float positions[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, z, 1, 0, z, 1, 1, z, 0, 1, z};
        const uint32_t bottom[] = {0, 1, 2, 0, 2, 3}, top[] = {4, 5, 6, 4, 6, 7};
        const measure_mesh a = {positions, 8, bottom, 2}, b = {positions, 8, top, 2};
        const double expected = (double)z;
        double d = measure_two_sided(&a, &b, 0.05);
        /* a lower bound, short of h by what rounding could add (~1e-7 of the
         * longest edge, the squares' diagonal, growing as sqrt(h)) */
        CHECK(d <= expected && d >= expected - 1e-7 * (2.0 + expected), "h %g: measured %.17g", h, d);
        bvh tree;
        CHECK(bvh_build(&tree, positions, 8, bottom, 2) == BVH_OK, "bvh");
        double with = measure_two_sided_with(&a, &tree, &b, 0.05);
        bvh_free(&tree);
        CHECK(with == d, "h %g: with a prebuilt tree %.17g, without %.17g", h, with, d);
    }
}

/* a 4 x 4 grid of unit squares; the tent raises the middle vertex (2, 2) */
static void test_tent(void)
{
    float flat[25 * 3], tent[25 * 3];
    uint32_t triangles[16 * 6];
    uint32_t n = 0;
    for (uint32_t j = 0; j < 5; ++j)
        for (uint32_t i = 0; i < 5; ++i) {
            float *p = flat + 3 * (5 * j + i), *q = tent + 3 * (5 * j + i);
            p[0] = q[0] = (float)i;
            p[1] = q[1] = (float)j;
            p[2] = 0.0f;
            q[2] = i == 2 && j == 2 ? 0.5f : 0.0f;
        }
    for (uint32_t j = 0; j < 4; ++j)
        for (uint32_t i = 0; i < 4; ++i) {
            const uint32_t v = 5 * j + i;
            const uint32_t quad[6] = {v, v + 1, v + 6, v, v + 6, v + 5};
            for (int k = 0; k < 6; ++k) triangles[n++] = quad[k];
        }
    const measure_mesh a = {flat, 25, triangles, 32}, b = {tent, 25, triangles, 32};
    /* the apex is a vertex, always sampled; the flat grid's nearest point to it
     * is right below: 0.5 */
    double d = measure_two_sided(&a, &b, 0.25);
    CHECK(fabs(d - 0.5) <= 1e-6, "tent measured %.17g", d);
    /* the other way round: the flat grid's farthest point from the tent is
     * below the apex, about 0.45 from the faces around it (0.5 / sqrt(1.25)
     * from their planes): below 0.5, above 0.3 */
    double back = measure_one_sided(&a, &b, 0.25);
    CHECK(back > 0.3 && back <= 0.5, "flat to tent %.17g", back);
}

/* measure_one_sided as it was before samples were skipped: the same grid of
 * samples, the exact closest point for each, less the same overestimate
 * (measure.c's extent_of and overestimate, restated) */
static void reference_extent(const measure_mesh *m, double *longest, double *largest)
{
    double longest2 = 0.0;
    *largest = 0.0;
    for (uint32_t t = 0; t < m->triangle_count; ++t) {
        vec3d p[3];
        for (int k = 0; k < 3; ++k) p[k] = geom_vec3d_from_floats(m->positions + 3 * (size_t)m->triangles[3 * t + k]);
        for (int k = 0; k < 3; ++k) {
            longest2 = fmax(longest2, geom_distance2(p[k], p[(k + 1) % 3]));
            *largest = fmax(*largest, fmax(fabs(p[k].x), fmax(fabs(p[k].y), fabs(p[k].z))));
        }
    }
    *longest = sqrt(longest2);
}

static double reference_one_sided(const measure_mesh *a, const measure_mesh *b, double spacing)
{
    double a_edge, a_mag, b_edge, b_mag, worst = 0.0;
    reference_extent(a, &a_edge, &a_mag);
    reference_extent(b, &b_edge, &b_mag);
    bvh tree;
    if (bvh_build(&tree, b->positions, b->vertex_count, b->triangles, b->triangle_count) != BVH_OK) return -1.0;
    for (uint32_t t = 0; t < a->triangle_count; ++t) {
        vec3d p[3];
        for (int k = 0; k < 3; ++k) p[k] = geom_vec3d_from_floats(a->positions + 3 * (size_t)a->triangles[3 * t + k]);
        double longest = fmax(geom_distance(p[0], p[1]), fmax(geom_distance(p[1], p[2]), geom_distance(p[2], p[0])));
        int n = (int)ceil(longest / spacing);
        n = n < 1 ? 1 : n > 64 ? 64 : n;
        for (int i = 0; i <= n; ++i)
            for (int j = 0; j <= n - i; ++j) {
                double u = (double)i / n, v = (double)j / n, w = 1.0 - u - v;
                double q[3] = {u * p[0].x + v * p[1].x + w * p[2].x, u * p[0].y + v * p[1].y + w * p[2].y,
                               u * p[0].z + v * p[1].z + w * p[2].z};
                bvh_hit hit;
                if (!bvh_closest(&tree, q, INFINITY, &hit)) continue;
                double d = sqrt(hit.distance2);
                d -= 4.0 * sqrt(DBL_EPSILON * (d + b_edge) * b_edge) + 16.0 * DBL_EPSILON * fmax(a_mag, b_mag);
                if (d > worst) worst = d;
            }
    }
    bvh_free(&tree);
    return worst;
}

/* an n x n grid over [0, 1]^2, heights random in [0, bump), triangulated
 * with the diagonal flipped at random */
static void bumpy_grid(uint32_t n, double bump, float *positions, uint32_t *triangles)
{
    for (uint32_t j = 0; j <= n; ++j)
        for (uint32_t i = 0; i <= n; ++i) {
            float *p = positions + 3 * ((n + 1) * j + i);
            p[0] = (float)i / (float)n;
            p[1] = (float)j / (float)n;
            p[2] = (float)rng_uniform(0.0, bump);
        }
    uint32_t k = 0;
    for (uint32_t j = 0; j < n; ++j)
        for (uint32_t i = 0; i < n; ++i) {
            const uint32_t v = (n + 1) * j + i, w = v + n + 1;
            const uint32_t flip = rng_uniform(0.0, 1.0) < 0.5;
            const uint32_t quad[2][6] = {{v, v + 1, w + 1, v, w + 1, w}, {v, v + 1, w, v + 1, w + 1, w}};
            for (int c = 0; c < 6; ++c) triangles[k++] = quad[flip][c];
        }
}

static void test_skipped_samples_change_nothing(void)
{
    enum { FINE = 24, COARSE = 6 };
    static float fine[3 * (FINE + 1) * (FINE + 1)], coarse[3 * (COARSE + 1) * (COARSE + 1)];
    static uint32_t fine_triangles[6 * FINE * FINE], coarse_triangles[6 * COARSE * COARSE];
    for (int round = 0; round < 8; ++round) {
        const double bump = round < 4 ? 0.05 : 1e-6; /* the latter: distances near rounding */
        bumpy_grid(FINE, bump, fine, fine_triangles);
        bumpy_grid(COARSE, bump, coarse, coarse_triangles);
        const measure_mesh a = {fine, (FINE + 1) * (FINE + 1), fine_triangles, 2 * FINE * FINE};
        const measure_mesh b = {coarse, (COARSE + 1) * (COARSE + 1), coarse_triangles, 2 * COARSE * COARSE};
        for (double spacing = 0.2; spacing >= 0.005; spacing /= 4) {
            const double ab = reference_one_sided(&a, &b, spacing), ba = reference_one_sided(&b, &a, spacing);
            const double one = measure_one_sided(&a, &b, spacing), two = measure_two_sided(&a, &b, spacing);
            const double self = measure_one_sided(&a, &a, spacing), self_reference = reference_one_sided(&a, &a, spacing);
            CHECK(one == ab, "round %d spacing %g: fine to coarse %.17g, reference %.17g", round, spacing, one, ab);
            CHECK(two == fmax(ab, ba), "round %d spacing %g: two-sided %.17g, reference %.17g", round, spacing, two,
                  fmax(ab, ba));
            CHECK(self == self_reference, "round %d spacing %g: against itself %.17g, reference %.17g", round, spacing,
                  self, self_reference);
        }
    }
}

int main(void)
{
    RUN(test_slivers_against_themselves);
    RUN(test_lifted_square);
    RUN(test_tent);
    RUN(test_skipped_samples_change_nothing);
    return check_summary();
}
