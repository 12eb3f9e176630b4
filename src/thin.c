/* thin.c - the thin-region map; see thin.h. */
#include "thin.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geom.h"

#define THIN_MAX_CUBES_PER_TRIANGLE 64
/* |sum of area-weighted normals| / area below which a neighbourhood holds
 * surface facing away from its mean: two opposite sheets give ~0, a tube
 * narrower than the cube ~0, one noisy sheet stays close to 1 */
#define THIN_MIN_COHERENCE 0.5

/* CUBE_NEAR_THIN: the cube or one of its 26 neighbours is thin (such a cube
 * may hold no triangle: it is then only this flag) */
enum { CUBE_MIXED = 1, CUBE_SPECIAL = 2, CUBE_THIN = 4, CUBE_NEAR_THIN = 8 };

struct thin_cube {
    int64_t key[3];
    double sum[3];    /* sum of area-weighted normals of the triangles touching it */
    double area;      /* their area */
    int32_t material; /* of the first triangle seen; CUBE_MIXED when another differs */
    uint32_t component;
    uint8_t flags;
};

static uint32_t hash_key(const int64_t k[3])
{
    uint64_t h = (uint64_t)k[0] * 0x9E3779B97F4A7C15ULL ^ (uint64_t)k[1] * 0xC2B2AE3D27D4EB4FULL ^
                 (uint64_t)k[2] * 0x165667B19E3779F9ULL;
    h ^= h >> 29;
    return (uint32_t)(h ^ (h >> 32));
}

static uint32_t find(const thin_map *m, const int64_t k[3])
{
    for (uint32_t i = hash_key(k) & m->mask;; i = (i + 1) & m->mask) {
        uint32_t c = m->slot[i];
        if (c == UINT32_MAX) return UINT32_MAX;
        if (!memcmp(m->cubes[c].key, k, sizeof m->cubes[c].key)) return c;
    }
}

static int rehash(thin_map *m, uint32_t capacity)
{
    uint32_t *slot = malloc((size_t)capacity * sizeof *slot);
    if (!slot) return -1;
    memset(slot, 0xff, (size_t)capacity * sizeof *slot);
    free(m->slot);
    m->slot = slot;
    m->mask = capacity - 1;
    for (uint32_t c = 0; c < m->count; ++c) {
        uint32_t i = hash_key(m->cubes[c].key) & m->mask;
        while (m->slot[i] != UINT32_MAX) i = (i + 1) & m->mask;
        m->slot[i] = c;
    }
    return 0;
}

/* The cube with key k, added (empty) when absent; UINT32_MAX when out of memory. */
static uint32_t find_or_add(thin_map *m, const int64_t k[3], int32_t material, uint32_t component)
{
    uint32_t c = find(m, k);
    if (c != UINT32_MAX) return c;
    if (m->count == m->capacity) {
        uint32_t cap = m->capacity ? 2 * m->capacity : 1024;
        thin_cube *grown = realloc(m->cubes, (size_t)cap * sizeof *grown);
        if (!grown) return UINT32_MAX;
        m->cubes = grown;
        m->capacity = cap;
    }
    if (2 * ((size_t)m->count + 1) > (size_t)m->mask + 1 && rehash(m, 2 * (m->mask + 1))) return UINT32_MAX;
    c = m->count++;
    thin_cube *q = &m->cubes[c];
    memset(q, 0, sizeof *q);
    memcpy(q->key, k, sizeof q->key);
    q->material = material;
    q->component = component;
    uint32_t i = hash_key(k) & m->mask;
    while (m->slot[i] != UINT32_MAX) i = (i + 1) & m->mask;
    m->slot[i] = c;
    return c;
}

static uint32_t root(uint32_t *parent, uint32_t v)
{
    while (parent[v] != v) {
        parent[v] = parent[parent[v]];
        v = parent[v];
    }
    return v;
}

/* The cube range of triangle t's box, or 0 when it spans too many cubes or
 * is not finite. */
static int cube_range(const thin_map *m, const vec3d p[3], int64_t lo[3], int64_t hi[3])
{
    const double c[3][3] = {{p[0].x, p[0].y, p[0].z}, {p[1].x, p[1].y, p[1].z}, {p[2].x, p[2].y, p[2].z}};
    double cubes = 1.0;
    for (int a = 0; a < 3; ++a) {
        double l = geom_floor(geom_fmin(c[0][a], geom_fmin(c[1][a], c[2][a])) * m->inv_cell);
        double h = geom_floor(geom_fmax(c[0][a], geom_fmax(c[1][a], c[2][a])) * m->inv_cell);
        if (!(l >= -4e15 && h <= 4e15)) return 0;
        lo[a] = (int64_t)l;
        hi[a] = (int64_t)h;
        cubes *= h - l + 1.0;
    }
    return cubes <= THIN_MAX_CUBES_PER_TRIANGLE;
}

static void triangle_points(const float *positions, const uint32_t *triangles, uint32_t t, vec3d p[3])
{
    for (int k = 0; k < 3; ++k) p[k] = geom_vec3d_from_floats(positions + 3 * (size_t)triangles[3 * (size_t)t + k]);
}

int thin_map_build(thin_map *m, double radius, const float *positions, uint32_t vertex_count,
                   const uint32_t *triangles, uint32_t triangle_count, const int32_t *material,
                   const uint8_t *special)
{
    memset(m, 0, sizeof *m);
    m->inv_cell = 1.0 / radius;
    if (!(radius > 0.0) || !isfinite(m->inv_cell)) {
        m->all_thin = 1;
        return 0;
    }
    uint32_t *parent = malloc(((size_t)vertex_count + 1) * sizeof *parent);
    if (!parent || rehash(m, 1024)) goto oom;
    for (uint32_t v = 0; v < vertex_count; ++v) parent[v] = v;
    for (uint32_t t = 0; t < triangle_count; ++t) {
        const uint32_t *tv = triangles + 3 * (size_t)t;
        uint32_t a = root(parent, tv[0]);
        for (int k = 1; k < 3; ++k) {
            uint32_t b = root(parent, tv[k]);
            if (a != b) parent[b] = a;
        }
    }
    /* pass 1: cubes, normal sums, mixing. Neighbouring triangles mostly
     * come one after another and lie in the same cube: the last cube found
     * is tried before the hash. */
    int64_t last_key[3] = {0, 0, 0};
    uint32_t last = UINT32_MAX;
    for (uint32_t t = 0; t < triangle_count && !m->all_thin; ++t) {
        const uint32_t *tv = triangles + 3 * (size_t)t;
        vec3d p[3], n;
        triangle_points(positions, triangles, t, p);
        int64_t lo[3], hi[3];
        if (!cube_range(m, p, lo, hi)) {
            m->all_thin = 1;
            break;
        }
        n = geom_triangle_normal(&p[0], &p[1], &p[2]); /* twice the area, along the normal */
        const double twice_area = geom_length(n);
        const int real = isfinite(twice_area);
        const int odd = special && (special[tv[0]] || special[tv[1]] || special[tv[2]]);
        const uint32_t component = root(parent, tv[0]);
        int64_t k[3];
        for (k[0] = lo[0]; k[0] <= hi[0]; ++k[0])
            for (k[1] = lo[1]; k[1] <= hi[1]; ++k[1])
                for (k[2] = lo[2]; k[2] <= hi[2]; ++k[2]) {
                    uint32_t c = last;
                    if (c == UINT32_MAX || k[0] != last_key[0] || k[1] != last_key[1] || k[2] != last_key[2]) {
                        c = find_or_add(m, k, material[t], component);
                        if (c == UINT32_MAX) goto oom;
                        memcpy(last_key, k, sizeof last_key);
                        last = c;
                    }
                    thin_cube *q = &m->cubes[c];
                    if (q->material != material[t] || q->component != component) q->flags |= CUBE_MIXED;
                    if (odd) q->flags |= CUBE_SPECIAL;
                    if (real) {
                        q->sum[0] += n.x;
                        q->sum[1] += n.y;
                        q->sum[2] += n.z;
                        q->area += twice_area;
                    } else {
                        q->flags |= CUBE_SPECIAL;
                    }
                }
    }
    free(parent);
    parent = NULL;
    if (m->all_thin) return 0;
    /* a cube is thin unless its neighbourhood is one coherent sheet of one
     * component and one material with nothing special */
    for (uint32_t c = 0; c < m->count; ++c) {
        thin_cube *q = &m->cubes[c];
        int64_t k[3];
        double d[3] = {0, 0, 0}, area = 0.0;
        int thin = 0;
        for (int dx = -1; dx <= 1; ++dx)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dz = -1; dz <= 1; ++dz) {
                    k[0] = q->key[0] + dx;
                    k[1] = q->key[1] + dy;
                    k[2] = q->key[2] + dz;
                    uint32_t o = find(m, k);
                    if (o == UINT32_MAX) continue;
                    const thin_cube *r = &m->cubes[o];
                    area += r->area;
                    thin |= (r->flags & (CUBE_MIXED | CUBE_SPECIAL)) || r->material != q->material ||
                            r->component != q->component;
                    for (int a = 0; a < 3; ++a) d[a] += r->sum[a];
                }
        double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        thin |= !(len >= THIN_MIN_COHERENCE * area && area > 0.0);
        if (thin) q->flags |= CUBE_THIN;
    }
    /* the thin cubes grown by one cube: a query then looks up the cubes its
     * box overlaps instead of that box grown by one (27 for a small box) */
    const uint32_t occupied = m->count;
    for (uint32_t c = 0; c < occupied; ++c) {
        if (!(m->cubes[c].flags & CUBE_THIN)) continue;
        int64_t key[3], k[3];
        memcpy(key, m->cubes[c].key, sizeof key); /* find_or_add may move the cubes */
        for (int dx = -1; dx <= 1; ++dx)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dz = -1; dz <= 1; ++dz) {
                    k[0] = key[0] + dx;
                    k[1] = key[1] + dy;
                    k[2] = key[2] + dz;
                    uint32_t o = find_or_add(m, k, 0, 0);
                    if (o == UINT32_MAX) goto oom;
                    m->cubes[o].flags |= CUBE_NEAR_THIN;
                }
    }
    return 0;
oom:
    free(parent);
    thin_map_free(m);
    return -1;
}

void thin_map_free(thin_map *m)
{
    free(m->slot);
    free(m->cubes);
    memset(m, 0, sizeof *m);
}

int thin_map_box(const thin_map *m, const double lo[3], const double hi[3])
{
    if (m->all_thin) return 1;
    int64_t a[3], b[3];
    double cubes = 1.0;
    for (int k = 0; k < 3; ++k) {
        double l = geom_floor(lo[k] * m->inv_cell) - 1.0, h = geom_floor(hi[k] * m->inv_cell) + 1.0;
        if (!(l >= -4e15 && h <= 4e15 && l <= h)) return 1;
        a[k] = (int64_t)l;
        b[k] = (int64_t)h;
        cubes *= h - l + 1.0;
    }
    if (cubes > THIN_MAX_QUERY_CUBES) return 1;
    /* a thin cube in the grown range is one next to a cube of the box's own
     * range [a + 1, b - 1]: one that is near thin */
    int64_t k[3];
    for (k[0] = a[0] + 1; k[0] < b[0]; ++k[0])
        for (k[1] = a[1] + 1; k[1] < b[1]; ++k[1])
            for (k[2] = a[2] + 1; k[2] < b[2]; ++k[2]) {
                uint32_t c = find(m, k);
                if (c != UINT32_MAX && (m->cubes[c].flags & CUBE_NEAR_THIN)) return 1;
            }
    return 0;
}
