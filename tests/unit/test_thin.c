/* test_thin.c - where the original counts as thin (thin.h): the cases the
 * self-intersection test must keep (two sheets, a tube, a second part or
 * material lying on a surface, a border) and the ones it may skip (one
 * sheet, also a noisy one). */
#include "check.h"
#include "thin.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define RNG_SEED 0x7468696e2d6d6170ULL
#include "rng.h"

typedef struct mesh {
    uint32_t nv, nt;
    float pos[3 * 4096];
    uint32_t tri[3 * 8192];
    int32_t mat[8192];
} mesh;

/* An n x n grid of [0, 1]^2 at height z (plus noise), facing up or down. */
static void add_sheet(mesh *m, uint32_t n, double z, int down, double noise, int32_t material)
{
    uint32_t base = m->nv;
    for (uint32_t j = 0; j <= n; ++j)
        for (uint32_t i = 0; i <= n; ++i) {
            float *p = m->pos + 3 * (size_t)m->nv++;
            p[0] = (float)((double)i / n);
            p[1] = (float)((double)j / n);
            p[2] = (float)(z + (noise > 0 ? rng_uniform(-noise, noise) : 0.0));
        }
    for (uint32_t j = 0; j < n; ++j)
        for (uint32_t i = 0; i < n; ++i) {
            uint32_t a = base + j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
            uint32_t q[2][3] = {{a, b, d}, {a, d, c}};
            for (int t = 0; t < 2; ++t) {
                uint32_t *o = m->tri + 3 * (size_t)m->nt;
                o[0] = q[t][0];
                o[1] = down ? q[t][2] : q[t][1];
                o[2] = down ? q[t][1] : q[t][2];
                m->mat[m->nt++] = material;
            }
        }
}

/* Fraction of the grid points over [0.3, 0.7]^2 at height z whose box query
 * says thin. */
static double thin_fraction(const thin_map *map, double z, double half)
{
    int thin = 0, all = 0;
    for (int j = 0; j <= 10; ++j)
        for (int i = 0; i <= 10; ++i) {
            double lo[3] = {0.3 + 0.04 * i - half, 0.3 + 0.04 * j - half, z - half};
            double hi[3] = {lo[0] + 2 * half, lo[1] + 2 * half, lo[2] + 2 * half};
            thin += thin_map_box(map, lo, hi);
            all++;
        }
    return (double)thin / all;
}

static double run(mesh *m, double radius, const uint8_t *special, double z, double half)
{
    thin_map map;
    CHECK(thin_map_build(&map, radius, m->pos, m->nv, m->tri, m->nt, m->mat, special) == 0, "build");
    double f = thin_fraction(&map, z, half);
    thin_map_free(&map);
    return f;
}

static void test_one_sheet(void)
{
    static mesh m;
    memset(&m, 0, sizeof m);
    add_sheet(&m, 40, 0.0, 0, 0.0, 0);
    CHECK(run(&m, 0.02, NULL, 0.0, 0.005) == 0.0, "a flat sheet is not thin");
    memset(&m, 0, sizeof m);
    add_sheet(&m, 40, 0.0, 0, 0.004, 0); /* noise of 1/6 of an edge: normals off by up to ~20 degrees */
    CHECK(run(&m, 0.02, NULL, 0.0, 0.005) == 0.0, "a noisy sheet is not thin");
}

static void test_two_sheets(void)
{
    static mesh m;
    /* a plate of thickness 0.01: top faces up, bottom faces down */
    memset(&m, 0, sizeof m);
    add_sheet(&m, 30, 0.01, 0, 0.0, 0);
    add_sheet(&m, 30, 0.0, 1, 0.0, 0);
    CHECK(run(&m, 0.02, NULL, 0.01, 0.002) == 1.0, "a plate thinner than the radius is thin everywhere");
    /* the same sheets far apart (0.2 = 10 radii): each one alone */
    memset(&m, 0, sizeof m);
    add_sheet(&m, 30, 0.2, 0, 0.0, 0);
    add_sheet(&m, 30, 0.0, 1, 0.0, 0);
    CHECK(run(&m, 0.02, NULL, 0.2, 0.002) == 0.0, "sheets 10 radii apart are not thin");
    /* two parts facing the same way, 0.01 apart (a decal, a second shell):
     * thin by component; the same with one component but two materials */
    memset(&m, 0, sizeof m);
    add_sheet(&m, 30, 0.01, 0, 0.0, 0);
    add_sheet(&m, 30, 0.0, 0, 0.0, 0);
    CHECK(run(&m, 0.02, NULL, 0.01, 0.002) == 1.0, "two components facing the same way are thin");
    memset(&m, 0, sizeof m);
    add_sheet(&m, 30, 0.0, 0, 0.0, 0);
    for (uint32_t t = 0; t < m.nt; ++t) m.mat[t] = (t / 60) % 2; /* stripes of material */
    CHECK(run(&m, 0.02, NULL, 0.0, 0.002) == 1.0, "a material change is thin");
}

static void test_tube_and_border(void)
{
    static mesh m;
    memset(&m, 0, sizeof m);
    /* a closed tube along x of radius 0.008 (< radius 0.02) */
    const uint32_t ring = 12, rings = 40;
    for (uint32_t j = 0; j <= rings; ++j)
        for (uint32_t i = 0; i < ring; ++i) {
            float *p = m.pos + 3 * (size_t)m.nv++;
            double a = 2 * M_PI * i / ring;
            p[0] = (float)((double)j / rings);
            p[1] = (float)(0.5 + 0.008 * cos(a));
            p[2] = (float)(0.008 * sin(a));
        }
    for (uint32_t j = 0; j < rings; ++j)
        for (uint32_t i = 0; i < ring; ++i) {
            uint32_t a = j * ring + i, b = j * ring + (i + 1) % ring, c = a + ring, d = b + ring;
            uint32_t q[2][3] = {{a, c, d}, {a, d, b}};
            for (int t = 0; t < 2; ++t) {
                memcpy(m.tri + 3 * (size_t)m.nt, q[t], sizeof q[t]);
                m.mat[m.nt++] = 0;
            }
        }
    thin_map map;
    CHECK(thin_map_build(&map, 0.02, m.pos, m.nv, m.tri, m.nt, m.mat, NULL) == 0, "build");
    double lo[3] = {0.5, 0.5, 0.0}, hi[3] = {0.51, 0.5, 0.0};
    CHECK(thin_map_box(&map, lo, hi), "a tube narrower than the radius is thin");
    double far_lo[3] = {0.5, 5.0, 5.0}, far_hi[3] = {0.5, 5.0, 5.0};
    CHECK(!thin_map_box(&map, far_lo, far_hi), "empty space far away holds nothing to run into");
    double wide_lo[3] = {-10, -10, -10}, wide_hi[3] = {10, 10, 10};
    CHECK(thin_map_box(&map, wide_lo, wide_hi), "a box of more cubes than the query cap counts as thin");
    double nan_lo[3] = {NAN, 0, 0};
    CHECK(thin_map_box(&map, nan_lo, hi), "a NaN box counts as thin");
    thin_map_free(&map);

    /* a flat sheet whose border vertices are special: thin near the border only */
    memset(&m, 0, sizeof m);
    add_sheet(&m, 40, 0.0, 0, 0.0, 0);
    uint8_t special[41 * 41];
    for (uint32_t j = 0; j <= 40; ++j)
        for (uint32_t i = 0; i <= 40; ++i) special[j * 41 + i] = i == 0 || j == 0 || i == 40 || j == 40;
    CHECK(thin_map_build(&map, 0.02, m.pos, m.nv, m.tri, m.nt, m.mat, special) == 0, "build");
    double at_border[3] = {0.0, 0.5, 0.0}, inside[3] = {0.5, 0.5, 0.0};
    CHECK(thin_map_box(&map, at_border, at_border), "a border is thin");
    CHECK(!thin_map_box(&map, inside, inside), "the middle of a bordered sheet is not");
    thin_map_free(&map);

    /* a radius that cannot be used: everything thin */
    CHECK(thin_map_build(&map, 0.0, m.pos, m.nv, m.tri, m.nt, m.mat, NULL) == 0 && thin_map_box(&map, inside, inside),
          "radius 0: everything is thin");
    thin_map_free(&map);
}

int main(void)
{
    RUN(test_one_sheet);
    RUN(test_two_sheets);
    RUN(test_tube_and_border);
    return check_summary();
}
