/* test_bvh.c - every BVH query against brute force over all triangles (the
 * same geom function, so answers must agree bit for bit), on random soups
 * with degenerate and duplicated triangles, a tessellated sphere, a flat grid
 * full of exact ties, a pathological spread that hits the depth cap, and a
 * copy of a model moved 1e5 units away. */
#include "bvh.h"
#include "check.h"
#include "geom.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define RNG_SEED 0x627668746573ULL
#include "rng.h"

static uint32_t rng_below(uint32_t n)
{
    return (uint32_t)(rng_next() % n);
}

/* ---- meshes --------------------------------------------------------------- */

typedef struct {
    float *positions;
    uint32_t *indices;
    size_t vertex_count;
    size_t triangle_count;
} mesh;

static mesh mesh_alloc(size_t vertex_count, size_t triangle_count)
{
    mesh m;
    m.positions = calloc(3 * vertex_count + 1, sizeof(float));
    m.indices = calloc(3 * triangle_count + 1, sizeof(uint32_t));
    m.vertex_count = vertex_count;
    m.triangle_count = triangle_count;
    return m;
}

static void mesh_free(mesh *m)
{
    free(m->positions);
    free(m->indices);
}

static double snap(double v, double grid)
{
    return grid > 0.0 ? floor(v / grid) * grid : v;
}

/* Random triangles in [-1, 1]^3 with sizes from 1e-3 to 0.2, and on purpose:
 * collinear ones, ones with a repeated vertex, single points, and exact
 * duplicates of the previous triangle (distance ties). With grid > 0 every
 * coordinate is a multiple of it. */
static mesh make_soup(size_t triangle_count, double grid)
{
    mesh m = mesh_alloc(3 * triangle_count, triangle_count);
    for (size_t t = 0; t < triangle_count; t++) {
        float *v = m.positions + 9 * t;
        double centre[3], size = pow(10.0, rng_uniform(-3.0, -0.7));
        for (int axis = 0; axis < 3; axis++) centre[axis] = rng_uniform(-1.0, 1.0);
        for (int corner = 0; corner < 3; corner++)
            for (int axis = 0; axis < 3; axis++)
                v[3 * corner + axis] =
                    (float)snap(centre[axis] + size * rng_uniform(-1.0, 1.0), grid);
        if (t % 50 == 7) {   /* collinear: third vertex on the line of the first two */
            double s = rng_uniform(-0.5, 1.5);
            for (int axis = 0; axis < 3; axis++)
                v[6 + axis] = (float)snap(v[axis] + s * (v[3 + axis] - v[axis]), grid);
        }
        if (t % 77 == 3) memcpy(v + 3, v, 3 * sizeof(float));       /* repeated vertex */
        if (t % 101 == 5) {                                          /* a single point */
            memcpy(v + 3, v, 3 * sizeof(float));
            memcpy(v + 6, v, 3 * sizeof(float));
        }
        for (int corner = 0; corner < 3; corner++)
            m.indices[3 * t + corner] = (uint32_t)(3 * t + corner);
        if (t % 37 == 36) /* an exact duplicate of the previous triangle */
            memcpy(m.indices + 3 * t, m.indices + 3 * (t - 1), 3 * sizeof(uint32_t));
    }
    return m;
}

/* A UV sphere of radius 1 with shared vertices: 2 * slices * (stacks - 1)
 * triangles, including the pole fans. */
static mesh make_sphere(uint32_t stacks, uint32_t slices)
{
    size_t vertex_count = (size_t)(stacks + 1) * (slices + 1);
    size_t triangle_count = 2 * (size_t)slices * (stacks - 1);
    mesh m = mesh_alloc(vertex_count, triangle_count);
    const double pi = 3.14159265358979323846;
    for (uint32_t i = 0; i <= stacks; i++)
        for (uint32_t j = 0; j <= slices; j++) {
            double theta = pi * i / stacks, phi = 2.0 * pi * j / slices;
            float *v = m.positions + 3 * ((size_t)i * (slices + 1) + j);
            v[0] = (float)(sin(theta) * cos(phi));
            v[1] = (float)(sin(theta) * sin(phi));
            v[2] = (float)cos(theta);
        }
    size_t t = 0;
    for (uint32_t i = 0; i < stacks; i++)
        for (uint32_t j = 0; j < slices; j++) {
            uint32_t v00 = i * (slices + 1) + j, v01 = v00 + 1;
            uint32_t v10 = v00 + slices + 1, v11 = v10 + 1;
            if (i != 0) {
                m.indices[3 * t] = v00; m.indices[3 * t + 1] = v10; m.indices[3 * t + 2] = v01;
                t++;
            }
            if (i != stacks - 1) {
                m.indices[3 * t] = v01; m.indices[3 * t + 1] = v10; m.indices[3 * t + 2] = v11;
                t++;
            }
        }
    m.triangle_count = t;
    return m;
}

/* A flat n x n grid of unit squares in z = 0, two triangles each: points
 * above shared edges and vertices are at exactly equal distance from several
 * triangles. */
static mesh make_grid(uint32_t n)
{
    mesh m = mesh_alloc((size_t)(n + 1) * (n + 1), 2 * (size_t)n * n);
    for (uint32_t i = 0; i <= n; i++)
        for (uint32_t j = 0; j <= n; j++) {
            float *v = m.positions + 3 * ((size_t)i * (n + 1) + j);
            v[0] = (float)j;
            v[1] = (float)i;
            v[2] = 0.0f;
        }
    for (uint32_t i = 0; i < n; i++)
        for (uint32_t j = 0; j < n; j++) {
            uint32_t v00 = i * (n + 1) + j, v01 = v00 + 1, v10 = v00 + n + 1, v11 = v10 + 1;
            /* Reverse order of rows so the lowest triangle index is not
             * always the first one the tree meets. */
            size_t base = 2 * ((size_t)(n - 1 - i) * n + j);
            uint32_t *tri = m.indices + 3 * base;
            tri[0] = v00; tri[1] = v01; tri[2] = v11;
            tri[3] = v00; tri[4] = v11; tri[5] = v10;
        }
    return m;
}

/* ---- brute force ---------------------------------------------------------- */

/* What a hit looks like before any query wrote it. */
static bvh_hit no_hit(void)
{
    bvh_hit hit = {UINT32_MAX, INFINITY, {0.0, 0.0, 0.0}};
    return hit;
}

static double brute_triangle_distance2(const mesh *m, uint32_t t, const double p[3], vec3d *q)
{
    vec3d point = geom_vec3d_from_doubles(p);
    vec3d a = geom_vec3d_from_floats(m->positions + 3 * (size_t)m->indices[3 * (size_t)t]);
    vec3d b = geom_vec3d_from_floats(m->positions + 3 * (size_t)m->indices[3 * (size_t)t + 1]);
    vec3d c = geom_vec3d_from_floats(m->positions + 3 * (size_t)m->indices[3 * (size_t)t + 2]);
    return geom_point_triangle_distance2(&point, &a, &b, &c, q);
}

typedef int (*triangle_predicate)(void *context, uint32_t triangle);

/* Closest by the same rule as bvh_closest: the lowest index among equal
 * distances, which a strict "<" in index order gives. */
static int brute_closest(const mesh *m, const double p[3], triangle_predicate keep,
                         void *context, bvh_hit *hit)
{
    double best = INFINITY;
    uint32_t best_t = UINT32_MAX;
    vec3d best_q = {0, 0, 0};
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        if (keep && !keep(context, t)) continue;
        vec3d q;
        double d2 = brute_triangle_distance2(m, t, p, &q);
        if (d2 < best) {
            best = d2;
            best_t = t;
            best_q = q;
        }
    }
    if (best_t == UINT32_MAX) return 0;
    hit->triangle = best_t;
    hit->distance2 = best;
    hit->point[0] = best_q.x;
    hit->point[1] = best_q.y;
    hit->point[2] = best_q.z;
    return 1;
}

static int brute_any_within(const mesh *m, const double p[3], double r,
                            triangle_predicate keep, void *context)
{
    if (!(r >= 0.0)) return 0;
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        if (keep && !keep(context, t)) continue;
        if (brute_triangle_distance2(m, t, p, NULL) <= r * r) return 1;
    }
    return 0;
}

/* ---- query points ---------------------------------------------------------- */

/* A mix: near a random triangle (on it, just off it, off an edge), exactly
 * at a vertex, uniform in the padded bounds, and far away. */
static void random_query(const mesh *m, double extent, double p[3])
{
    uint32_t kind = rng_below(5);
    uint32_t t = rng_below((uint32_t)m->triangle_count);
    const float *a = m->positions + 3 * (size_t)m->indices[3 * (size_t)t];
    const float *b = m->positions + 3 * (size_t)m->indices[3 * (size_t)t + 1];
    const float *c = m->positions + 3 * (size_t)m->indices[3 * (size_t)t + 2];
    if (kind == 0 || kind == 1) {
        double s = rng_uniform(-0.3, 1.0), u = rng_uniform(-0.3, 1.0 - s);
        double offset = kind == 0 ? 0.0 : rng_uniform(-0.05, 0.05) * extent;
        for (int axis = 0; axis < 3; axis++)
            p[axis] = a[axis] + s * (b[axis] - a[axis]) + u * (c[axis] - a[axis]) +
                      offset * rng_uniform(-1, 1);
    } else if (kind == 2) {
        for (int axis = 0; axis < 3; axis++) p[axis] = a[axis];
    } else if (kind == 3) {
        for (int axis = 0; axis < 3; axis++) p[axis] = rng_uniform(-1.3, 1.3) * extent;
    } else {
        for (int axis = 0; axis < 3; axis++) p[axis] = rng_uniform(-20.0, 20.0) * extent;
    }
}

/* ---- the core comparison ---------------------------------------------------- */

typedef struct {
    int closest_mismatch, any_mismatch, any_wrong_side, limit_mismatch;
} mismatch_counts;

/* Runs `queries` random queries against brute force, through bvh_closest,
 * bvh_any_within just below / just above the distance and at random radii,
 * bvh_closest_unless_within at random radii, and bvh_closest with max_dist
 * on both sides of the distance. */
static mismatch_counts compare_with_brute_force(const mesh *m, const bvh *tree, int queries,
                                                double extent)
{
    mismatch_counts counts = {0, 0, 0, 0};
    for (int i = 0; i < queries; i++) {
        double p[3];
        random_query(m, extent, p);
        bvh_hit expect = no_hit(), got = no_hit();
        int expect_found = brute_closest(m, p, NULL, NULL, &expect);
        int found = bvh_closest(tree, p, INFINITY, &got);
        if (found != expect_found || got.triangle != expect.triangle ||
            got.distance2 != expect.distance2 || got.point[0] != expect.point[0] ||
            got.point[1] != expect.point[1] || got.point[2] != expect.point[2]) {
            if (counts.closest_mismatch++ < 5)
                printf("#   query %d: bvh %u %.17g, brute force %u %.17g\n", i, got.triangle,
                       got.distance2, expect.triangle, expect.distance2);
        }

        double d = sqrt(expect.distance2);
        double below = d * (1.0 - 1e-12), above = d * (1.0 + 1e-12) + 1e-300;
        if (d == 0.0) below = -1.0;
        int got_below = bvh_any_within(tree, p, below);
        int got_above = bvh_any_within(tree, p, above);
        if (got_below != brute_any_within(m, p, below, NULL, NULL)) counts.any_mismatch++;
        if (got_above != brute_any_within(m, p, above, NULL, NULL)) counts.any_mismatch++;
        if (got_below != 0 || got_above != 1) counts.any_wrong_side++;
        double r = rng_uniform(0.0, 2.0) * d;
        if (bvh_any_within(tree, p, r) != brute_any_within(m, p, r, NULL, NULL))
            counts.any_mismatch++;

        /* stopping early: a triangle within `enough` (measured as ever),
         * else the exact answer */
        double enough = rng_uniform(0.0, 2.0) * d;
        bvh_hit early = no_hit();
        int ended = bvh_closest_unless_within(tree, p, INFINITY, enough, NULL, NULL, &early);
        if (ended == 2 ? !(early.distance2 <= enough * enough) || early.distance2 < expect.distance2 ||
                             early.distance2 != bvh_triangle_distance2(tree, early.triangle, p)
                       : ended != expect_found || (ended && (early.triangle != expect.triangle ||
                                                             early.distance2 != expect.distance2)))
            counts.limit_mismatch++;

        bvh_hit limited = no_hit();
        if (bvh_closest(tree, p, below, &limited) != 0) counts.limit_mismatch++;
        if (bvh_closest(tree, p, above, &limited) != 1 || limited.triangle != expect.triangle ||
            limited.distance2 != expect.distance2)
            counts.limit_mismatch++;
    }
    return counts;
}

static void check_counts(mismatch_counts c, const char *what)
{
    CHECK(c.closest_mismatch == 0, "%s: %d closest answers differ from brute force", what,
          c.closest_mismatch);
    CHECK(c.any_mismatch == 0, "%s: %d any_within answers differ from brute force", what,
          c.any_mismatch);
    CHECK(c.any_wrong_side == 0, "%s: %d any_within answers on the wrong side", what,
          c.any_wrong_side);
    CHECK(c.limit_mismatch == 0, "%s: %d max_dist answers wrong", what, c.limit_mismatch);
}

/* Structural promises: a permutation of the triangles, leaves of 2..4, every
 * triangle's vertices inside its leaf box and all ancestors, left child
 * right after its parent, depth within the cap, fewer nodes than triangles. */
static int check_structure(const mesh *m, const bvh *tree)
{
    int errors = 0;
    uint32_t n = tree->triangle_count;
    char *seen = calloc(n + 1, 1);
    /* Walk with an explicit stack of (node, depth); check each triangle
     * against the boxes on its path by re-walking from the root. */
    uint32_t stack[2 * BVH_MAX_DEPTH + 2], depth_of[2 * BVH_MAX_DEPTH + 2];
    uint32_t path[BVH_MAX_DEPTH + 1];
    int top = 0;
    stack[top] = 0;
    depth_of[top++] = 0;
    uint32_t leaves = 0;
    while (top > 0) {
        top--;
        uint32_t node_index = stack[top], depth = depth_of[top];
        if (depth > BVH_MAX_DEPTH || node_index >= tree->node_count) {
            errors++;
            continue;
        }
        path[depth] = node_index;
        const bvh_node *node = &tree->nodes[node_index];
        if (node->count == 0) {
            if (node->offset <= node_index + 1 || node->offset >= tree->node_count) errors++;
            stack[top] = node->offset;
            depth_of[top++] = depth + 1;
            stack[top] = node_index + 1;
            depth_of[top++] = depth + 1;
            continue;
        }
        leaves++;
        if (node->count > 4 || (node->count < 2 && n > 1)) errors++;
        for (uint32_t i = 0; i < node->count; i++) {
            uint32_t t = tree->triangle_order[node->offset + i];
            if (t >= n || seen[t]) {
                errors++;
                continue;
            }
            seen[t] = 1;
            for (int corner = 0; corner < 3; corner++) {
                const float *v = m->positions + 3 * (size_t)m->indices[3 * (size_t)t + corner];
                for (uint32_t level = 0; level <= depth; level++) {
                    const bvh_node *box = &tree->nodes[path[level]];
                    for (int axis = 0; axis < 3; axis++)
                        if (!(box->lo[axis] <= v[axis] && v[axis] <= box->hi[axis])) errors++;
                }
            }
        }
    }
    for (uint32_t t = 0; t < n; t++)
        if (!seen[t]) errors++;
    if (n > 1 && tree->node_count >= n) errors++;
    if (tree->node_count != 2 * leaves - 1) errors++;
    if (tree->depth > BVH_MAX_DEPTH) errors++;
    free(seen);
    return errors;
}

/* ---- tests ---------------------------------------------------------------- */

static void test_random_soup_matches_brute_force(void)
{
    mesh m = make_soup(5000, 0.0);
    bvh tree;
    CHECK(bvh_build(&tree, m.positions, m.vertex_count, m.indices, m.triangle_count) == BVH_OK,
          "build");
    CHECK(check_structure(&m, &tree) == 0, "structure");
    check_counts(compare_with_brute_force(&m, &tree, 2000, 1.0), "soup");
    bvh_free(&tree);
    mesh_free(&m);
}

static void test_sphere_matches_brute_force(void)
{
    mesh m = make_sphere(51, 50);   /* 5,000 triangles */
    bvh tree;
    CHECK(m.triangle_count == 5000, "sphere has %zu triangles", m.triangle_count);
    CHECK(bvh_build(&tree, m.positions, m.vertex_count, m.indices, m.triangle_count) == BVH_OK,
          "build");
    CHECK(check_structure(&m, &tree) == 0, "structure");
    check_counts(compare_with_brute_force(&m, &tree, 2000, 1.0), "sphere");

    /* The centre is almost equally far from every triangle. */
    double centre[3] = {0, 0, 0};
    bvh_hit expect = no_hit(), got = no_hit();
    brute_closest(&m, centre, NULL, NULL, &expect);
    CHECK(bvh_closest(&tree, centre, INFINITY, &got) && got.triangle == expect.triangle &&
              got.distance2 == expect.distance2,
          "sphere centre: bvh %u, brute force %u", got.triangle, expect.triangle);
    bvh_free(&tree);
    mesh_free(&m);
}

static void test_grid_ties_go_to_lowest_index(void)
{
    mesh m = make_grid(40);
    bvh tree;
    CHECK(bvh_build(&tree, m.positions, m.vertex_count, m.indices, m.triangle_count) == BVH_OK,
          "build");
    int mismatches = 0, ties = 0;
    for (int i = 0; i < 2000; i++) {
        /* Above a grid vertex or on a grid line: several triangles tie. */
        double p[3] = {(double)rng_below(41), (double)rng_below(41), rng_uniform(0.0, 3.0)};
        if (i % 3 == 1) p[0] += 0.5;
        if (i % 3 == 2) p[0] = p[1] = rng_below(40) + 0.25;   /* on a diagonal */
        if (i % 7 == 0) p[2] = 0.0;
        if (i % 11 == 0) p[0] = -2.0;                         /* off the side */
        bvh_hit expect = no_hit(), got = no_hit();
        brute_closest(&m, p, NULL, NULL, &expect);
        if (!bvh_closest(&tree, p, INFINITY, &got) || got.triangle != expect.triangle ||
            got.distance2 != expect.distance2)
            mismatches++;
        /* Count how often the answer really was a tie. */
        int equal = 0;
        for (uint32_t t = 0; t < m.triangle_count; t++)
            if (brute_triangle_distance2(&m, t, p, NULL) == expect.distance2) equal++;
        if (equal > 1) ties++;
    }
    CHECK(mismatches == 0, "%d grid answers differ (tie rule)", mismatches);
    CHECK(ties > 1500, "only %d of 2000 grid queries were ties: the test lost its point", ties);
    bvh_free(&tree);
    mesh_free(&m);
}

typedef struct {
    const uint8_t *material;
    uint8_t wanted;
    int calls;
} material_filter;

static int keep_material(void *context, uint32_t triangle)
{
    material_filter *f = context;
    f->calls++;
    return f->material[triangle] == f->wanted;
}

static void test_filtered_queries_match_brute_force(void)
{
    mesh m = make_soup(5000, 0.0);
    uint8_t *material = malloc(m.triangle_count);
    for (size_t t = 0; t < m.triangle_count; t++)
        material[t] = (uint8_t)(t < 2500 ? (t * 7) % 3 : 3);   /* 0-2 mixed, 3 in a block */
    bvh tree;
    CHECK(bvh_build(&tree, m.positions, m.vertex_count, m.indices, m.triangle_count) == BVH_OK,
          "build");
    int closest_mismatch = 0, any_mismatch = 0, bad_witness = 0;
    material_filter filter = {material, 0, 0};
    for (int i = 0; i < 2000; i++) {
        double p[3];
        random_query(&m, 1.0, p);
        filter.wanted = (uint8_t)(i % 4);
        bvh_hit expect = no_hit(), got = no_hit();
        int expect_found = brute_closest(&m, p, keep_material, &filter, &expect);
        int found = bvh_closest_filtered(&tree, p, INFINITY, keep_material, &filter, &got);
        if (found != expect_found || got.triangle != expect.triangle ||
            got.distance2 != expect.distance2)
            closest_mismatch++;

        double r = sqrt(expect.distance2) * rng_uniform(0.9, 1.1);
        uint32_t witness = UINT32_MAX;
        int any = bvh_any_within_filtered(&tree, p, r, keep_material, &filter, &witness);
        if (any != brute_any_within(&m, p, r, keep_material, &filter)) any_mismatch++;
        if (any && (witness >= m.triangle_count || material[witness] != filter.wanted ||
                    !(brute_triangle_distance2(&m, witness, p, NULL) <= r * r)))
            bad_witness++;
    }
    CHECK(closest_mismatch == 0, "%d filtered closest answers differ", closest_mismatch);
    CHECK(any_mismatch == 0, "%d filtered any_within answers differ", any_mismatch);
    CHECK(bad_witness == 0, "%d witnesses fail the filter or the radius", bad_witness);

    /* A filter that accepts nothing finds nothing. */
    filter.wanted = 9;
    double p[3] = {0, 0, 0};
    bvh_hit hit = no_hit();
    CHECK(bvh_closest_filtered(&tree, p, INFINITY, keep_material, &filter, &hit) == 0,
          "empty filter finds something");
    CHECK(bvh_any_within_filtered(&tree, p, INFINITY, keep_material, &filter, NULL) == 0,
          "empty filter within");
    bvh_free(&tree);
    free(material);
    mesh_free(&m);
}

/* bvh_visit_near against brute force: every triangle within r is visited,
 * each once, none whose vertex box is beyond r, in the same order on a
 * second call; nothing for a negative or NaN radius or a non-finite point. */
typedef struct {
    uint32_t *seen;   /* per triangle: times visited */
    uint32_t *order;  /* the visits, in order */
    uint32_t count, cap;
} visit_log;

static void log_visit(void *context, uint32_t triangle)
{
    visit_log *v = context;
    v->seen[triangle]++;
    if (v->count < v->cap) v->order[v->count] = triangle;
    v->count++;
}

static double brute_box_distance2(const mesh *m, uint32_t t, const double p[3])
{
    double d2 = 0.0;
    for (int axis = 0; axis < 3; axis++) {
        double lo = INFINITY, hi = -INFINITY;
        for (int k = 0; k < 3; k++) {
            const double x = m->positions[3 * (size_t)m->indices[3 * (size_t)t + (uint32_t)k] + (uint32_t)axis];
            lo = fmin(lo, x);
            hi = fmax(hi, x);
        }
        const double gap = p[axis] < lo ? lo - p[axis] : p[axis] > hi ? p[axis] - hi : 0.0;
        d2 += gap * gap;
    }
    return d2;
}

static void visit_near_case(const mesh *m, const char *what, int queries)
{
    bvh tree;
    CHECK(bvh_build(&tree, m->positions, m->vertex_count, m->indices, m->triangle_count) == BVH_OK, "build %s", what);
    const uint32_t n = (uint32_t)m->triangle_count;
    visit_log a = {calloc(n, sizeof(uint32_t)), calloc(n, sizeof(uint32_t)), 0, n};
    visit_log b = {calloc(n, sizeof(uint32_t)), calloc(n, sizeof(uint32_t)), 0, n};
    int missed = 0, twice = 0, beyond = 0, reordered = 0;
    long visited = 0, within = 0;
    for (int i = 0; i < queries; i++) {
        double p[3];
        random_query(m, 1.0, p);
        bvh_hit hit = no_hit();
        brute_closest(m, p, NULL, NULL, &hit);
        const double r = i % 7 == 0 ? 0.0 : sqrt(hit.distance2) * rng_uniform(0.5, 3.0) + rng_uniform(0.0, 0.05);
        memset(a.seen, 0, n * sizeof(uint32_t));
        memset(b.seen, 0, n * sizeof(uint32_t));
        a.count = b.count = 0;
        bvh_visit_near(&tree, p, r, log_visit, &a);
        bvh_visit_near(&tree, p, r, log_visit, &b);
        reordered += a.count != b.count || memcmp(a.order, b.order, a.count * sizeof(uint32_t)) != 0;
        for (uint32_t t = 0; t < n; t++) {
            const int in = brute_triangle_distance2(m, t, p, NULL) <= r * r;
            within += in;
            visited += a.seen[t] > 0;
            missed += in && a.seen[t] == 0;
            twice += a.seen[t] > 1;
            beyond += a.seen[t] > 0 && !(brute_box_distance2(m, t, p) <= r * r * (1.0 + 1e-12));
        }
    }
    CHECK(missed == 0, "%s: %d triangles within r not visited", what, missed);
    CHECK(twice == 0, "%s: %d triangles visited more than once", what, twice);
    CHECK(beyond == 0, "%s: %d visited triangles have their box beyond r", what, beyond);
    CHECK(reordered == 0, "%s: %d queries visited in another order the second time", what, reordered);
    CHECK(within > queries, "%s: not vacuous (%ld triangles within r over %d queries)", what, within, queries);
    printf("#   visit_near %s: %ld visits, %ld within r\n", what, visited, within);

    double p[3] = {0.1, 0.2, 0.3};
    a.count = 0;
    bvh_visit_near(&tree, p, -1.0, log_visit, &a);
    bvh_visit_near(&tree, p, NAN, log_visit, &a);
    p[0] = INFINITY;
    bvh_visit_near(&tree, p, 1.0, log_visit, &a);
    p[0] = NAN;
    bvh_visit_near(&tree, p, 1.0, log_visit, &a);
    CHECK(a.count == 0, "%s: %u visits for a negative or NaN radius or a non-finite point", what, a.count);
    free(a.seen);
    free(a.order);
    free(b.seen);
    free(b.order);
    bvh_free(&tree);
}

static void test_visit_near_matches_brute_force(void)
{
    mesh soup = make_soup(3000, 0.0);
    visit_near_case(&soup, "soup", 600);
    mesh_free(&soup);
    mesh sphere = make_sphere(30, 40);
    visit_near_case(&sphere, "sphere", 600);
    mesh_free(&sphere);
    mesh grid = make_grid(40);
    visit_near_case(&grid, "grid", 300);
    mesh_free(&grid);
}

static void test_translated_model_same_results(void)
{
    /* The same soup on a 1/64 grid, once at the origin and once moved by
     * 1e5 (exact in float: the float ulp at 1e5 is 1/128). */
    mesh m = make_soup(5000, 1.0 / 64.0);
    mesh moved = mesh_alloc(m.vertex_count, m.triangle_count);
    const double shift[3] = {1e5, -1e5, 1e5};
    for (size_t v = 0; v < m.vertex_count; v++)
        for (int axis = 0; axis < 3; axis++) {
            moved.positions[3 * v + axis] = (float)(m.positions[3 * v + axis] + shift[axis]);
            if ((double)moved.positions[3 * v + axis] - shift[axis] != m.positions[3 * v + axis])
                CHECK(0, "shift not exact at vertex %zu", v);
        }
    memcpy(moved.indices, m.indices, 3 * m.triangle_count * sizeof(uint32_t));

    bvh tree, moved_tree;
    CHECK(bvh_build(&tree, m.positions, m.vertex_count, m.indices, m.triangle_count) == BVH_OK &&
              bvh_build(&moved_tree, moved.positions, moved.vertex_count, moved.indices,
                        moved.triangle_count) == BVH_OK,
          "build");
    check_counts(compare_with_brute_force(&moved, &moved_tree, 1000, 1e5), "moved soup");

    int distance_differs = 0, triangle_differs = 0;
    for (int i = 0; i < 2000; i++) {
        double p[3], moved_p[3];
        random_query(&m, 1.0, p);
        for (int axis = 0; axis < 3; axis++) {
            p[axis] = snap(p[axis], 1.0 / 1024.0);   /* exact after the shift too */
            moved_p[axis] = p[axis] + shift[axis];
        }
        bvh_hit hit = no_hit(), moved_hit = no_hit();
        bvh_closest(&tree, p, INFINITY, &hit);
        bvh_closest(&moved_tree, moved_p, INFINITY, &moved_hit);
        double d = sqrt(hit.distance2), moved_d = sqrt(moved_hit.distance2);
        /* Rounding at 1e5 costs ~1e-11 absolute. */
        if (!(fabs(d - moved_d) <= 1e-9)) distance_differs++;
        /* A different triangle is fine only for a (near) tie. */
        if (moved_hit.triangle != hit.triangle) {
            double other = sqrt(brute_triangle_distance2(&m, moved_hit.triangle, p, NULL));
            if (!(fabs(other - d) <= 1e-9)) triangle_differs++;
        }
    }
    CHECK(distance_differs == 0, "%d translated distances differ", distance_differs);
    CHECK(triangle_differs == 0, "%d translated answers pick a farther triangle", triangle_differs);
    bvh_free(&tree);
    bvh_free(&moved_tree);
    mesh_free(&m);
    mesh_free(&moved);
}

static void test_identical_triangles(void)
{
    /* 3,000 copies of one triangle: every split is a median of equal keys
     * and every query is a 3,000-way tie. */
    float positions[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    uint32_t *indices = malloc(3 * 3000 * sizeof(uint32_t));
    for (int t = 0; t < 3000; t++) {
        indices[3 * t] = 0;
        indices[3 * t + 1] = 1;
        indices[3 * t + 2] = 2;
    }
    bvh tree;
    CHECK(bvh_build(&tree, positions, 3, indices, 3000) == BVH_OK, "build");
    mesh m = {positions, indices, 3, 3000};
    CHECK(check_structure(&m, &tree) == 0, "structure");
    double p[3] = {0.2, 0.2, 1.0};
    bvh_hit hit = no_hit();
    CHECK(bvh_closest(&tree, p, INFINITY, &hit) && hit.triangle == 0 && hit.distance2 == 1.0,
          "tie goes to triangle 0, got %u", hit.triangle);
    bvh_free(&tree);
    free(indices);
}

static void test_depth_cap_on_exponential_spread(void)
{
    /* Four triangles at each x = 1e-38 * 1.5^k, up to ~1e38: every binned
     * split peels off only the top few, so without the cap the tree would be
     * ~430 levels deep. Also exercises coordinates across the float range. */
    size_t n = 4 * 431;
    mesh m = mesh_alloc(3 * n, n);
    for (size_t t = 0; t < n; t++) {
        double x = 1e-38 * pow(1.5, (double)(t / 4));
        float *v = m.positions + 9 * t;
        float y = (float)(t % 4);
        v[0] = (float)x; v[1] = y; v[2] = 0;
        v[3] = (float)x; v[4] = y + 1; v[5] = 0;
        v[6] = (float)x; v[7] = y; v[8] = 1;
        for (int corner = 0; corner < 3; corner++)
            m.indices[3 * t + corner] = (uint32_t)(3 * t + corner);
    }
    bvh tree;
    CHECK(bvh_build(&tree, m.positions, m.vertex_count, m.indices, m.triangle_count) == BVH_OK,
          "build");
    CHECK(tree.depth <= BVH_MAX_DEPTH && tree.depth >= BVH_MAX_DEPTH - 8,
          "depth %u: the cap was not what limited it", tree.depth);
    CHECK(check_structure(&m, &tree) == 0, "structure");
    int mismatches = 0;
    for (int i = 0; i < 1000; i++) {
        double p[3] = {pow(10.0, rng_uniform(-39, 39)), rng_uniform(-1, 5), rng_uniform(-1, 2)};
        if (i % 2) p[0] = -p[0];
        bvh_hit expect = no_hit(), got = no_hit();
        brute_closest(&m, p, NULL, NULL, &expect);
        if (!bvh_closest(&tree, p, INFINITY, &got) || got.triangle != expect.triangle ||
            got.distance2 != expect.distance2)
            mismatches++;
        double r = sqrt(expect.distance2) * rng_uniform(0.5, 1.5);
        if (bvh_any_within(&tree, p, r) != brute_any_within(&m, p, r, NULL, NULL)) mismatches++;
    }
    CHECK(mismatches == 0, "%d answers differ on the exponential spread", mismatches);
    bvh_free(&tree);
    mesh_free(&m);
}

static void test_tiny_trees(void)
{
    float positions[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 5, 5, 5};
    uint32_t indices[6] = {0, 1, 2, 1, 2, 3};
    bvh tree;
    double p[3] = {0.1, 0.1, 2.0};
    bvh_hit hit = no_hit();

    CHECK(bvh_build(&tree, positions, 4, indices, 1) == BVH_OK, "one triangle");
    CHECK(tree.node_count == 1 && tree.nodes[0].count == 1, "one leaf");
    CHECK(bvh_closest(&tree, p, INFINITY, &hit) && hit.triangle == 0 && hit.distance2 == 4.0,
          "one triangle closest");
    CHECK(bvh_closest(&tree, p, 1.9, &hit) == 0, "max_dist excludes");
    CHECK(bvh_closest(&tree, p, 2.0, &hit) == 1, "max_dist is inclusive");
    CHECK(bvh_any_within(&tree, p, 2.0) == 1 && bvh_any_within(&tree, p, 1.999) == 0, "within");
    CHECK(bvh_closest(&tree, p, -1.0, &hit) == 0 && bvh_closest(&tree, p, NAN, &hit) == 0,
          "negative / NaN max_dist");
    CHECK(bvh_any_within(&tree, p, -1.0) == 0 && bvh_any_within(&tree, p, NAN) == 0,
          "negative / NaN radius");
    double bad_p[3] = {NAN, 0, 0}, inf_p[3] = {INFINITY, 0, 0};
    CHECK(bvh_closest(&tree, bad_p, INFINITY, &hit) == 0 &&
              bvh_any_within(&tree, inf_p, INFINITY) == 0,
          "non-finite query point");
    CHECK(bvh_closest(&tree, p, INFINITY, NULL) == 1, "NULL hit is allowed");
    bvh_free(&tree);

    CHECK(bvh_build(&tree, positions, 4, indices, 2) == BVH_OK, "two triangles");
    /* Above, the slope of triangle 1 comes closer; below, triangle 0 wins. */
    double under[3] = {0.1, 0.1, -2.0};
    CHECK(bvh_closest(&tree, p, INFINITY, &hit) && hit.triangle == 1, "two: above");
    CHECK(bvh_closest(&tree, under, INFINITY, &hit) && hit.triangle == 0 && hit.distance2 == 4.0,
          "two: below");
    bvh_free(&tree);
    bvh_free(&tree);   /* twice is safe */

    CHECK(bvh_build(&tree, positions, 4, indices, 0) == BVH_OK, "empty");
    CHECK(bvh_closest(&tree, p, INFINITY, &hit) == 0 && bvh_any_within(&tree, p, INFINITY) == 0,
          "empty tree finds nothing");
    CHECK(bvh_memory_bytes(&tree) == 0, "empty tree owns nothing");
    bvh_free(&tree);
}

static void test_build_rejects_bad_input(void)
{
    float positions[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0};
    uint32_t indices[6] = {0, 1, 2, 0, 2, 3};
    bvh tree;

    uint32_t out_of_range[3] = {0, 1, 4};
    CHECK(bvh_build(&tree, positions, 4, out_of_range, 1) == BVH_ERROR_INDEX_OUT_OF_RANGE,
          "index 4 of 4 vertices");
    CHECK(tree.nodes == NULL && tree.triangle_count == 0, "failed tree is empty");
    bvh_free(&tree);

    positions[10] = NAN;
    CHECK(bvh_build(&tree, positions, 4, indices, 2) == BVH_ERROR_NONFINITE_POSITION, "NaN");
    bvh_free(&tree);
    positions[10] = INFINITY;
    CHECK(bvh_build(&tree, positions, 4, indices, 2) == BVH_ERROR_NONFINITE_POSITION, "inf");
    bvh_free(&tree);
    /* A non-finite vertex no triangle uses is harmless. */
    CHECK(bvh_build(&tree, positions, 4, indices, 1) == BVH_OK, "unused NaN vertex");
    bvh_free(&tree);

    CHECK(bvh_build(&tree, positions, 4, NULL, 1) == BVH_ERROR_INVALID_ARGUMENT, "NULL indices");
    CHECK(bvh_build(&tree, positions, 4, indices, BVH_MAX_TRIANGLES + 1) ==
              BVH_ERROR_TOO_MANY_TRIANGLES,
          "too many");
    CHECK(strcmp(bvh_result_string(BVH_ERROR_NONFINITE_POSITION),
                 "vertex position is NaN or infinite") == 0,
          "result string");
}

static void test_build_is_deterministic(void)
{
    mesh m = make_soup(5000, 0.0);
    bvh first, second;
    bvh_build(&first, m.positions, m.vertex_count, m.indices, m.triangle_count);
    bvh_build(&second, m.positions, m.vertex_count, m.indices, m.triangle_count);
    CHECK(first.node_count == second.node_count &&
              memcmp(first.nodes, second.nodes, first.node_count * sizeof(bvh_node)) == 0 &&
              memcmp(first.triangle_order, second.triangle_order,
                     first.triangle_count * sizeof(uint32_t)) == 0,
          "two builds differ");
    CHECK(sizeof(bvh_node) == 32, "node is %zu bytes", sizeof(bvh_node));
    CHECK(bvh_memory_bytes(&first) < 32 * m.triangle_count, "%zu bytes for %zu triangles",
          bvh_memory_bytes(&first), m.triangle_count);
    bvh_free(&first);
    bvh_free(&second);
    mesh_free(&m);
}

/* Two threads build the root's subtrees at once: the tree must be the
 * one-thread tree node for node (a soup, a sphere whose root split is
 * uneven, and a grid of exact ties), and a tree too small for a thread too. */
static void test_threaded_build_is_the_same_tree(void)
{
    mesh meshes[4] = {make_soup(20000, 0.0), make_sphere(90, 120), make_grid(80), make_soup(3000, 0.0)};
    for (int i = 0; i < 4; i++) {
        const mesh *m = &meshes[i];
        bvh one, two;
        CHECK(bvh_build(&one, m->positions, m->vertex_count, m->indices, m->triangle_count) == BVH_OK &&
                  bvh_build_threads(&two, m->positions, m->vertex_count, m->indices, m->triangle_count, 2) ==
                      BVH_OK,
              "mesh %d: build", i);
        CHECK(one.node_count == two.node_count && one.depth == two.depth &&
                  memcmp(one.nodes, two.nodes, one.node_count * sizeof(bvh_node)) == 0 &&
                  memcmp(one.triangle_order, two.triangle_order, one.triangle_count * sizeof(uint32_t)) == 0,
              "mesh %d (%zu triangles): the two-thread tree differs (%u / %u nodes)", i, m->triangle_count,
              one.node_count, two.node_count);
        bvh_free(&one);
        bvh_free(&two);
        mesh_free(&meshes[i]);
    }
}

int main(void)
{
    RUN(test_random_soup_matches_brute_force);
    RUN(test_sphere_matches_brute_force);
    RUN(test_grid_ties_go_to_lowest_index);
    RUN(test_filtered_queries_match_brute_force);
    RUN(test_visit_near_matches_brute_force);
    RUN(test_translated_model_same_results);
    RUN(test_identical_triangles);
    RUN(test_depth_cap_on_exponential_spread);
    RUN(test_tiny_trees);
    RUN(test_build_rejects_bad_input);
    RUN(test_build_is_deterministic);
    RUN(test_threaded_build_is_the_same_tree);
    return check_summary();
}
