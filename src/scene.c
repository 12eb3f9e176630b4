/* scene.c - see scene.h. */
#include "scene.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accessor.h"
#include "jsonr.h"
#include "radix.h"

static void warn(scene *s, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void warn(scene *s, const char *fmt, ...)
{
    if (s->warning_count == s->warning_capacity && s->warning_capacity < SCENE_MAX_WARNINGS_KEPT) {
        const uint32_t capacity = s->warning_capacity ? 2 * s->warning_capacity : 16;
        char(*grown)[256] = realloc(s->warnings, capacity * sizeof *grown);
        if (grown) s->warnings = grown, s->warning_capacity = capacity;
    }
    if (s->warning_count < s->warning_capacity) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(s->warnings[s->warning_count], sizeof s->warnings[0], fmt, ap);
        va_end(ap);
    }
    s->warning_count++;
}

/* ---- transforms ------------------------------------------------------------ */

static void mat_mul(const double a[16], const double b[16], double out[16])
{
    double r[16];
    for (int c = 0; c < 4; ++c)
        for (int row = 0; row < 4; ++row) {
            double sum = 0.0;
            for (int k = 0; k < 4; ++k) sum += a[k * 4 + row] * b[c * 4 + k];
            r[c * 4 + row] = sum;
        }
    memcpy(out, r, sizeof r);
}

/* Local transform of a node: its matrix, or T * R * S. */
static void local_transform(const gltf_node *n, double out[16])
{
    if (n->has_matrix) {
        memcpy(out, n->matrix, 16 * sizeof(double));
        return;
    }
    const double x = n->rotation[0], y = n->rotation[1], z = n->rotation[2], w = n->rotation[3];
    const double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w),
                         2 * (x * y - z * w), 1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
                         2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y)};
    memset(out, 0, 16 * sizeof(double));
    for (int c = 0; c < 3; ++c)
        for (int row = 0; row < 3; ++row) out[c * 4 + row] = r[c * 3 + row] * n->scale[c];
    out[12] = n->translation[0];
    out[13] = n->translation[1];
    out[14] = n->translation[2];
    out[15] = 1.0;
}

/* The largest singular value of m's 3x3 part: the square root of the largest
 * eigenvalue of A = M^T M (entry (i, j): column i . column j), found by
 * Jacobi rotations, which keep A symmetric and converge in a few sweeps for
 * 3x3. The longest column is a lower bound of it (equal without shear), so
 * the result is never below that. */
double scene_max_scale(const double m[16])
{
    double a[3][3], longest = 0.0;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            a[i][j] = m[i * 4] * m[j * 4] + m[i * 4 + 1] * m[j * 4 + 1] + m[i * 4 + 2] * m[j * 4 + 2];
    for (int i = 0; i < 3; ++i) longest = fmax(longest, sqrt(a[i][i]));
    for (int sweep = 0; sweep < 32; ++sweep) {
        const double off = fabs(a[0][1]) + fabs(a[0][2]) + fabs(a[1][2]);
        if (!(off > 1e-17 * (a[0][0] + a[1][1] + a[2][2]))) break; /* diagonal to rounding (or NaN) */
        for (int p = 0; p < 2; ++p)
            for (int q = p + 1; q < 3; ++q) {
                if (a[p][q] == 0.0) continue;
                const double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                const double t = fabs(theta) > 1e150 ? 0.5 / theta
                                                      : (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
                const double c = 1.0 / sqrt(t * t + 1.0), sn = t * c, apq = a[p][q];
                const int r = 3 - p - q; /* the third index */
                const double arp = a[r][p], arq = a[r][q];
                a[p][p] -= t * apq;
                a[q][q] += t * apq;
                a[p][q] = a[q][p] = 0.0;
                a[r][p] = a[p][r] = c * arp - sn * arq;
                a[r][q] = a[q][r] = sn * arp + c * arq;
            }
    }
    const double top = fmax(a[0][0], fmax(a[1][1], a[2][2]));
    return fmax(longest, top > 0.0 ? sqrt(top) : 0.0);
}

int scene_mesh_stretch(const scene *s, uint32_t node, double *stretch, lp_error *err)
{
    const int64_t skin = s->nodes[node].skin;
    *stretch = scene_max_scale(s->nodes[node].world);
    if (skin < 0) return LP_OK;
    char pointer[64];
    snprintf(pointer, sizeof pointer, "/skins/%lld/joints", (long long)skin);
    char *joints = gltf_get_json(s->doc, pointer);
    snprintf(pointer, sizeof pointer, "/skins/%lld/inverseBindMatrices", (long long)skin);
    char *ibm_index = gltf_get_json(s->doc, pointer);
    float *ibm = NULL;
    uint32_t ibm_count = 0, components = 0;
    /* inverse bind matrices that cannot be read as float MAT4 (invalid, which
     * the loader keeps as it is) count as identities: the input's own error
     * does not stop the run */
    lp_error unread = {0, "", 0};
    if (ibm_index && accessor_read_floats(s->doc, strtoll(ibm_index, NULL, 10), &ibm, &ibm_count, &components, &unread))
        ibm_count = 0;
    free(ibm_index);
    if (components != 16) ibm_count = 0;
    double best = 0.0;
    /* joints: a JSON array of node indices (the loader checked them) */
    jsonr r = {0};
    const int parsed = joints ? jsonr_parse(&r, joints, strlen(joints)) : -1;
    /* for want of memory the stretch would come out smaller, not fail */
    if (parsed == -2 || gltf_out_of_memory(s->doc) || unread.out_of_memory) {
        if (parsed == 0) jsonr_free(&r);
        free(joints);
        free(ibm);
        return lp_no_memory(err, "nodes[%u]: out of memory reading skins[%lld]", node, (long long)skin);
    }
    const uint32_t joint_count = parsed == 0 ? jsonr_size(&r, 0) : 0;
    for (uint32_t k = 0; k < joint_count; ++k) {
        const double j = jsonr_number(&r, jsonr_element(&r, 0, k), -1.0);
        if (!(j >= 0 && j < s->node_count)) continue;
        double bind[16], m[16];
        for (int i = 0; i < 16; ++i) bind[i] = k < ibm_count ? (double)ibm[16 * (size_t)k + i] : (i % 5 == 0);
        mat_mul(s->nodes[(uint32_t)j].world, bind, m);
        for (int i = 0; i < 16; ++i)
            if (!isfinite(m[i])) best = INFINITY; /* a NaN matrix: fmax would skip it */
        best = fmax(best, scene_max_scale(m));
    }
    jsonr_free(&r);
    free(joints);
    free(ibm);
    if (!isfinite(best) || best > FLT_MAX)
        return lp_fail(err, LP_INVALID, "nodes[%u]: a joint of skins[%lld] is NaN or stretches the mesh beyond float range",
                       node, (long long)skin);
    if (joint_count) *stretch = best;
    return LP_OK;
}

/* ---- node graph -------------------------------------------------------------- */

void scene_local_transform(const scene *s, uint32_t n, double out[16])
{
    gltf_node g;
    gltf_get_node(s->doc, n, &g);
    local_transform(&g, out);
}

/* Checks references, gives every node its parent, refuses cycles and absurd
 * depth, and computes world transforms root-down with an explicit stack. */
static int load_nodes(scene *s, lp_error *err)
{
    const size_t n = gltf_count(s->doc, GLTF_NODES);
    const size_t meshes = gltf_count(s->doc, GLTF_MESHES), skins = gltf_count(s->doc, GLTF_SKINS),
                 cameras = gltf_count(s->doc, GLTF_CAMERAS);
    if (n > UINT32_MAX / 2) return lp_fail(err, LP_INVALID, "too many nodes (%zu)", n);
    s->node_count = (uint32_t)n;
    s->nodes = calloc(n ? n : 1, sizeof *s->nodes);
    uint32_t *stack = malloc((n ? n : 1) * sizeof *stack);
    uint32_t *depth = calloc(n ? n : 1, sizeof *depth);
    int rc = LP_OK;
    if (!s->nodes || !stack || !depth) {
        rc = lp_no_memory(err, "out of memory for %zu nodes", n);
        goto done;
    }
    for (size_t i = 0; i < n; ++i) s->nodes[i].parent = -1;
    for (size_t i = 0; i < n; ++i) {
        gltf_node g;
        gltf_get_node(s->doc, i, &g);
        scene_node *node = &s->nodes[i];
        node->name = gltf_name(s->doc, GLTF_NODES, i);
        node->mesh = g.mesh;
        node->skin = g.skin;
        node->lod_count = (uint32_t)g.lod_count;
        node->lod_ids = g.lod_ids;
        if (g.mesh >= 0 && (size_t)g.mesh >= meshes) {
            rc = lp_fail(err, LP_INVALID, "nodes[%zu].mesh %lld does not exist", i, (long long)g.mesh);
            goto done;
        }
        if (g.skin >= 0 && (size_t)g.skin >= skins) {
            rc = lp_fail(err, LP_INVALID, "nodes[%zu].skin %lld does not exist", i, (long long)g.skin);
            goto done;
        }
        if (g.camera >= 0 && (size_t)g.camera >= cameras) {
            rc = lp_fail(err, LP_INVALID, "nodes[%zu].camera %lld does not exist", i, (long long)g.camera);
            goto done;
        }
        for (size_t l = 0; l < g.lod_count; ++l)
            if (g.lod_ids[l] < 0 || (size_t)g.lod_ids[l] >= n) {
                rc = lp_fail(err, LP_INVALID, "nodes[%zu].extensions.MSFT_lod.ids[%zu] is not a node", i, l);
                goto done;
            }
        for (size_t c = 0; c < g.child_count; ++c) {
            int64_t child = g.children[c];
            if ((size_t)child >= n) {
                rc = lp_fail(err, LP_INVALID, "nodes[%zu].children[%zu] = %lld does not exist", i, c, (long long)child);
                goto done;
            }
            if ((size_t)child == i || s->nodes[child].parent >= 0) {
                rc = lp_fail(err, LP_INVALID, "nodes[%lld] has more than one parent (or is its own child)",
                             (long long)child);
                goto done;
            }
            s->nodes[child].parent = (int64_t)i;
        }
    }
    /* Walk down from the roots; a node never reached sits on a cycle. */
    uint32_t top = 0, reached = 0;
    for (size_t i = 0; i < n; ++i)
        if (s->nodes[i].parent < 0) {
            gltf_node g;
            gltf_get_node(s->doc, i, &g);
            local_transform(&g, s->nodes[i].world);
            stack[top++] = (uint32_t)i;
        }
    while (top) {
        uint32_t i = stack[--top];
        reached++;
        gltf_node g;
        gltf_get_node(s->doc, i, &g);
        for (size_t c = 0; c < g.child_count; ++c) {
            uint32_t child = (uint32_t)g.children[c];
            gltf_node gc;
            gltf_get_node(s->doc, child, &gc);
            double local[16];
            local_transform(&gc, local);
            mat_mul(s->nodes[i].world, local, s->nodes[child].world);
            depth[child] = depth[i] + 1;
            if (depth[child] > SCENE_MAX_DEPTH) {
                rc = lp_fail(err, LP_INVALID, "nodes[%u] is nested deeper than %d levels", child, SCENE_MAX_DEPTH);
                goto done;
            }
            stack[top++] = child;
        }
    }
    if (reached != n) {
        for (size_t i = 0; i < n; ++i) depth[i] = 0;
        /* name one node of the cycle: follow parents until a repeat */
        size_t start = 0;
        for (size_t i = 0; i < n; ++i)
            if (s->nodes[i].parent >= 0) start = i;
        size_t v = start;
        for (size_t step = 0; step <= n; ++step) v = (size_t)s->nodes[v].parent;
        rc = lp_fail(err, LP_INVALID, "nodes[%zu] is part of a cycle in the node hierarchy", v);
        goto done;
    }
    /* A mesh placed beyond float's range (scales that multiply past it down a
     * deep hierarchy) has no size on screen that a switching distance could
     * express: refused, rather than written as null distances. */
    for (size_t i = 0; i < n; ++i) {
        if (s->nodes[i].mesh < 0) continue;
        for (int k = 0; k < 16; ++k)
            if (!(fabs(s->nodes[i].world[k]) <= FLT_MAX)) {
                rc = lp_fail(err, LP_INVALID,
                             "nodes[%zu]: its world transform is beyond the float range (its own and its parents' "
                             "transforms multiplied)",
                             i);
                goto done;
            }
    }
done:
    free(stack);
    free(depth);
    return rc;
}

/* Marks the nodes reachable from the default scene (the "scene" property, or
 * scene 0 when the file names none). */
static int mark_scene(scene *s, lp_error *err)
{
    const size_t scenes = gltf_count(s->doc, GLTF_SCENES);
    int64_t chosen = gltf_default_scene(s->doc);
    if (chosen >= 0 && (size_t)chosen >= scenes)
        return lp_fail(err, LP_INVALID, "scene %lld does not exist (the file has %zu scenes)", (long long)chosen, scenes);
    for (size_t i = 0; i < scenes; ++i) {
        gltf_scene sc;
        gltf_get_scene(s->doc, i, &sc);
        for (size_t k = 0; k < sc.node_count; ++k) {
            if ((size_t)sc.nodes[k] >= s->node_count)
                return lp_fail(err, LP_INVALID, "scenes[%zu].nodes[%zu] = %lld does not exist", i, k,
                               (long long)sc.nodes[k]);
            if (s->nodes[sc.nodes[k]].parent >= 0)
                return lp_fail(err, LP_INVALID, "scenes[%zu].nodes[%zu]: nodes[%lld] is not a root node", i, k,
                               (long long)sc.nodes[k]);
        }
    }
    if (chosen < 0 && scenes > 0) chosen = 0;
    s->default_scene = chosen;
    if (chosen < 0) return LP_OK;
    gltf_scene sc;
    gltf_get_scene(s->doc, (size_t)chosen, &sc);
    /* Mark whole subtrees: a node is in the scene if its root is. */
    for (size_t k = 0; k < sc.node_count; ++k) s->nodes[sc.nodes[k]].in_scene = 1;
    int changed = 1;
    while (changed) { /* parents precede nothing in particular, so iterate to a fixed point */
        changed = 0;
        for (uint32_t i = 0; i < s->node_count; ++i) {
            int64_t p = s->nodes[i].parent;
            if (!s->nodes[i].in_scene && p >= 0 && s->nodes[p].in_scene) {
                s->nodes[i].in_scene = 1;
                changed = 1;
            }
        }
    }
    return LP_OK;
}

/* ---- primitives ---------------------------------------------------------------- */

/* Expands TRIANGLES / TRIANGLE_STRIP / TRIANGLE_FAN into a triangle list. */
static int triangulate(scene *s, scene_primitive *p, const uint32_t *idx, uint32_t n, const char *where,
                       lp_error *err)
{
    uint32_t tris = 0;
    if (p->mode == 4) {
        if (n % 3) warn(s, "%s: %u indices is not a multiple of 3; the last %u are ignored", where, n, n % 3);
        tris = n / 3;
    } else if (p->mode == 5 || p->mode == 6) {
        tris = n >= 3 ? n - 2 : 0;
    }
    p->triangle_count = tris;
    p->triangles = malloc((tris ? (size_t)tris : 1) * 3 * sizeof *p->triangles);
    if (!p->triangles) return lp_no_memory(err, "%s: out of memory", where);
    for (uint32_t t = 0; t < tris; ++t) {
        uint32_t *out = p->triangles + 3 * (size_t)t;
        if (p->mode == 4) {
            out[0] = idx[3 * t];
            out[1] = idx[3 * t + 1];
            out[2] = idx[3 * t + 2];
        } else if (p->mode == 5) { /* strip: every other triangle flips to keep the winding */
            out[0] = idx[t + (t & 1)];
            out[1] = idx[t + 1 - (t & 1)];
            out[2] = idx[t + 2];
        } else { /* fan */
            out[0] = idx[0];
            out[1] = idx[t + 1];
            out[2] = idx[t + 2];
        }
    }
    return LP_OK;
}

static int load_primitive(scene *s, size_t mesh, size_t prim, scene_primitive *p, lp_error *err)
{
    char where[64];
    snprintf(where, sizeof where, "meshes[%zu].primitives[%zu]", mesh, prim);
    gltf_primitive g;
    gltf_get_primitive(s->doc, mesh, prim, &g);
    const size_t accessors = gltf_count(s->doc, GLTF_ACCESSORS);
    p->index = (uint32_t)prim;
    p->mode = g.mode;
    p->material = g.material;
    p->indices = g.indices;
    p->target_count = (uint32_t)g.target_count;
    if (g.mode < 0 || g.mode > 6) return lp_fail(err, LP_INVALID, "%s.mode %d is not 0..6", where, g.mode);
    if (g.material >= 0 && (size_t)g.material >= gltf_count(s->doc, GLTF_MATERIALS))
        return lp_fail(err, LP_INVALID, "%s.material %lld does not exist", where, (long long)g.material);
    if (g.indices >= 0 && (size_t)g.indices >= accessors)
        return lp_fail(err, LP_INVALID, "%s.indices %lld does not exist", where, (long long)g.indices);
    int position = -1;
    for (size_t a = 0; a < g.attribute_count; ++a) {
        if ((size_t)g.attributes[a].accessor >= accessors)
            return lp_fail(err, LP_INVALID, "%s.attributes.%s = %lld does not exist", where, g.attributes[a].name,
                           (long long)g.attributes[a].accessor);
        if (strcmp(g.attributes[a].name, "POSITION") == 0) position = (int)a;
    }
    for (size_t t = 0; t < g.target_count; ++t)
        for (size_t a = 0; a < g.target_attribute_counts[t]; ++a)
            if ((size_t)g.target_attributes[t][a].accessor >= accessors)
                return lp_fail(err, LP_INVALID, "%s.targets[%zu].%s does not exist", where, t,
                               g.target_attributes[t][a].name);
    if (position < 0) {
        p->skipped = 1;
        warn(s, "%s has no POSITION; it is kept as it is and not processed", where);
        return LP_OK;
    }
    p->stream_count = (uint32_t)g.attribute_count;
    p->streams = calloc(g.attribute_count, sizeof *p->streams);
    if (!p->streams) return lp_no_memory(err, "%s: out of memory", where);
    for (size_t a = 0; a < g.attribute_count; ++a) {
        scene_stream *st = &p->streams[a];
        uint32_t count;
        st->name = g.attributes[a].name;
        st->accessor = g.attributes[a].accessor;
        int rc = accessor_read_floats(s->doc, st->accessor, &st->values, &count, &st->components, err);
        if (rc) return rc;
        if (a == (size_t)position) p->vertex_count = count;
        else if (a > (size_t)position && count != p->vertex_count)
            return lp_fail(err, LP_INVALID, "%s.attributes.%s has %u elements but POSITION has %u", where, st->name,
                           count, p->vertex_count);
    }
    for (size_t a = 0; a < (size_t)position; ++a) {
        gltf_accessor acc;
        gltf_get_accessor(s->doc, (size_t)p->streams[a].accessor, &acc);
        if (acc.count != p->vertex_count)
            return lp_fail(err, LP_INVALID, "%s.attributes.%s has %llu elements but POSITION has %u", where,
                           p->streams[a].name, (unsigned long long)acc.count, p->vertex_count);
    }
    if (p->streams[position].components != 3)
        return lp_fail(err, LP_INVALID, "%s: POSITION must be VEC3", where);
    p->positions = p->streams[position].values;
    for (size_t i = 0; i < (size_t)p->vertex_count * 3; ++i)
        if (!isfinite(p->positions[i]))
            return lp_fail(err, LP_INVALID, "%s: POSITION of vertex %zu is not finite (accessors[%lld])", where, i / 3,
                           (long long)p->streams[position].accessor);
    if (p->mode < 4) return LP_OK; /* points and lines pass through */
    uint32_t *idx = NULL, n = 0;
    if (g.indices >= 0) {
        int rc = accessor_read_indices(s->doc, g.indices, p->vertex_count, &idx, &n, err);
        if (rc) return rc;
    } else {
        n = p->vertex_count;
        idx = malloc((n ? n : 1) * sizeof *idx);
        if (!idx) return lp_no_memory(err, "%s: out of memory", where);
        for (uint32_t i = 0; i < n; ++i) idx[i] = i;
    }
    int rc = triangulate(s, p, idx, n, where, err);
    free(idx);
    return rc;
}

static void mesh_bounds(scene_mesh *m)
{
    for (int k = 0; k < 3; ++k) {
        m->bbox_min[k] = INFINITY;
        m->bbox_max[k] = -INFINITY;
    }
    for (uint32_t p = 0; p < m->primitive_count; ++p) {
        const scene_primitive *pr = &m->primitives[p];
        m->triangle_count += pr->triangle_count;
        for (size_t i = 0; i < (size_t)pr->triangle_count * 3; ++i) {
            const float *v = pr->positions + 3 * (size_t)pr->triangles[i];
            for (int k = 0; k < 3; ++k) {
                if (v[k] < m->bbox_min[k]) m->bbox_min[k] = v[k];
                if (v[k] > m->bbox_max[k]) m->bbox_max[k] = v[k];
            }
        }
    }
    m->has_bbox = m->triangle_count > 0;
    if (!m->has_bbox) {
        memset(m->bbox_min, 0, sizeof m->bbox_min);
        memset(m->bbox_max, 0, sizeof m->bbox_max);
    }
    double d2 = 0.0;
    for (int k = 0; k < 3; ++k) d2 += (m->bbox_max[k] - m->bbox_min[k]) * (m->bbox_max[k] - m->bbox_min[k]);
    m->diagonal = sqrt(d2);
}

/* ---- degenerate geometry: kept, but named in a warning ------------------------------ */

static int compare_triangle_keys(const void *a, const void *b)
{
    const uint32_t *x = a, *y = b;
    for (int k = 0; k < 4; ++k) /* sorted corners, then the winding */
        if (x[k] != y[k]) return x[k] < y[k] ? -1 : 1;
    return 0;
}

static void sort3(uint32_t k[3])
{
    for (int pass = 0; pass < 2; ++pass)
        for (int i = 0; i < 2; ++i)
            if (k[i] > k[i + 1]) {
                uint32_t x = k[i];
                k[i] = k[i + 1];
                k[i + 1] = x;
            }
}

/* The parity of the permutation that sorts a triangle's corners: a
 * rotation keeps it, a reversal of the winding flips it (equal corners: 0). */
static uint32_t winding_parity(const uint32_t *v)
{
    return ((uint32_t)(v[0] > v[1]) + (uint32_t)(v[0] > v[2]) + (uint32_t)(v[1] > v[2])) & 1u;
}

/* Repeats among triangles sorted by corners, then winding: over each run
 * with the same corners, n0 and n1 of the two windings, the ones beyond the
 * first of their winding count as same and min(n0, n1) as reversed. */
typedef struct repeat_counts {
    uint32_t same, reversed;
} repeat_counts;

static void count_run(repeat_counts *c, uint32_t n0, uint32_t n1)
{
    c->same += (n0 ? n0 - 1 : 0) + (n1 ? n1 - 1 : 0);
    c->reversed += n0 < n1 ? n0 : n1;
}

/* duplicate_triangles when every vertex number fits 21 bits: each triangle's
 * sorted corners and winding packed in one 64-bit key, the keys sorted by
 * radix (glibc's qsort with a comparison function was about 0.4 s of loading
 * a 1.1M-triangle mesh). Returns 0 when the scratch cannot be allocated. */
static int duplicate_triangles_packed(const scene_primitive *p, repeat_counts *c)
{
    const uint32_t n = p->triangle_count;
    uint64_t *key = malloc(((size_t)n + 1) * sizeof *key);
    if (!key) return -1;
    for (uint32_t t = 0; t < n; ++t) {
        uint32_t k[3];
        memcpy(k, p->triangles + 3 * (size_t)t, sizeof k);
        const uint32_t parity = winding_parity(k);
        sort3(k);
        key[t] = (uint64_t)k[0] << 43 | (uint64_t)k[1] << 22 | (uint64_t)k[2] << 1 | parity;
    }
    const int rc = radix_sort_u64(key, NULL, n, UINT64_MAX);
    for (uint32_t t = 0; !rc && t < n;) {
        uint32_t runs[2] = {0, 0}, end = t;
        for (; end < n && key[end] >> 1 == key[t] >> 1; ++end) runs[key[end] & 1u]++;
        count_run(c, runs[0], runs[1]);
        t = end;
    }
    free(key);
    return rc;
}

/* Triangles of a primitive that use the same three vertices as an earlier
 * one: in the same winding (c->same), or in the other (c->reversed: a back,
 * weld.h, which each level keeps as a side of its own). Nothing is counted
 * when the scratch cannot be allocated. */
static void duplicate_triangles(const scene_primitive *p, repeat_counts *c)
{
    if (p->vertex_count <= (1u << 21)) {
        duplicate_triangles_packed(p, c);
        return;
    }
    uint32_t *keys = malloc(((size_t)p->triangle_count + 1) * 4 * sizeof *keys);
    if (!keys) return;
    for (uint32_t t = 0; t < p->triangle_count; ++t) {
        uint32_t *key = keys + 4 * (size_t)t;
        memcpy(key, p->triangles + 3 * (size_t)t, 3 * sizeof *key);
        key[3] = winding_parity(key);
        sort3(key);
    }
    qsort(keys, p->triangle_count, 4 * sizeof *keys, compare_triangle_keys);
    for (uint32_t t = 0; t < p->triangle_count;) {
        uint32_t runs[2] = {0, 0}, end = t;
        for (; end < p->triangle_count && memcmp(keys + 4 * (size_t)end, keys + 4 * (size_t)t, 3 * sizeof *keys) == 0; ++end)
            runs[keys[4 * (size_t)end + 3]]++;
        count_run(c, runs[0], runs[1]);
        t = end;
    }
    free(keys);
}

static int zero_area(const float *positions, const uint32_t *tri)
{
    const float *a = positions + 3 * (size_t)tri[0], *b = positions + 3 * (size_t)tri[1],
                *c = positions + 3 * (size_t)tri[2];
    const double u[3] = {(double)b[0] - a[0], (double)b[1] - a[1], (double)b[2] - a[2]};
    const double v[3] = {(double)c[0] - a[0], (double)c[1] - a[1], (double)c[2] - a[2]};
    const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    return n[0] == 0.0 && n[1] == 0.0 && n[2] == 0.0;
}

/* Warns about what the simplifier tolerates but a user should hear of:
 * triangle primitives without triangles, zero-area and duplicate triangles,
 * vertices no triangle uses (when no other object reads the POSITION
 * accessor), non-finite attribute values (positions are checked at load),
 * and a mesh whose triangles span no volume (diagonal 0: it gets no levels).
 * Nothing is changed. */
static void warn_degenerate(scene *s, uint32_t m)
{
    const scene_mesh *mesh = &s->meshes[m];
    for (uint32_t pi = 0; pi < mesh->primitive_count; ++pi) {
        const scene_primitive *p = &mesh->primitives[pi];
        if (p->skipped) continue;
        for (uint32_t a = 0; a < p->stream_count; ++a) {
            const scene_stream *st = &p->streams[a];
            size_t bad = 0;
            for (size_t i = 0; i < (size_t)p->vertex_count * st->components; ++i) bad += !isfinite(st->values[i]);
            if (bad)
                warn(s, "meshes[%u].primitives[%u].attributes.%s: %zu values are NaN or infinite (copied as they are)",
                     m, pi, st->name, bad);
        }
        if (p->mode < 4) continue;
        if (!p->triangle_count) {
            warn(s, "meshes[%u].primitives[%u] has no triangle", m, pi);
            continue;
        }
        uint32_t flat = 0, unused = 0;
        uint8_t *used = calloc((size_t)p->vertex_count + 1, 1);
        for (uint32_t t = 0; t < p->triangle_count; ++t) {
            flat += (uint32_t)zero_area(p->positions, p->triangles + 3 * (size_t)t);
            for (int k = 0; used && k < 3; ++k) used[p->triangles[3 * (size_t)t + k]] = 1;
        }
        for (uint32_t v = 0; used && v < p->vertex_count; ++v) unused += !used[v];
        free(used);
        /* vertices another primitive also reads may be its: a LOD mesh shares
         * its original's accessors, and a level with placed vertices has a
         * POSITION of its own, sparse over the original's data */
        for (uint32_t a = 0; a < p->stream_count; ++a) {
            gltf_accessor acc;
            const size_t index = (size_t)p->streams[a].accessor;
            if (gltf_accessor_refs_at_load(s->doc, index) > 1 ||
                (p->streams[a].values == p->positions && gltf_get_accessor(s->doc, index, &acc) == 0 &&
                 acc.has_sparse && acc.buffer_view >= 0))
                unused = 0;
        }
        repeat_counts repeats = {0, 0};
        duplicate_triangles(p, &repeats);
        if (flat)
            warn(s, "meshes[%u].primitives[%u]: %u of %u triangles have no area (kept in LOD0; levels may drop them)",
                 m, pi, flat, p->triangle_count);
        if (repeats.same)
            warn(s, "meshes[%u].primitives[%u]: %u triangles repeat the vertices of another (kept in LOD0)", m, pi,
                 repeats.same);
        if (repeats.reversed)
            warn(s, "meshes[%u].primitives[%u]: %u triangles repeat the vertices of another in the opposite winding "
                    "(a back side: kept in LOD0 and at every level)", m, pi, repeats.reversed);
        if (unused)
            warn(s, "meshes[%u].primitives[%u]: %u of %u vertices are used by no triangle (ignored for the bounds)",
                 m, pi, unused, p->vertex_count);
    }
    if (mesh->triangle_count && !(mesh->diagonal > 0))
        warn(s, "meshes[%u]: its triangles span no space (bounding-box diagonal %g): it gets no LOD levels", m,
             mesh->diagonal);
}

/* level_only[m] = 1 when every node that uses mesh m is a level of some
 * node's MSFT_lod chain (and one does): a level of a chain already written,
 * whose geometry warnings would repeat LOD0's once per level. */
static uint8_t *level_only_meshes(const scene *s, size_t mesh_count)
{
    uint8_t *is_level = calloc((size_t)s->node_count + 1, 1);
    uint8_t *level_only = calloc(mesh_count + 1, 1);
    uint8_t *other_use = calloc(mesh_count + 1, 1);
    if (!is_level || !level_only || !other_use) {
        free(is_level);
        free(other_use);
        free(level_only);
        return NULL;
    }
    for (uint32_t i = 0; i < s->node_count; ++i)
        for (uint32_t l = 0; l < s->nodes[i].lod_count; ++l) is_level[s->nodes[i].lod_ids[l]] = 1;
    for (uint32_t i = 0; i < s->node_count; ++i) {
        const int64_t m = s->nodes[i].mesh;
        if (m < 0 || (size_t)m >= mesh_count) continue;
        if (is_level[i]) level_only[m] = 1;
        else other_use[m] = 1;
    }
    for (size_t m = 0; m < mesh_count; ++m) level_only[m] &= (uint8_t)!other_use[m];
    free(is_level);
    free(other_use);
    return level_only;
}

static int load_meshes(scene *s, lp_error *err)
{
    const size_t n = gltf_count(s->doc, GLTF_MESHES);
    s->mesh_count = (uint32_t)n;
    s->meshes = calloc(n ? n : 1, sizeof *s->meshes);
    if (!s->meshes) return lp_no_memory(err, "out of memory for %zu meshes", n);
    uint8_t *level_only = level_only_meshes(s, n);
    if (!level_only) return lp_no_memory(err, "out of memory");
    for (size_t m = 0; m < n; ++m) {
        scene_mesh *mesh = &s->meshes[m];
        mesh->name = gltf_name(s->doc, GLTF_MESHES, m);
        const size_t prims = gltf_primitive_count(s->doc, m);
        mesh->primitive_count = (uint32_t)prims;
        mesh->primitives = calloc(prims ? prims : 1, sizeof *mesh->primitives);
        if (!mesh->primitives) return free(level_only), lp_no_memory(err, "out of memory");
        for (size_t p = 0; p < prims; ++p) {
            int rc = load_primitive(s, m, p, &mesh->primitives[p], err);
            if (rc) return free(level_only), rc;
        }
        mesh_bounds(mesh);
        if (!level_only[m]) warn_degenerate(s, (uint32_t)m);
    }
    free(level_only);
    for (uint32_t i = 0; i < s->node_count; ++i)
        if (s->nodes[i].in_scene && s->nodes[i].mesh >= 0) s->meshes[s->nodes[i].mesh].instance_count++;
    for (uint32_t m = 0; m < s->mesh_count; ++m) {
        s->meshes[m].instances = calloc(s->meshes[m].instance_count + 1, sizeof(uint32_t));
        if (!s->meshes[m].instances) return lp_no_memory(err, "out of memory");
        s->meshes[m].instance_count = 0;
    }
    for (uint32_t i = 0; i < s->node_count; ++i)
        if (s->nodes[i].in_scene && s->nodes[i].mesh >= 0) {
            scene_mesh *mesh = &s->meshes[s->nodes[i].mesh];
            mesh->instances[mesh->instance_count++] = i;
        }
    return LP_OK;
}

/* Builds the model over a loaded document (or cleans up after a failed load). */
static int scene_build(scene *out, int load_rc, const char *load_msg, lp_error *err)
{
    if (load_rc) return lp_fail(err, load_rc, "%s", load_msg);
    int rc = load_nodes(out, err);
    if (!rc) rc = mark_scene(out, err);
    if (!rc) rc = load_meshes(out, err);
    if (rc) scene_free(out);
    return rc;
}

int scene_load(const char *path, const scene_options *options, scene *out, lp_error *err)
{
    memset(out, 0, sizeof *out);
    out->default_scene = -1;
    char msg[sizeof err->msg];
    int rc = gltf_load(path, options ? &options->load : NULL, &out->doc, msg, sizeof msg);
    return scene_build(out, rc, msg, err);
}

int scene_load_memory(const void *bytes, size_t size, const char *path, const scene_options *options, scene *out,
                      lp_error *err)
{
    memset(out, 0, sizeof *out);
    out->default_scene = -1;
    char msg[sizeof err->msg];
    int rc = gltf_load_memory(bytes, size, path, options ? &options->load : NULL, &out->doc, msg, sizeof msg);
    return scene_build(out, rc, msg, err);
}

/* The arrays scene_load allocated for one primitive. */
static void free_primitive_data(scene_primitive *pr)
{
    for (uint32_t a = 0; pr->streams && a < pr->stream_count; ++a) free(pr->streams[a].values);
    free(pr->streams);
    free(pr->triangles);
}

void scene_release_mesh_data(scene *s, uint32_t mesh)
{
    if (mesh >= s->mesh_count) return;
    scene_mesh *m = &s->meshes[mesh];
    for (uint32_t p = 0; m->primitives && p < m->primitive_count; ++p) {
        scene_primitive *pr = &m->primitives[p];
        free_primitive_data(pr);
        pr->streams = NULL;
        pr->stream_count = 0;
        pr->positions = NULL;
        pr->vertex_count = 0;
        pr->triangles = NULL;
        pr->triangle_count = 0;
    }
}

int scene_reload_mesh_data(scene *s, uint32_t mesh, lp_error *err)
{
    if (mesh >= s->mesh_count) return LP_OK;
    scene_mesh *m = &s->meshes[mesh];
    const uint32_t warnings = s->warning_count; /* said once, at the load */
    int rc = LP_OK;
    for (uint32_t p = 0; m->primitives && p < m->primitive_count && !rc; ++p)
        if (!m->primitives[p].skipped && !m->primitives[p].streams)
            rc = load_primitive(s, mesh, p, &m->primitives[p], err);
    s->warning_count = warnings;
    return rc;
}

void scene_free(scene *s)
{
    for (uint32_t m = 0; s->meshes && m < s->mesh_count; ++m) {
        scene_mesh *mesh = &s->meshes[m];
        for (uint32_t p = 0; mesh->primitives && p < mesh->primitive_count; ++p) free_primitive_data(&mesh->primitives[p]);
        free(mesh->primitives);
        free(mesh->instances);
    }
    free(s->meshes);
    free(s->nodes);
    free(s->channels);
    free(s->warnings);
    gltf_free(s->doc);
    memset(s, 0, sizeof *s);
}
