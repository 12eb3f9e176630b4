/* weld.h - welding: one topology per mesh, the first step of the certified
 * simplifier (DESIGN.md §3 "Welding", §5).
 *
 * A glTF mesh is a list of primitives, each with its own vertex arrays; the
 * same point of the surface is usually stored several times (once per
 * material, per UV island, per normal crease). The simplifier needs one
 * connected surface with the attribute discontinuities marked, so this module
 * welds every triangle primitive of one scene_mesh BY EXACT POSITION into:
 *
 * - position vertices: the distinct positions (float xyz, bitwise equal after
 *   -0.0 is read as +0.0; the stored value has +0.0) used by a kept triangle,
 *   numbered by first appearance (primitives in order, then triangles in
 *   order, then corners 0, 1, 2);
 * - wedges: one per (primitive, glTF vertex index) used by a kept triangle,
 *   numbered by first appearance the same way. A wedge carries the attributes
 *   (it IS a glTF vertex); output index buffers point at wedges. Wedges whose
 *   attribute VALUES are equal (every stream, compared bitwise with -0.0 ==
 *   +0.0) in the same primitive at the same position form a wedge class; the
 *   class id is the lowest wedge number of the class. Morph target deltas
 *   are not in the scene model's streams and are not compared;
 * - triangles: 3 wedges + 3 position vertices each + the primitive they came
 *   from (whose material they have). Triangles that are degenerate BY INDEX
 *   after welding (two corners on one position vertex) are dropped and
 *   counted; zero-area triangles with three distinct positions are kept.
 *   A dropped triangle whose segment (or point) is not an edge (vertex) of a
 *   kept triangle is "dangling": it may lie off the welded surface, where no
 *   simplified face could be certified to stay near it. Dangling triangles
 *   are kept BESIDE the topology (dangling_*), as they are: every level
 *   carries them unchanged, so they are covered by themselves, and their
 *   position vertices are LOCKED (never removed, never moved) so that they
 *   stay valid in every level. Their positions and wedges that no kept
 *   triangle uses are numbered after all the kept triangles' ones, by first
 *   appearance among the dangling triangles; such vertices have no triangle
 *   in the adjacency (an empty range) and such wedges are their own class;
 * - back faces: a kept triangle whose three position vertices are an earlier
 *   kept triangle's in the opposite winding is that triangle's BACK (a
 *   double-sided sheet modelled as two coincident layers, as exporters and
 *   some games' foliage cards do; the back may have its own vertices,
 *   primitive and material). Backs are taken out of
 *   the topology, which would otherwise see four triangles on every edge and
 *   lock the whole sheet; each front triangle has at most one back, the
 *   earliest unpaired one (input order). The front of a pair is then chosen
 *   again so that neighbouring fronts agree in winding (both sides shuffled
 *   together in one primitive still give one oriented layer; the first pair
 *   of each connected part keeps its front; a pair over two primitives is
 *   never turned). Only a triangle on a non-manifold
 *   edge can be a front or a back: a pair that shares its edges with no other
 *   triangle (a lone two-sided triangle, a closed "pillow") stays in the
 *   topology, where it is a closed surface of its own (and a mesh without a
 *   non-manifold edge is welded as before, at no cost). A level gives every face whose
 *   triangle has a back a back face: the same corners in the opposite
 *   winding, in the back's primitive, each corner the back layer's wedge
 *   that faces of the front's wedge class there use (weld_back_wedge). As
 *   point sets the back layer of a level IS its front layer, and the
 *   original's back layer its front layer; the simplifier certifies faces
 *   with a back only against originals with a back of the same material
 *   (simplify.h), so the levels' certificates hold for the back faces, per
 *   material and facing, by symmetry. Two rules keep the back
 *   layer where it was: a vertex where triangles of one primitive with a back
 *   meet triangles of that primitive without one, or with backs of another
 *   primitive, is LOCKED (so a face never grows over ground whose back was
 *   different; where the front primitive changes as well, the seam keeps
 *   each side on its ground); and when the
 *   back layer's wedge at some vertex is not decided by the front's wedge
 *   class there and the back primitive (the back has an attribute seam the
 *   front lacks), the pairs with a corner there are no backs: both stay in
 *   the topology (their edges non-manifold: locked, kept), and the other
 *   pairs stay backs (no corner of theirs has that key, so none conflicts);
 * - adjacency: for each position vertex the triangles around it (CSR), and
 *   for each triangle edge the opposite edge, or a border / non-manifold
 *   marker, plus a seam flag;
 * - a kind for each position vertex (below) and statistics.
 *
 * Edges. Edge e of triangle t is numbered 3t + e; it runs from corner e to
 * corner (e + 1) % 3 (so it starts at corner 3t + e of the corner arrays).
 * An undirected edge used by one triangle is a border edge; used by exactly
 * two triangles in opposite directions it is a manifold interior edge and
 * each side's opposite is the other; used by more than two triangles, or by
 * two in the same direction (inconsistent orientation), it is non-manifold.
 * A manifold interior edge is a SEAM edge when the two triangles across it
 * disagree on the attribute values at either end (their wedges at that end
 * are in different classes); triangles of different primitives always
 * disagree, so a change of material is a seam. Mirrored UVs (same position
 * and normal, different UV) are therefore seams too.
 *
 * Vertex kinds. The umbrella of a vertex is its incident triangles; a fan is
 * a maximal sequence of them joined by manifold interior edges around it.
 * Across a seam edge at v the attribute change may be at v itself (v's own
 * wedge class differs on the two sides) or only at the far end (e.g. the
 * ring around a UV sphere's pole: every spoke is a seam because the pole has
 * one wedge per triangle, but the ring vertex has one value).
 *
 *   kind      when                                                  may move (half-edge collapse
 *                                                                   onto a neighbour)
 *   MANIFOLD  one closed fan, one wedge class (identical attribute  onto any neighbour across a
 *             values, one primitive) all around                     non-seam edge
 *   BORDER    one open fan (it lies on exactly one boundary loop),  only along one of its two
 *             one wedge class                                       border edges
 *   SEAM      one closed fan, exactly two seam edges, its class     only along one of its two seam
 *             changes across both (two wedge classes): the values   edges, moving the wedges on
 *             or the material change along one line through it      both sides together
 *   LOCKED    everything else: a non-manifold edge at it, several   never
 *             fans (bow-tie, pinch), a border vertex on a seam,
 *             three or more seam edges with its class changing
 *             (seams crossing, three materials meeting)
 *
 * Collapse rules in words: manifold onto anything, border only along its
 * border, seam only along its seam (both wedges together), locked never
 * moves. weld_collapse_allowed() is this table. One refinement of "onto
 * anything": a MANIFOLD (or BORDER) vertex with a seam edge whose change is
 * at the far end (the pole ring above) must not collapse along THAT edge:
 * its remaining triangles would each need one of the far end's two wedges,
 * and no choice keeps the discontinuity where it was; every other edge is
 * fine. LOCKED is the kind for anything unclear: it only costs reduction,
 * never correctness. A geometric corner of a border or seam line (the line
 * bends) is NOT locked here; the certificate (DESIGN.md §4: border chords,
 * per-material certification) decides whether it may be cut.
 *
 * Memory and time: every output array is one allocation (sized after a
 * counting pass); scratch is a few arrays and two open-addressing hash
 * tables (positions, wedge classes), each sized once for a load of at most
 * 1/2; edges are paired per vertex from the vertex-triangle lists (a sort of
 * each vertex's edges, d log d for a vertex of degree d). No per-element
 * allocation. O(n log d) expected time in the number of corners plus
 * attribute components. The result depends on nothing but the
 * input (fixed hash functions, fixed iteration order), not on addresses,
 * threads or earlier calls. No global state: threads may weld different
 * meshes at once (the scene is only read). A large mesh's topology (wedge
 * classes, edge pairing, seams, kinds) is built on up to the given number
 * of threads, each writing its own range of the arrays: the same result. */
#ifndef LODPIPE_WELD_H
#define LODPIPE_WELD_H

#include <stdint.h>

#include "scene.h"
#include "status.h"

typedef enum weld_kind {
    WELD_MANIFOLD = 0,
    WELD_BORDER = 1,
    WELD_SEAM = 2,
    WELD_LOCKED = 3,
    WELD_KIND_COUNT = 4
} weld_kind;

/* edge_opposite markers (every real edge number is below both). */
#define WELD_EDGE_IS_BORDER UINT32_MAX
#define WELD_EDGE_IS_NONMANIFOLD (UINT32_MAX - 1u)

/* edge_flags bits; a manifold interior non-seam edge has flags 0. */
#define WELD_FLAG_SEAM 1u
#define WELD_FLAG_BORDER 2u
#define WELD_FLAG_NONMANIFOLD 4u

/* Largest number of input triangles (over the welded primitives) and of
 * glTF vertices (summed over them) weld_build accepts. */
#define WELD_MAX_TRIANGLES 0x50000000u
#define WELD_MAX_VERTICES 0xF0000000u

typedef struct weld_stats {
    uint32_t primitives;           /* triangle primitives welded */
    uint32_t input_triangles;      /* triangles of those primitives */
    uint32_t triangles;            /* in the topology = input - degenerate - back */
    uint32_t degenerate_triangles; /* dropped: two corners on one position vertex */
    uint32_t degenerate_dangling;  /* of those, ones whose segment/point is not
                                      an edge/vertex of a kept triangle (see weld.c):
                                      kept beside the topology, = dangling_count */
    uint32_t vertices;             /* position vertices */
    uint32_t wedges;
    uint32_t wedge_classes;        /* distinct (position, primitive, attribute values) */
    uint32_t vertices_by_kind[WELD_KIND_COUNT];
    uint32_t wedges_by_kind[WELD_KIND_COUNT]; /* by the kind of their position vertex */
    uint32_t edges;                /* undirected */
    uint32_t border_edges;
    uint32_t nonmanifold_edges;
    uint32_t seam_edges;
    uint32_t nonmanifold_vertices; /* several fans meet there (bow-tie, pinch) */
    uint32_t back_triangles;       /* kept triangles taken out as backs, = back_count */
} weld_stats;

typedef struct weld_result {
    /* position vertices */
    uint32_t vertex_count;
    float *positions;                  /* 3 per vertex */
    uint8_t *vertex_kind;              /* weld_kind */
    uint32_t *vertex_triangle_offsets; /* vertex_count + 1 */
    uint32_t *vertex_triangles;        /* 3 * triangle_count; ascending per vertex */

    /* wedges (= the glTF vertices used) */
    uint32_t wedge_count;
    uint32_t *wedge_primitive; /* index into scene_mesh.primitives */
    uint32_t *wedge_index;     /* vertex index in that primitive */
    uint32_t *wedge_vertex;    /* position vertex */
    uint32_t *wedge_class;     /* lowest wedge with the same position, primitive and values */

    /* triangles (corner 3t + c) and their edges (edge 3t + e, corner e -> e + 1) */
    uint32_t triangle_count;
    uint32_t *triangle_wedges;    /* 3 per triangle (simplify_mesh takes it over: NULL afterwards) */
    uint32_t *triangle_vertices;  /* 3 per triangle, = wedge_vertex[triangle_wedges[..]] */
    uint32_t *triangle_primitive; /* 1 per triangle */
    uint32_t *edge_opposite;      /* 3 per triangle: opposite edge or a WELD_EDGE_IS_ marker
                                     (NULL after weld_release_edge_opposite) */
    uint8_t *edge_flags;          /* 3 per triangle: WELD_FLAG_ bits */

    /* dangling dropped triangles (above), in input order: not part of the
     * topology, carried by every level as they are */
    uint32_t dangling_count;
    uint32_t *dangling_wedges;    /* 3 per triangle */
    uint32_t *dangling_vertices;  /* 3 per triangle, = wedge_vertex[dangling_wedges[..]] */
    uint32_t *dangling_primitive; /* 1 per triangle */

    /* back faces (above): taken out of the topology, in input order */
    uint32_t back_count;
    uint32_t *back_wedges;     /* 3 per back triangle, in its own winding */
    uint32_t *back_primitive;  /* 1 per back triangle */
    uint32_t *triangle_back;   /* per triangle: its back, or WELD_NO_BACK; NULL when back_count is 0 */
    /* the back layer's wedge for a front corner: sorted keys
     * (front wedge class << 32 | back primitive) and the wedge of each */
    uint32_t back_map_count;
    uint64_t *back_map_key;
    uint32_t *back_map_wedge;

    weld_stats stats;
} weld_result;

#define WELD_NO_BACK UINT32_MAX

/* Welds every primitive of `mesh` that is not skipped and has triangles (its
 * mode is 4..6; scene_load expanded strips and fans) into `out`, as described
 * above. `out` borrows nothing from `mesh`: attribute values stay in the
 * scene and are reached through wedge_primitive / wedge_index.
 * Returns LP_OK, or LP_INVALID with a message naming the mesh when a triangle
 * index is out of range, a primitive lacks positions, the mesh is larger than
 * WELD_MAX_*, or memory runs out; `out` is then empty (safe to weld_free).
 * `threads` is a "threads" option (threads.h: 0 is one per core), the
 * simplifier's own. */
int weld_build(const scene_mesh *mesh, uint32_t threads, weld_result *out, lp_error *err);

/* The back layer's wedge for a face corner whose front wedge has class
 * front_class, on a face whose back is in primitive back_primitive; NONE
 * (UINT32_MAX) when the original has no such corner. */
uint32_t weld_back_wedge(const weld_result *w, uint32_t front_class, uint32_t back_primitive);

/* Triangles of level 0 as the levels count them: the topology's, their
 * backs and the dangling ones. */
uint32_t weld_level0_triangles(const weld_result *w);

/* Frees every array of `w` and zeroes it. Safe on a zeroed or freed result. */
void weld_free(weld_result *w);

/* Frees edge_opposite and sets it to NULL; everything else stays. The weld
 * needs the pairing to find fans and seams (edge_flags and the vertex kinds
 * keep what it found); the simplifier and the writers never read it, so a
 * caller that keeps the result alive through simplification drops it first
 * (12 bytes a triangle). Safe to call twice. */
void weld_release_edge_opposite(weld_result *w);

/* The collapse rule table: may a vertex of kind `kind` be collapsed (half-
 * edge collapse, the vertex disappears into the other end) along an edge
 * whose edge_flags are `flags`? MANIFOLD: along a manifold non-seam edge
 * (flags 0); BORDER: along a border edge; SEAM: along a seam edge (one of
 * its two); LOCKED: never. Non-manifold edges: never. This says what the
 * kinds allow; the simplifier still runs the link condition (DESIGN.md §5)
 * and the certificate. */
int weld_collapse_allowed(weld_kind kind, uint8_t flags);

/* "manifold", "border", "seam", "locked" (or "?"). */
const char *weld_kind_name(weld_kind kind);

#endif
