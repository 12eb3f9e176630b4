/* certify.c - the two-sided certificate; see certify.h for what it proves.
 *
 * Follows DESIGN.md §4 (after Cohen et al.'s simplification envelopes and Cox
 * & Chibelushi's local error bound): convexity of the point-triangle distance
 * (a piece is within eps of one triangle when its corners are) and the
 * 1-Lipschitz bound at the minimal enclosing ball's centre, with 1-to-4
 * subdivision as the fallback. */
#include "certify.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geom.h"
#include "overlay.h"
#include "threads.h"

static vec3d vertex_of(const cert_original *o, uint32_t v)
{
    return geom_vec3d_from_floats(o->positions + 3 * (size_t)v);
}

static void triangle_of(const cert_original *o, uint32_t t, vec3d out[3])
{
    for (int k = 0; k < 3; ++k) out[k] = vertex_of(o, o->triangles[3 * (size_t)t + k]);
}

/* The ball, normal cone and material of cluster c (its range set). */
static void describe_cluster(const cert_original *o, cert_cluster_info *c)
{
    const uint32_t *order = o->tree.triangle_order + c->first;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double axis[3] = {0.0, 0.0, 0.0};
    int real = 0;
    c->material = o->material[order[0]];
    for (uint32_t i = 0; i < c->count; ++i) {
        const uint32_t t = order[i];
        if (o->material[t] != c->material) c->material = CERT_MIXED;
        for (int k = 0; k < 3; ++k)
            for (int a = 0; a < 3; ++a) {
                double x = o->positions[3 * (size_t)o->triangles[3 * (size_t)t + k] + a];
                lo[a] = geom_fmin(lo[a], x);
                hi[a] = geom_fmax(hi[a], x);
            }
        if (o->degenerate[t]) continue; /* a segment needs no agreeing normal (certify.h) */
        real = 1;
        for (int a = 0; a < 3; ++a) axis[a] += o->normals[3 * (size_t)t + a];
    }
    double r2 = 0.0;
    for (int a = 0; a < 3; ++a) c->centre[a] = 0.5 * (lo[a] + hi[a]);
    for (uint32_t i = 0; i < c->count; ++i)
        for (int k = 0; k < 3; ++k) {
            const float *x = o->positions + 3 * (size_t)o->triangles[3 * (size_t)order[i] + k];
            double d2 = 0.0;
            for (int a = 0; a < 3; ++a) d2 += (x[a] - c->centre[a]) * (x[a] - c->centre[a]);
            r2 = geom_fmax(r2, d2);
        }
    c->radius = sqrt(r2) * (1.0 + 1e-12);
    const double len = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    c->cone_sin = 2.0; /* no cone */
    if (!real) {
        c->cone_sin = -1.0; /* every triangle degenerate: any face's normal will do */
        c->axis[0] = 1.0;
        c->axis[1] = c->axis[2] = 0.0;
    } else if (len > 0.0 && isfinite(len)) {
        double m = 1.0;
        for (int a = 0; a < 3; ++a) c->axis[a] = axis[a] / len;
        for (uint32_t i = 0; i < c->count; ++i) {
            const uint32_t t = order[i];
            if (o->degenerate[t]) continue;
            const double *n = o->normals + 3 * (size_t)t;
            m = geom_fmin(m, n[0] * c->axis[0] + n[1] * c->axis[1] + n[2] * c->axis[2]);
        }
        /* n . axis >= m = cos(theta): a face normal g agrees with all of them
         * when angle(axis, g) < 90 degrees - theta, i.e. axis . g > sin(theta);
         * the slack inside the root covers the cancellation in 1 - m^2 */
        if (m > 1e-6) c->cone_sin = sqrt(geom_fmax(0.0, 1.0 - m * m) + 1e-14) + 1e-9;
    }
}

/* Clusters: the maximal BVH subtrees of at most CERT_CLUSTER_MAX triangles
 * (depth first, so the triangles of a subtree are one run of the order);
 * their ranges and cluster_of, not yet their descriptions. */
static int find_clusters(cert_original *o)
{
    const bvh *tree = &o->tree;
    o->cluster_of = malloc(((size_t)o->triangle_count + 1) * sizeof *o->cluster_of);
    uint32_t *below = malloc(((size_t)tree->node_count + 1) * sizeof *below);
    uint32_t *first = malloc(((size_t)tree->node_count + 1) * sizeof *first);
    /* each cluster is a subtree of its own, so there are no more than leaves:
     * (nodes + 1) / 2 in a tree whose inner nodes have two children */
    o->clusters = malloc(((size_t)tree->node_count / 2 + 2) * sizeof *o->clusters);
    if (!o->cluster_of || !below || !first || !o->clusters) {
        free(below);
        free(first);
        return -1;
    }
    /* children come after their parent in the node array */
    for (uint32_t i = tree->node_count; i-- > 0;) {
        const bvh_node *n = &tree->nodes[i];
        if (n->count) {
            below[i] = n->count;
            first[i] = n->offset;
        } else {
            below[i] = below[i + 1] + below[n->offset];
            first[i] = first[i + 1];
        }
    }
    uint32_t stack[BVH_MAX_DEPTH + 2], depth = 0;
    o->cluster_count = 0;
    if (tree->node_count) stack[depth++] = 0;
    while (depth) {
        const uint32_t i = stack[--depth];
        const bvh_node *n = &tree->nodes[i];
        if (below[i] > CERT_CLUSTER_MAX && !n->count) {
            stack[depth++] = n->offset; /* right after left: the runs come out in order */
            stack[depth++] = i + 1;
            continue;
        }
        cert_cluster_info *c = &o->clusters[o->cluster_count];
        c->first = first[i];
        c->count = below[i];
        for (uint32_t k = 0; k < c->count; ++k) o->cluster_of[tree->triangle_order[c->first + k]] = o->cluster_count;
        o->cluster_count++;
    }
    free(below);
    free(first);
    return 0;
}

/* Each cluster's distinct vertices: the whole-cluster test measures every
 * vertex against a face, and its triangles share most of their corners (the
 * 1.1M-triangle bunny: 49,102 clusters of 22.6 triangles, 19.4 distinct
 * vertices each against 68 corners). */
static int collect_cluster_vertices(cert_original *o, uint32_t vertex_count)
{
    uint32_t *seen = malloc(((size_t)vertex_count + 1) * sizeof *seen);
    o->cluster_vertex_start = malloc(((size_t)o->cluster_count + 1) * sizeof *o->cluster_vertex_start);
    size_t cap = (size_t)o->triangle_count + 16, n = 0;
    o->cluster_vertices = malloc(cap * sizeof *o->cluster_vertices);
    if (!seen || !o->cluster_vertex_start || !o->cluster_vertices) {
        free(seen);
        return -1;
    }
    memset(seen, 0xff, ((size_t)vertex_count + 1) * sizeof *seen);
    for (uint32_t c = 0; c < o->cluster_count; ++c) {
        const cert_cluster_info *info = &o->clusters[c];
        o->cluster_vertex_start[c] = (uint32_t)n;
        for (uint32_t i = 0; i < info->count; ++i)
            for (int k = 0; k < 3; ++k) {
                const uint32_t v = o->triangles[3 * (size_t)o->tree.triangle_order[info->first + i] + k];
                if (seen[v] == c) continue;
                seen[v] = c;
                if (n == cap) {
                    uint32_t *grown = realloc(o->cluster_vertices, 2 * cap * sizeof *grown);
                    if (!grown) {
                        free(seen);
                        return -1;
                    }
                    o->cluster_vertices = grown;
                    cap *= 2;
                }
                o->cluster_vertices[n++] = v;
            }
    }
    o->cluster_vertex_start[o->cluster_count] = (uint32_t)n;
    free(seen);
    return 0;
}

/* Clusters described per item of the team (build_clusters). */
#define DESCRIBE_CHUNK 1024u

/* The cluster work after find_clusters, as items of a team (lp_team_for):
 * item 0 collects the cluster vertices, item k > 0 describes chunk k - 1.
 * Each writes only its own part of the arrays. */
typedef struct cluster_work {
    cert_original *o;
    uint32_t vertex_count;
    int failed; /* written by item 0 only */
} cluster_work;

static void cluster_item(void *p, uint32_t k)
{
    cluster_work *work = p;
    cert_original *o = work->o;
    if (k == 0) {
        work->failed = collect_cluster_vertices(o, work->vertex_count) != 0;
        return;
    }
    const uint32_t first = (k - 1) * DESCRIBE_CHUNK;
    const uint32_t end = o->cluster_count - first < DESCRIBE_CHUNK ? o->cluster_count : first + DESCRIBE_CHUNK;
    for (uint32_t c = first; c < end; ++c) describe_cluster(o, &o->clusters[c]);
}

/* find_clusters, then the descriptions and the cluster vertices on up to
 * `threads` threads. Returns 0, or -1 when memory runs out. */
static int build_clusters(cert_original *o, uint32_t vertex_count, unsigned threads)
{
    if (find_clusters(o)) return -1;
    cluster_work work = {.o = o, .vertex_count = vertex_count};
    const uint32_t items = 1 + (o->cluster_count + DESCRIBE_CHUNK - 1) / DESCRIBE_CHUNK;
    /* one chunk of descriptions (up to 1024 clusters, 32K triangles) is not
     * worth a thread */
    lp_team_for(items <= 2 ? 1 : threads, items, cluster_item, &work);
    return work.failed ? -1 : 0;
}

/* Fewer triangles than this: their normals are computed on the calling
 * thread (a thread costs more). */
#define NORMALS_BESIDE_MIN 4096u

/* Every triangle's unit normal and whether it has none. */
static void *compute_normals(void *p)
{
    cert_original *o = p;
    for (uint32_t t = 0; t < o->triangle_count; ++t) {
        vec3d q[3], n;
        triangle_of(o, t, q);
        o->degenerate[t] = !geom_triangle_unit_normal(&q[0], &q[1], &q[2], &n);
        o->normals[3 * (size_t)t] = n.x;
        o->normals[3 * (size_t)t + 1] = n.y;
        o->normals[3 * (size_t)t + 2] = n.z;
    }
    return NULL;
}

int cert_original_init(cert_original *o, const float *positions, uint32_t vertex_count,
                       const uint32_t *triangles, uint32_t triangle_count, const int32_t *material,
                       const uint32_t *vertex_offsets, const uint32_t *vertex_triangles, unsigned threads)
{
    memset(o, 0, sizeof *o);
    o->triangle_count = triangle_count;
    o->positions = positions;
    o->triangles = triangles;
    o->material = material;
    o->vertex_offsets = vertex_offsets;
    o->vertex_triangles = vertex_triangles;
    o->ring_scan_max = CERT_RING_SCAN_MAX;
    o->normals = malloc(((size_t)triangle_count * 3 + 1) * sizeof *o->normals); /* compute_normals fills them */
    o->degenerate = malloc((size_t)triangle_count + 1);
    if (!o->normals || !o->degenerate) {
        cert_original_free(o);
        return -1;
    }
    /* the tree needs no normals: with threads, they are computed beside it
     * (when there are enough of them to be worth a thread) */
    lp_beside normals;
    lp_beside_start(&normals, threads > 1 && triangle_count > NORMALS_BESIDE_MIN, compute_normals, o);
    const bvh_result tree_rc = bvh_build_threads(&o->tree, positions, vertex_count, triangles, triangle_count, threads);
    lp_beside_join(&normals);
    if (tree_rc != BVH_OK || build_clusters(o, vertex_count, threads) != 0) {
        cert_original_free(o);
        return -1;
    }
    return 0;
}

void cert_original_free(cert_original *o)
{
    free(o->normals);
    free(o->degenerate);
    free(o->clusters);
    free(o->cluster_of);
    free(o->cluster_vertex_start);
    free(o->cluster_vertices);
    bvh_free(&o->tree);
    memset(o, 0, sizeof *o);
}

void cert_face_normal(cert_tri *f)
{
    vec3d a = geom_vec3d_from_doubles(f->p[0]), b = geom_vec3d_from_doubles(f->p[1]),
          c = geom_vec3d_from_doubles(f->p[2]), n;
    f->degenerate = !geom_triangle_unit_normal(&a, &b, &c, &n);
    f->n[0] = n.x;
    f->n[1] = n.y;
    f->n[2] = n.z;
    geom_triangle_box((const double(*)[3])f->p, f->lo, f->hi);
}

double cert_tri_box_distance2(const cert_tri *f, const vec3d *p)
{
    const double q[3] = {p->x, p->y, p->z};
    double d2 = 0.0;
    for (int k = 0; k < 3; ++k) {
        double d = q[k] < f->lo[k] ? f->lo[k] - q[k] : (q[k] > f->hi[k] ? q[k] - f->hi[k] : 0.0);
        d2 += d * d;
    }
    return d2;
}

/* ---- (a): a face of the level against the original -------------------------- */

typedef struct face_filter {
    const cert_original *o;
    int32_t material;
    const double *n;
} face_filter;

/* A witness for a level face: same material, a real normal pointing the same
 * way (so a thin sheet is never certified against its other side). */
static int witness_ok(void *context, uint32_t t)
{
    const face_filter *f = context;
    const double *nt = f->o->normals + 3 * (size_t)t;
    return f->o->material[t] == f->material && !f->o->degenerate[t] &&
           nt[0] * f->n[0] + nt[1] * f->n[1] + nt[2] * f->n[2] > 0.0;
}

/* The largest squared corner distance of the piece to tri, or INFINITY as
 * soon as one exceeds cap2 (NaN too). */
static double corners_below(const vec3d piece[3], const vec3d tri[3], double cap2)
{
    double worst2 = 0.0;
    for (int k = 0; k < 3; ++k) {
        const double d2 = geom_point_triangle_distance2(&piece[k], &tri[0], &tri[1], &tri[2], NULL);
        if (!(d2 <= cap2)) return INFINITY;
        if (d2 > worst2) worst2 = d2;
    }
    return worst2;
}

/* How far from the centre of a piece's enclosing ball (centre, radius) an
 * original triangle may lie and still hold all the piece's corners within
 * accept: each corner is within radius of the centre, so accept + radius,
 * widened by a millionth and by 1e-12 of the coordinates' size to cover the
 * rounding of the point-triangle distances. Beyond it, corners_below finds
 * a corner farther than accept. */
static double ball_reach(const vec3d *centre, double radius, double accept)
{
    return (accept + radius) * (1.0 + 1e-6) + 1e-12 * (geom_max_abs_component(*centre) + radius);
}

/* The largest corner distance of the piece to tri, or INFINITY as soon as
 * one corner is farther than accept (the callers accept only <= accept). */
static double max_corner_distance(const vec3d piece[3], const vec3d tri[3], double accept)
{
    return sqrt(corners_below(piece, tri, accept * accept));
}

/* Whether triangle t has one of corner[0 .. k - 1] as a vertex: a loop over
 * the triangles around corner[k] met it already around that one (every
 * triangle is in the ring of each of its vertices). */
static int around_earlier(const cert_original *o, uint32_t t, const uint32_t *corner, int k)
{
    const uint32_t *tv = o->triangles + 3 * (size_t)t;
    for (int j = 0; j < k; ++j)
        if (tv[0] == corner[j] || tv[1] == corner[j] || tv[2] == corner[j]) return 1;
    return 0;
}

static void split4(const vec3d p[3], vec3d out[4][3])
{
    vec3d m01 = geom_lerp(p[0], p[1], 0.5), m12 = geom_lerp(p[1], p[2], 0.5), m20 = geom_lerp(p[2], p[0], 0.5);
    const vec3d pieces[4][3] = {{p[0], m01, m20}, {m01, p[1], m12}, {m20, m12, p[2]}, {m01, m12, m20}};
    memcpy(out, pieces, sizeof pieces);
}

/* ---- (a) overlay: the originals under F, flood-filled from F's corners ------ */

#define OVERLAY_MAX_ORIGINALS 256 /* more originals under one face: the overlay fails */

enum { FLOOD_PENDING = 0, FLOOD_ACCEPTED = 1, FLOOD_PASSED_OVER = 2 };

#define FLOOD_TABLE 512 /* open-addressing index of the queued ids: >= 2 * OVERLAY_MAX_ORIGINALS, a power of 2 */

typedef struct flood {
    uint32_t id[OVERLAY_MAX_ORIGINALS];
    uint8_t required[OVERLAY_MAX_ORIGINALS];
    uint8_t state[OVERLAY_MAX_ORIGINALS];
    uint16_t slot[FLOOD_TABLE]; /* index into id, or FLOOD_EMPTY */
    uint32_t count;
} flood;

#define FLOOD_EMPTY UINT16_MAX
_Static_assert(FLOOD_TABLE == 512 && FLOOD_TABLE >= 2 * OVERLAY_MAX_ORIGINALS, "flood_add hashes to 9 bits");

static void flood_init(flood *q)
{
    q->count = 0;
    memset(q->slot, 0xff, sizeof q->slot);
}

/* Queues original t (once). Returns 0 when the flood must fail: it is full,
 * or t is required now but was already passed over as an optional corner
 * triangle (its piece was empty or it was not a witness), so the edge that
 * needs it has no accepted neighbour. */
static int flood_add(flood *q, uint32_t t, int required)
{
    uint32_t h = (t * 0x9e3779b1u) >> 23; /* top 9 bits: FLOOD_TABLE slots */
    for (;; h = (h + 1) & (FLOOD_TABLE - 1)) {
        const uint16_t i = q->slot[h];
        if (i == FLOOD_EMPTY) break;
        if (q->id[i] == t) {
            if (required && q->state[i] == FLOOD_PASSED_OVER) return 0;
            q->required[i] |= (uint8_t)required;
            return 1;
        }
    }
    if (q->count == OVERLAY_MAX_ORIGINALS) return 0;
    q->slot[h] = (uint16_t)q->count;
    q->id[q->count] = t;
    q->state[q->count] = FLOOD_PENDING;
    q->required[q->count++] = (uint8_t)required;
    return 1;
}

/* The original triangle across t's edge (a, b), wound the same way (it runs
 * b -> a), or UINT32_MAX when the edge is a border, non-manifold or the
 * neighbour is wound the other way. */
static uint32_t original_across(const cert_original *o, uint32_t t, uint32_t a, uint32_t b)
{
    uint32_t found = UINT32_MAX;
    for (uint32_t i = o->vertex_offsets[a]; i < o->vertex_offsets[a + 1]; ++i) {
        uint32_t g = o->vertex_triangles[i];
        if (g == t) continue;
        const uint32_t *gv = o->triangles + 3 * (size_t)g;
        for (int k = 0; k < 3; ++k) {
            if (gv[k] != b) continue;
            if (gv[(k + 1) % 3] == a) {
                if (found != UINT32_MAX) return UINT32_MAX; /* non-manifold */
                found = g;
            } else if (gv[(k + 2) % 3] == a) {
                return UINT32_MAX; /* wound the other way, or non-manifold */
            }
        }
    }
    return found;
}

/* DESIGN.md §4 (a)2. F is partitioned by the projections of the originals
 * under it; each piece is checked at its corners against its original. The
 * accepted pieces cover F when they have no open edge inside F (every
 * original edge entering F's interior has an accepted neighbour, same
 * material, facing F's way, wound consistently) and one of them holds F's
 * centroid: a closed union with no boundary inside F is all of F. */
static int overlay_a(const cert_original *o, face_filter *filter, const vec3d p[3], const cert_tri *f, double accept,
                     double *bound)
{
    overlay_subject sub;
    if (!overlay_subject_init(&sub, p)) return 0;
    flood q;
    flood_init(&q);
    for (int k = 0; k < 3; ++k)
        for (uint32_t i = o->vertex_offsets[f->vertex[k]]; i < o->vertex_offsets[f->vertex[k] + 1]; ++i)
            if (!flood_add(&q, o->vertex_triangles[i], 0)) return 0;
    double worst = 0.0;
    int centroid = 0;
    for (uint32_t i = 0; i < q.count; ++i) {
        const uint32_t t = q.id[i];
        const int ok = witness_ok(filter, t);
        double m = INFINITY;
        vec3d tri[3];
        triangle_of(o, t, tri);
        overlay_piece_result piece = ok ? overlay_piece(&sub, tri, &m, NULL, NULL) : OVERLAY_UNUSABLE;
        if (piece != OVERLAY_PIECE || !(m <= accept)) {
            /* a corner triangle that does not reach into F is no concern; a
             * piece that is too far, or a required neighbour missing, is */
            if (q.required[i] || (piece == OVERLAY_PIECE && ok)) return 0;
            q.state[i] = FLOOD_PASSED_OVER;
            continue;
        }
        q.state[i] = FLOOD_ACCEPTED;
        if (m > worst) worst = m;
        if (!centroid) centroid = overlay_covers_centroid(&sub, tri);
        const uint32_t *tv = o->triangles + 3 * (size_t)t;
        for (int k = 0; k < 3; ++k) {
            if (!overlay_edge_enters(&sub, tri[k], tri[(k + 1) % 3])) continue;
            uint32_t g = original_across(o, t, tv[k], tv[(k + 1) % 3]);
            if (g == UINT32_MAX || !flood_add(&q, g, 1)) return 0;
        }
    }
    if (!centroid) return 0;
    if (worst > *bound) *bound = worst;
    return 1;
}

static int overlay_now(const cert_original *o, face_filter *filter, const vec3d p[3], const cert_tri *f, double accept,
                       double *bound)
{
    double overlay_bound = 0.0;
    if (!overlay_a(o, filter, p, f, accept, &overlay_bound)) return 0;
    if (overlay_bound > *bound) *bound = overlay_bound;
    return 1;
}

/* The search for one original triangle holding a whole piece (corners p)
 * within accept, among the triangles around the corners hv of the piece's
 * closest original. */
typedef struct best_search {
    const cert_original *o;
    face_filter *filter;
    const vec3d *p;
    double accept;
    const uint32_t *hv;
    double best, best2;
} best_search;

/* Measures triangle t for the search: the largest corner distance of the
 * piece to it, kept when it is the smallest so far. A triangle with a corner
 * no nearer than the best's farthest cannot lower the best. */
static void best_measure(best_search *b, uint32_t t)
{
    if (!witness_ok(b->filter, t)) return;
    vec3d tri[3];
    triangle_of(b->o, t, tri);
    const double worst2 = corners_below(b->p, tri, geom_fmin(b->accept * b->accept, b->best2));
    const double m = sqrt(worst2);
    if (m < b->best) {
        b->best = m;
        b->best2 = worst2;
    }
}

/* bvh_visit_near's visitor: a triangle near the piece counts when it is
 * around one of hv's vertices. */
static void best_visit(void *context, uint32_t t)
{
    best_search *b = context;
    if (around_earlier(b->o, t, b->hv, 3)) best_measure(b, t);
}

/* The smallest largest-corner-distance of the piece to one triangle around
 * hv's vertices (INFINITY when none is within accept). Short rings are
 * walked. Around a vertex of high valence (a fan's hub: thousands of
 * sectors) a walk per piece made certifying a sliver fan quadratic, so the
 * tree then visits just the triangles within ball_reach of one corner of
 * the piece: one that counts holds every corner within accept. The others
 * could only measure INFINITY, and the minimum does not depend on the order
 * of the measures: the same answer either way. The corner is the one
 * farthest from the vertex of the largest ring: every sector of a fan lies
 * near a point near its hub. This ball lies inside the one of radius
 * r + accept around the piece's centre that the tree visited before, which
 * at a fan's hub held every sector: on a cylinder of 1,000 segments with
 * fanned caps, one thread, the visits went from 5.4 to 2.9 % of the profile
 * (the run time within its noise). */
static double best_around(const cert_original *o, face_filter *filter, const vec3d p[3], const uint32_t hv[3],
                          double accept)
{
    best_search b = {o, filter, p, accept, hv, INFINITY, INFINITY};
    uint32_t ring = 0, largest = 0, hub = hv[0];
    for (int k = 0; k < 3; ++k) {
        const uint32_t n = o->vertex_offsets[hv[k] + 1] - o->vertex_offsets[hv[k]];
        ring += n;
        if (n > largest) largest = n, hub = hv[k];
    }
    if (ring > o->ring_scan_max) {
        const vec3d h = vertex_of(o, hub);
        int far = 0;
        double far2 = -1.0;
        for (int k = 0; k < 3; ++k) {
            const double d2 = geom_distance2(p[k], h);
            if (d2 > far2) far2 = d2, far = k;
        }
        const double q[3] = {p[far].x, p[far].y, p[far].z};
        bvh_visit_near(&o->tree, q, ball_reach(&p[far], 0.0, accept), best_visit, &b);
        return b.best;
    }
    /* a triangle already measured around an earlier corner is skipped */
    for (int k = 0; k < 3; ++k)
        for (uint32_t i = o->vertex_offsets[hv[k]]; i < o->vertex_offsets[hv[k] + 1]; ++i) {
            const uint32_t t = o->vertex_triangles[i];
            if (!around_earlier(o, t, hv, k)) best_measure(&b, t);
        }
    return b.best;
}

static int piece_a(const cert_original *o, face_filter *filter, const cert_tri *f, const vec3d p[3], int depth,
                   double eps, double accept, double *bound)
{
    vec3d c;
    double r;
    geom_triangle_enclosing_ball(&p[0], &p[1], &p[2], &c, &r);
    const double cq[3] = {c.x, c.y, c.z};
    bvh_hit hit;
    /* Once a piece has set *bound, most later ones fall below it: a witness
     * within *bound - r then accepts the piece without changing *bound,
     * exactly as the closest one would (it is no farther, and sqrt and + r
     * round monotonically), so the search may stop at the first such one.
     * The slack keeps the rounding of d + r from missing *bound, which
     * would cost a second, exact search. */
    const double enough = (geom_fmin(*bound, accept) - r) * (1.0 - 1e-12);
    const int found = bvh_closest_unless_within(&o->tree, cq, eps, enough, witness_ok, filter, &hit);
    if (found == 2 && sqrt(hit.distance2) + r <= geom_fmin(*bound, accept)) return 1;
    /* The ball's centre lies in the piece; when nothing of the right kind is
     * within eps of it, the piece cannot be certified at any depth. */
    if (found == 2 && !bvh_closest_filtered(&o->tree, cq, eps, witness_ok, filter, &hit)) return 0;
    if (!found) return 0;
    const double d = sqrt(hit.distance2);
    if (d + r <= accept) {
        if (d + r > *bound) *bound = d + r;
        return 1;
    }
    /* Convexity: the closest triangle or one around its corners may hold the
     * whole piece within eps. */
    const double best = best_around(o, filter, p, o->triangles + 3 * (size_t)hit.triangle, accept);
    if (best <= accept) {
        if (best > *bound) *bound = best;
        return 1;
    }
    /* The four quarters, then (a whole face only) the overlay. Either order
     * accepts the same faces, since a face passes when either does; only
     * the cost and the bound differ. Measured under callgrind, the 278k
     * chain on one thread: 28.13 G instructions with the overlay first on
     * faces under 256 originals of mean area (the rule before), 24.38 G
     * under 64, 21.58 G under 16, 21.40 G with the quarters always first;
     * the levels were the same, the bounds the same or a few ppm of eps
     * larger (d + r of the quarters instead of the overlay's corners), which
     * the simplifier takes back where it sets a level's bound
     * (cert_face_overlay). */
    if (depth < CERT_MAX_DEPTH) {
        vec3d pieces[4][3];
        split4(p, pieces);
        double quarters = *bound;
        int k = 0;
        while (k < 4 && piece_a(o, filter, f, pieces[k], depth + 1, eps, accept, &quarters)) k++;
        if (k == 4) {
            *bound = quarters;
            return 1;
        }
    }
    return depth == 0 && overlay_now(o, filter, p, f, accept, bound);
}

/* F's corners, when they are original vertices where the original has them
 * (half-edge collapses never move one), are points of O: every point of F is
 * within r of its nearest corner, r being the radius of F's minimal
 * enclosing ball (the point farthest from every corner is the circumcentre
 * of a non-obtuse triangle; in an obtuse one it lies on the longest side,
 * within half of it from an end). Each corner lies on every original
 * triangle around it, so when one of them is a witness for F at each
 * corner, F is within r of witnesses: with r <= eps, certified with bound
 * r. No distance is computed; while faces are small against eps (most of a
 * level's collapses) this decides almost every face. */
static int corners_hold(const cert_original *o, face_filter *filter, const cert_tri *f, const vec3d p[3],
                        double accept, double *bound)
{
    vec3d c;
    double r;
    geom_triangle_enclosing_ball(&p[0], &p[1], &p[2], &c, &r);
    if (!(r <= accept)) return 0;
    for (int k = 0; k < 3; ++k) {
        const uint32_t v = f->vertex[k];
        const vec3d at = vertex_of(o, v);
        if (at.x != p[k].x || at.y != p[k].y || at.z != p[k].z) return 0; /* a placed vertex */
        int witnessed = 0;
        for (uint32_t i = o->vertex_offsets[v]; i < o->vertex_offsets[v + 1] && !witnessed; ++i)
            witnessed = witness_ok(filter, o->vertex_triangles[i]);
        if (!witnessed) return 0;
    }
    *bound = r;
    return 1;
}

int cert_face(const cert_original *o, const cert_tri *f, double eps, double *bound)
{
    *bound = 0.0;
    if (f->degenerate) return 0;
    face_filter filter = {o, f->material, f->n};
    vec3d p[3];
    for (int k = 0; k < 3; ++k) p[k] = geom_vec3d_from_doubles(f->p[k]);
    const double accept = eps * (1.0 - CERT_MARGIN);
    if (corners_hold(o, &filter, f, p, accept, bound)) return 1;
    for (int k = 0; k < 3; ++k) {
        uint32_t v = f->vertex[k];
        for (uint32_t i = o->vertex_offsets[v]; i < o->vertex_offsets[v + 1]; ++i) {
            uint32_t t = o->vertex_triangles[i];
            if (around_earlier(o, t, f->vertex, k) || !witness_ok(&filter, t)) continue;
            vec3d tri[3];
            triangle_of(o, t, tri);
            double m = max_corner_distance(p, tri, accept);
            if (m <= accept) {
                *bound = m;
                return 1;
            }
        }
    }
    return piece_a(o, &filter, f, p, 0, eps, accept, bound);
}

int cert_face_overlay(const cert_original *o, const cert_tri *f, double eps, double *bound)
{
    *bound = 0.0;
    if (f->degenerate) return 0;
    face_filter filter = {o, f->material, f->n};
    vec3d p[3];
    for (int k = 0; k < 3; ++k) p[k] = geom_vec3d_from_doubles(f->p[k]);
    return overlay_now(o, &filter, p, f, eps * (1.0 - CERT_MARGIN), bound);
}

/* ---- (b): an original triangle against the level's faces -------------------- */

typedef struct cover_state {
    const cert_original *o;
    uint32_t t;
    const cert_tri *faces;
    uint32_t count;
    const uint32_t *first;
    uint32_t first_count;
    uint32_t *used;
    uint32_t used_count;
    double accept;
    double bound;
    int tightest; /* choose the tightest face per piece, not the first that holds */
} cover_state;

static int face_may_witness(const cover_state *s, const cert_tri *f)
{
    if (f->degenerate || f->material != s->o->material[s->t]) return 0;
    if (s->o->degenerate[s->t]) return 1;
    const double *nt = s->o->normals + 3 * (size_t)s->t;
    return nt[0] * f->n[0] + nt[1] * f->n[1] + nt[2] * f->n[2] > 0.0;
}

static int already_used(const cover_state *s, uint32_t id)
{
    for (uint32_t i = 0; i < s->used_count; ++i)
        if (s->used[i] == id) return 1;
    return 0;
}

static int use_face(cover_state *s, uint32_t id, double value)
{
    if (!already_used(s, id)) {
        if (s->used_count == CERT_MAX_WITNESSES) return 0;
        s->used[s->used_count++] = id;
    }
    if (value > s->bound) s->bound = value;
    return 1;
}

/* The largest corner distance of the piece to f, or INFINITY as soon as one
 * corner is farther than accept (the box test first). */
static double corners_within(const cert_tri *f, const vec3d p[3], const vec3d *centre, double radius, double accept)
{
    double reach = accept + radius;
    if (cert_tri_box_distance2(f, centre) > reach * reach) return INFINITY;
    vec3d tri[3];
    for (int k = 0; k < 3; ++k) tri[k] = geom_vec3d_from_doubles(f->p[k]);
    return max_corner_distance(p, tri, accept);
}

/* ---- (b) overlay: t partitioned by the projections of the candidate faces -- */

#define OVERLAY_MAX_FACES 512

/* The face among s->faces across f's edge (a, b): it runs b -> a. */
static uint32_t face_across(const cover_state *s, uint32_t a, uint32_t b)
{
    uint32_t found = UINT32_MAX;
    for (uint32_t i = 0; i < s->count; ++i) {
        const uint32_t *fv = s->faces[i].vertex;
        for (int k = 0; k < 3; ++k)
            if (fv[k] == b && fv[(k + 1) % 3] == a) {
                if (found != UINT32_MAX) return UINT32_MAX; /* non-manifold */
                found = i;
            }
    }
    return found;
}

/* DESIGN.md §4 (b)2, the same argument as overlay_a with the roles swapped:
 * every candidate face of t's kind whose projected piece of t is within eps
 * is accepted; the accepted ones must have no open edge inside t and one of
 * them must hold t's centroid. They become t's registration, so there may be
 * at most CERT_MAX_WITNESSES of them. (Proving a piece that its own face does
 * not hold against the other faces was tried: on the bunny at 1/64 % it
 * removed 2 more triangles of 69,451. Such pieces are genuinely too far.) */
static int overlay_b(cover_state *s, const vec3d p[3])
{
    if (s->o->degenerate[s->t] || s->count > OVERLAY_MAX_FACES || s->used_count != 0) return 0;
    overlay_subject sub;
    if (!overlay_subject_init(&sub, p)) return 0;
    vec3d c;
    double r;
    geom_triangle_enclosing_ball(&p[0], &p[1], &p[2], &c, &r);
    double value[OVERLAY_MAX_FACES];
    uint32_t accepted[CERT_MAX_WITNESSES], naccepted = 0;
    int centroid = 0;
    for (uint32_t i = 0; i < s->count; ++i) {
        const cert_tri *f = &s->faces[i];
        value[i] = INFINITY;
        const double reach = s->accept + r;
        if (!face_may_witness(s, f) || cert_tri_box_distance2(f, &c) > reach * reach) continue;
        vec3d w[3];
        for (int k = 0; k < 3; ++k) w[k] = geom_vec3d_from_doubles(f->p[k]);
        double m;
        if (overlay_piece(&sub, w, &m, NULL, NULL) != OVERLAY_PIECE || !(m <= s->accept)) continue;
        if (naccepted == CERT_MAX_WITNESSES) return 0;
        accepted[naccepted++] = i;
        value[i] = m;
        if (!centroid) centroid = overlay_covers_centroid(&sub, w);
    }
    if (!centroid) return 0;
    for (uint32_t j = 0; j < naccepted; ++j) {
        const cert_tri *f = &s->faces[accepted[j]];
        for (int k = 0; k < 3; ++k) {
            vec3d a = geom_vec3d_from_doubles(f->p[k]), b = geom_vec3d_from_doubles(f->p[(k + 1) % 3]);
            if (!overlay_edge_enters(&sub, a, b)) continue;
            uint32_t g = face_across(s, f->vertex[k], f->vertex[(k + 1) % 3]);
            if (g == UINT32_MAX || !(value[g] <= s->accept)) return 0;
        }
    }
    for (uint32_t j = 0; j < naccepted; ++j)
        if (!use_face(s, s->faces[accepted[j]].id, value[accepted[j]])) return 0;
    return 1;
}

/* One piece of t: a face that holds all its corners (faces t used before
 * first, then faces already used for other pieces, then any), else the
 * Lipschitz test at the ball's centre, else four smaller pieces. */
static int piece_b(cover_state *s, const vec3d p[3], int depth)
{
    vec3d c;
    double r;
    geom_triangle_enclosing_ball(&p[0], &p[1], &p[2], &c, &r);
    for (uint32_t i = 0; i < s->first_count; ++i) {
        const cert_tri *f = &s->faces[s->first[i]];
        if (!face_may_witness(s, f)) continue;
        double m = corners_within(f, p, &c, r, s->accept);
        if (m <= s->accept && use_face(s, f->id, m)) return 1;
    }
    double tight = INFINITY;
    uint32_t tight_id = 0;
    for (uint32_t i = 0; i < s->count; ++i) {
        const cert_tri *f = &s->faces[i];
        if ((s->used_count == CERT_MAX_WITNESSES && !already_used(s, f->id)) || !face_may_witness(s, f)) continue;
        double m = corners_within(f, p, &c, r, s->accept);
        if (!s->tightest && m <= s->accept && use_face(s, f->id, m)) return 1;
        if (m < tight) {
            tight = m;
            tight_id = f->id;
        }
    }
    if (s->tightest && tight <= s->accept && use_face(s, tight_id, tight)) return 1;
    double best = INFINITY;
    uint32_t best_id = 0;
    for (uint32_t i = 0; i < s->count; ++i) {
        const cert_tri *f = &s->faces[i];
        if (!face_may_witness(s, f) || cert_tri_box_distance2(f, &c) >= best * best) continue;
        vec3d tri[3];
        for (int k = 0; k < 3; ++k) tri[k] = geom_vec3d_from_doubles(f->p[k]);
        double d = sqrt(geom_point_triangle_distance2(&c, &tri[0], &tri[1], &tri[2], NULL));
        if (d < best) {
            best = d;
            best_id = f->id;
        }
    }
    if (best + r <= s->accept && use_face(s, best_id, best + r)) return 1;
    /* The centre lies in the piece: if it is not within eps, nothing helps. */
    if (!(best <= s->accept)) return 0;
    if (depth == 0 && overlay_b(s, p)) return 1;
    if (depth >= CERT_MAX_DEPTH) return 0;
    vec3d pieces[4][3];
    split4(p, pieces);
    for (int k = 0; k < 4; ++k)
        if (!piece_b(s, pieces[k], depth + 1)) return 0;
    return 1;
}

int cert_cover(const cert_original *o, uint32_t t, const cert_tri *faces, uint32_t count, double eps,
               const uint32_t *first, uint32_t first_count, uint32_t used[CERT_MAX_WITNESSES],
               uint32_t *used_count, double *bound)
{
    cover_state s = {o, t, faces, count, first, first_count, used, 0, eps * (1.0 - CERT_MARGIN), 0.0, 0};
    vec3d p[3];
    triangle_of(o, t, p);
    int ok = piece_b(&s, p, 0);
    *used_count = s.used_count;
    *bound = s.bound;
    return ok;
}

int cert_cover_within(const cert_original *o, uint32_t t, const cert_tri *faces, uint32_t count, double limit,
                      double *bound)
{
    uint32_t used[CERT_MAX_WITNESSES];
    cover_state s = {o, t, faces, count, NULL, 0, used, 0, limit, 0.0, 1};
    vec3d p[3];
    triangle_of(o, t, p);
    int ok = piece_b(&s, p, 0);
    *bound = s.bound;
    return ok;
}

/* ---- (b) for a whole cluster --------------------------------------------------- */

static double cluster_within(const cert_original *o, uint32_t cluster, const cert_tri *f, double accept)
{
    const cert_cluster_info *c = &o->clusters[cluster];
    if (f->degenerate || f->material != c->material || c->material == CERT_MIXED) return INFINITY;
    if (!(c->axis[0] * f->n[0] + c->axis[1] * f->n[1] + c->axis[2] * f->n[2] > c->cone_sin)) return INFINITY;
    const vec3d centre = {c->centre[0], c->centre[1], c->centre[2]};
    const double reach = accept + c->radius;
    if (cert_tri_box_distance2(f, &centre) > reach * reach) return INFINITY; /* then every vertex is beyond accept */
    vec3d tri[3];
    for (int k = 0; k < 3; ++k) tri[k] = geom_vec3d_from_doubles(f->p[k]);
    geom_prepared_triangle face; /* measured from the centre and up to every vertex */
    geom_prepare_triangle(&tri[0], &tri[1], &tri[2], &face);
    const double d = sqrt(geom_point_prepared_triangle_distance2(&centre, &face));
    if (d + c->radius <= accept) return d + c->radius;
    /* every vertex is within radius of the centre, so at least d - radius
     * from F (1-Lipschitz): none within accept, when that exceeds it */
    if (d - c->radius > accept) return INFINITY;
    /* convexity: every triangle is within accept when its corners are */
    double worst2 = 0.0;
    const double accept2 = accept * accept;
    for (uint32_t i = o->cluster_vertex_start[cluster]; i < o->cluster_vertex_start[cluster + 1]; ++i) {
        const vec3d x = vertex_of(o, o->cluster_vertices[i]);
        const double d2 = geom_point_prepared_triangle_distance2(&x, &face);
        if (!(d2 <= accept2)) return INFINITY;
        if (d2 > worst2) worst2 = d2;
    }
    return sqrt(worst2);
}

/* Whether face i is among the ones tried first. */
static int tried_first(const uint32_t *first, uint32_t first_count, uint32_t i)
{
    for (uint32_t j = 0; j < first_count; ++j)
        if (first[j] == i) return 1;
    return 0;
}

int cert_cluster(const cert_original *o, uint32_t c, const cert_tri *faces, uint32_t count, double eps,
                 const uint32_t *first, uint32_t first_count, uint32_t *face, double *bound)
{
    const double accept = eps * (1.0 - CERT_MARGIN);
    for (uint32_t i = 0; i < first_count + count; ++i) {
        if (i >= first_count && tried_first(first, first_count, i - first_count)) continue; /* it failed then */
        const cert_tri *f = i < first_count ? &faces[first[i]] : &faces[i - first_count];
        double m = cluster_within(o, c, f, accept);
        if (m <= accept) {
            *face = f->id;
            *bound = m;
            return 1;
        }
    }
    return 0;
}

int cert_cluster_within(const cert_original *o, uint32_t c, const cert_tri *f, double limit)
{
    return cluster_within(o, c, f, limit) <= limit;
}
