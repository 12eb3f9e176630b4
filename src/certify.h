/* certify.h - the two-sided certificate (DESIGN.md §4).
 *
 * The original mesh O is a fixed set of triangles with a material group and a
 * unit normal each (a triangle whose normal cannot be computed is
 * "degenerate"). Two tests decide, for a candidate level, whether a piece of
 * surface is within eps of the other side:
 *
 * (a) cert_face: every point of the triangle F is within eps of the original
 *     triangles of F's material whose normal agrees with F's (n_t . n_F > 0).
 * (b) cert_cover: every point of the original triangle t is within eps of
 *     the union of some (at most CERT_MAX_WITNESSES) of the candidate faces,
 *     each of t's material and with a normal agreeing with t's (unless t is
 *     degenerate: a segment has no side). The faces used are returned: they
 *     are t's registration.
 *
 * What a "yes" proves. Both tests split the triangle in question into pieces
 * (1-to-4 subdivision, depth <= CERT_MAX_DEPTH) and accept a piece P with one
 * witness triangle W when either
 *   - every corner of P is within eps of W: the distance to a fixed triangle
 *     is convex, so its maximum over P is at a corner; or
 *   - d(c, W) + r <= eps, where c, r are the centre and radius of P's minimal
 *     enclosing ball: the distance is 1-Lipschitz.
 * Every piece accepted means the whole triangle is within eps (the partition
 * changes cost and tightness, never soundness). Distances are computed in
 * double from float inputs; a value is accepted only when
 * d <= eps * (1 - CERT_MARGIN), written as a positive comparison so that NaN
 * rejects. The returned bound is the largest accepted value (<= eps).
 *
 * What it assumes: the caller passes the true current geometry of the faces.
 * The tests are read-only on O and thread-safe. */
#ifndef LODPIPE_CERTIFY_H
#define LODPIPE_CERTIFY_H

#include <stdint.h>

#include "bvh.h"
#include "geom.h"

/* Depth 6 (up to 4^6 pieces) rather than 4: a placed or creased level often
 * lies near eps from the original along a fold, and only smaller pieces find a
 * single face each. Measured: bunny at 1/64 % with placement 45,573 -> 43,590
 * triangles, fandisk at 1/4 % 446 -> 302, same run time within noise (1.1M
 * chain 31-38 s either way); depth 8 helped fandisk further but doubled its
 * time. */
#define CERT_MAX_DEPTH 6
#define CERT_MAX_WITNESSES 4
#define CERT_MARGIN 1e-9

/* Clusters of originals (registry.h): maximal subtrees of the BVH with at
 * most CERT_CLUSTER_MAX triangles, i.e. compact runs of its triangle order. */
#define CERT_CLUSTER_MAX 32

typedef struct cert_cluster_info {
    double centre[3], radius;  /* a ball holding every vertex of its triangles */
    double axis[3];            /* normal cone: every real normal n has n . axis >= cos(half angle) */
    double cone_sin;           /* sin(half angle), > 1 when there is no cone below 90 degrees */
    uint32_t first, count;     /* tree.triangle_order[first .. first + count - 1] */
    int32_t material;          /* shared by all its triangles; CERT_MIXED when they differ */
} cert_cluster_info;

#define CERT_MIXED INT32_MIN

typedef struct cert_original {
    uint32_t triangle_count;
    const float *positions;          /* borrowed, xyz per vertex */
    const uint32_t *triangles;       /* borrowed, 3 vertices per triangle */
    const int32_t *material;         /* borrowed, per triangle */
    const uint32_t *vertex_offsets;  /* borrowed CSR: triangles around each vertex */
    const uint32_t *vertex_triangles;
    double *normals;                 /* owned: unit normal per triangle (0 when degenerate) */
    uint8_t *degenerate;             /* owned */
    bvh tree;
    cert_cluster_info *clusters;     /* owned */
    uint32_t cluster_count;
    uint32_t *cluster_of;            /* owned: per triangle */
    /* owned: the distinct vertices of cluster c's triangles are
     * cluster_vertices[cluster_vertex_start[c] .. cluster_vertex_start[c + 1] - 1] */
    uint32_t *cluster_vertex_start, *cluster_vertices;
    /* A piece's search for one original holding it walks the triangles
     * around its closest original's corners when they number at most this
     * (CERT_RING_SCAN_MAX), else asks the tree for the ones near the piece:
     * the same answer either way (tests set 0 and UINT32_MAX to compare). */
    uint32_t ring_scan_max;
} cert_original;

#define CERT_RING_SCAN_MAX 48

/* Builds normals, the BVH (with bvh_build_threads: the same tree for any
 * thread count) and the clusters, on up to `threads` threads (the normals
 * beside the tree, the clusters' descriptions shared out): the same result
 * for any thread count. Returns 0, or -1 (out of memory / bad input). */
int cert_original_init(cert_original *o, const float *positions, uint32_t vertex_count,
                       const uint32_t *triangles, uint32_t triangle_count, const int32_t *material,
                       const uint32_t *vertex_offsets, const uint32_t *vertex_triangles, unsigned threads);
void cert_original_free(cert_original *o);

/* A candidate face: its current corners, material group and unit normal. */
typedef struct cert_tri {
    double p[3][3];
    double n[3];
    double lo[3], hi[3]; /* bounding box of p */
    int32_t material;
    int degenerate;
    uint32_t id;
    uint32_t vertex[3]; /* original vertex ids of the corners (a level's vertices are original ones) */
} cert_tri;

/* Fills n, degenerate and the box from p. */
void cert_face_normal(cert_tri *f);

/* Squared distance from p to the box of f (set): a lower bound of
 * d(p, F)^2, the one the tests below prune with. */
double cert_tri_box_distance2(const cert_tri *f, const vec3d *p);

/* (a): 1 when F is certified within eps of O, with *bound the largest
 * accepted value; 0 otherwise. A degenerate F is never certified. First,
 * when F's corners are original vertices at their place and each lies on a
 * witness, the radius of F's minimal enclosing ball (no distance computed:
 * every point of F is that close to a corner); then the original triangles
 * around F's corner vertices as whole-face witnesses (cheap, and usually
 * enough at fine levels), then the BVH. */
int cert_face(const cert_original *o, const cert_tri *f, double eps, double *bound);

/* (a) by the overlay alone (DESIGN.md §4 (a)2), with no subdivision: 1 when
 * it certifies F, with *bound the largest piece-corner distance (plus the
 * rounding slack); 0 otherwise. cert_face tries the subdivision first, which
 * is cheaper but bounds a piece by d + r; the simplifier calls this on the
 * faces that set a level's bound, where the overlay's tighter number counts. */
int cert_face_overlay(const cert_original *o, const cert_tri *f, double eps, double *bound);

/* (b): 1 when original triangle t is certified within eps of the union of
 * faces[0..count-1]; *used receives up to CERT_MAX_WITNESSES distinct face
 * ids (in first-use order), *bound the largest accepted value. 0 otherwise.
 * first[0..first_count-1] are indices into faces to try before the others
 * (t's previous witnesses: usually one of them still holds). */
int cert_cover(const cert_original *o, uint32_t t, const cert_tri *faces, uint32_t count, double eps,
               const uint32_t *first, uint32_t first_count, uint32_t used[CERT_MAX_WITNESSES],
               uint32_t *used_count, double *bound);

/* (b) for a whole cluster with one face: 1 when some face among
 * faces[first[0..first_count-1]], then faces[0..count-1] in order, holds every
 * triangle of cluster c within eps; *face receives its id and *bound the
 * accepted value. The face must be of the cluster's material, not degenerate,
 * and agree with every real normal of the cluster (its normal cone); then
 * either d(centre, F) + radius <= eps (the distance is 1-Lipschitz and the
 * ball holds the triangles), or every vertex of every triangle is within eps
 * of F (the distance to F is convex, so a triangle is within eps when its
 * corners are). Acceptance as in cert_cover. A mixed cluster is never
 * certified whole. */
int cert_cluster(const cert_original *o, uint32_t c, const cert_tri *faces, uint32_t count, double eps,
                 const uint32_t *first, uint32_t first_count, uint32_t *face, double *bound);

/* The invariant checker's re-run of cert_cluster against one face, accepting
 * at d <= limit. */
int cert_cluster_within(const cert_original *o, uint32_t c, const cert_tri *f, double limit);

/* The invariant checker's re-run of (b): is t within `limit` (accepted as
 * d <= limit) of faces[0..count-1] (at most CERT_MAX_WITNESSES), choosing the
 * tightest face for every piece? It accepts wherever cert_cover accepted with
 * a bound <= limit over these faces, so a "no" is a broken invariant. */
int cert_cover_within(const cert_original *o, uint32_t t, const cert_tri *faces, uint32_t count, double limit,
                      double *bound);

#endif
