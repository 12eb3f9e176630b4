/* simplify.h - the certified simplifier: one welded mesh through a ladder of
 * eps values (DESIGN.md §5, §6).
 *
 * Promise. For each level k, every point of the level is within
 * levels[k].bound of the original mesh (the welded triangles, per material,
 * their backs and the weld's dangling triangles, which every level carries as
 * they are, after its faces) and every point of the original is within
 * levels[k].bound of the level:
 * the two-sided Hausdorff distance, in mesh units, certified by certify.h,
 * with bound <= eps_k = fraction_k * diagonal. Each level is simplified from
 * the previous one (its vertices are a subset) and certified against the
 * original, so errors do not add up. When a collapse cannot be certified it
 * is not made; a level that removes nothing is simply equal to the previous.
 * A level's faces come first, then the back faces of those whose triangle
 * has a back (weld.h: the same corners in the other winding, in the back's
 * primitive), then the dangling triangles.
 *
 * How. Half-edge collapses u -> v (v keeps its position and attributes, so
 * nothing is interpolated and all levels can share one vertex buffer), legal
 * by the vertex kinds of weld.h, the link condition, a degree floor, the
 * flip guard and a self-intersection test (no new face may cross a face of
 * the level that the faces it replaces did not already meet, so crossings the
 * input has move with their faces and no others appear: tested where the
 * original is thin, thin.h, or everywhere in strict mode, DESIGN.md §5);
 * ordered by a position quadric, ranked again
 * after each pass has evaluated the cheapest quarter; evaluated in batches whose
 * neighbourhoods are disjoint, certified in parallel and committed in a fixed
 * order, so the result does not depend on the thread count. A rejected
 * candidate is retried only after its neighbourhood changes.
 *
 * Region rounds. A level of a large mesh begins with rounds in which the
 * alive vertices are cut into the cells of a cubic grid (regions of about
 * 4,096 vertices) and each region is simplified by one thread on its own:
 * its interior vertices (those whose 2-ball lies in it) in cost order from a
 * priority queue, each candidate evaluated exactly as in the passes and
 * committed at once, up to three quarters of them; the next round shifts
 * the grid by half a cell. A region changes only the faces it owns (all
 * three vertices in it) and defers a candidate that would need anything
 * else; faces of other regions lie in other cells and cannot cross its
 * faces. The regions of a round are independent, so the result does not
 * depend on which thread runs which, nor on the thread count. The passes
 * then finish the level.
 *
 * Vertex removal (Cohen et al.). When the passes have converged, each
 * interior vertex whose ring has 4 to 10 corners, one primitive and no seam
 * is removed with another triangulation of its hole than a collapse's fan
 * (holefill.h): the cheapest few by distance to the removed vertex, each made
 * in place, put through the same flip guard, crossing test and two-sided
 * certificate, then kept or undone; serially, so deterministic. The passes
 * then resume around what changed. No vertex moves and no attribute is made:
 * the new faces take the ring vertices' wedges, so levels still nest.
 *
 * Full-edge placement (options.full_edge_levels): on those levels, when the
 * half-edge collapse of an edge between two interior vertices of one wedge
 * class is not certified, it is tried once more with v moved to the
 * quadric's minimizer (float32, as written); the faces around u and v are
 * then all changed faces, tested and certified the same way. Such levels,
 * and every later one, carry their vertex positions (simplify_level.
 * positions); v keeps its attributes. */
#ifndef LODPIPE_SIMPLIFY_H
#define LODPIPE_SIMPLIFY_H

#include <stdint.h>

#include "status.h"
#include "weld.h"

#define SIMPLIFY_MAX_LEVELS 16
/* A vertex with more faces around it than this is a hub: it and its
 * neighbours are held at every level (simplify.c says why) */
#define SIMPLIFY_HUB_FACES 4096
/* A vertex rejected with more faces around it than this is tried again only
 * once an eighth of them are gone, until the level's last pass (simplify.c:
 * retry_due) */
#define SIMPLIFY_PATIENT_FACES 64

typedef struct simplify_options {
    const double *fractions;  /* eps_k / diagonal, increasing, level_count of them */
    uint32_t level_count;
    uint32_t threads;         /* 0: one per online core */
    double flip_cos;          /* reject when a changed face's normal turns to cos <= this (0.25) */
    int verify;               /* re-check the invariants after every commit, the certificate's
                                 early rejections against its full test, and every batch
                                 reservation against a walk of the candidate's 2-ball (slow) */
    int strict_intersections; /* self-intersection test everywhere, not only where the original is thin */
    uint32_t full_edge_levels;/* bit k: level k may use full-edge placement (0: half-edge only) */
    uint32_t region_vertices; /* vertices per region of the region rounds (0: the default; for tests) */
    uint32_t hub_faces;       /* more faces than this around a vertex make it a hub, held with its
                                 neighbours (simplify_result.held_vertices); no collapse makes one
                                 (0: SIMPLIFY_HUB_FACES; another value for tests) */
    uint32_t patient_faces;   /* retry_due's patience above this many faces (0: SIMPLIFY_PATIENT_FACES;
                                 another value for tests) */
} simplify_options;

enum {
    SIMPLIFY_REJECT_KIND,     /* vertex kind or edge type forbids it */
    SIMPLIFY_REJECT_LINK,     /* link condition or degree floor */
    SIMPLIFY_REJECT_FLIP,     /* a face would turn too far or become degenerate */
    SIMPLIFY_REJECT_INTERSECT,/* a new face would cross a face of the level that the replaced faces did not meet
                                 (tested after the certificate: a collapse failing both counts as COVER or FACE) */
    SIMPLIFY_REJECT_COVER,    /* (b): an original would not stay within eps */
    SIMPLIFY_REJECT_FACE,     /* (a): a new face would leave eps of the original */
    SIMPLIFY_REJECT_CONFLICT, /* an earlier commit of the batch changed its data: retried */
    SIMPLIFY_REJECT_COUNT
};

typedef struct simplify_stats {
    uint64_t candidates;      /* vertices evaluated */
    uint64_t attempts;        /* (u, v) pairs evaluated */
    uint64_t commits;
    uint64_t rejected[SIMPLIFY_REJECT_COUNT];
    uint32_t passes, batches;
    /* originals certified in clusters (certify.h): clusters registered whole
     * by the between-pass sweep, split back by a collapse, whole at the end */
    uint64_t cluster_merges, cluster_splits;
    uint32_t clusters_whole;
    /* the main thread's time: choosing candidates and reserving batches
     * (the workers evaluate the reserved candidates meanwhile), finishing a
     * batch's evaluation once it is complete, committing; and the level's
     * whole time */
    double seconds_select, seconds_certify, seconds_commit, seconds;
    /* vertices removed with another triangulation of their hole than a
     * collapse's fan, and the time of those sweeps (serial, at the end of
     * each round of passes) */
    uint64_t removals;
    double seconds_removal;
    /* options.verify: the invariant checks made (after every commit, every
     * cluster sweep and the level's end), all passed; 0 without verify */
    uint64_t verify_checks;
    /* region rounds (simplify.c) run at the level's start, the commits made
     * in them (also counted in commits), the candidates a region left to a
     * later round or to the global passes (counted again when tried again),
     * and their time */
    uint32_t rounds;
    uint64_t region_commits, deferred;
    double seconds_regions;
} simplify_stats;

typedef struct simplify_level {
    double eps;                 /* absolute */
    double bound;               /* certified two-sided bound, <= eps */
    uint32_t triangle_count;    /* faces, their back faces, then the weld's dangling_count triangles */
    uint32_t *wedges;           /* 3 weld wedges per triangle */
    uint32_t *primitive;        /* per triangle: index into the mesh's primitives */
    /* NULL while every vertex is where the weld put it; else, once a level
     * with full-edge placement has moved a vertex, this level's position of
     * every weld vertex (3 floats each; the certificate used exactly these) */
    float *positions;
    simplify_stats stats;
} simplify_level;

typedef struct simplify_result {
    double diagonal;
    double seconds_setup; /* before the first level: BVH, clusters, quadrics, lists */
    /* vertices no level removes because they are, or neighbour, a hub (a
     * fan from one point: more than options.hub_faces faces around it): the
     * collapses next to one would each read all its faces */
    uint32_t held_vertices;
    double seconds_weld;  /* set by the caller that welded the mesh (0 otherwise) */
    uint32_t level_count;
    simplify_level levels[SIMPLIFY_MAX_LEVELS];
} simplify_result;

/* primitive_material[p]: the material of the mesh's primitive p (-1: none);
 * faces are certified only against original triangles of their material,
 * and a face with a back (weld.h) only against triangles with a back of the
 * same material, so that its back face holds, mirrored, for the backs.
 * Returns LP_OK, LP_INVALID (out of memory) or LP_PROMISE (the invariant
 * checker found a broken invariant: a bug, reported rather than written).
 * w is read only, except that its triangle_wedges array is taken over (the
 * simplifier's corner wedges start as it and change in place; a copy would
 * cost 12 bytes a triangle at the memory peak): w->triangle_wedges is NULL
 * afterwards, whatever the result. The levels' wedges are in out. */
int simplify_mesh(weld_result *w, const int64_t *primitive_material, const simplify_options *options,
                  simplify_result *out, lp_error *err);
void simplify_result_free(simplify_result *r);

#endif
