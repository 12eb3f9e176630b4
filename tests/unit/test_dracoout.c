/* test_dracoout.c - the Draco position grid bound (dracoout.h) against the real
 * encoder and decoder (Debian libdraco through third_party/draco_codec): every
 * decoded coordinate lies within the grid's per-axis bound of its exact value,
 * for 1..30 bits, far from the origin and near it, and the bound is not
 * loose at coarse grids (the real error reaches most of half a step). */
#define RNG_SEED 0x5eedd4ac0ull
#include "check.h"
#include "rng.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "draco_codec/draco_codec.h"
#include "dracoout.h"

enum { POINTS = 600 };

/* Encodes POINTS random points (faces: consecutive triples) on the explicit
 * grid of their box at `bits`, sequential (order kept); returns the largest
 * decoded error per axis divided by the axis bound (<= 1 when the bound
 * holds), and in *half_step_share the largest error / (step / 2). */
static double worst_share(double center, double extent, int bits, double *half_step_share)
{
    float *x = malloc(3 * POINTS * sizeof *x), *y = malloc(3 * POINTS * sizeof *y);
    uint32_t *faces = malloc(POINTS * sizeof *faces);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < 3 * POINTS; ++i) {
        x[i] = (float)(center + rng_uniform(-0.5, 0.5) * extent * (i % 3 == 1 ? 0.3 : 1.0));
        if (x[i] < lo[i % 3]) lo[i % 3] = x[i];
        if (x[i] > hi[i % 3]) hi[i % 3] = x[i];
    }
    for (int i = 0; i < POINTS; ++i) faces[i] = (uint32_t)i;
    dracoout_grid g;
    dracoout_grid_of(lo, hi, bits, &g);
    draco_encode_attribute a;
    memset(&a, 0, sizeof a);
    a.semantic = DRACO_SEMANTIC_POSITION;
    a.gltf_component_type = 5126;
    a.components = 3;
    a.values = x;
    a.quantization_bits = bits;
    a.explicit_grid = 1;
    memcpy(a.origin, g.origin, sizeof g.origin);
    a.range = g.range;
    draco_encode_options o = {5, 1, 0};
    uint8_t *stream = NULL;
    size_t size = 0;
    uint32_t id = 0;
    char why[256] = "";
    double worst = INFINITY;
    *half_step_share = 0;
    draco_mesh *m = NULL;
    if (draco_encode_mesh(POINTS, faces, POINTS / 3, &a, 1, &o, &stream, &size, &id, why, sizeof why) == 0 &&
        draco_decode_mesh(stream, size, &m, why, sizeof why) == 0 && draco_mesh_num_points(m) == POINTS &&
        draco_mesh_read_attribute(m, id, 5126, 3, y, why, sizeof why) == 0) {
        worst = 0;
        const double half_step = 0.5 * (double)g.range / (double)((1u << bits) - 1u);
        for (int i = 0; i < 3 * POINTS; ++i) {
            double e = fabs((double)y[i] - (double)x[i]);
            if (e / g.axis_bound[i % 3] > worst) worst = e / g.axis_bound[i % 3];
            if (e / half_step > *half_step_share) *half_step_share = e / half_step;
        }
    }
    CHECK(worst < INFINITY, "encode/decode failed: %s", why);
    if (m) draco_mesh_free(m);
    free(stream);
    free(x);
    free(y);
    free(faces);
    return worst;
}

static void test_bound_holds_for_every_bit_count(void)
{
    static const double centers[] = {0.0, 1.0, -37.5, 1000.0, -2.5e5};
    static const double sizes[] = {1.0, 0.01, 250.0};
    /* every count up to 16, then the float32 limits; Draco's encoder is slow at
     * many bits (its tables grow with them), so not every one above 16 */
    static const int kBits[] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 20, 23, 24, 25, 27, 30};
    for (size_t b = 0; b < sizeof kBits / sizeof kBits[0]; ++b)
        for (size_t c = 0; c < sizeof centers / sizeof centers[0]; ++c)
            for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; ++s) {
                double share;
                const int bits = kBits[b];
                if (bits > 16 && (s > 0 || (c != 0 && c != 4))) continue; /* near and far from the origin */
                double worst = worst_share(centers[c], sizes[s], bits, &share);
                CHECK(worst <= 1.0, "bits %d center %g size %g: error %.3f x the bound", bits, centers[c], sizes[s],
                      worst);
            }
}

/* Far from the origin float32 itself is coarse (its half-ulp at 1e5 is
 * 0.0039): the bound must hold there and stay within a small multiple of
 * that, or Draco is refused for levels float32 could carry (the slack's
 * origin term was once 16 u |o|, 0.095 a coordinate at 1e5). */
static void test_bound_far_from_the_origin(void)
{
    const double center = 1e5, extent = 3.76, half_ulp = 0.00390625;
    for (int bits = 14; bits <= 30; bits += 16) {
        double share;
        const double worst = worst_share(center, extent, bits, &share);
        CHECK(worst <= 1.0, "bits %d at %g: error %.3f x the bound", bits, center, worst);
    }
    const double lo[3] = {center, center, center}, hi[3] = {center + extent, center + extent, center + extent};
    dracoout_grid g;
    dracoout_grid_of(lo, hi, 30, &g);
    for (int c = 0; c < 3; ++c)
        CHECK(g.axis_bound[c] <= 4 * half_ulp, "axis %d: bound %g at 30 bits, float32's half-ulp %g", c,
              g.axis_bound[c], half_ulp);
}

static void test_bound_is_tight_on_coarse_grids(void)
{
    for (int bits = 4; bits <= 14; bits += 5) {
        double share;
        worst_share(0.0, 1.0, bits, &share);
        CHECK(share > 0.8 && share <= 1.01, "bits %d: worst error %.3f x half a step", bits, share);
    }
}

/* Draco stores an explicit grid's origin and range as six-decimal text: a
 * box of 3.5e-8 had range 0 (every point decoded to one), and an origin with
 * more decimals moved. The grid must be one the text keeps exactly. */
static void test_bound_holds_for_tiny_and_off_lattice_boxes(void)
{
    const double cases[][2] = {{1e-8, 3.5e-8}, {0.123456789, 1e-5}, {-7.654321987, 2e-4}, {3e-12, 1e-11}};
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
        double share;
        double worst = worst_share(cases[k][0], cases[k][1], 14, &share);
        CHECK(worst <= 1.0, "center %g extent %g: worst error %.3g x its axis bound", cases[k][0], cases[k][1], worst);
    }
}

static void test_single_point_has_no_error(void)
{
    double p[3] = {3.5, -2.0, 1e6};
    dracoout_grid g;
    dracoout_grid_of(p, p, 14, &g);
    CHECK(g.bound == 0 && g.range > 0, "bound %g range %g", g.bound, (double)g.range);
}

static void test_grid_contains_the_box(void)
{
    double lo[3] = {(double)0.1f, -3.0, 7.0}, hi[3] = {0.30000001192092896, 5.0, 7.25}; /* float values */
    dracoout_grid g;
    dracoout_grid_of(lo, hi, 12, &g);
    for (int c = 0; c < 3; ++c) {
        CHECK((double)g.origin[c] == (double)(float)lo[c], "origin %d", c);
        CHECK((double)g.origin[c] + (double)g.range >= hi[c], "axis %d not covered", c);
    }
    CHECK((double)g.range >= 8.0 && (double)g.range < 8.0 * (1 + 1e-6), "range %.9g", (double)g.range);
    /* the Euclidean length of the per-axis bounds, and more than the exact half step */
    double len = sqrt(g.axis_bound[0] * g.axis_bound[0] + g.axis_bound[1] * g.axis_bound[1] +
                      g.axis_bound[2] * g.axis_bound[2]);
    CHECK(fabs(len - g.bound) <= 1e-15 * len, "bound %g vs %g", g.bound, len);
    CHECK(g.bound > sqrt(3.0) * 0.5 * 8.0 / 4095.0, "bound %g", g.bound);
}

int main(void)
{
    RUN(test_bound_holds_for_every_bit_count);
    RUN(test_bound_far_from_the_origin);
    RUN(test_bound_is_tight_on_coarse_grids);
    RUN(test_bound_holds_for_tiny_and_off_lattice_boxes);
    RUN(test_single_point_has_no_error);
    RUN(test_grid_contains_the_box);
    return check_summary();
}
