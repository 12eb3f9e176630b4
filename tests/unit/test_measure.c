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
 *   samples reach the apex. */
#include "bvh.h"
#include "check.h"
#include "measure.h"

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

int main(void)
{
    RUN(test_slivers_against_themselves);
    RUN(test_lifted_square);
    RUN(test_tent);
    return check_summary();
}
