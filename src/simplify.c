/* simplify.c - the certified simplification loop; see simplify.h.
 *
 * Follows DESIGN.md §6: candidates ordered by a Garland-Heckbert quadric; a
 * sweep builds batches of candidates whose 3-rings are disjoint (Ramsey et
 * al.'s independent sets), the batch is certified on all cores against a
 * snapshot, and commits run serially in cost order. The cheap, necessary
 * tests run first (kinds, link condition, degree floor, flip guard), then the
 * certificate: (b) the originals whose registration a change touches, then
 * (a) the changed faces (certify.h).
 *
 * The main loop, per level and pass:
 *   collect_candidates (parallel) -> rank the cheapest share -> while
 *   unprocessed: reserve a batch
 *   (serial; the workers evaluate each candidate as soon as it is reserved)
 *   -> batch_close (the rest of the evaluation, parallel) -> process_batch
 *   (commits, serial, in order; a helper thread applies their face-grid
 *   updates meanwhile, gridlog.h)
 */
#include "simplify.h"

#include <math.h>
#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "certify.h"
#include "clock.h"
#include "facegrid.h"
#include "gridlog.h"
#include "geom.h"
#include "holefill.h"
#include "intersect.h"
#include "keymap.h"
#include "quadric.h"
#include "radix.h"
#include "registry.h"
#include "thin.h"
#include "threads.h"
#include "workpool.h"

#define NONE UINT32_MAX
#define GRIDLOG_RING 4096   /* grid updates in flight (about 100 bytes each) */
#define BATCH_SIZE 512      /* fixed: the result must not depend on the thread count */
/* The pool's helpers (workpool.h) are woken for a batch once this many
 * candidates are reserved: a lone candidate cannot be shared. Which thread
 * evaluates changes nothing in the result. The grid's updates get a helper
 * thread of their own (gridlog.h) only for a batch this large: starting a
 * thread costs about as much as evaluating ten small candidates (when the
 * evaluations too started threads per batch, 500 meshes of 96 triangles took
 * 24 s on two threads, 16 s of it in the kernel, 5.5 s on one). */
#define BATCH_PARALLEL_MIN 2
#define GRIDLOG_PARALLEL_MIN 64
#define TARGETS_TRIED 3     /* cheapest legal targets tried per candidate */
#define MAX_CANDIDATE_FACES 384
/* A pass evaluates the cheapest quarter of its candidates (at least
 * PASS_MIN), then the rest are ranked again: the order is computed when the
 * pass starts, and every commit changes the costs around it, so a pass that
 * went through all candidates would make its expensive collapses on stale
 * costs, before cheap ones its own commits opened. Measured over the 28
 * single levels of the quality tables (bunny, fandisk, rocker-arm, igea at
 * 1/64 .. 1 %): 0.7 % fewer triangles in geometric mean, the bunny 1.7 %
 * (1/16 %: 10,981 -> 10,813; 1/8 %: 4,876 -> 4,765); a quarter did better
 * than a half (0.4 %) or 0.35 (0.5 %). The price is selection: more passes
 * each rank every candidate again; on the 1.1M chain, six interleaved pairs
 * against the full passes gave 15.4-15.7 -> 16.4-16.9 s (selection 3.0 -> 4.0
 * s, certificate 6.1 -> 5.7 s), two earlier pairs 13.3 -> 12.6 s. */
#define PASS_SHARE 4
#define PASS_MIN 16
/* A backstop, not a stopping rule: every pass commits or rejects at least one
 * candidate, and a rejected one returns only after a commit near it, so the
 * passes end by themselves; the most any level of the quality tables needed
 * was 478 (fandisk at 1 %, whose 1 % level the old cap of 400 had cut
 * short). */
#define MAX_PASSES 100000
#define MAX_THREADS 64
/* Hubs: a vertex with more faces around it than SIMPLIFY_HUB_FACES
 * (simplify.h) is a hub (a fan from one point: a cone's apex, a disc
 * triangulated from its centre, the pole of a sphere of that many
 * segments): it and its neighbours are held for the
 * whole ladder, and no collapse or removal gives a vertex more faces. Every
 * collapse next to a hub makes faces that meet all of its faces at the hub,
 * which the certificate and the intersection test look at, and the batches
 * take such collapses one at a time (each one's footprint holds the hub),
 * so a cone of n faces cost about n squared: 1.2 s for 4,000 faces, 6.7 s
 * for 10,000, and one of 100,000 had not finished after 7 minutes (now 0.15
 * s, kept whole). The price is that such a fan stays whole: a UV sphere of
 * 8,000 segments and 6 rings (80,000 triangles) keeps 32,156 triangles at 1
 * %, against 136 before, in 13 s against 27. A sphere of 2,000 segments is
 * below the limit and simplified as before (232 triangles at 1 %). */
enum { HELD_NEIGHBOUR = 1, HELD_HUB = 2 };
/* an evaluation's outcome besides SIMPLIFY_REJECT_*: in a region, the
 * candidate needs what another region may change; it waits for a round
 * with other boundaries, or for the global passes */
#define REJECT_DEFERRED SIMPLIFY_REJECT_COUNT
/* doubles per changed face in a thread's arena: bound, box lo xyz, box hi
 * xyz, and the box before the collapse (lo xyz, hi xyz) */
#define CHANGED_RECORD 13

/* ---- growable scratch arrays (per thread; grown, never shrunk) ------------- */

typedef struct u32vec {
    uint32_t *data;
    size_t size, cap;
} u32vec;

typedef struct f64vec {
    double *data;
    size_t size, cap;
} f64vec;

static int grow(void **data, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap) return 0;
    size_t cap2 = *cap ? *cap : 64;
    while (cap2 < need) cap2 *= 2;
    void *p = realloc(*data, cap2 * elem);
    if (!p) return -1;
    *data = p;
    *cap = cap2;
    return 0;
}

/* Inline with the room test first (so is f64_push): the walks of the
 * neighbourhoods and the certificate's records push millions of values,
 * nearly all into room already there. */
static inline __attribute__((always_inline)) int u32_push(u32vec *v, uint32_t x)
{
    if (v->size == v->cap && grow((void **)&v->data, &v->cap, v->size + 1, sizeof *v->data)) return -1;
    v->data[v->size++] = x;
    return 0;
}

static inline __attribute__((always_inline)) int f64_push(f64vec *v, double x)
{
    if (v->size == v->cap && grow((void **)&v->data, &v->cap, v->size + 1, sizeof *v->data)) return -1;
    v->data[v->size++] = x;
    return 0;
}

/* One neighbour x of the candidate vertex u: the faces on edge (u, x). */
typedef struct neighbour {
    uint32_t x;
    uint32_t count;     /* faces containing u and x */
    uint32_t forward;   /* of those, faces where the edge runs u -> x */
    uint32_t face[2];
    int seam;           /* interior edge whose attributes or material change across it */
    int class_change_at_u;
    int full;           /* full-edge placement allowed on this edge (place is the new position) */
    double place[3];
    double cost;
    double length2; /* squared length of the edge u - x: the order among equal costs */
} neighbour;

/* Stars committed (the alive faces of each, and its box): per star i its
 * faces are faces[end[i - 1] .. end[i] - 1] and its box box[6 i ..], lo then
 * hi. A later candidate's new faces were not tested against these faces
 * where they are now: the batch's commits re-test them (crosses_stars). */
typedef struct star_list {
    u32vec faces, end;
    f64vec box;
} star_list;

struct region;

typedef struct scratch {
    /* the region being run (region_round), NULL in the global passes: an
     * evaluation then reads and writes only what that region owns this
     * round, and sets deferred when it would need anything else */
    const struct region *region;
    int deferred;
    u32vec faces_u, faces_v, nbr_v, ring, cand_faces, recheck, changed;
    neighbour *nb;
    size_t nb_size, nb_cap;
    cert_tri *tris;
    size_t tris_cap;
    /* the changed faces after the collapse being tried (changed's order),
     * with normals and boxes: made once by flip_ok for the tests after it */
    cert_tri *after;
    size_t after_cap;
    double *before_box; /* 6 per changed face: its box before (lo, hi), also from flip_ok */
    size_t before_box_cap;
    /* the faces the change being tested replaces, as they are before it
     * (corners and boxes): a face they already cross may go on crossing the
     * new ones (star_crosses) */
    cert_tri *replaced;
    size_t replaced_count, replaced_cap;
    uint32_t *vertex_seen; /* stamps, sized nv */
    keymap faces;          /* candidate faces seen -> index in cand_faces (NONE: over the cap) */
    keymap origs;          /* originals already in recheck */
    keymap nb_index;       /* neighbour x -> its entry in nb, once nb outgrows NB_SCAN_MAX */
    uint32_t stamp;
    /* results of the candidates this thread evaluated */
    u32vec out_u32;
    f64vec out_f64;
    int oom;
    /* with verify: a vertex whose collapse cover_doomed rejected and the
     * (b) loop accepted (NONE: none) */
    uint32_t doomed_passed;
} scratch;

#define REGION_SHARED UINT32_MAX

/* The faces a region owns, in a grid of their own for its crossing tests
 * (numbered locally: their index in faces), kept current by its commits.
 * Made at the region's first crossing test (ready): the tests run only
 * where the original is thin, and most regions never make one (measured on
 * the 1.1M-triangle chain: 139 of 220), so their commits keep no grid. It
 * is not built again with larger cells as its faces grow: with the boxes,
 * a face the coarser cells report costs a box test, and the rebuilds cost
 * more than they saved (ir.sh 15.160 -> 15.080 G, with 3x cells). */
typedef struct own_grid {
    facegrid grid;
    u32vec faces; /* local number -> face */
    /* local number -> its face's box now (lo, hi; set for the alive ones):
     * crosses_local turns away most of what the grid reports with it, before
     * crosses reads the corners */
    f64vec box;
    keymap local; /* face -> local number */
    int ready;
} own_grid;

/* One region of a round (region_round): the alive vertices in one cell of
 * the round's grid, simplified by one thread with evaluations and commits
 * in turn, while other threads run other regions. What it changes is its
 * own: its clock (the stamps its commits write start at the round's), its
 * grid of faces, its statistics and the count of faces that died. */
typedef struct region {
    uint32_t id;
    uint32_t begin, end;     /* its vertices: spatial[begin .. end) */
    uint32_t clock;
    own_grid *own;           /* its thread's, while it runs */
    const facegrid *shared;  /* the round's grid of the faces no region owns */
    simplify_stats stats;
    uint32_t faces_died;
    int failed; /* out of memory, or a broken invariant (verify) */
} region;

typedef struct candidate {
    uint32_t u, v;      /* v == NONE: rejected */
    int moved;          /* full-edge collapse: v moves to place */
    double place[3];
    int thin;           /* star_is_thin of the accepted collapse (the commit re-tests crossings only then) */
    int reason;
    uint32_t thread;
    size_t u32_off, f64_off;
    uint32_t changed_count, recheck_count;
    uint32_t attempts;
    double cost;
} candidate;

/* The next level's thin map, built on a thread of its own while this level
 * runs (thin_ahead_start). */
typedef struct thin_ahead {
    const struct sim *s;
    double radius;
    thin_map map;
    int rc;      /* thin_map_build's */
    int running; /* the thread is to be joined */
    pthread_t thread;
} thin_ahead;

typedef struct sim {
    const weld_result *w;
    uint32_t nv, nf;
    /* current vertex positions: the weld's, or once full-edge placement is
     * allowed, a copy that full-edge collapses move (moved_positions) */
    const float *positions;
    float *moved_positions;
    uint32_t full_edge_levels; /* bit k: level k may place vertices */
    int full_edge;             /* this level may */
    int moved_any;             /* a vertex has moved: levels carry positions */
    int32_t *face_material;
    uint32_t *corner_vertex, *corner_wedge, *corner_next;
    uint8_t *face_alive;
    double *face_bound;
    /* per unit of registration (registry.h): original t is unit t, cluster c
     * unit nf + c; its certified bound and the batch that last changed it */
    double *unit_bound;
    uint32_t *unit_stamp;
    /* bit c % 64 of word c / 64: one of cluster c's originals was
     * re-registered, try it whole again (words: a pass's sweep over a mesh's
     * clusters skips 64 clean ones at a time) */
    atomic_uint_least64_t *cluster_dirty;
    uint32_t *vertex_first;
    uint8_t *vertex_alive;
    /* the alive vertices that are not locked, ascending: the passes late in
     * a level would otherwise scan every vertex of the original for a few
     * candidates (compacted as vertices die) */
    uint32_t *movable, movable_count;
    /* a rejected candidate waits until its neighbourhood changes: commits
     * are numbered (commit_clock); change_stamp[x] is the last commit that
     * changed a face around x, reject_stamp[u] the clock when u was rejected
     * (NONE: not rejected), removal_stamp[u] the clock when no triangulation
     * of u's hole was certified (NONE: not tried this level; allocated by
     * the first removal sweep, after the first pass's memory peak) */
    uint32_t *change_stamp, *reject_stamp, *removal_stamp;
    /* per vertex: its faces when it was last rejected (saturated), for
     * retry_due's patience with a vertex of many faces; patient: the passes
     * apply that patience (0 for one pass before the level may end) */
    uint16_t *reject_faces;
    uint32_t patient_faces;
    int patient;
    size_t held_back; /* the last collect_candidates' held back candidates */
    uint32_t commit_clock;
    /* the passes' ordering cost of each vertex (collect_candidates), kept
     * from one pass to the next: cost_clock[u] is the clock it was computed
     * at (NONE: never), cost_faces[u] how many faces u had then. Allocated
     * by the first pass, after the first level's memory peak. */
    double *cost;
    uint32_t *cost_clock, *cost_faces;
    /* batch reservations (reserve_footprint): the batch_stamp of the batch
     * whose W holds the vertex, and of the batch whose W holds it or one of
     * its neighbours that is not a hub. Allocated by the first pass (the
     * region rounds reserve nothing). */
    uint32_t *vertex_stamp, *near_stamp;
    uint32_t batch_stamp;
    quadric *quadrics;
    double origin[3];
    /* every alive face, for the self-intersection test of the global
     * passes; rebuilt when the faces have halved, so cells follow the faces'
     * growing size. Built when a level's first pass needs it (grid_current
     * 0), or after the region rounds, which fill it with the faces no
     * region owns (each round's shared grid): one built at the level's
     * start would be thrown away unread. Rebuilt in place (facegrid_reset),
     * so its pages are faulted in once per mesh, not at every rebuild. */
    facegrid grid;
    gridlog grid_log; /* the commit's updates of grid (gridlog.h) */
    uint32_t grid_built_with;
    int grid_current; /* grid holds the level's alive faces as they are */
    /* ascending, the faces that were alive when it was last compacted
     * (live_faces): a superset of the alive faces, since faces only die.
     * The sweeps over faces late in a level (a grid's rebuild, the level's
     * snapshot) visit these, not every face of the original. NULL until
     * the first sweep. */
    uint32_t *face_list, face_list_count;
    uint32_t faces_alive; /* count of face_alive */
    /* the stars committed in the current batch, for the commit's re-test of
     * crossings, which concerns only these faces */
    star_list batch_stars;
    /* The region phase (region_round). Per vertex its region this round
     * and whether it is interior (its 2-ball lies in its region); per face
     * its owner: the region that holds all three of its vertices, else
     * REGION_SHARED (no region changes it this round). spatial holds the
     * alive vertices (spatial_count of them), grouped by region; region_cell
     * is the first round's cell size, for region_alive0 alive vertices. */
    uint32_t *region_of, *face_owner, *spatial;
    uint32_t *queued; /* per vertex: the version of its latest entry in its region's queue */
    uint32_t *queued_to; /* per vertex: the neighbour whose edge gave that entry's cost (NONE: none) */
    uint32_t spatial_count, region_alive0;
    double region_cell;
    uint8_t *interior;
    /* what each thread keeps while it runs regions (MAX_THREADS of them),
     * and region_partition's cell keys and sort scratch: kept from round to
     * round of a level, so that a round does not fault them in anew, and
     * freed after the level's rounds (region_scratch_free) */
    struct region_thread *region_threads;
    uint64_t *region_key;
    radix_scratch region_sort;
    uint32_t region_vertices; /* vertices per region: 0 for REGION_SIZE */
    uint32_t hub_faces;       /* SIMPLIFY_HUB_FACES, or the options' (tests) */
    uint32_t rounds;          /* region rounds run so far (all levels) */
    registry reg;
    cert_original orig;
    /* where the original is thin (another sheet within 2 eps): the only
     * places the self-intersection test runs unless strict */
    thin_map thin;
    int thin_ready; /* thin is this level's (thin_ready()) */
    thin_ahead ahead;
    uint8_t *special; /* border or locked vertices */
    /* per vertex: 0, or held for the ladder (hub_faces): HELD_HUB, or
     * HELD_NEIGHBOUR of one; held_count of them */
    uint8_t *held;
    uint32_t held_count;
    int strict;
    double eps, flip_cos;
    /* the largest original coordinate's magnitude: 1e-6 of it plus eps is
     * the rounding allowance of certify_change's early rejection
     * (cover_doomed) */
    double extent;
    int verify;
    uint32_t level;
    uint32_t thread_count;
    workpool pool; /* threads 1 .. thread_count - 1, for every parallel step */
    scratch scratch[MAX_THREADS];
    scratch serial; /* for the serial phases */
    simplify_stats *stats;
    char verify_msg[256];
    int verify_failed;
} sim;

/* In a region (sc->region), the faces it may read: its own, and shared
 * ones (no region changes those this round). In the global passes, all. */
static int face_readable(const sim *s, const scratch *sc, uint32_t f)
{
    if (!sc->region) return 1;
    const uint32_t owner = s->face_owner[f];
    return owner == sc->region->id || owner == REGION_SHARED;
}

/* The faces it may also register originals to or change: its own. */
static int face_owned(const sim *s, const scratch *sc, uint32_t f)
{
    return !sc->region || s->face_owner[f] == sc->region->id;
}

static void vertex_position(const sim *s, uint32_t v, double out[3])
{
    for (int k = 0; k < 3; ++k) out[k] = s->positions[3 * (size_t)v + k];
}

/* The collapse being evaluated: u's corners move to v; when moved (full-edge
 * placement), v itself moves to place. */
typedef struct collapse {
    uint32_t u, v;
    int moved;
    double place[3];
} collapse;

/* Never removed in this ladder: locked by the weld, or held (hub_faces). */
static int fixed_vertex(const sim *s, uint32_t u) { return s->w->vertex_kind[u] == WELD_LOCKED || s->held[u]; }

static uint32_t wedge_class_of_corner(const sim *s, uint32_t c)
{
    return s->w->wedge_class[s->corner_wedge[c]];
}

/* Alive faces around v, from its corner list. */
static int gather_faces(const sim *s, uint32_t v, u32vec *out)
{
    out->size = 0;
    for (uint32_t c = s->vertex_first[v]; c != NONE; c = s->corner_next[c])
        if (s->face_alive[c / 3] && s->corner_vertex[c] == v && u32_push(out, c / 3)) return -1;
    return 0;
}

/* The number of alive faces around v. */
static uint32_t faces_around(const sim *s, uint32_t v)
{
    uint32_t n = 0;
    for (uint32_t c = s->vertex_first[v]; c != NONE; c = s->corner_next[c])
        n += s->face_alive[c / 3] && s->corner_vertex[c] == v;
    return n;
}

static uint32_t corner_of(const sim *s, uint32_t f, uint32_t v)
{
    for (uint32_t k = 0; k < 3; ++k)
        if (s->corner_vertex[3 * f + k] == v) return 3 * f + k;
    return NONE;
}

static int face_has(const sim *s, uint32_t f, uint32_t v) { return corner_of(s, f, v) != NONE; }

/* ---- neighbourhood of a candidate -------------------------------------------- */

/* u's entry for neighbour x in sc->nb, appended when absent (NULL: no
 * memory). A short table is scanned; from NB_SCAN_MAX entries on (a vertex
 * of high valence, e.g. the centre of a disc's fan) every entry is also in
 * sc->nb_index, or building the table would cost valence^2. Same table in
 * the same order either way. */
#define NB_SCAN_MAX 16
static neighbour *find_or_add(scratch *sc, uint32_t x)
{
    if (sc->nb_size <= NB_SCAN_MAX) {
        for (size_t i = 0; i < sc->nb_size; ++i)
            if (sc->nb[i].x == x) return &sc->nb[i];
    } else {
        const uint32_t *at = keymap_find(&sc->nb_index, x);
        if (at) return &sc->nb[*at];
    }
    if (grow((void **)&sc->nb, &sc->nb_cap, sc->nb_size + 1, sizeof *sc->nb)) return NULL;
    if (sc->nb_size == NB_SCAN_MAX) { /* index the scanned entries */
        keymap_clear(&sc->nb_index);
        for (size_t i = 0; i < sc->nb_size; ++i)
            if (keymap_insert(&sc->nb_index, sc->nb[i].x, (uint32_t)i) < 0) return NULL;
    }
    if (sc->nb_size >= NB_SCAN_MAX && keymap_insert(&sc->nb_index, x, (uint32_t)sc->nb_size) < 0) return NULL;
    neighbour *n = &sc->nb[sc->nb_size++];
    memset(n, 0, sizeof *n);
    n->x = x;
    n->face[0] = n->face[1] = NONE;
    return n;
}

/* Builds u's neighbour table from faces_u; returns the number of wedge
 * classes at u (up to 3), or -1 on a non-manifold edge, or on no memory
 * (then sc->oom is set: running out must fail the level, not reject u). */
static int classify_neighbours(const sim *s, scratch *sc, uint32_t u)
{
    sc->nb_size = 0;
    uint32_t classes[3], nclass = 0;
    for (size_t i = 0; i < sc->faces_u.size; ++i) {
        uint32_t f = sc->faces_u.data[i], cu = corner_of(s, f, u);
        uint32_t k = cu - 3 * f, cls = wedge_class_of_corner(s, cu);
        int known = 0;
        for (uint32_t j = 0; j < nclass; ++j) known |= classes[j] == cls;
        if (!known && nclass < 3) classes[nclass++] = cls;
        uint32_t next = s->corner_vertex[3 * f + (k + 1) % 3], prev = s->corner_vertex[3 * f + (k + 2) % 3];
        /* room for both first: then b's insertion cannot move a */
        if (sc->nb_size + 2 > sc->nb_cap && grow((void **)&sc->nb, &sc->nb_cap, sc->nb_size + 2, sizeof *sc->nb))
            return sc->oom = 1, -1;
        neighbour *a = find_or_add(sc, next), *b = a ? find_or_add(sc, prev) : NULL;
        if (!b) return sc->oom = 1, -1;
        if (a->count < 2) a->face[a->count] = f;
        a->count++;
        a->forward++;
        if (b->count < 2) b->face[b->count] = f;
        b->count++;
    }
    for (size_t i = 0; i < sc->nb_size; ++i) {
        neighbour *n = &sc->nb[i];
        if (n->count > 2 || (n->count == 2 && n->forward != 1)) return -1;
        if (n->count == 2) {
            uint32_t f0 = n->face[0], f1 = n->face[1];
            uint32_t u0 = wedge_class_of_corner(s, corner_of(s, f0, u)), u1 = wedge_class_of_corner(s, corner_of(s, f1, u));
            uint32_t x0 = wedge_class_of_corner(s, corner_of(s, f0, n->x)), x1 = wedge_class_of_corner(s, corner_of(s, f1, n->x));
            n->class_change_at_u = u0 != u1;
            n->seam = u0 != u1 || x0 != x1 || s->w->triangle_primitive[f0] != s->w->triangle_primitive[f1];
        }
    }
    return (int)nclass;
}

/* The cost of collapsing u onto x: the quadric at x. Inline, and its
 * quadric never in memory: the region queues price every edge around a
 * vertex each time one of its neighbours changes. */
static inline __attribute__((always_inline)) double half_edge_cost(const sim *s, uint32_t u, uint32_t x)
{
    quadric q = s->quadrics[u];
    quadric_add(&q, &s->quadrics[x]);
    const float *p = s->positions + 3 * (size_t)x;
    const double b[3] = {p[0] - s->origin[0], p[1] - s->origin[1], p[2] - s->origin[2]};
    return quadric_error(&q, b);
}

/* The cost of collapsing u onto x: half_edge_cost. With *full on entry,
 * also the position full-edge placement would give the kept vertex, *place:
 * the quadric's minimizer, on the segment [u, x] when the minimizer is
 * ill-defined or farther than the edge's length from its middle, rounded to
 * float as the output stores it; *full is cleared when that gains nothing
 * over x. The order stays the half-edge one: measured on the bunny (with
 * placement from the start of a level, before it waited for the half-edge
 * passes), ordering by the placed cost gave more triangles at 1/64..1/2 %
 * (e.g. 46,265 against 45,653 at 1/64 %, 3,953 against 3,859 at 1/8 %). */
static double edge_cost(const sim *s, uint32_t u, uint32_t x, int *full, double place[3])
{
    const double at_x = half_edge_cost(s, u, x);
    if (!*full) return at_x;
    quadric q = s->quadrics[u];
    quadric_add(&q, &s->quadrics[x]);
    double pu[3], px[3], a[3], b[3], m[3], rel[3];
    vertex_position(s, x, px);
    for (int k = 0; k < 3; ++k) b[k] = px[k] - s->origin[k];
    vertex_position(s, u, pu);
    double len2 = 0.0, off2 = 0.0;
    for (int k = 0; k < 3; ++k) {
        a[k] = pu[k] - s->origin[k];
        len2 += (a[k] - b[k]) * (a[k] - b[k]);
    }
    int solved = quadric_minimizer(&q, m);
    for (int k = 0; k < 3 && solved; ++k) off2 += (m[k] - 0.5 * (a[k] + b[k])) * (m[k] - 0.5 * (a[k] + b[k]));
    if (!solved || !(off2 <= len2)) quadric_segment_minimizer(&q, a, b, m);
    for (int k = 0; k < 3; ++k) {
        place[k] = (double)(float)(m[k] + s->origin[k]);
        rel[k] = place[k] - s->origin[k];
    }
    if (!(quadric_error(&q, rel) < at_x)) *full = 0;
    return at_x;
}

/* Full-edge placement is offered only between two interior vertices of one
 * wedge class (weld kind manifold, then and now): moving a border, seam or
 * locked vertex would move what those kinds pin down, and a held one stays
 * where it is. */
static int placeable(const sim *s, uint32_t x)
{
    return s->full_edge && s->w->vertex_kind[x] == WELD_MANIFOLD && !s->held[x];
}

/* v is still interior with one wedge class and one primitive around it
 * (sc->faces_v gathered): its fan closes up. */
static int fan_is_plain(const sim *s, const scratch *sc, uint32_t v)
{
    if (sc->faces_v.size == 0) return 0;
    const uint32_t f0 = sc->faces_v.data[0];
    const uint32_t cls = wedge_class_of_corner(s, corner_of(s, f0, v)), prim = s->w->triangle_primitive[f0];
    for (size_t i = 0; i < sc->faces_v.size; ++i) {
        uint32_t f = sc->faces_v.data[i], cv = corner_of(s, f, v);
        if (wedge_class_of_corner(s, cv) != cls || s->w->triangle_primitive[f] != prim) return 0;
        uint32_t next = s->corner_vertex[3 * f + (cv - 3 * f + 1) % 3];
        int closed = 0;
        for (size_t j = 0; j < sc->faces_v.size && !closed; ++j) {
            uint32_t g = sc->faces_v.data[j], cg = corner_of(s, g, v);
            closed = s->corner_vertex[3 * g + (cg - 3 * g + 2) % 3] == next;
        }
        if (!closed) return 0;
    }
    return 1;
}

/* Marks the targets the kind rules allow (cost >= 0) and prices them; the
 * kind is recomputed from the current topology (weld.h's table). */
static int legal_targets(const sim *s, scratch *sc, uint32_t u, int nclass)
{
    uint32_t borders = 0, seams_at_u = 0;
    for (size_t i = 0; i < sc->nb_size; ++i) {
        borders += sc->nb[i].count == 1;
        seams_at_u += sc->nb[i].count == 2 && sc->nb[i].class_change_at_u;
    }
    weld_kind kind;
    if (borders == 0 && nclass == 1) kind = WELD_MANIFOLD;
    else if (borders == 2 && nclass == 1 && seams_at_u == 0) kind = WELD_BORDER;
    else if (borders == 0 && nclass == 2 && seams_at_u == 2) kind = WELD_SEAM;
    else return 0;
    int legal = 0;
    const vec3d at_u = geom_vec3d_from_floats(s->positions + 3 * (size_t)u);
    for (size_t i = 0; i < sc->nb_size; ++i) {
        neighbour *n = &sc->nb[i];
        uint8_t flags = n->count == 1 ? WELD_FLAG_BORDER : (n->seam ? WELD_FLAG_SEAM : 0);
        int ok = weld_collapse_allowed(kind, flags);
        if (ok && kind == WELD_SEAM) ok = n->class_change_at_u; /* along its own seam line */
        if (!ok) {
            n->cost = -1.0;
            continue;
        }
        n->full = kind == WELD_MANIFOLD && flags == 0 && placeable(s, u) && placeable(s, n->x);
        n->cost = edge_cost(s, u, n->x, &n->full, n->place);
        n->length2 = geom_distance2(at_u, geom_vec3d_from_floats(s->positions + 3 * (size_t)n->x));
        legal++;
    }
    return legal;
}

/* ---- evaluation of one candidate (read-only on the mesh) --------------------- */

/* Face f as it is (cl NULL) or after the collapse cl. */
static void corners_after(const sim *s, uint32_t f, const collapse *cl, cert_tri *t)
{
    for (int k = 0; k < 3; ++k) {
        uint32_t x = s->corner_vertex[3 * f + k];
        if (cl && x == cl->u) x = cl->v;
        t->vertex[k] = x;
        if (cl && cl->moved && x == cl->v) memcpy(t->p[k], cl->place, sizeof t->p[k]);
        else vertex_position(s, x, t->p[k]);
    }
    t->material = s->face_material[f];
    t->id = f;
}

static void face_after(const sim *s, uint32_t f, const collapse *cl, cert_tri *t)
{
    corners_after(s, f, cl, t);
    cert_face_normal(t);
}

/* face_after without the normal (n and degenerate are left unset), for the
 * callers that need only the corners and the box: the unit normal's square
 * root and division were most of face_after's time. */
static void face_box_after(const sim *s, uint32_t f, const collapse *cl, cert_tri *t)
{
    corners_after(s, f, cl, t);
    geom_triangle_box((const double(*)[3])t->p, t->lo, t->hi);
}

/* Face f's box now: face_box_after(s, f, NULL) without filling a cert_tri
 * (the grid builds take every face's box, twice). */
static void face_box(const sim *s, uint32_t f, double lo[3], double hi[3])
{
    double p[3][3];
    for (int k = 0; k < 3; ++k) vertex_position(s, s->corner_vertex[3 * f + k], p[k]);
    geom_triangle_box((const double(*)[3])p, lo, hi);
}

/* 1 when face f's box now is exactly [lo, hi] (the invariant checker's test
 * that a commit sees the geometry its evaluation saw). */
static int face_box_is(const sim *s, uint32_t f, const double lo[3], const double hi[3])
{
    double now_lo[3], now_hi[3];
    face_box(s, f, now_lo, now_hi);
    return !memcmp(now_lo, lo, sizeof now_lo) && !memcmp(now_hi, hi, sizeof now_hi);
}

static int next_stamp(scratch *sc)
{
    if (++sc->stamp == 0) return -1; /* 4 billion candidates: never in practice */
    return 0;
}

/* Adds face f to the candidate faces of (b) (once). In a region, a face it
 * does not own defers the candidate (sc->deferred): a registration to it
 * would change that face's list. */
static int add_candidate_face(const sim *s, scratch *sc, uint32_t f, uint32_t u, uint32_t v)
{
    if (!s->face_alive[f] || keymap_find(&sc->faces, f)) return 0; /* (a dead face has no owner this round) */
    if (!face_owned(s, sc, f)) {
        sc->deferred = 1;
        return 0;
    }
    if (face_has(s, f, u) && face_has(s, f, v)) return 0; /* removed by the collapse */
    const int room = sc->cand_faces.size < MAX_CANDIDATE_FACES;
    if (keymap_insert(&sc->faces, f, room ? (uint32_t)sc->cand_faces.size : NONE) < 0) return -1;
    return room ? u32_push(&sc->cand_faces, f) : 0;
}

/* Link condition (Dey et al.), with a border closed by a cone to one extra
 * vertex w: Lk(u) n Lk(v) = Lk(uv). Its vertex part is that the common
 * neighbours of u and v are exactly the far corners of the faces on edge
 * (u, v) (w is common only when uv is a border edge, which the kinds ensure:
 * a border vertex moves only along its border). Its edge part: no edge xy in
 * both links, i.e. no faces uxy and vxy. For an interior far corner a, that
 * is a with three faces (its link the triangle u v b); for a border one, the
 * edge aw: the faces on au and av both borders, a with one face. So the
 * far corner must keep at least 3 faces inside the surface and 1 on a
 * border; a locked one (perhaps non-manifold) keeps the interior floor. v
 * keeps as many, which the condition implies for a manifold v and guards a
 * locked one; and v must not become a hub (more than hub_faces faces). */
static uint32_t faces_left_floor(const sim *s, uint32_t x) { return s->w->vertex_kind[x] == WELD_BORDER ? 1 : 3; }

static int link_ok(const sim *s, scratch *sc, uint32_t u, const neighbour *e)
{
    const uint32_t v = e->x;
    if (gather_faces(s, v, &sc->faces_v)) return -1;
    if (next_stamp(sc)) return -1;
    for (size_t i = 0; i < sc->nb_size; ++i) sc->vertex_seen[sc->nb[i].x] = sc->stamp;
    uint32_t common = 0;
    sc->nbr_v.size = 0;
    for (size_t i = 0; i < sc->faces_v.size; ++i) {
        uint32_t f = sc->faces_v.data[i];
        for (int k = 0; k < 3; ++k) {
            uint32_t x = s->corner_vertex[3 * f + k];
            if (x == v || x == u) continue;
            if (sc->vertex_seen[x] == sc->stamp) {
                common++;
                sc->vertex_seen[x] = sc->stamp - 1; /* count once */
            }
        }
    }
    if (common != e->count) return 0;
    /* faces left around v and around the far corners */
    size_t v_after = sc->faces_v.size - e->count + (sc->faces_u.size - e->count);
    if (v_after < faces_left_floor(s, v) || v_after > s->hub_faces) return 0;
    for (uint32_t i = 0; i < e->count; ++i) {
        uint32_t f = e->face[i], far = NONE;
        for (int k = 0; k < 3; ++k)
            if (s->corner_vertex[3 * f + k] != u && s->corner_vertex[3 * f + k] != v) far = s->corner_vertex[3 * f + k];
        if (faces_around(s, far) - 1 < faces_left_floor(s, far)) return 0; /* f counts: at least 1 */
    }
    return 1;
}

/* The faces the collapse changes and keeps, in sc->changed: u's faces off the
 * edge (u, v) and, when v moves, v's (sc->faces_u and sc->faces_v gathered);
 * sc->after and sc->before_box get room for them. */
static int gather_changed(const sim *s, scratch *sc, const collapse *cl)
{
    sc->changed.size = 0;
    for (size_t i = 0; i < sc->faces_u.size; ++i)
        if (!face_has(s, sc->faces_u.data[i], cl->v) && u32_push(&sc->changed, sc->faces_u.data[i])) return -1;
    if (cl->moved)
        for (size_t i = 0; i < sc->faces_v.size; ++i)
            if (!face_has(s, sc->faces_v.data[i], cl->u) && u32_push(&sc->changed, sc->faces_v.data[i])) return -1;
    if (grow((void **)&sc->after, &sc->after_cap, sc->changed.size + 1, sizeof *sc->after)) return -1;
    return grow((void **)&sc->before_box, &sc->before_box_cap, 6 * sc->changed.size + 1, sizeof *sc->before_box);
}

/* Also fills sc->after (complete when it returns 1). */
static int flip_ok(const sim *s, scratch *sc, const collapse *cl)
{
    for (size_t i = 0; i < sc->changed.size; ++i) {
        uint32_t f = sc->changed.data[i];
        cert_tri before, *after = &sc->after[i];
        face_after(s, f, NULL, &before);
        memcpy(sc->before_box + 6 * i, before.lo, sizeof before.lo);
        memcpy(sc->before_box + 6 * i + 3, before.hi, sizeof before.hi);
        face_after(s, f, cl, after);
        if (after->degenerate) return 0;
        if (before.degenerate) continue;
        double c = before.n[0] * after->n[0] + before.n[1] * after->n[1] + before.n[2] * after->n[2];
        if (!(c > s->flip_cos)) return 0;
    }
    return 1;
}

typedef struct crossing_query {
    const sim *s;
    const scratch *sc;     /* in a region: other regions' faces are skipped */
    const cert_tri *faces; /* the new faces */
    size_t count;
    const collapse *cl; /* NULL: a change made in place, whose faces are skip */
    const uint32_t *skip;
    size_t skip_count;
    const cert_tri *replaced; /* sc->replaced */
    size_t replaced_count;
    double lo[3], hi[3]; /* the box of the new faces */
    int finite;          /* every new face is (stars_finite) */
} crossing_query;

/* 1 when every corner of faces[0 .. n) is finite: then a pair whose boxes
 * meet can skip intersect_triangles' own finiteness and box tests. */
static int stars_finite(const cert_tri *faces, size_t n)
{
    for (size_t i = 0; i < n; ++i)
        if (!intersect_finite((const double(*)[3])faces[i].p)) return 0;
    return 1;
}

/* 1 when face g of a grid is one to test against the new faces. */
static int crossing_candidate(const crossing_query *q, uint32_t g)
{
    const sim *s = q->s;
    /* another region's face lies in that region's cell, apart from every
     * face this region makes (region_partition): it cannot cross them */
    if (!face_readable(s, q->sc, g)) return 0;
    if (!s->face_alive[g]) return 0;
    /* the changed faces themselves are tested apart */
    if (q->cl && (face_has(s, g, q->cl->u) || (q->cl->moved && face_has(s, g, q->cl->v)))) return 0;
    for (size_t i = 0; i < q->skip_count; ++i)
        if (g == q->skip[i]) return 0;
    return 1;
}

/* 1 when the triangle other, whose box is [lo, hi], meets one of the faces
 * q's change replaces (more than in the corners they share, or too near to
 * tell). */
static int crossed_before(const crossing_query *q, const double other[3][3], const double lo[3], const double hi[3])
{
    for (size_t i = 0; i < q->replaced_count; ++i) {
        const cert_tri *r = &q->replaced[i];
        int apart = 0;
        for (int a = 0; a < 3; ++a) apart |= (lo[a] > r->hi[a]) | (hi[a] < r->lo[a]);
        if (!apart && intersect_triangles((const double(*)[3])r->p, other)) return 1;
    }
    return 0;
}

/* 1 when a new face of q whose box meets [lo, hi], the box of the triangle
 * other (finite: intersect_finite of it), would cross it, and none of the
 * faces the change replaces met it: a crossing the level already has (the
 * input's own, where parts of a mesh pass through each other) moves with
 * the faces that carry it instead of freezing every face around it, while a
 * face that crossed nothing is never made to cross. */
static int crosses_triangle(const crossing_query *q, const double other[3][3], int finite, const double lo[3],
                            const double hi[3])
{
    const int near = q->finite && finite; /* then a pair whose boxes meet is near (intersect.h) */
    for (size_t i = 0; i < q->count; ++i) {
        const cert_tri *f = &q->faces[i];
        int apart = 0; /* boxes first: most grid neighbours are not close */
        for (int a = 0; a < 3; ++a) apart |= (lo[a] > f->hi[a]) | (hi[a] < f->lo[a]);
        if (apart) continue;
        const double(*p)[3] = (const double(*)[3])f->p;
        if (near ? intersect_triangles_near(p, other) : intersect_triangles(p, other))
            return !crossed_before(q, other, lo, hi);
    }
    return 0;
}

/* 1 when the box [lo, hi] misses the box of q's new faces. | rather than
 * ||: one predictable branch (most grid neighbours are apart). */
static int apart_from_star(const crossing_query *q, const double lo[3], const double hi[3])
{
    return (lo[0] > q->hi[0]) | (hi[0] < q->lo[0]) | (lo[1] > q->hi[1]) | (hi[1] < q->lo[1]) | (lo[2] > q->hi[2]) |
           (hi[2] < q->lo[2]);
}

static int crosses(void *context, uint32_t g)
{
    const crossing_query *q = context;
    if (!crossing_candidate(q, g)) return 0;
    double other[3][3], lo[3], hi[3];
    for (int k = 0; k < 3; ++k) vertex_position(q->s, q->s->corner_vertex[3 * g + k], other[k]);
    const int finite = intersect_finite((const double(*)[3])other);
    if (finite) /* plain comparisons: no NaN to skip */
        for (int a = 0; a < 3; ++a) {
            lo[a] = other[0][a] < other[1][a] ? other[0][a] : other[1][a];
            lo[a] = lo[a] < other[2][a] ? lo[a] : other[2][a];
            hi[a] = other[0][a] > other[1][a] ? other[0][a] : other[1][a];
            hi[a] = hi[a] > other[2][a] ? hi[a] : other[2][a];
        }
    else
        geom_triangle_box((const double(*)[3])other, lo, hi);
    if (apart_from_star(q, lo, hi)) return 0;
    return crosses_triangle(q, (const double(*)[3])other, finite, lo, hi);
}

/* crosses for a region's own grid, whose faces are numbered locally. */
typedef struct local_query {
    const crossing_query *q;
    const uint32_t *faces;
    const double *box;
} local_query;

static int crosses_local(void *context, uint32_t local)
{
    const local_query *lq = context;
    const crossing_query *q = lq->q;
    /* crosses' tests on the same box (the face's, kept by own_grid_move),
     * the star's first: the grid's cells are coarse, most faces they report
     * are apart from the star */
    const double *b = lq->box + 6 * (size_t)local;
    if (apart_from_star(q, b, b + 3)) return 0;
    const uint32_t g = lq->faces[local];
    if (!crossing_candidate(q, g)) return 0;
    double other[3][3];
    for (int k = 0; k < 3; ++k) vertex_position(q->s, q->s->corner_vertex[3 * g + k], other[k]);
    /* the kept box is the one crosses computes (but for the sign of a zero,
     * which no comparison sees) */
    return crosses_triangle(q, (const double(*)[3])other, intersect_finite((const double(*)[3])other), b, b + 3);
}

/* The box of faces[0 .. n) (their boxes set). */
static void union_box(const cert_tri *faces, size_t n, double lo[3], double hi[3])
{
    for (int a = 0; a < 3; ++a) lo[a] = INFINITY, hi[a] = -INFINITY;
    for (size_t i = 0; i < n; ++i)
        for (int a = 0; a < 3; ++a) {
            lo[a] = geom_fmin(lo[a], faces[i].lo[a]);
            hi[a] = geom_fmax(hi[a], faces[i].hi[a]);
        }
}

/* The new star's faces into sc->tris (corners and boxes, no normals), and
 * their box. Returns the face count, or -1 when memory runs out. */
static long new_star(const sim *s, scratch *sc, const collapse *cl, double lo[3], double hi[3])
{
    const size_t n = sc->changed.size;
    if (grow((void **)&sc->tris, &sc->tris_cap, n + 1, sizeof *sc->tris)) return -1;
    for (size_t i = 0; i < n; ++i) face_box_after(s, sc->changed.data[i], cl, &sc->tris[i]);
    union_box(sc->tris, n, lo, hi);
    return (long)n;
}

/* 1 when a new face of q would cross a face of the stars in l whose box
 * meets [lo, hi] (a face they list that died since is skipped by crosses). */
static int crosses_stars(const star_list *l, const crossing_query *q, const double lo[3], const double hi[3])
{
    uint32_t begin = 0;
    for (size_t i = 0; i < l->end.size; ++i) {
        const double *box = l->box.data + 6 * i;
        const uint32_t end = l->end.data[i];
        /* | rather than ||: one predictable branch per star (most are apart) */
        const int apart = (box[0] > hi[0]) | (box[3] < lo[0]) | (box[1] > hi[1]) | (box[4] < lo[1]) |
                          (box[2] > hi[2]) | (box[5] < lo[2]);
        if (!apart)
            for (uint32_t k = begin; k < end; ++k)
                if (crosses((void *)q, l->faces.data[k])) return 1;
        begin = end;
    }
    return 0;
}

/* sc->replaced: the faces around u and, when v moves, around v (sc->faces_u
 * and sc->faces_v), as they are now. Returns -1 when memory runs out. */
static int gather_replaced(const sim *s, scratch *sc, const collapse *cl)
{
    const size_t n = sc->faces_u.size + (cl->moved ? sc->faces_v.size : 0);
    if (grow((void **)&sc->replaced, &sc->replaced_cap, n + 1, sizeof *sc->replaced)) return -1;
    sc->replaced_count = 0;
    for (size_t i = 0; i < sc->faces_u.size; ++i)
        face_box_after(s, sc->faces_u.data[i], NULL, &sc->replaced[sc->replaced_count++]);
    for (size_t i = 0; cl->moved && i < sc->faces_v.size; ++i)
        if (!face_has(s, sc->faces_v.data[i], cl->u)) /* the edge's faces are u's too */
            face_box_after(s, sc->faces_v.data[i], NULL, &sc->replaced[sc->replaced_count++]);
    return 0;
}

/* The commit's re-test: 1 when a face of the new star would cross a face
 * that an earlier commit of this batch changed (those were not there when the
 * candidate was tested). Only the stars committed in this batch are visited,
 * not the grid: their lists hold exactly those faces. */
static int crosses_batch(const sim *s, scratch *sc, const collapse *cl)
{
    double lo[3], hi[3];
    long n = new_star(s, sc, cl, lo, hi);
    if (n < 0) return sc->oom = 1, 1;
    if (n == 0) return 0;
    if (gather_replaced(s, sc, cl)) return sc->oom = 1, 1;
    crossing_query q = {s, sc, sc->tris, (size_t)n, cl, NULL, 0, sc->replaced, sc->replaced_count,
                        {lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}, stars_finite(sc->tris, (size_t)n)};
    return crosses_stars(&s->batch_stars, &q, lo, hi);
}

static int own_grid_init(const sim *s, const region *rg, own_grid *g);

/* 1 when a face of the new star (sc->after, from flip_ok) would cross
 * another face of the level or another new face. One grid query over the
 * star's box: its faces overlap, and one query per face would meet the same
 * neighbours several times. For a change made in place (cl NULL), the grid
 * still holds the changed faces (sc->changed) where they were: they are
 * skipped, and the caller made sc->replaced before the change. */
static int star_crosses(const sim *s, scratch *sc, const collapse *cl)
{
    const size_t n = sc->changed.size;
    double lo[3], hi[3];
    union_box(sc->after, n, lo, hi);
    const int finite = stars_finite(sc->after, n);
    for (size_t i = 0; i < n; ++i)
        for (size_t j = i + 1; j < n; ++j) {
            const cert_tri *f = &sc->after[i], *g = &sc->after[j];
            int apart = 0;
            for (int a = 0; a < 3; ++a) apart |= g->lo[a] > f->hi[a] || g->hi[a] < f->lo[a];
            const double(*fp)[3] = (const double(*)[3])f->p, (*gp)[3] = (const double(*)[3])g->p;
            if (finite ? !apart && intersect_triangles_near(fp, gp) : intersect_triangles(fp, gp)) return 1;
        }
    if (!n) return 0;
    if (cl && gather_replaced(s, sc, cl)) return sc->oom = 1, 1;
    crossing_query q = {s, sc, sc->after, n, cl, cl ? NULL : sc->changed.data, cl ? 0 : n, sc->replaced,
                        sc->replaced_count, {lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}, finite};
    if (!sc->region) return facegrid_query(&s->grid, lo, hi, crosses, &q);
    /* in a region: its own faces and the shared ones (another region's
     * faces cannot cross these, region_partition) */
    own_grid *own = sc->region->own;
    if (!own->ready && own_grid_init(s, sc->region, own)) return sc->oom = 1, 1;
    local_query lq = {&q, own->faces.data, own->box.data};
    return facegrid_query(&own->grid, lo, hi, crosses_local, &lq) ||
           facegrid_query(sc->region->shared, lo, hi, crosses, &q);
}

static void box_add(double lo[3], double hi[3], const double p[3])
{
    for (int a = 0; a < 3; ++a) {
        lo[a] = geom_fmin(lo[a], p[a]);
        hi[a] = geom_fmax(hi[a], p[a]);
    }
}

/* 1 when the collapse (u's faces in sc->faces_u, their neighbour table in
 * sc->nb, v's faces in sc->faces_v when v moves) must be tested for
 * self-intersections: strict mode, or the original is thin (thin.h) near the
 * new star, whose box is within that of u's ring (and v's ring and new place
 * when v moves). */
static int star_is_thin(const sim *s, const scratch *sc, const collapse *cl)
{
    if (s->strict) return 1;
    double p[3], lo[3], hi[3];
    vertex_position(s, cl->v, p);
    for (int a = 0; a < 3; ++a) lo[a] = hi[a] = p[a];
    /* the corners of u's faces are u and its neighbours (classify_neighbours
     * listed each once: the next and previous corner of every face): each
     * point once instead of once per face it is in. The box is the same:
     * geom_fmin/fmax skip NaN whatever the order, and a min or max of the same
     * points in another order differs at most in the sign of a zero, which
     * thin_map_box's floor(x * inv_cell) does not see */
    vertex_position(s, cl->u, p);
    box_add(lo, hi, p);
    for (size_t i = 0; i < sc->nb_size; ++i) {
        vertex_position(s, sc->nb[i].x, p);
        box_add(lo, hi, p);
    }
    if (cl->moved) {
        box_add(lo, hi, cl->place);
        for (size_t i = 0; i < sc->faces_v.size; ++i)
            for (int k = 0; k < 3; ++k) {
                vertex_position(s, s->corner_vertex[3 * sc->faces_v.data[i] + k], p);
                box_add(lo, hi, p);
            }
    }
    return thin_map_box(&s->thin, lo, hi);
}

/* The faces unit (an original t < nf, or cluster unit - nf) is registered to. */
static uint32_t unit_faces(const sim *s, uint32_t unit, uint32_t out[REGISTRY_SLOTS])
{
    uint32_t n = 0;
    if (unit >= s->nf) {
        uint32_t f = registry_cluster_face(&s->reg, unit - s->nf);
        if (f != REGISTRY_NONE) out[n++] = f;
        return n;
    }
    for (uint32_t k = 0; k < REGISTRY_SLOTS; ++k) {
        uint32_t f = s->reg.slot_face[(size_t)unit * REGISTRY_SLOTS + k];
        if (f != REGISTRY_NONE) out[n++] = f;
    }
    return n;
}

/* sc->tris[*prepared .. cand_faces.size): the candidate faces after the
 * collapse. The changed faces lead the list, in sc->changed's order, unless
 * one was left out: flip_ok made them already. Returns -1 out of memory. */
static int prepare_candidates(const sim *s, scratch *sc, const collapse *cl, size_t *prepared)
{
    if (grow((void **)&sc->tris, &sc->tris_cap, sc->cand_faces.size + 1, sizeof *sc->tris)) return -1;
    for (size_t i = *prepared; i < sc->cand_faces.size; ++i) {
        const uint32_t f = sc->cand_faces.data[i];
        if (cl && i < sc->changed.size && sc->changed.data[i] == f)
            sc->tris[i] = sc->after[i];
        else
            face_after(s, f, cl, &sc->tris[i]);
    }
    *prepared = sc->cand_faces.size;
    return 0;
}

/* 1 when p is certainly farther than reach from face f (its corners and
 * box set): the box first, a lower bound on the distance to the triangle. */
static int beyond_face(const vec3d *p, const cert_tri *f, double reach2)
{
    if (cert_tri_box_distance2(f, p) > reach2) return 1;
    vec3d w[3];
    for (int k = 0; k < 3; ++k) w[k] = geom_vec3d_from_doubles(f->p[k]);
    return geom_point_triangle_distance2(p, &w[0], &w[1], &w[2], NULL) > reach2;
}

/* certify_change's early rejection in the global passes: 1 when its (b)
 * loop would certainly end with SIMPLIFY_REJECT_COVER, because u's original
 * place is beyond reach of every face the loop can use; 0 when the loop
 * must run; -1 out of memory. Rejecting at once leaves what the loop would
 * leave: nothing appended to the arena, and scratch (sc->recheck,
 * cand_faces, faces, tris) that the next call rebuilds. sc->tris[0 ..
 * *prepared) are made as the loop would make them. Measured on the 1.1M
 * chain: it decides 1,307 of the 2,695 cover rejections.
 *
 * Why the loop cannot accept. Let t be an original triangle with u as a
 * corner whose unit is in sc->recheck: t itself, or t's cluster. The loop
 * reaches every unit unless it rejects earlier, and outside a region its
 * only rejection is this one. A cluster is accepted whole only when one face
 * F holds every vertex of its triangles (u among them) within accept, by
 * its ball (which holds u) or by the vertices themselves; else it is split
 * and t is certified alone. cert_cover accepts t only when every piece is
 * accepted, the one with u as a corner among them (split4 keeps the corners
 * exact), and a piece is accepted with a face W by u's own distance, by the
 * ball around the piece, or by the overlay, each proving every point of the
 * piece, u included, within accept of W up to rounding. The faces are
 * sc->tris (the faces after the collapse) and, once a triangle fails with
 * them, the 2-ring added to them: the faces around the vertices of the star
 * faces, less the dead ones, those already seen (a face over the cap of
 * candidates is seen but never used) and those the collapse removes. Both
 * are measured here, the ring only when the first list is beyond reach. A
 * witness must also be of t's material and agree with its normal: not
 * asking only measures more faces. So when u is beyond accept of every
 * one, no unit holding t passes, and the loop ends with
 * SIMPLIFY_REJECT_COVER at t or before.
 *
 * Rounding. The loop's tests compute distances from double corners of
 * magnitude below m = the largest original coordinate plus eps (placed
 * vertices are within eps of the original). Those distances are the true
 * ones within ~1e-15 relative plus a few ulps of m, or overestimates (thin
 * triangles, geom.h), which only reject more; the balls hold their points
 * exactly (geom.h, describe_cluster) and the overlay adds its own slack. So
 * an acceptance means u within accept + a few ulps of m of the witness. The
 * distances measured here overestimate by at most ~sqrt(ulp) * 4 m (geom.h's
 * thin case, ~6e-8 m), and the box test's rounding is relative, a few ulps.
 * Reach is accept + far_slack (1e-6 m), far above both: a face beyond
 * reach here is beyond accept for the loop. */
static int cover_doomed(const sim *s, scratch *sc, const collapse *cl, size_t star_faces, size_t *prepared)
{
    const cert_original *o = &s->orig;
    const uint32_t u = cl->u;
    int held = 0;
    for (uint32_t i = o->vertex_offsets[u]; i < o->vertex_offsets[u + 1] && !held; ++i) {
        const uint32_t t = o->vertex_triangles[i];
        held = keymap_find(&sc->origs, t) || keymap_find(&sc->origs, s->nf + o->cluster_of[t]);
    }
    if (!held) return 0;
    if (prepare_candidates(s, sc, cl, prepared)) return -1;
    const vec3d p = geom_vec3d_from_floats(o->positions + 3 * (size_t)u);
    const double far_slack = 1e-6 * (s->extent + s->eps);
    const double reach = s->eps * (1.0 - CERT_MARGIN) + far_slack, reach2 = reach * reach;
    for (size_t i = 0; i < sc->cand_faces.size; ++i)
        if (!beyond_face(&p, &sc->tris[i], reach2)) return 0;
    /* the 2-ring, as the loop's widening walks it (u's and v's faces are
     * all among the candidates already) */
    for (size_t j = 0; j < star_faces; ++j) {
        const uint32_t f = sc->cand_faces.data[j];
        for (int k = 0; k < 3; ++k) {
            const uint32_t x = s->corner_vertex[3 * f + k];
            if (x == u || x == cl->v) continue;
            for (uint32_t cc = s->vertex_first[x]; cc != NONE; cc = s->corner_next[cc]) {
                const uint32_t g = cc / 3;
                if (s->corner_vertex[cc] != x || !s->face_alive[g]) continue;
                if (keymap_find(&sc->faces, g) || (face_has(s, g, u) && face_has(s, g, cl->v))) continue;
                cert_tri ring;
                face_box_after(s, g, cl, &ring);
                if (!beyond_face(&p, &ring, reach2)) return 0;
            }
        }
    }
    return 1;
}

/* Certifies a change of the mesh: the collapse cl, or with cl NULL a change
 * already made in place (a vertex removal; the geometry read is the current
 * one). changing[0 .. changing_count) hold the faces that change or die;
 * others, faces around them that stay (may be NULL); sc->changed and
 * sc->after (the changed faces after, from flip_ok) and sc->before_box are
 * set. On success appends the records to the thread's arena: per
 * re-certified original (t, n, used[4]) + bound, then per changed face its id
 * + its CHANGED_RECORD (bound, box after, box before).
 * Returns 1 accepted, 0 rejected (reason set). */
static int certify_change(const sim *s, scratch *sc, candidate *c, const collapse *cl, const u32vec *const *changing,
                          int changing_count, const u32vec *others)
{
    const double eps = s->eps;
    const uint32_t u = cl ? cl->u : NONE, v = cl ? cl->v : NONE;
    /* originals whose registration uses a face that changes or dies */
    keymap_clear(&sc->faces);
    keymap_clear(&sc->origs);
    sc->recheck.size = 0;
    for (int side = 0; side < changing_count; ++side) {
        const u32vec *star = changing[side];
        for (size_t i = 0; i < star->size; ++i)
            REGISTRY_FOR_EACH(&s->reg, star->data[i], slot) {
                uint32_t cluster = registry_slot_cluster(&s->reg, slot);
                uint32_t unit = cluster == REGISTRY_NONE ? slot / REGISTRY_SLOTS : s->nf + cluster;
                int fresh = keymap_insert(&sc->origs, unit, 0);
                if (fresh < 0 || (fresh && u32_push(&sc->recheck, unit))) return sc->oom = 1, 0;
                if (fresh && sc->region) { /* it is re-registered: every face of it must be the region's */
                    uint32_t on[REGISTRY_SLOTS], n = unit_faces(s, unit, on);
                    for (uint32_t k = 0; k < n; ++k)
                        if (!face_owned(s, sc, on[k])) {
                            sc->deferred = 1;
                            c->reason = REJECT_DEFERRED;
                            return 0;
                        }
                }
            }
    }
    /* candidate faces: the changed ones, the others around them and the
     * faces the originals used before; the 2-ring only when those are not
     * enough */
    sc->cand_faces.size = 0;
    for (int side = 0; side <= changing_count; ++side) {
        const u32vec *list = side < changing_count ? changing[side] : others;
        for (size_t i = 0; list && i < list->size; ++i)
            if (add_candidate_face(s, sc, list->data[i], u, v)) return sc->oom = 1, 0;
    }
    const size_t star_faces = sc->cand_faces.size;
    for (size_t i = 0; i < sc->recheck.size; ++i) {
        uint32_t faces[REGISTRY_SLOTS], n = unit_faces(s, sc->recheck.data[i], faces);
        for (uint32_t k = 0; k < n; ++k)
            if (add_candidate_face(s, sc, faces[k], u, v)) return sc->oom = 1, 0;
    }
    if (sc->deferred) {
        c->reason = REJECT_DEFERRED;
        return 0;
    }
    size_t prepared = 0;
    /* (the region rounds mostly accept: measured on the 1.1M chain, 169
     * cover rejections in 547,728 certificates, against 2,695 in 11,553 in
     * the global passes) */
    const int doomed = cl && !sc->region ? cover_doomed(s, sc, cl, star_faces, &prepared) : 0;
    if (doomed < 0) return sc->oom = 1, 0;
    if (doomed && !s->verify) { /* (verify runs the loop: it must reject) */
        c->reason = SIMPLIFY_REJECT_COVER;
        return 0;
    }
    int ring_added = 0;
    const size_t u32_start = sc->out_u32.size, f64_start = sc->out_f64.size;
    /* (b) first: the originals must stay covered. A cluster registered whole
     * stays whole when one face still holds it, else it is split: its
     * originals join the list, each certified on its own. */
    for (size_t i = 0; i < sc->recheck.size; ++i) {
        uint32_t t = sc->recheck.data[i], used[CERT_MAX_WITNESSES], n = 0, first[REGISTRY_SLOTS], nfirst = 0;
        double bound = 0.0;
        for (;;) {
            if (prepare_candidates(s, sc, cl, &prepared)) return sc->oom = 1, 0;
            uint32_t before[REGISTRY_SLOTS], nbefore = unit_faces(s, t, before);
            nfirst = 0;
            for (uint32_t k = 0; k < nbefore; ++k) {
                const uint32_t *at = keymap_find(&sc->faces, before[k]);
                if (at && *at != NONE) first[nfirst++] = *at;
            }
            if (t >= s->nf) {
                const uint32_t cluster = t - s->nf;
                n = cert_cluster(&s->orig, cluster, sc->tris, (uint32_t)sc->cand_faces.size, eps, first, nfirst, used,
                                 &bound);
                if (!n) { /* split */
                    const cert_cluster_info *info = &s->orig.clusters[cluster];
                    for (uint32_t k = 0; k < info->count; ++k)
                        if (u32_push(&sc->recheck, s->orig.tree.triangle_order[info->first + k])) return sc->oom = 1, 0;
                }
                break;
            }
            if (cert_cover(&s->orig, t, sc->tris, (uint32_t)sc->cand_faces.size, eps, first, nfirst, used, &n, &bound))
                break;
            if (ring_added) {
                sc->out_u32.size = u32_start;
                sc->out_f64.size = f64_start;
                c->reason = SIMPLIFY_REJECT_COVER;
                return 0;
            }
            /* widen to the 2-ring around the new star. The faces around u
             * and v are in already (changing and others): walking them again
             * from each star face would cost valence^2 around a hub */
            ring_added = 1;
            for (size_t j = 0; j < star_faces; ++j) {
                uint32_t f = sc->cand_faces.data[j];
                for (int k = 0; k < 3; ++k) {
                    uint32_t x = s->corner_vertex[3 * f + k];
                    if (cl && (x == u || x == v)) continue;
                    for (uint32_t cc = s->vertex_first[x]; cc != NONE; cc = s->corner_next[cc])
                        if (s->corner_vertex[cc] == x && add_candidate_face(s, sc, cc / 3, u, v)) return sc->oom = 1, 0;
                }
            }
            if (sc->deferred) {
                sc->out_u32.size = u32_start;
                sc->out_f64.size = f64_start;
                c->reason = REJECT_DEFERRED;
                return 0;
            }
        }
        if (u32_push(&sc->out_u32, t) || u32_push(&sc->out_u32, n)) return sc->oom = 1, 0;
        for (uint32_t k = 0; k < CERT_MAX_WITNESSES; ++k)
            if (u32_push(&sc->out_u32, k < n ? used[k] : NONE)) return sc->oom = 1, 0;
        if (f64_push(&sc->out_f64, bound)) return sc->oom = 1, 0;
    }
    if (doomed) sc->doomed_passed = u; /* process_batch reports it */
    /* (a): every changed face within eps of the original */
    uint32_t changed = 0;
    for (size_t i = 0; i < sc->changed.size; ++i) {
        uint32_t f = sc->changed.data[i];
        const cert_tri *t = &sc->after[i];
        double bound;
        if (!cert_face(&s->orig, t, eps, &bound)) {
            sc->out_u32.size = u32_start;
            sc->out_f64.size = f64_start;
            c->reason = SIMPLIFY_REJECT_FACE;
            return 0;
        }
        if (u32_push(&sc->out_u32, f) || f64_push(&sc->out_f64, bound)) return sc->oom = 1, 0;
        /* its boxes after and before, for the commit's grid update */
        for (int a = 0; a < 6; ++a)
            if (f64_push(&sc->out_f64, a < 3 ? t->lo[a] : t->hi[a - 3])) return sc->oom = 1, 0;
        for (int a = 0; a < 6; ++a)
            if (f64_push(&sc->out_f64, sc->before_box[6 * i + a])) return sc->oom = 1, 0;
        changed++;
    }
    c->u32_off = u32_start;
    c->f64_off = f64_start;
    c->recheck_count = (uint32_t)sc->recheck.size;
    c->changed_count = changed;
    return 1;
}

/* Cheaper first; among equal costs the shorter edge, then the lower vertex
 * number (a total order: the neighbours are distinct). Equal costs are the
 * rule on flat parts, where every quadric is exactly 0: there the nearest
 * neighbour is the target that leaves no sliver (a 300 x 300 grid at z = 0,
 * candidates in candidate_before's order: 6.6 s with the lower number first, 1.6 s with the
 * shorter edge). */
static int neighbour_before(const neighbour *a, const neighbour *b)
{
    return a->cost < b->cost ||
           (a->cost == b->cost && (a->length2 < b->length2 || (a->length2 == b->length2 && a->x < b->x)));
}

/* u's handful of neighbours in that order, by insertion (glibc's qsort
 * copies each record through a merge buffer: 8 % of the instructions of a
 * whole run). */
static void sort_neighbours(neighbour *nb, size_t n)
{
    for (size_t i = 1; i < n; ++i) {
        const neighbour key = nb[i];
        size_t j = i;
        for (; j > 0 && neighbour_before(&key, &nb[j - 1]); --j) nb[j] = nb[j - 1];
        nb[j] = key;
    }
}

static void evaluate(const sim *s, scratch *sc, candidate *c)
{
    const uint32_t u = c->u;
    sc->deferred = 0;
    c->v = NONE;
    c->reason = SIMPLIFY_REJECT_KIND;
    c->attempts = 0;
    if (!s->vertex_alive[u] || fixed_vertex(s, u)) return;
    if (gather_faces(s, u, &sc->faces_u)) {
        sc->oom = 1;
        return;
    }
    int nclass = classify_neighbours(s, sc, u);
    if (nclass <= 0) return;
    if (legal_targets(s, sc, u, nclass) == 0) return;
    sort_neighbours(sc->nb, sc->nb_size);
    uint32_t tried = 0;
    for (size_t i = 0; i < sc->nb_size && tried < TARGETS_TRIED; ++i) {
        const neighbour *e = &sc->nb[i];
        if (e->cost < 0.0) continue;
        tried++;
        c->attempts++;
        int link = link_ok(s, sc, u, e);
        if (link < 0) {
            sc->oom = 1;
            return;
        }
        if (!link) {
            c->reason = SIMPLIFY_REJECT_LINK;
            continue;
        }
        /* the half-edge collapse first (v stays on the original surface, which
         * leaves later collapses more room), then, when offered, full-edge
         * placement */
        collapse tries[2];
        int try_count = 0;
        tries[try_count++] = (collapse){u, e->x, 0, {0.0, 0.0, 0.0}};
        if (e->full && fan_is_plain(s, sc, e->x))
            tries[try_count++] = (collapse){u, e->x, 1, {e->place[0], e->place[1], e->place[2]}};
        for (int i_try = 0; i_try < try_count; ++i_try) {
            const collapse *cl = &tries[i_try];
            if (gather_changed(s, sc, cl)) {
                sc->oom = 1;
                return;
            }
            if (!flip_ok(s, sc, cl)) {
                c->reason = SIMPLIFY_REJECT_FLIP;
                continue;
            }
            /* The certificate before the crossing test: a collapse must pass
             * both, so the order changes only which reason a rejection is
             * counted under. The crossing test compares every new face with
             * every other, which at a vertex of valence n (the centre of a
             * disc's fan, retried after each collapse on its rim) is n^2
             * triangle pairs; the certificate rejects most such collapses
             * first, and in general rejects far more often (1.1M chain: 639
             * cover and 143 face rejections against 23 crossings). A deferral
             * still defers only when the crossing test would not have
             * rejected first. u's faces change or die; v's change too when it
             * moves, else they are candidates that stay. */
            const u32vec *changing[2] = {&sc->faces_u, &sc->faces_v};
            const int certified =
                certify_change(s, sc, c, cl, changing, cl->moved ? 2 : 1, cl->moved ? NULL : &sc->faces_v);
            if (sc->oom) return;
            const int thin = (certified || sc->deferred) && star_is_thin(s, sc, cl);
            if (thin && star_crosses(s, sc, cl)) {
                if (sc->oom) return;
                if (certified) { /* drop the records certify_change appended */
                    sc->out_u32.size = c->u32_off;
                    sc->out_f64.size = c->f64_off;
                }
                sc->deferred = 0;
                c->reason = SIMPLIFY_REJECT_INTERSECT;
                continue;
            }
            if (certified) {
                c->v = e->x;
                c->thin = thin;
                c->moved = cl->moved;
                memcpy(c->place, cl->place, sizeof c->place);
                c->cost = e->cost;
                return;
            }
            if (sc->oom || sc->deferred) return;
        }
    }
}

/* ---- parallel evaluation of a batch ------------------------------------------ */

/* A batch is evaluated while it is being reserved: evaluation only reads the
 * mesh, and reservation only writes its stamps and the serial scratch, so a
 * worker may take each candidate as soon as the main thread has reserved it.
 * Once the batch is complete (closed), the main thread evaluates too. Which
 * candidates form the batch, and what each evaluation sees, do not depend on
 * the timing. */
typedef struct batch_job {
    sim *s;
    candidate *cands;
    atomic_size_t next;      /* the next candidate to claim */
    atomic_size_t published; /* cands[0 .. published) are reserved */
    atomic_int closed;       /* published is final */
} batch_job;

/* Claims and evaluates the batch's candidates until it is closed and all are
 * claimed; thread picks the scratch (a workpool_fn). */
static void batch_worker(void *p, uint32_t thread)
{
    batch_job *job = p;
    scratch *sc = &job->s->scratch[thread];
    for (;;) {
        /* closed before published: once closed is seen, published is final */
        const int closed = atomic_load_explicit(&job->closed, memory_order_acquire);
        const size_t ready = atomic_load_explicit(&job->published, memory_order_acquire);
        size_t i = atomic_load_explicit(&job->next, memory_order_relaxed);
        if (i < ready) {
            if (atomic_compare_exchange_weak_explicit(&job->next, &i, i + 1, memory_order_relaxed,
                                                      memory_order_relaxed)) {
                job->cands[i].thread = thread;
                evaluate(job->s, sc, &job->cands[i]);
            }
            continue;
        }
        if (closed) return;
        sched_yield(); /* the main thread is reserving the next candidate */
    }
}

typedef struct batch_run {
    batch_job job;
    int helped; /* the pool's helpers were woken */
} batch_run;

static void batch_open(sim *s, batch_run *r, candidate *cands)
{
    r->job.s = s;
    r->job.cands = cands;
    atomic_init(&r->job.next, 0);
    atomic_init(&r->job.published, 0);
    atomic_init(&r->job.closed, 0);
    r->helped = 0;
    for (uint32_t t = 0; t < s->thread_count; ++t) {
        s->scratch[t].out_u32.size = 0;
        s->scratch[t].out_f64.size = 0;
    }
}

/* cands[0 .. count) are reserved; the helpers are woken once there are
 * BATCH_PARALLEL_MIN (a smaller batch is evaluated by batch_close alone). */
static void batch_publish(sim *s, batch_run *r, size_t count)
{
    atomic_store_explicit(&r->job.published, count, memory_order_release);
    if (count != BATCH_PARALLEL_MIN) return;
    workpool_start(&s->pool, batch_worker, &r->job);
    r->helped = 1;
}

/* No more candidates: evaluates what is left on this thread too, and waits
 * for the helpers. */
static void batch_close(sim *s, batch_run *r)
{
    atomic_store_explicit(&r->job.closed, 1, memory_order_release);
    batch_worker(&r->job, 0);
    if (r->helped) workpool_finish(&s->pool);
    r->helped = 0;
}

/* ---- commit -------------------------------------------------------------------- */

/* Marks the vertices of every face around v (after the collapse onto it) as
 * changed by this commit (the next value of *clock): a candidate within one
 * edge of them reads a face that changed (collect_candidates), i.e. every
 * vertex within two edges of v. */
static void stamp_changes(sim *s, uint32_t v, uint32_t *clock_now)
{
    const uint32_t clock = ++*clock_now;
    s->change_stamp[v] = clock;
    for (uint32_t c = s->vertex_first[v]; c != NONE; c = s->corner_next[c])
        if (s->face_alive[c / 3] && s->corner_vertex[c] == v)
            for (int j = 0; j < 3; ++j) s->change_stamp[s->corner_vertex[3 * (c / 3) + j]] = clock;
}

/* Has a commit after `clock` stamped u or a vertex of a face around it (so a
 * face within two edges of u changed)? */
static int changed_since(const sim *s, uint32_t u, uint32_t clock)
{
    if (s->change_stamp[u] > clock) return 1;
    for (uint32_t c = s->vertex_first[u]; c != NONE; c = s->corner_next[c])
        if (s->face_alive[c / 3] && s->corner_vertex[c] == u)
            for (int j = 0; j < 3; ++j)
                if (s->change_stamp[s->corner_vertex[3 * (c / 3) + j]] > clock) return 1;
    return 0;
}

/* Patience with a vertex of many faces. A rejected vertex is tried again
 * once its neighbourhood has changed (changed_since); but at the centre of a
 * fan every collapse on the rim changes it, and trying the centre costs in
 * proportion to its faces, so a fan of n faces whose centre stays cost n^2
 * (a disc of 1,000 triangles 1.2 s, a cylinder with two such caps 6.8 s).
 * A vertex that had more than patient_faces (SIMPLIFY_PATIENT_FACES) faces
 * when it was rejected therefore waits, while the passes are patient, until
 * an eighth of them are gone: about log(n) tries instead of n. Before a
 * level ends, one impatient pass tries every changed one (the level loop),
 * so a level ends on the same condition as without patience: no candidate
 * left that changed since its rejection (verify_settled). Vertices of
 * ordinary valence never wait longer. A limit of 32 instead of 64 changed
 * fandisk's chain (134/76/20/10 -> 136/70/22/10); 64 changed no level of
 * the corpus. */
enum { RETRY_NOT = 0, RETRY_NOW, RETRY_LATER };

static int retry_due(const sim *s, uint32_t u, int patient)
{
    if (!changed_since(s, u, s->reject_stamp[u])) return RETRY_NOT;
    const uint32_t then = s->reject_faces[u];
    if (!patient || then <= s->patient_faces) return RETRY_NOW;
    return 8 * (uint64_t)faces_around(s, u) <= 7 * (uint64_t)then ? RETRY_NOW : RETRY_LATER;
}

/* With verify, at a level's end: every vertex rejected during the level was
 * tried again after its neighbourhood last changed (retry_due's promise,
 * patience or not). Returns 0, or -1 with verify_msg set. */
static int verify_settled(sim *s)
{
    for (uint32_t i = 0; i < s->movable_count; ++i) {
        const uint32_t u = s->movable[i];
        if (!s->vertex_alive[u] || s->reject_stamp[u] == NONE || !changed_since(s, u, s->reject_stamp[u])) continue;
        snprintf(s->verify_msg, sizeof s->verify_msg,
                 "vertex %u (%u faces): rejected at clock %u, its neighbourhood changed since, not tried again "
                 "before the level ended", u, faces_around(s, u), s->reject_stamp[u]);
        s->verify_failed = 1;
        return -1;
    }
    return 0;
}

/* u was rejected at clock: it waits for retry_due. */
static void note_rejection(sim *s, uint32_t u, uint32_t clock)
{
    const uint32_t faces = faces_around(s, u);
    s->reject_stamp[u] = clock;
    s->reject_faces[u] = faces > UINT16_MAX ? UINT16_MAX : (uint16_t)faces;
}

/* Drops corners of dead faces and corners that no longer belong to v. */
static void prune_corner_list(sim *s, uint32_t v)
{
    uint32_t *link = &s->vertex_first[v];
    while (*link != NONE) {
        uint32_t c = *link;
        if (!s->face_alive[c / 3] || s->corner_vertex[c] != v) *link = s->corner_next[c];
        else link = &s->corner_next[c];
    }
}

/* u leaves the level: its quadric goes to the vertex that takes its place. */
static void retire_vertex(sim *s, uint32_t u, uint32_t heir)
{
    quadric_add(&s->quadrics[heir], &s->quadrics[u]);
    s->vertex_alive[u] = 0;
    s->vertex_first[u] = NONE;
}

static int verify_after_commit(sim *s, const candidate *c);

/* A certified candidate's records in its thread's arena (certify_change
 * wrote them): per re-certified unit (t, n, used[CERT_MAX_WITNESSES]) and
 * its bound, then per changed face its id and CHANGED_RECORD doubles. */
typedef struct records {
    const uint32_t *units;      /* the unit of i is units[i * UNIT_RECORD] */
    const double *unit_bounds;
    const uint32_t *changed;    /* face ids */
    const double *changed_f64;  /* CHANGED_RECORD per face */
} records;

#define UNIT_RECORD (2 + CERT_MAX_WITNESSES)

static records records_of(const sim *s, const candidate *c)
{
    const scratch *res = &s->scratch[c->thread];
    records r = {NULL, NULL, NULL, NULL};
    /* A candidate that wrote no records (no unit re-certified, no face
     * changed) may come from an arena never grown: no offset from NULL. */
    if (res->out_u32.data) {
        r.units = res->out_u32.data + c->u32_off;
        r.changed = r.units + (size_t)c->recheck_count * UNIT_RECORD;
    }
    if (res->out_f64.data) {
        r.unit_bounds = res->out_f64.data + c->f64_off;
        r.changed_f64 = r.unit_bounds + c->recheck_count;
    }
    return r;
}

/* A cluster one of whose originals was re-registered: try it whole again.
 * Regions of one round may mark the same cluster. */
static void mark_cluster_dirty(sim *s, uint32_t cluster)
{
    atomic_fetch_or_explicit(&s->cluster_dirty[cluster / 64], (uint_least64_t)1 << (cluster % 64),
                             memory_order_relaxed);
}

/* Marks every cluster dirty. */
static void mark_clusters_dirty(sim *s)
{
    const uint32_t n = s->orig.cluster_count;
    for (uint32_t w = 0; w < (n + 63) / 64; ++w) {
        const uint32_t bits = n - 64 * w < 64 ? n - 64 * w : 64;
        atomic_store_explicit(&s->cluster_dirty[w], bits == 64 ? ~(uint_least64_t)0 : ((uint_least64_t)1 << bits) - 1,
                              memory_order_relaxed);
    }
}

/* The certified change c's records: its changed faces' bounds, and each
 * re-certified original's (or cluster's) registration and bound. */
static void commit_records(sim *s, const candidate *c, simplify_stats *stats)
{
    const records rec = records_of(s, c);
    for (uint32_t i = 0; i < c->changed_count; ++i)
        s->face_bound[rec.changed[i]] = rec.changed_f64[CHANGED_RECORD * (size_t)i];
    for (uint32_t i = 0; i < c->recheck_count; ++i) {
        const uint32_t *r = rec.units + (size_t)i * UNIT_RECORD;
        if (r[0] >= s->nf) { /* a cluster: whole again (one face) or split (no face) */
            registry_clear_cluster(&s->reg, r[0] - s->nf);
            if (r[1]) registry_set_cluster(&s->reg, r[0] - s->nf, r[2]);
            else stats->cluster_splits++;
        } else {
            registry_clear(&s->reg, r[0]);
            registry_set(&s->reg, r[0], r + 2, r[1]);
            mark_cluster_dirty(s, s->orig.cluster_of[r[0]]);
        }
        s->unit_bound[r[0]] = rec.unit_bounds[i];
        s->unit_stamp[r[0]] = s->batch_stamp;
    }
}

/* Where a commit's effects go besides the mesh: in the global passes the
 * serial scratch, the level's statistics, the global clock, the batch's
 * stars and the grid log (rg NULL); in a region of a round its thread's
 * scratch and its own statistics, clock and grid (the level's grid is
 * rebuilt after the region phase). */
typedef struct committer {
    scratch *sc;
    simplify_stats *stats;
    uint32_t *clock;
    star_list *stars;
    region *rg;
} committer;

/* A face of the region died, or is now in [lo, hi]. */
static void own_grid_remove(own_grid *g, uint32_t f)
{
    if (!g->ready) return;
    const uint32_t *local = keymap_find(&g->local, f);
    if (!local) return;
    facegrid_remove(&g->grid, *local);
}

/* As the global passes' grid log does, a face whose old and new boxes lie
 * in the same cells keeps its entries: only the crossing tests read this
 * grid, and which faces a query reports does not change. */
static int own_grid_move(own_grid *g, uint32_t f, const double old_lo[3], const double old_hi[3], const double lo[3],
                         const double hi[3])
{
    if (!g->ready) return 0;
    const uint32_t *local = keymap_find(&g->local, f);
    if (!local) return -1;
    memcpy(g->box.data + 6 * (size_t)*local, lo, 3 * sizeof *lo);
    memcpy(g->box.data + 6 * (size_t)*local + 3, hi, 3 * sizeof *hi);
    if (facegrid_contains(&g->grid, *local) && facegrid_same_cells(&g->grid, old_lo, old_hi, lo, hi)) return 0;
    return facegrid_insert(&g->grid, *local, lo, hi) == FACEGRID_OK ? 0 : -1;
}

/* Applies an accepted collapse. Returns 1 committed, 0 skipped because an
 * earlier commit of the batch re-registered one of its originals (a region
 * evaluates each candidate after the commits before it: never). */
static int commit(sim *s, const candidate *c, const committer *cm)
{
    const uint32_t u = c->u, v = c->v;
    const collapse cl = {u, v, c->moved, {c->place[0], c->place[1], c->place[2]}};
    const records rec = records_of(s, c);
    const uint32_t *changed = rec.changed;
    const double *changed_f64 = rec.changed_f64;
    if (!cm->rg)
        for (uint32_t i = 0; i < c->recheck_count; ++i)
            if (s->unit_stamp[rec.units[(size_t)i * UNIT_RECORD]] == s->batch_stamp) return 0;

    scratch *sc = cm->sc;
    /* In a region the candidate was evaluated just now, on this scratch, and
     * nothing changed the mesh since: sc->faces_u (gathered first), faces_v
     * (by link_ok for the accepted target) and changed (by gather_changed
     * for the accepted try, the last one) are the lists gathering again
     * would give, in the same order. */
    if (!cm->rg) {
        if (gather_faces(s, u, &sc->faces_u)) return sc->oom = 1, 0;
        if (cl.moved && gather_faces(s, v, &sc->faces_v)) return sc->oom = 1, 0;
        if (gather_changed(s, sc, &cl)) return sc->oom = 1, 0;
    }
    /* faces committed earlier in this batch were not there when the candidate
     * was tested for crossings (its star and the thin map are as they were) */
    if (!cm->rg && c->thin && crosses_batch(s, sc, &cl)) return 0;
    if (sc->oom) return 0;
    if (s->verify) /* the grid update's old boxes (from the evaluation) are the faces' boxes now */
        for (size_t i = 0; i < sc->changed.size && i < c->changed_count; ++i) {
            const double *old_box = changed_f64 + CHANGED_RECORD * i + 7;
            if (!face_box_is(s, sc->changed.data[i], old_box, old_box + 3)) {
                s->verify_failed = 1;
                snprintf(s->verify_msg, sizeof s->verify_msg, "collapse %u -> %u: face %u's box moved since it was evaluated",
                         u, v, sc->changed.data[i]);
                return 0;
            }
        }
    /* which of v's wedges replaces u's in each face: read from the faces on
     * edge (u, v), one per side (two for a seam) */
    uint32_t map_class[2] = {NONE, NONE}, map_wedge[2] = {NONE, NONE}, mapped = 0;
    for (size_t i = 0; i < sc->faces_u.size; ++i) {
        uint32_t f = sc->faces_u.data[i], cv = corner_of(s, f, v);
        if (cv == NONE || mapped == 2) continue;
        map_class[mapped] = wedge_class_of_corner(s, corner_of(s, f, u));
        map_wedge[mapped] = s->corner_wedge[cv];
        mapped++;
    }
    for (size_t i = 0; i < sc->faces_u.size; ++i) {
        uint32_t f = sc->faces_u.data[i], cu = corner_of(s, f, u);
        if (face_has(s, f, v)) {
            s->face_alive[f] = 0;
            if (cm->rg) cm->rg->faces_died++;
            else s->faces_alive--;
            continue;
        }
        uint32_t cls = wedge_class_of_corner(s, cu), wedge = NONE;
        for (uint32_t k = 0; k < mapped; ++k)
            if (map_class[k] == cls) wedge = map_wedge[k];
        if (wedge == NONE) { /* the kind rules exclude this; never write a wrong attribute */
            s->verify_failed = 1;
            snprintf(s->verify_msg, sizeof s->verify_msg, "collapse %u -> %u: no wedge of v for face %u", u, v, f);
            return 0;
        }
        s->corner_vertex[cu] = v;
        s->corner_wedge[cu] = wedge;
    }
    if (cl.moved) {
        for (int k = 0; k < 3; ++k) s->moved_positions[3 * (size_t)v + k] = (float)cl.place[k];
        s->moved_any = 1;
    }
    /* the faces that moved: u's, and v's when v moved (the faces on the edge
     * are in both lists, dead by now) */
    double star_box[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    uint32_t next_changed = 0; /* the alive faces come in the order certify_change met them */
    for (int side = 0; side < (cl.moved ? 2 : 1); ++side) {
        const u32vec *star = side ? &sc->faces_v : &sc->faces_u;
        for (size_t i = 0; i < star->size; ++i) {
            uint32_t f = star->data[i];
            if (!s->face_alive[f]) {
                if (cm->rg) own_grid_remove(cm->rg->own, f);
                else gridlog_remove(&s->grid_log, f);
                continue;
            }
            if (next_changed == c->changed_count || changed[next_changed] != f) { /* never certified: a bug */
                s->verify_failed = 1;
                snprintf(s->verify_msg, sizeof s->verify_msg, "collapse %u -> %u: face %u was not certified", u, v, f);
                return 0;
            }
            cert_tri t;
            const double *record = changed_f64 + CHANGED_RECORD * (size_t)next_changed;
            memcpy(t.lo, record + 1, sizeof t.lo);
            memcpy(t.hi, record + 4, sizeof t.hi);
            const double *old_box = record + 7;
            next_changed++;
            if (s->verify && !face_box_is(s, f, t.lo, t.hi)) { /* the certified geometry is the committed one */
                s->verify_failed = 1;
                snprintf(s->verify_msg, sizeof s->verify_msg, "collapse %u -> %u: face %u is not where it was certified", u, v, f);
                return 0;
            }
            if (cm->rg) {
                if (own_grid_move(cm->rg->own, f, old_box, old_box + 3, t.lo, t.hi)) return sc->oom = 1, 0;
                continue;
            }
            gridlog_move(&s->grid_log, f, old_box, old_box + 3, t.lo, t.hi);
            if (u32_push(&cm->stars->faces, f)) return sc->oom = 1, 0;
            for (int a = 0; a < 3; ++a) {
                star_box[a] = geom_fmin(star_box[a], t.lo[a]);
                star_box[3 + a] = geom_fmax(star_box[3 + a], t.hi[a]);
            }
        }
    }
    if (!cm->rg) {
        if (u32_push(&cm->stars->end, (uint32_t)cm->stars->faces.size)) return sc->oom = 1, 0;
        for (int a = 0; a < 6; ++a)
            if (f64_push(&cm->stars->box, star_box[a])) return sc->oom = 1, 0;
    }
    commit_records(s, c, cm->stats);
    /* u's corners join v's list */
    uint32_t cnext;
    for (uint32_t cc = s->vertex_first[u]; cc != NONE; cc = cnext) {
        cnext = s->corner_next[cc];
        if (s->face_alive[cc / 3] && s->corner_vertex[cc] == v) {
            s->corner_next[cc] = s->vertex_first[v];
            s->vertex_first[v] = cc;
        }
    }
    prune_corner_list(s, v);
    /* the far corners of the faces that died: their lists would otherwise
     * carry dead corners through every later walk of the neighbourhood */
    for (size_t i = 0; i < sc->faces_u.size; ++i) {
        uint32_t f = sc->faces_u.data[i];
        if (s->face_alive[f]) continue;
        for (int k = 0; k < 3; ++k) {
            uint32_t x = s->corner_vertex[3 * f + k];
            if (x != u && x != v) prune_corner_list(s, x);
        }
    }
    retire_vertex(s, u, v);
    stamp_changes(s, v, cm->clock);
    if (s->verify && verify_after_commit(s, c) != 0) return 0;
    return 1;
}

/* ---- the invariant checker (LODPIPE_VERIFY=1) --------------------------------- */

/* Registrations agree both ways; every alive face has alive, distinct
 * vertices; every unit given (an original, or a cluster registered whole) is
 * still covered by its registered faces and every face given is still within
 * eps (re-certified from scratch). */
static int verify_state(sim *s, const uint32_t *units, size_t unit_count, const uint32_t *faces, size_t face_count)
{
    if (registry_verify(&s->reg, s->face_alive, s->verify_msg, sizeof s->verify_msg) != 0) return -1;
    for (uint32_t f = 0; f < s->nf; ++f) {
        if (!s->face_alive[f]) continue;
        for (int k = 0; k < 3; ++k) {
            uint32_t x = s->corner_vertex[3 * f + k];
            if (!s->vertex_alive[x] || x == s->corner_vertex[3 * f + (k + 1) % 3]) {
                snprintf(s->verify_msg, sizeof s->verify_msg, "face %u has a dead or repeated vertex %u", f, x);
                return -1;
            }
        }
    }
    scratch *sc = &s->serial;
    for (size_t i = 0; i < unit_count; ++i) {
        uint32_t t = units[i], on[REGISTRY_SLOTS], n = unit_faces(s, t, on);
        if (grow((void **)&sc->tris, &sc->tris_cap, REGISTRY_SLOTS, sizeof *sc->tris)) return sc->oom = 1, -1;
        for (uint32_t k = 0; k < n; ++k) face_after(s, on[k], NULL, &sc->tris[k]);
        double bound;
        /* the recorded bound, with the certificate's margin and a hair of rounding */
        double limit = s->unit_bound[t] * (1.0 + 1e-12);
        if (t >= s->nf) { /* a cluster: whole to one face, or split (its originals are checked apart) */
            if (n && !cert_cluster_within(&s->orig, t - s->nf, &sc->tris[0], limit)) {
                snprintf(s->verify_msg, sizeof s->verify_msg,
                         "cluster %u is not held by its registered face within its recorded bound %.17g", t - s->nf,
                         s->unit_bound[t]);
                return -1;
            }
            continue;
        }
        if (!cert_cover_within(&s->orig, t, sc->tris, n, limit, &bound)) {
            snprintf(s->verify_msg, sizeof s->verify_msg,
                     "original %u is not covered by its registered faces within its recorded bound %.17g", t,
                     s->unit_bound[t]);
            return -1;
        }
    }
    for (size_t i = 0; i < face_count; ++i) {
        cert_tri t;
        face_after(s, faces[i], NULL, &t);
        double bound;
        /* cert_face accepts at eps * (1 - margin): undo it to test the recorded bound */
        double limit = s->face_bound[faces[i]] * (1.0 + 1e-12) / (1.0 - CERT_MARGIN);
        if (s->face_alive[faces[i]] && !cert_face(&s->orig, &t, limit, &bound)) {
            snprintf(s->verify_msg, sizeof s->verify_msg, "face %u is not within its recorded bound %.17g of the original",
                     faces[i], s->face_bound[faces[i]]);
            return -1;
        }
    }
    /* serial: with verify on, the region rounds run on one thread and the
     * passes commit (and check) on the main thread */
    s->stats->verify_checks++;
    return 0;
}

static int verify_after_commit(sim *s, const candidate *c)
{
    const records rec = records_of(s, c);
    u32vec units = {0}, faces = {0};
    int rc = 0;
    for (uint32_t i = 0; i < c->recheck_count && !rc; ++i) rc = u32_push(&units, rec.units[(size_t)i * UNIT_RECORD]);
    for (uint32_t i = 0; i < c->changed_count && !rc; ++i) rc = u32_push(&faces, rec.changed[i]);
    if (!rc) rc = verify_state(s, units.data, units.size, faces.data, faces.size);
    free(units.data);
    free(faces.data);
    if (rc) s->verify_failed = 1;
    return rc;
}

/* ---- candidates, batches, passes ----------------------------------------------- */

typedef struct ranked {
    double cost;
    uint32_t u;
} ranked;

/* The order of candidates, for the passes (ranked_before) and the region
 * queues (queued_before): cheaper first, and among equal costs a fixed
 * permutation of the vertex numbers (keymap_hash, a bijection of 32-bit
 * integers), so a strict total order (costs are never NaN) that any correct
 * sort turns into the same sequence. Vertex numbers follow the input's
 * layout, rows of a grid for example; a flat part, where every cost is
 * exactly 0, collapsed in that order is swept row by row into long slivers
 * and fans that the certificate and the crossing test then pay for. A 300 x 300 grid at z = 0 (180,000 triangles) took 24 s by vertex
 * number and takes 1.6 s in this order with neighbour_before's shorter edge
 * first (51 s in vertex order with the shorter edge first); the corpus's
 * level sizes moved by a few triangles either way. */
static inline int candidate_before(double x_cost, uint32_t x, double y_cost, uint32_t y)
{
    return x_cost < y_cost || (x_cost == y_cost && keymap_hash(x) < keymap_hash(y));
}

static int ranked_before(const ranked *x, const ranked *y)
{
    return candidate_before(x->cost, x->u, y->cost, y->u);
}

static void swap_ranked(ranked *a, ranked *b)
{
    ranked t = *a;
    *a = *b;
    *b = t;
}

static void heap_sift_ranked(ranked *a, size_t root, size_t n)
{
    for (;;) {
        size_t child = 2 * root + 1;
        if (child >= n) return;
        if (child + 1 < n && ranked_before(&a[child], &a[child + 1])) child++;
        if (!ranked_before(&a[root], &a[child])) return;
        swap_ranked(&a[root], &a[child]);
        root = child;
    }
}

/* Hoare partition of a[0 .. n) (n > 16) around the median of its first,
 * middle and last entries: returns left with a[0 .. left) <= pivot <=
 * a[left .. n). */
static size_t partition_ranked(ranked *a, size_t n)
{
    const ranked *x = &a[0], *y = &a[n / 2], *z = &a[n - 1];
    const ranked *median = ranked_before(x, y) ? (ranked_before(y, z) ? y : ranked_before(x, z) ? z : x)
                                               : (ranked_before(x, z) ? x : ranked_before(y, z) ? z : y);
    const ranked pivot = *median;
    size_t i = 0, j = n - 1;
    for (;;) {
        while (ranked_before(&a[i], &pivot)) i++;
        while (ranked_before(&pivot, &a[j])) j--;
        if (i >= j) break;
        swap_ranked(&a[i], &a[j]);
        i++;
        j--;
    }
    return j + 1;
}

/* Introsort in place: quicksort (median of three, Hoare partition), heapsort
 * past a depth limit, insertion sort for short runs. glibc's qsort allocates
 * a copy of the array (16 bytes a vertex) while it merges, at the moment the
 * simplifier's memory peaks; this needs none, and is about twice as fast. */
static void sort_ranked_depth(ranked *a, size_t n, unsigned depth)
{
    while (n > 16) {
        if (depth-- == 0) {
            for (size_t i = n / 2; i-- > 0;) heap_sift_ranked(a, i, n);
            for (size_t end = n - 1; end > 0; --end) {
                swap_ranked(&a[0], &a[end]);
                heap_sift_ranked(a, 0, end);
            }
            return;
        }
        /* recurse into the shorter side */
        const size_t left = partition_ranked(a, n);
        if (left < n - left) {
            sort_ranked_depth(a, left, depth);
            a += left;
            n -= left;
        } else {
            sort_ranked_depth(a + left, n - left, depth);
            n = left;
        }
    }
    for (size_t i = 1; i < n; ++i)
        for (size_t j = i; j > 0 && ranked_before(&a[j], &a[j - 1]); --j) swap_ranked(&a[j], &a[j - 1]);
}

static void sort_ranked(ranked *a, size_t n)
{
    unsigned depth = 0;
    for (size_t m = n; m > 1; m >>= 1) depth += 2;
    sort_ranked_depth(a, n, depth);
}

/* Below this many movable vertices one thread collects alone (a thread's
 * start costs more than it saves). */
#define COLLECT_PARALLEL_MIN 16384

/* The candidates among movable[begin, end): alive, not locked, not rejected
 * since their neighbourhood last changed, each with the cost of its cheapest
 * neighbour (an ordering hint; evaluation applies the rules). The alive
 * vertices are compacted to the front of the range, in order, and the
 * candidates written to out[begin ..], unsorted. Reads the mesh and writes
 * only the range's own entries (movable, out, reject_stamp and the cost
 * cache of its vertices), so disjoint ranges may be collected at once. */
typedef struct collect_range {
    sim *s;
    ranked *out;
    uint32_t begin, end;
    uint32_t kept, count; /* results: alive vertices, candidates */
    uint32_t held;        /* results: candidates retry_due holds back for patience */
} collect_range;

/* u's cost, how the region queues and the passes order candidates: that of
 * its cheapest half-edge collapse, the neighbour at its end in *to
 * (NONE when u has no edge of finite cost). */
static double cheapest_edge(const sim *s, uint32_t u, uint32_t *to)
{
    double best = INFINITY;
    uint32_t best_to = NONE;
    for (uint32_t c = s->vertex_first[u]; c != NONE; c = s->corner_next[c]) {
        if (!s->face_alive[c / 3] || s->corner_vertex[c] != u) continue;
        const uint32_t x = s->corner_vertex[3 * (c / 3) + (c % 3 + 1) % 3];
        const double e = half_edge_cost(s, u, x);
        if (e < best) best = e, best_to = x;
    }
    *to = best_to;
    return best;
}

/* The cost of u's cheapest edge (INFINITY: u has no face), the ordering
 * hint of collect_candidates. It reads u's faces and the quadric and place
 * of each neighbour, which change only by a commit that stamps u
 * (stamp_changes: the heir and every vertex of a face around it), or by a
 * face of u dying, which the count of u's faces tells: so the cost computed
 * at a clock stays exact until u is stamped after it or its face count
 * falls. Most vertices are unchanged from one pass to the next. */
static double vertex_cost(sim *s, uint32_t u)
{
    const uint32_t faces = faces_around(s, u);
    if (s->cost_clock[u] != NONE && s->change_stamp[u] <= s->cost_clock[u] && faces == s->cost_faces[u])
        return s->cost[u];
    uint32_t to;
    s->cost[u] = cheapest_edge(s, u, &to);
    s->cost_clock[u] = s->commit_clock;
    s->cost_faces[u] = faces;
    return s->cost[u];
}

static void collect_range_run(collect_range *r)
{
    sim *s = r->s;
    uint32_t kept = r->begin, n = r->begin;
    r->held = 0;
    for (uint32_t i = r->begin; i < r->end; ++i) {
        const uint32_t u = s->movable[i];
        if (!s->vertex_alive[u]) continue;
        s->movable[kept++] = u;
        if (s->reject_stamp[u] != NONE) {
            const int due = retry_due(s, u, s->patient);
            r->held += due == RETRY_LATER;
            if (due != RETRY_NOW) continue;
            s->reject_stamp[u] = NONE;
        }
        const double best = vertex_cost(s, u);
        if (best < INFINITY) {
            r->out[n].cost = best;
            r->out[n].u = u;
            n++;
        }
    }
    r->kept = kept - r->begin;
    r->count = n - r->begin;
}

typedef struct collect_job {
    collect_range ranges[MAX_THREADS];
    uint32_t parts;
    atomic_uint next; /* the next range to claim */
} collect_job;

/* Claims and collects ranges until none is left (a workpool_fn). */
static void collect_worker(void *p, uint32_t thread)
{
    (void)thread;
    collect_job *job = p;
    for (;;) {
        const uint32_t k = atomic_fetch_add_explicit(&job->next, 1, memory_order_relaxed);
        if (k >= job->parts) return;
        collect_range_run(&job->ranges[k]);
    }
}

/* Every candidate of the level into out (unsorted; the count is returned,
 * or -1 when memory runs out), the movable list compacted to its alive
 * vertices. The movable vertices are
 * cut into one contiguous range per thread and the ranges' results joined in
 * range order, so movable and the set of candidates are what one thread
 * would give; ranking them (rank_cheapest) then fixes their order. */
static long collect_candidates(sim *s, ranked *out)
{
    if (!s->cost) {
        s->cost = malloc(((size_t)s->nv + 1) * sizeof *s->cost);
        s->cost_clock = malloc(((size_t)s->nv + 1) * sizeof *s->cost_clock);
        s->cost_faces = malloc(((size_t)s->nv + 1) * sizeof *s->cost_faces);
        if (!s->cost || !s->cost_clock || !s->cost_faces) return s->serial.oom = 1, -1;
        memset(s->cost_clock, 0xff, ((size_t)s->nv + 1) * sizeof *s->cost_clock);
    }
    collect_job job;
    collect_range *ranges = job.ranges;
    const uint32_t parts = s->movable_count >= COLLECT_PARALLEL_MIN ? s->thread_count : 1;
    job.parts = parts;
    atomic_init(&job.next, 0);
    for (uint32_t t = 0; t < parts; ++t) {
        ranges[t].s = s;
        ranges[t].out = out;
        ranges[t].begin = (uint32_t)((uint64_t)s->movable_count * t / parts);
        ranges[t].end = (uint32_t)((uint64_t)s->movable_count * (t + 1) / parts);
    }
    if (parts > 1) workpool_start(&s->pool, collect_worker, &job);
    collect_worker(&job, 0);
    if (parts > 1) workpool_finish(&s->pool);
    uint32_t kept = 0;
    size_t n = 0;
    s->held_back = 0;
    for (uint32_t t = 0; t < parts; ++t) {
        memmove(s->movable + kept, s->movable + ranges[t].begin, (size_t)ranges[t].kept * sizeof *s->movable);
        memmove(out + n, out + ranges[t].begin, (size_t)ranges[t].count * sizeof *out);
        kept += ranges[t].kept;
        n += ranges[t].count;
        s->held_back += ranges[t].held;
    }
    s->movable_count = kept;
    return (long)n;
}

/* Puts the `share` cheapest of a[0 .. n) in a[0 .. share), in order (the
 * rest after them, in no order): a pass takes only those. ranked_before is a
 * total order (vertices are distinct), so the result does not depend on the
 * order a[] came in. Quickselect narrows to the side that holds the share's
 * end; a short part, or any part past a depth limit, is sorted whole. */
static void rank_cheapest(ranked *a, size_t n, size_t share)
{
    if (share > n) share = n;
    ranked *part = a;
    size_t m = n, k = share; /* the k cheapest of part[0 .. m) go first */
    unsigned depth = 0;
    for (size_t x = n; x > 1; x >>= 1) depth += 2;
    while (k > 0 && k < m) {
        if (m <= 16 || depth-- == 0) {
            sort_ranked(part, m);
            break;
        }
        const size_t left = partition_ranked(part, m);
        if (k <= left) {
            m = left;
        } else {
            part += left;
            m -= left;
            k -= left;
        }
    }
    sort_ranked(a, share);
}

/* Lists v and every vertex within `depths` edges of it (1 to 3) in ring,
 * each once (sc's vertex_seen), nearest first: ball_end[d] is the end of
 * those within d + 1 edges (ball_end[0]: v and its neighbours). A hub's star
 * is not walked (its neighbours are reached from elsewhere or not at all).
 * With stop, it stops at the first vertex y it reaches with stop[y] ==
 * stop_value and returns 0 (ball_end then unset); else 1; -1 when memory
 * runs out. */
static int two_ball(const sim *s, scratch *sc, u32vec *ring, uint32_t v, const uint32_t *stop, uint32_t stop_value,
                    int depths, size_t *ball_end)
{
    ring->size = 0;
    if (next_stamp(sc) || u32_push(ring, v)) return -1;
    sc->vertex_seen[v] = sc->stamp;
    if (stop && stop[v] == stop_value) return 0;
    size_t begin = 0;
    for (int depth = 0; depth < depths; ++depth) {
        const size_t end = ring->size;
        for (size_t i = begin; i < end; ++i) {
            const uint32_t x = ring->data[i];
            /* a hub's neighbours are held: no candidate is found through it,
             * and no candidate next to it is reserved */
            if (s->held[x] == HELD_HUB) continue;
            for (uint32_t c = s->vertex_first[x]; c != NONE; c = s->corner_next[c]) {
                if (!s->face_alive[c / 3] || s->corner_vertex[c] != x) continue;
                for (int k = 0; k < 3; ++k) {
                    const uint32_t y = s->corner_vertex[3 * (c / 3) + k];
                    if (sc->vertex_seen[y] == sc->stamp) continue;
                    sc->vertex_seen[y] = sc->stamp;
                    if (stop && stop[y] == stop_value) return 0;
                    if (u32_push(ring, y)) return -1;
                }
            }
        }
        begin = end;
        ball_end[depth] = ring->size;
    }
    return 1;
}

/* 1 when u's R meets no W reserved in the current batch, from the near marks
 * (reserve_footprint). */
static int footprint_free(const sim *s, uint32_t u)
{
    const uint32_t stamp = s->batch_stamp;
    for (uint32_t c = s->vertex_first[u]; c != NONE; c = s->corner_next[c]) {
        if (!s->face_alive[c / 3] || s->corner_vertex[c] != u) continue;
        for (int k = 0; k < 3; ++k) {
            const uint32_t x = s->corner_vertex[3 * (c / 3) + k];
            if (s->held[x] == HELD_HUB) {
                if (s->vertex_stamp[x] == stamp) return 0;
                continue;
            }
            if (s->near_stamp[x] == stamp) return 0;
            if (s->held[x] != HELD_NEIGHBOUR) continue;
            for (uint32_t d = s->vertex_first[x]; d != NONE; d = s->corner_next[d]) {
                if (!s->face_alive[d / 3] || s->corner_vertex[d] != x) continue;
                for (int j = 0; j < 3; ++j)
                    if (s->vertex_stamp[s->corner_vertex[3 * (d / 3) + j]] == stamp) return 0;
            }
        }
    }
    return 1;
}

/* Reserves a candidate's neighbourhood in the current batch. Its evaluation
 * reads the faces around every vertex within two edges of u (R, the 2-ball);
 * its commit writes the faces around u and the lists and quadric of one
 * neighbour, all incident to the 1-ball of u (W); with full-edge placement
 * the neighbour v moves too, so the faces around v change and W is the
 * 2-ball. Two candidates are independent when neither's W meets the other's
 * R, that is when they are more than 2 + w edges apart (w = 1, or 2 with
 * placement); and that holds exactly when u's R meets no W reserved before
 * (the other half of the condition says the same thing). Registrations are
 * checked at commit (unit_stamp). Returns 1 and marks u's W, or 0 when the
 * candidate must wait.
 *
 * R is two_ball's walk: u, its neighbours, and the neighbours of those that
 * are not hubs. Walking it for every candidate cost a pass the star of every
 * large fan next to a candidate, again for each candidate that then had to
 * wait (a UV sphere's pole of 4,000 faces: every candidate of a pass walked
 * it). So the test is turned around: a reservation marks, beside W
 * (vertex_stamp), the vertices next to W (near_stamp: W and the neighbours
 * of its vertices that are not hubs, whose stars may be huge), and u's R
 * meets W exactly when some x of u's 1-ball is near, or x is a hub's
 * neighbour with a neighbour in W (a hub in W marks no neighbour near). The
 * decisions, and so the levels, are those of walking R; a candidate that
 * waits reads only its own 1-ball (and the stars of hubs' neighbours in it). */
static int reserve_footprint(sim *s, uint32_t u)
{
    const uint32_t stamp = s->batch_stamp;
    scratch *sc = &s->serial;
    size_t ball_end[3];
    const int free_now = footprint_free(s, u);
    if (s->verify) { /* the invariant checker's mode: the decision is that of walking R */
        const int walked = two_ball(s, sc, &sc->ring, u, s->vertex_stamp, stamp, 2, ball_end);
        if (walked < 0) return sc->oom = 1, 0;
        if (walked != free_now) {
            s->verify_failed = 1;
            snprintf(s->verify_msg, sizeof s->verify_msg,
                     "reservation of %u: the near marks say %s, walking its 2-ball says %s", u,
                     free_now ? "free" : "taken", walked ? "free" : "taken");
            return 0;
        }
    }
    if (!free_now) return 0;
    /* W is the ball of w edges, near the ball of w + 1 (two_ball does not
     * walk a hub's star) */
    const int w = s->full_edge ? 2 : 1;
    if (two_ball(s, sc, &sc->ring, u, NULL, 0, w + 1, ball_end) < 0) return sc->oom = 1, 0;
    for (size_t i = 0; i < ball_end[w - 1]; ++i) s->vertex_stamp[sc->ring.data[i]] = stamp;
    for (size_t i = 0; i < sc->ring.size; ++i) s->near_stamp[sc->ring.data[i]] = stamp;
    return 1;
}

static void process_batch(sim *s, candidate *batch, size_t count, long *commits);

#define MERGE_FACES_TRIED 8

/* Registers whole every cluster that one face now holds, among those whose
 * originals were re-registered since the last try (cluster_dirty): the faces
 * tried are the ones its originals are registered to. Serial, between
 * batches, or in a round beside region_partition. Returns 0, or -1 (out of memory, or a broken invariant). */
static int merge_clusters(sim *s)
{
    scratch *sc = &s->serial;
    u32vec merged = {0};
    if (grow((void **)&sc->tris, &sc->tris_cap, MERGE_FACES_TRIED, sizeof *sc->tris)) return sc->oom = 1, -1;
    uint_least64_t dirty = 0;
    for (uint32_t c = 0; c < s->orig.cluster_count; ++c) {
        if (c % 64 == 0) {
            if (!atomic_load_explicit(&s->cluster_dirty[c / 64], memory_order_relaxed)) {
                c += 63;
                continue;
            }
            dirty = atomic_exchange_explicit(&s->cluster_dirty[c / 64], 0, memory_order_relaxed);
        }
        if (!((dirty >> (c % 64)) & 1)) continue;
        /* whole already: its originals hold no slot (registry.h), so no
         * face to try (every cluster is dirty at a level's start) */
        if (registry_cluster_face(&s->reg, c) != REGISTRY_NONE) continue;
        const cert_cluster_info *info = &s->orig.clusters[c];
        if (info->material == CERT_MIXED || info->cone_sin > 1.0) continue;
        const uint32_t *order = s->orig.tree.triangle_order + info->first;
        uint32_t faces[MERGE_FACES_TRIED], n = 0;
        for (uint32_t i = 0; i < info->count && n < MERGE_FACES_TRIED; ++i) {
            uint32_t on[REGISTRY_SLOTS], m = unit_faces(s, order[i], on);
            for (uint32_t k = 0; k < m && n < MERGE_FACES_TRIED; ++k) {
                uint32_t j = 0;
                while (j < n && faces[j] != on[k]) j++;
                if (j == n) face_after(s, faces[n++] = on[k], NULL, &sc->tris[j]);
            }
        }
        uint32_t face;
        double bound;
        if (!cert_cluster(&s->orig, c, sc->tris, n, s->eps, NULL, 0, &face, &bound)) continue;
        for (uint32_t i = 0; i < info->count; ++i) registry_clear(&s->reg, order[i]);
        registry_set_cluster(&s->reg, c, face);
        s->unit_bound[s->nf + c] = bound;
        s->stats->cluster_merges++;
        if (s->verify && u32_push(&merged, s->nf + c)) {
            free(merged.data);
            return sc->oom = 1, -1;
        }
    }
    int rc = s->verify ? verify_state(s, merged.data, merged.size, NULL, 0) : 0;
    free(merged.data);
    if (rc) s->verify_failed = 1;
    return rc;
}

/* Makes grid g again over the alive faces among faces[0 .. n) (faces 0 ..
 * n - 1 when faces is NULL), entered under their own numbers or, with
 * local, under their index in faces. Cells are twice the faces' mean
 * extent: a query then visits few faces that are not near it. Except over
 * the whole original (the first level's passes when no region round ran
 * before them), where 4x spans fewer cells per face: measured on a
 * 1.1M-triangle chain (when its first level still built this grid), 2x
 * throughout cost 19 bytes a triangle more at the peak, 4x throughout 1.4 s
 * more time. And 3x in a region's own grid (local), built once while its
 * faces grow, whose queries test the boxes before anything else (ir.sh on
 * the 278k mesh: 1.5x 15.160, 2x 15.102, 3x 15.080, 4x 15.091 G).
 * With boxes, the box of each alive faces[i] (lo, hi) goes to boxes + 6 i.
 * Returns the number of alive faces, or -1 when memory runs out. */
static long grid_fill(const sim *s, facegrid *g, const uint32_t *faces, size_t n, int local, uint32_t capacity,
                      double *boxes)
{
    double extent = 0.0;
    uint32_t alive = 0;
    double lo[3], hi[3];
    for (size_t i = 0; i < n; ++i) {
        const uint32_t f = faces ? faces[i] : (uint32_t)i;
        if (!s->face_alive[f]) continue;
        face_box(s, f, lo, hi);
        if (boxes) {
            memcpy(boxes + 6 * i, lo, sizeof lo);
            memcpy(boxes + 6 * i + 3, hi, sizeof hi);
        }
        const double e = geom_fmax(hi[0] - lo[0], geom_fmax(hi[1] - lo[1], hi[2] - lo[2]));
        if (isfinite(e)) extent += e;
        alive++;
    }
    const double factor = local ? 3.0 : alive == s->nf ? 4.0 : 2.0;
    double cell = alive ? factor * extent / alive : 1.0;
    if (!(cell > 0.0) || !isfinite(cell)) cell = 1.0;
    if (facegrid_reset(g, cell, capacity) != FACEGRID_OK) return -1;
    for (size_t i = 0; i < n; ++i) {
        const uint32_t f = faces ? faces[i] : (uint32_t)i;
        if (!s->face_alive[f]) continue;
        if (!boxes) face_box(s, f, lo, hi); /* else kept by the first sweep */
        const double *box_lo = boxes ? boxes + 6 * i : lo, *box_hi = boxes ? boxes + 6 * i + 3 : hi;
        if (facegrid_insert(g, local ? (uint32_t)i : f, box_lo, box_hi) != FACEGRID_OK) return -1;
    }
    return alive;
}

/* Compacts face_list to the alive faces (made at the first call). Returns
 * 0, or -1 when memory runs out. */
static int live_faces(sim *s)
{
    if (!s->face_list) {
        s->face_list = malloc(((size_t)s->nf + 1) * sizeof *s->face_list);
        if (!s->face_list) return -1;
        for (uint32_t f = 0; f < s->nf; ++f) s->face_list[f] = f;
        s->face_list_count = s->nf;
    }
    uint32_t n = 0;
    for (uint32_t i = 0; i < s->face_list_count; ++i)
        if (s->face_alive[s->face_list[i]]) s->face_list[n++] = s->face_list[i];
    s->face_list_count = n;
    return 0;
}

/* (Re)builds the level's face grid. Returns 0, or -1 when memory runs out. */
static int grid_rebuild(sim *s)
{
    if (live_faces(s)) return -1;
    const long alive = grid_fill(s, &s->grid, s->face_list, s->face_list_count, 0, s->nf, NULL);
    if (alive < 0) return -1;
    s->grid_built_with = s->faces_alive = (uint32_t)alive;
    s->grid_current = 1;
    return 0;
}

/* One sweep over the cheapest share of the candidates (PASS_SHARE) in cost
 * order, in batches of independent ones; a candidate that is not independent
 * of its batch, or beyond the share, waits for the next pass. Returns the
 * number of commits (+ waiting candidates in *waiting), or -1 on failure. */
static long run_pass(sim *s, ranked *ranks, candidate *batch, size_t *waiting)
{
    simplify_stats *st = s->stats;
    double t0 = lp_seconds();
    if (!s->vertex_stamp) {
        s->vertex_stamp = calloc((size_t)s->nv + 1, sizeof *s->vertex_stamp);
        s->near_stamp = calloc((size_t)s->nv + 1, sizeof *s->near_stamp);
        if (!s->vertex_stamp || !s->near_stamp) return s->serial.oom = 1, -1;
    }
    if (!s->grid_current && grid_rebuild(s)) return -1;
    if (merge_clusters(s)) return -1;
    const long collected = collect_candidates(s, ranks);
    if (collected < 0) return -1;
    size_t n = (size_t)collected;
    long commits = 0;
    const size_t share = n <= PASS_MIN ? n : n / PASS_SHARE > PASS_MIN ? n / PASS_SHARE : PASS_MIN;
    *waiting = n - share;
    rank_cheapest(ranks, n, share);
    n = share;
    st->seconds_select += lp_seconds() - t0;
    batch_run run;
    for (size_t i = 0; i < n;) {
        if (++s->batch_stamp == 0) return -1;
        batch_open(s, &run, batch);
        size_t count = 0;
        double t1 = lp_seconds();
        for (; i < n && count < BATCH_SIZE; ++i) {
            if (!reserve_footprint(s, ranks[i].u)) {
                if (s->serial.oom || s->verify_failed) break;
                (*waiting)++;
                continue;
            }
            batch[count++].u = ranks[i].u;
            batch_publish(s, &run, count);
        }
        const double t2 = lp_seconds();
        st->seconds_select += t2 - t1;
        batch_close(s, &run);
        st->seconds_certify += lp_seconds() - t2;
        if (s->serial.oom || s->verify_failed) return -1;
        if (count) process_batch(s, batch, count, &commits);
        if (commits < 0) return -1;
        /* the first pass of a level removes most faces: cells sized for the
         * faces it started with would make every crossing query visit many
         * cells */
        if (s->faces_alive < s->grid_built_with / 2 && grid_rebuild(s)) return -1;
    }
    return commits;
}

/* Commits an evaluated batch's accepted candidates in order. Adds to
 * *commits, or sets it to -1 on failure. */
static void process_batch(sim *s, candidate *batch, size_t count, long *commits)
{
    simplify_stats *st = s->stats;
    double t3 = lp_seconds();
    st->batches++;
    for (uint32_t t = 0; t < s->thread_count; ++t) {
        if (s->scratch[t].doomed_passed != NONE) {
            s->verify_failed = 1;
            snprintf(s->verify_msg, sizeof s->verify_msg,
                     "collapse of %u: rejected early as beyond cover (cover_doomed), passed the certificate's (b)",
                     s->scratch[t].doomed_passed);
        }
        if (s->scratch[t].oom || s->verify_failed) {
            *commits = -1;
            return;
        }
    }
    s->batch_stars.faces.size = s->batch_stars.end.size = s->batch_stars.box.size = 0;
    const committer cm = {&s->serial, st, &s->commit_clock, &s->batch_stars, NULL};
    /* the grid's updates go to the core that would otherwise wait */
    gridlog_start(&s->grid_log, &s->grid, s->thread_count > 1 && count >= GRIDLOG_PARALLEL_MIN);
    int failed = 0;
    for (size_t i = 0; i < count && !failed; ++i) {
        candidate *c = &batch[i];
        st->candidates++;
        st->attempts += c->attempts;
        if (c->v == NONE) {
            st->rejected[c->reason]++;
            note_rejection(s, c->u, s->commit_clock);
            continue;
        }
        if (!commit(s, c, &cm)) {
            failed = s->verify_failed || s->serial.oom;
            if (!failed) st->rejected[SIMPLIFY_REJECT_CONFLICT]++;
            continue;
        }
        st->commits++;
        (*commits)++;
    }
    if (gridlog_finish(&s->grid_log)) failed = s->serial.oom = 1;
    if (failed) *commits = -1;
    st->seconds_commit += lp_seconds() - t3;
}

/* ---- the thin map: built ahead ------------------------------------------------ */

/* Below this many faces a level's thin map is built when first needed, on
 * the main thread: starting a thread would cost more than the build. */
#define THIN_AHEAD_MIN 16384

static void *thin_ahead_run(void *p)
{
    thin_ahead *a = p;
    const sim *s = a->s;
    a->rc = thin_map_build(&a->map, a->radius, s->w->positions, s->w->vertex_count, s->w->triangle_vertices, s->nf,
                           s->face_material, s->special);
    return NULL;
}

/* Starts building the thin map of the given radius on a thread of its own:
 * the next level's beside the level now running, whose serial steps
 * (selection, commits, the passes' lone candidates) leave the second core
 * idle, or the first level's beside its first region round's serial steps.
 * A map reads only the original, so it is the same whichever thread builds
 * it; on a 1.1M-triangle chain each took 0.05 s on the main thread. */
static void thin_ahead_start(sim *s, double radius)
{
    thin_ahead *a = &s->ahead;
    if (s->strict || s->thread_count < 2 || s->nf < THIN_AHEAD_MIN || !(radius > 0.0) || a->running) return;
    a->s = s;
    a->radius = radius;
    a->rc = 0;
    memset(&a->map, 0, sizeof a->map);
    a->running = pthread_create(&a->thread, NULL, thin_ahead_run, a) == 0;
}

/* Waits for the map built ahead, if any; returns 1 when it is one of the
 * given radius (then moved into *out), else frees it and returns 0. */
static int thin_ahead_take(sim *s, double radius, thin_map *out)
{
    thin_ahead *a = &s->ahead;
    if (!a->running) return 0;
    pthread_join(a->thread, NULL);
    a->running = 0;
    if (a->rc != 0 || a->radius != radius) {
        thin_map_free(&a->map);
        return 0;
    }
    *out = a->map;
    memset(&a->map, 0, sizeof a->map);
    return 1;
}

/* Makes the level's thin map current (the one built ahead, or built now)
 * before anything is evaluated. Returns 0, or -1 when memory runs out. */
static int thin_ready(sim *s)
{
    if (s->thin_ready || s->strict) return 0;
    const double radius = 2.0 * s->eps;
    if (!thin_ahead_take(s, radius, &s->thin) &&
        thin_map_build(&s->thin, radius, s->w->positions, s->w->vertex_count, s->w->triangle_vertices, s->nf,
                       s->face_material, s->special))
        return -1;
    s->thin_ready = 1;
    return 0;
}

/* ---- regions: rounds of independent local simplification ------------------------ */

/* Early in a level most collapses are cheap and far apart, and the global
 * passes keep one core busy with their serial steps (reserving each batch's
 * neighbourhoods, committing) while the evaluations wait. A round cuts the
 * alive vertices into regions, the cells of a cubic grid holding about
 * REGION_SIZE vertices each; one thread simplifies a region on its own (a
 * priority queue of its candidates, each evaluated as in the passes and
 * committed at once), while other threads run other regions. A region owns
 * the faces whose three vertices are all in it and works only on its
 * interior vertices (their 2-ball lies in the region), so what it changes no
 * other region reads: a candidate that would register an original to a face
 * it does not own, or re-register one that a face of another region holds
 * too, is deferred to a later round; the faces another region owns lie in
 * that region's cell and cannot cross its new faces. Rounds shift the grid
 * by half a cell, and the global passes finish the level. Which region a
 * thread runs changes nothing: the result does not depend on the thread
 * count. */
#define REGION_SIZE 4096
/* A region stops when it has removed this many quarters of its interior
 * vertices: the vertices near its boundary stay as they are this round, and
 * a region taken as far as eps allows would leave long faces along them
 * that the next rounds could not undo. Measured on the 1.1M-triangle chain
 * (1 % level): 526 triangles without a cap, 491 with 2 quarters, 470 with
 * 3 (the global passes alone: 479); the bunny's 1/64 .. 1 % levels within
 * 1 % of the global passes' either way. */
#define REGION_TAKE 3
/* rounds run while this many regions' worth of vertices are alive */
#define REGION_MIN_REGIONS 4
/* and while a round removes at least 1/REGION_STOP of them */
#define REGION_STOP 32

enum { VERTEX_CORE = 1, VERTEX_INTERIOR = 2 };

/* Each vertex's cell of side `cell` (shifted by half a cell when shifted),
 * numbered x fastest, into key[] for spatial[0 .. n); returns the largest. */
static uint64_t cell_keys(const sim *s, uint32_t n, const double lo[3], const double hi[3], double cell, int shifted,
                          uint64_t *key)
{
    const double off = shifted ? 0.5 : 0.0;
    uint64_t dim[3], max_key = 0;
    for (int a = 0; a < 3; ++a) dim[a] = (uint64_t)((hi[a] - lo[a]) / cell + off) + 1;
    for (uint32_t i = 0; i < n; ++i) {
        const float *p = s->positions + 3 * (size_t)s->spatial[i];
        uint64_t c[3];
        for (int a = 0; a < 3; ++a) {
            const double q = (p[a] - lo[a]) / cell + off; /* monotone in p: cells keep their order */
            c[a] = q > 0.0 ? (uint64_t)q : 0;
            if (c[a] >= dim[a]) c[a] = dim[a] - 1;
        }
        key[i] = c[0] + dim[0] * (c[1] + dim[1] * c[2]);
        if (key[i] > max_key) max_key = key[i];
    }
    return max_key;
}

/* Cuts the alive vertices into the round's regions: the cells of a cubic
 * grid (shifted by half a cell in odd rounds, so a round's boundaries run
 * through the middle of the previous round's regions), sized so that a
 * region holds about `size` vertices. Two regions' vertices lie in
 * disjoint half-open cells, and so do the faces each region owns (a
 * triangle lies in the box of its corners): no face a region makes can
 * cross a face another one owns. Sets region_of, face_owner and the
 * interior flags. Returns the number of regions, or -1 when memory runs
 * out. */
static long region_partition(sim *s, region **regions, uint32_t size, int shifted)
{
    uint32_t n = 0;
    for (uint32_t i = 0; i < s->spatial_count; ++i)
        if (s->vertex_alive[s->spatial[i]]) s->spatial[n++] = s->spatial[i];
    s->spatial_count = n;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t i = 0; i < n; ++i)
        for (int a = 0; a < 3; ++a) {
            lo[a] = geom_fmin(lo[a], s->positions[3 * (size_t)s->spatial[i] + a]);
            hi[a] = geom_fmax(hi[a], s->positions[3 * (size_t)s->spatial[i] + a]);
        }
    if (!s->region_key) s->region_key = malloc(((size_t)s->nv + 1) * sizeof *s->region_key);
    uint64_t *key = s->region_key;
    if (!key) return -1;
    double extent = 0.0;
    for (int a = 0; a < 3; ++a) extent = geom_fmax(extent, hi[a] - lo[a]);
    if (!(extent > 0.0) || !isfinite(extent)) extent = 1.0;
    double cell;
    if (s->region_alive0 == 0) {
        /* the first round measures how many vertices a cell holds (a surface:
         * about the square of its side) and sizes the cells for `size`;
         * again when the cells were too fine to hold several vertices, or
         * far off */
        cell = extent / 32.0;
        for (int tries = 0; tries < 4; ++tries) {
            const uint64_t max_key = cell_keys(s, n, lo, hi, cell, 0, key);
            if (radix_sort_u64_with(key, s->spatial, n, max_key, &s->region_sort)) return -1;
            uint32_t cells = n ? 1 : 0;
            for (uint32_t i = 1; i < n; ++i) cells += key[i] != key[i - 1];
            const double mean = cells ? (double)n / cells : 1.0;
            cell *= sqrt((double)size / mean);
            if (!(cell > extent / 1048576.0)) cell = extent / 1048576.0; /* keys stay below 2^60 */
            if (mean >= 8.0 && mean >= size / 4.0 && mean <= size * 4.0) break;
        }
        s->region_cell = cell;
        s->region_alive0 = n;
    } else { /* fewer vertices, the same density per region: larger cells */
        cell = s->region_cell * sqrt((double)s->region_alive0 / (n ? n : 1));
    }
    const uint64_t max_key = cell_keys(s, n, lo, hi, cell, shifted, key);
    uint32_t parts = n ? 1 : 0;
    region *r = NULL;
    if (!radix_sort_u64_with(key, s->spatial, n, max_key, &s->region_sort)) {
        for (uint32_t i = 1; i < n; ++i) parts += key[i] != key[i - 1];
        r = calloc((size_t)parts + 1, sizeof *r);
    }
    if (!r) return -1;
    uint32_t k = 0;
    for (uint32_t i = 0; i < n; ++i) {
        if (i > 0 && key[i] != key[i - 1]) {
            r[k].end = i;
            r[++k].begin = i;
        }
        r[k].id = k;
        s->region_of[s->spatial[i]] = k;
    }
    if (n) r[k].end = n;
    for (uint32_t f = 0; f < s->nf; ++f) {
        if (!s->face_alive[f]) continue;
        const uint32_t *cv = s->corner_vertex + 3 * (size_t)f, a = s->region_of[cv[0]];
        s->face_owner[f] = a == s->region_of[cv[1]] && a == s->region_of[cv[2]] ? a : REGION_SHARED;
    }
    /* core: every face around the vertex is its region's; interior: so are
     * its neighbours' (then its 2-ball lies in the region, and stays there
     * while the region collapses its own interior vertices) */
    for (uint32_t i = 0; i < n; ++i) {
        const uint32_t x = s->spatial[i];
        uint8_t core = VERTEX_CORE;
        for (uint32_t c = s->vertex_first[x]; c != NONE && core; c = s->corner_next[c])
            if (s->face_alive[c / 3] && s->corner_vertex[c] == x && s->face_owner[c / 3] != s->region_of[x]) core = 0;
        s->interior[x] = core;
    }
    for (uint32_t i = 0; i < n; ++i) {
        const uint32_t x = s->spatial[i];
        if (!s->interior[x]) continue;
        int all = 1;
        for (uint32_t c = s->vertex_first[x]; c != NONE && all; c = s->corner_next[c])
            if (s->face_alive[c / 3] && s->corner_vertex[c] == x)
                for (int k = 0; k < 3; ++k) all &= s->interior[s->corner_vertex[3 * (c / 3) + k]] & VERTEX_CORE;
        if (all) s->interior[x] |= VERTEX_INTERIOR;
    }
    *regions = r;
    return parts;
}

/* A region's queue entry: u's cost when it was queued (queued[u] tells
 * whether it is still the latest). */
typedef struct queued_cost {
    double cost;
    uint32_t u, version;
} queued_cost;

static int queued_before(const queued_cost *x, const queued_cost *y)
{
    return candidate_before(x->cost, x->u, y->cost, y->u);
}

/* What one thread keeps while it runs regions: a region's queue (a binary
 * heap, cheapest first), the grid of its faces, the candidates it deferred
 * and a vertex list. */
typedef struct region_thread {
    queued_cost *heap;
    size_t heap_size, heap_cap;
    /* the region's interior vertices that wait after a rejection: while
     * there are none, a commit re-queues only its 1-ring */
    uint64_t waiting;
    own_grid own;
    u32vec deferred, ring;
} region_thread;

static void region_thread_free(region_thread *t)
{
    free(t->heap);
    facegrid_free(&t->own.grid);
    free(t->own.faces.data);
    free(t->own.box.data);
    keymap_free(&t->own.local);
    free(t->deferred.data);
    free(t->ring.data);
}

/* The faces region rg owns now (each from its first corner's vertex: its
 * corners' vertices stay the region's while it runs), their grid and
 * boxes. */
static int own_grid_init(const sim *s, const region *rg, own_grid *g)
{
    g->ready = 1; /* (a failure stops the region) */
    g->faces.size = 0;
    keymap_clear(&g->local);
    for (uint32_t i = rg->begin; i < rg->end; ++i) {
        const uint32_t x = s->spatial[i];
        for (uint32_t c = s->vertex_first[x]; c != NONE; c = s->corner_next[c]) {
            const uint32_t f = c / 3;
            if (!s->face_alive[f] || s->corner_vertex[c] != x || c != 3 * f || s->face_owner[f] != rg->id) continue;
            if (keymap_insert(&g->local, f, (uint32_t)g->faces.size) < 0 || u32_push(&g->faces, f)) return -1;
        }
    }
    if (grow((void **)&g->box.data, &g->box.cap, 6 * g->faces.size + 1, sizeof *g->box.data)) return -1;
    return grid_fill(s, &g->grid, g->faces.data, g->faces.size, 1, (uint32_t)g->faces.size, g->box.data) < 0 ? -1
                                                                                                               : 0;
}

static int heap_push(region_thread *t, queued_cost e)
{
    if (grow((void **)&t->heap, &t->heap_cap, t->heap_size + 1, sizeof *t->heap)) return -1;
    size_t i = t->heap_size++;
    while (i > 0) {
        const size_t parent = (i - 1) / 2;
        if (!queued_before(&e, &t->heap[parent])) break;
        t->heap[i] = t->heap[parent];
        i = parent;
    }
    t->heap[i] = e;
    return 0;
}

static queued_cost heap_pop(region_thread *t)
{
    const queued_cost top = t->heap[0], last = t->heap[--t->heap_size];
    size_t i = 0, n = t->heap_size;
    for (;;) {
        size_t child = 2 * i + 1;
        if (child >= n) break;
        if (child + 1 < n && queued_before(&t->heap[child + 1], &t->heap[child])) child++;
        if (!queued_before(&t->heap[child], &last)) break;
        t->heap[i] = t->heap[child];
        i = child;
    }
    if (n) t->heap[i] = last;
    return top;
}

/* May u be queued in its region: interior, alive, not fixed (locked or held)? */
static int queueable(const sim *s, uint32_t u)
{
    return (s->interior[u] & VERTEX_INTERIOR) && s->vertex_alive[u] && !fixed_vertex(s, u);
}

/* Queues u, a candidate of the region, with its current cost (the cost of
 * its cheapest neighbour, as the global passes rank it); an earlier entry
 * of u becomes stale. Returns 0, or -1 when memory runs out. */
static int region_queue(sim *s, region_thread *t, uint32_t u)
{
    if (!queueable(s, u)) return 0;
    const double best = cheapest_edge(s, u, &s->queued_to[u]);
    if (!(best < INFINITY)) return 0;
    return heap_push(t, (queued_cost){best, u, ++s->queued[u]});
}

/* region_queue for x, a neighbour of v after the commit of dead -> v, from
 * its latest entry's cost: of x's edges only the one to v changed (v's
 * quadric grew) and the one to dead went; an edge to any other y kept its
 * cost (the quadrics of x and y and y's place did not change). So when the
 * edge that gave the entry's cost leads elsewhere, the new cost is the
 * smaller of that edge's and the edge to v's: the value region_queue would
 * compute, for two edge costs instead of one per neighbour. */
static int region_queue_after(sim *s, region_thread *t, uint32_t x, uint32_t v, uint32_t dead)
{
    const uint32_t to = s->queued_to[x];
    if (to == NONE || to == v || to == dead || !queueable(s, x)) return region_queue(s, t, x);
    double best = half_edge_cost(s, x, to);
    int closer = 0;
    for (uint32_t c = s->vertex_first[x]; c != NONE; c = s->corner_next[c]) {
        if (!s->face_alive[c / 3] || s->corner_vertex[c] != x || s->corner_vertex[3 * (c / 3) + (c % 3 + 1) % 3] != v)
            continue;
        const double e = half_edge_cost(s, x, v);
        if (e < best) best = e, s->queued_to[x] = v, closer = 1;
        break; /* the edge's one face where v follows x (another would give the same cost) */
    }
    if (s->verify) { /* the invariant checker's mode: the same value as region_queue's, to the bit */
        uint32_t to_full;
        const double again = cheapest_edge(s, x, &to_full);
        if (memcmp(&again, &best, sizeof best) != 0) {
            snprintf(s->verify_msg, sizeof s->verify_msg,
                     "vertex %u: cost %.17g kept after the commit onto %u, %.17g computed afresh", x, best, v, again);
            s->verify_failed = 1;
            return -1;
        }
    }
    /* x's latest entry still waits in the queue (x was neither tried nor
     * rejected since: it is not waiting) with the cost of its edge to `to`:
     * unless the edge to v is cheaper, that entry stands, to the bit */
    if (!closer) return 0;
    return heap_push(t, (queued_cost){best, x, ++s->queued[x]});
}

/* After the commit of dead -> v: the vertices within two edges of v are
 * queued again with their new costs (v's quadric changed, so did the costs
 * of its neighbours) or, when they were rejected, tried again (a face within
 * two edges of them changed, as in collect_candidates). While no vertex of
 * the region waits after a rejection, only the 1-ring can change. */
static int region_requeue(sim *s, scratch *sc, region_thread *t, uint32_t v, uint32_t dead)
{
    size_t ball_end[2];
    if (two_ball(s, sc, &t->ring, v, NULL, 0, t->waiting ? 2 : 1, ball_end) < 0) return -1;
    const size_t one_ring_end = ball_end[0];
    for (size_t i = 0; i < t->ring.size; ++i) {
        const uint32_t x = t->ring.data[i];
        /* outside the region's interior nothing is read: region_queue skips it */
        if (!(s->interior[x] & VERTEX_INTERIOR)) continue;
        if (s->reject_stamp[x] != NONE) {
            if (retry_due(s, x, 1) != RETRY_NOW) continue;
            s->reject_stamp[x] = NONE;
            t->waiting--;
        } else if (i >= one_ring_end) {
            continue; /* queued, and its cost did not change: no neighbour's quadric did */
        } else if (i > 0) {
            if (region_queue_after(s, t, x, v, dead)) return -1;
            continue;
        }
        if (region_queue(s, t, x)) return -1;
    }
    return 0;
}

/* Simplifies region rg on this thread: its candidates in cost order, the
 * cheapest first, each evaluated and, when certified, committed at once;
 * the costs around a commit are updated and what it may have unblocked is
 * tried again, until the queue is empty or REGION_TAKE quarters of its
 * interior vertices are gone. */
static void region_run(sim *s, region *rg, uint32_t thread, region_thread *rt)
{
    scratch *sc = &s->scratch[thread];
    rg->own = &rt->own;
    rt->heap_size = 0;
    sc->region = rg;
    const committer cm = {sc, &rg->stats, &rg->clock, NULL, rg};
    rt->own.ready = 0;
    uint64_t interior = 0;
    rt->waiting = 0;
    for (uint32_t i = rg->begin; i < rg->end; ++i) {
        const uint32_t u = s->spatial[i];
        interior += (s->interior[u] & VERTEX_INTERIOR) != 0;
        if (s->reject_stamp[u] != NONE) {
            if (!(s->interior[u] & VERTEX_INTERIOR)) continue;
            if (retry_due(s, u, 1) != RETRY_NOW) {
                rt->waiting++;
                continue;
            }
            s->reject_stamp[u] = NONE;
        }
        if (region_queue(s, rt, u)) goto oom;
    }
    const uint64_t limit = interior * REGION_TAKE / 4;
    while (rt->heap_size && rg->stats.commits < limit) {
        const queued_cost e = heap_pop(rt);
        if (e.version != s->queued[e.u] || !s->vertex_alive[e.u]) continue; /* stale */
        candidate c;
        memset(&c, 0, sizeof c);
        c.u = e.u;
        c.thread = thread;
        sc->out_u32.size = sc->out_f64.size = 0;
        evaluate(s, sc, &c);
        if (sc->oom) goto oom;
        rg->stats.candidates++;
        rg->stats.attempts += c.attempts;
        if (c.v == NONE) {
            if (c.reason == REJECT_DEFERRED) {
                rg->stats.deferred++;
                if (u32_push(&rt->deferred, c.u)) goto oom;
            } else {
                rg->stats.rejected[c.reason]++;
            }
            note_rejection(s, c.u, rg->clock);
            rt->waiting++;
            continue;
        }
        if (!commit(s, &c, &cm)) { /* in a region only a failure stops a commit */
            rg->failed = 1;
            break;
        }
        rg->stats.commits++;
        if (region_requeue(s, sc, rt, c.v, c.u)) goto oom;
    }
    sc->region = NULL;
    return;
oom:
    sc->oom = 1;
    rg->failed = 1;
    sc->region = NULL;
}

typedef struct region_job {
    sim *s;
    region *regions;
    const uint32_t *order; /* the order threads take them in */
    uint32_t count;
    atomic_uint next;
    region_thread *threads;
} region_job;

/* Claims and runs regions until none is left (a workpool_fn). */
static void region_worker(void *p, uint32_t thread)
{
    region_job *job = p;
    for (;;) {
        const uint32_t k = atomic_fetch_add_explicit(&job->next, 1, memory_order_relaxed);
        if (k >= job->count) return;
        region_run(job->s, &job->regions[job->order[k]], thread, &job->threads[thread]);
    }
}

typedef struct merge_run {
    sim *s;
    int rc;
} merge_run;

/* merge_clusters as an lp_beside function */
static void *merge_clusters_run(void *p)
{
    merge_run *m = p;
    m->rc = merge_clusters(m->s);
    return NULL;
}

/* One round: partition, the regions on all cores (the largest first, for
 * the balance: the order changes nothing else), then their results gathered
 * in region order. Returns the commits, or -1 on failure (out of memory, or
 * a broken invariant). */
static long region_round(sim *s)
{
    const double t0 = lp_seconds();
    /* the merges beside the partition: they share nothing (merge_clusters
     * writes the registry, unit bounds, stats and the serial scratch, none
     * of which region_partition reads; the partition writes the region
     * fields, which the merges do not read), so either order gives the same
     * state */
    merge_run merge = {s, 0};
    lp_beside beside;
    lp_beside_start(&beside, s->thread_count > 1 && !s->verify, merge_clusters_run, &merge);
    const uint32_t size = s->region_vertices ? s->region_vertices : REGION_SIZE;
    region *regions = NULL;
    const long parts = region_partition(s, &regions, size, (int)(s->rounds % 2));
    lp_beside_join(&beside);
    if (merge.rc) {
        free(regions);
        return -1;
    }
    if (parts < 0) return s->serial.oom = 1, -1;
    /* the invariant checker reads the whole mesh: one thread then (the
     * same result) */
    const uint32_t threads = s->verify ? 1 : s->thread_count;
    region_thread *rt = s->region_threads;
    /* the faces no region owns stay as they are this round; their grid is
     * the level's (grid_current is 0 during the rounds, and region_phase
     * rebuilds it after them) */
    facegrid *shared = &s->grid;
    u32vec shared_faces = {0};
    int oom = 0;
    for (uint32_t f = 0; f < s->nf && !oom; ++f)
        if (s->face_alive[f] && s->face_owner[f] == REGION_SHARED) oom = u32_push(&shared_faces, f);
    if (!oom) oom = grid_fill(s, shared, shared_faces.data, shared_faces.size, 0, s->nf, NULL) < 0;
    free(shared_faces.data);
    if (oom) {
        free(regions);
        return s->serial.oom = 1, -1;
    }
    uint32_t *order = malloc(((size_t)parts + 1) * sizeof *order);
    if (!order) {
        free(regions);
        return s->serial.oom = 1, -1;
    }
    for (long k = 0; k < parts; ++k) {
        regions[k].clock = s->commit_clock;
        regions[k].shared = shared;
        /* by size, larger first (insertion: a few hundred regions) */
        long at = k;
        for (; at > 0 && regions[order[at - 1]].end - regions[order[at - 1]].begin < regions[k].end - regions[k].begin;
             --at)
            order[at] = order[at - 1];
        order[at] = (uint32_t)k;
    }
    region_job job = {s, regions, order, (uint32_t)parts, 0, rt};
    atomic_init(&job.next, 0);
    if (thin_ready(s)) {
        free(order);
        free(regions);
        return s->serial.oom = 1, -1;
    }
    if (threads > 1) workpool_start(&s->pool, region_worker, &job);
    region_worker(&job, 0);
    if (threads > 1) workpool_finish(&s->pool);
    long commits = 0;
    int failed = 0;
    uint32_t clock = s->commit_clock;
    simplify_stats *st = s->stats;
    for (long k = 0; k < parts; ++k) {
        const region *rg = &regions[k];
        failed |= rg->failed;
        commits += (long)rg->stats.commits;
        s->faces_alive -= rg->faces_died;
        if (rg->clock > clock) clock = rg->clock;
        st->candidates += rg->stats.candidates;
        st->attempts += rg->stats.attempts;
        st->commits += rg->stats.commits;
        st->deferred += rg->stats.deferred;
        st->cluster_splits += rg->stats.cluster_splits;
        for (int r = 0; r < SIMPLIFY_REJECT_COUNT; ++r) st->rejected[r] += rg->stats.rejected[r];
        st->region_commits += rg->stats.commits;
    }
    s->commit_clock = clock;
    free(order);
    /* the deferred ones are candidates again in the next round */
    for (uint32_t t = 0; t < threads; ++t) {
        for (size_t i = 0; i < rt[t].deferred.size; ++i) s->reject_stamp[rt[t].deferred.data[i]] = NONE;
        rt[t].deferred.size = 0;
    }
    free(regions);
    s->rounds++;
    st->rounds++;
    st->seconds_regions += lp_seconds() - t0;
    return failed ? -1 : commits;
}

/* Frees what the rounds kept from one to the next (their threads' grids and
 * queues, the partition's keys and sort scratch): the passes that follow
 * then reuse that memory instead of the peak growing by it. */
static void region_scratch_free(sim *s)
{
    if (s->region_threads)
        for (uint32_t t = 0; t < MAX_THREADS; ++t) region_thread_free(&s->region_threads[t]);
    free(s->region_threads);
    s->region_threads = NULL;
    free(s->region_key);
    s->region_key = NULL;
    radix_scratch_free(&s->region_sort);
}

/* The region phase of a level: rounds while there are enough vertices for
 * several regions and a round still removes a good share of them. Returns
 * 0, or -1 on failure. */
static int region_phase(sim *s)
{
    if (!s->region_of) {
        s->spatial = malloc(((size_t)s->nv + 1) * sizeof *s->spatial);
        s->region_of = malloc(((size_t)s->nv + 1) * sizeof *s->region_of);
        s->face_owner = malloc(((size_t)s->nf + 1) * sizeof *s->face_owner);
        s->interior = malloc((size_t)s->nv + 1);
        s->queued = calloc((size_t)s->nv + 1, sizeof *s->queued);
        s->queued_to = malloc(((size_t)s->nv + 1) * sizeof *s->queued_to);
        if (!s->spatial || !s->region_of || !s->face_owner || !s->interior || !s->queued || !s->queued_to)
            return s->serial.oom = 1, -1;
        for (uint32_t v = 0; v < s->nv; ++v) s->spatial[v] = v;
        s->spatial_count = s->nv;
    }
    if (!s->region_threads) s->region_threads = calloc(MAX_THREADS, sizeof *s->region_threads);
    if (!s->region_threads) return s->serial.oom = 1, -1;
    const uint32_t size = s->region_vertices ? s->region_vertices : REGION_SIZE, rounds_before = s->rounds;
    for (;;) {
        uint32_t alive = 0;
        for (uint32_t i = 0; i < s->spatial_count; ++i) alive += s->vertex_alive[s->spatial[i]];
        if (alive < (uint64_t)REGION_MIN_REGIONS * size) break;
        const long commits = region_round(s);
        if (commits < 0) return -1;
        if ((uint64_t)commits * REGION_STOP < alive) break;
    }
    region_scratch_free(s);
    /* the global passes' grid, for the faces as they are now */
    if (s->rounds != rounds_before && grid_rebuild(s)) return s->serial.oom = 1, -1;
    return 0;
}

/* ---- vertex removal with a chosen triangulation of the hole --------------------- */

/* Moves corner to vertex (with wedge): out of its old vertex's list, onto
 * the head of the new one's. */
static void move_corner(sim *s, uint32_t corner, uint32_t vertex, uint32_t wedge)
{
    const uint32_t old = s->corner_vertex[corner];
    s->corner_wedge[corner] = wedge;
    if (old == vertex) return; /* already in the list */
    s->corner_vertex[corner] = vertex;
    prune_corner_list(s, old);
    s->corner_next[corner] = s->vertex_first[vertex];
    s->vertex_first[vertex] = corner;
}

static int has_edge(const sim *s, uint32_t x, uint32_t y)
{
    for (uint32_t c = s->vertex_first[x]; c != NONE; c = s->corner_next[c])
        if (s->face_alive[c / 3] && s->corner_vertex[c] == x && face_has(s, c / 3, y)) return 1;
    return 0;
}

static void triangle_of_vertices(const sim *s, uint32_t x, uint32_t y, uint32_t z, int32_t material, cert_tri *t)
{
    const uint32_t v[3] = {x, y, z};
    for (int k = 0; k < 3; ++k) {
        t->vertex[k] = v[k];
        vertex_position(s, v[k], t->p[k]);
    }
    t->material = material;
    t->id = NONE;
    cert_face_normal(t);
}

static double dot3(const double *x, const double *y) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; }

/* A half-edge collapse u -> x fills u's hole with the fan from x; Cohen et
 * al. fill it with any triangulation. When no collapse of u is certified,
 * the other triangulations of its ring are tried (holefill.h), those that
 * keep the surface closest to u first, each made in place, tested and
 * certified as a collapse is, then kept or undone. Measured on the bunny
 * (default settings): 11,489 -> 10,981 triangles at 1/16 %, 5,090 -> 4,876
 * at 1/8 %. Certifying up to 3 triangulations per vertex instead of 14 gave
 * 11,029 and 4,910, and all of them (up to 132) 44,847 instead of 44,849 at
 * 1/64 % and 4,878 at 1/8 % (the first two before removal_costs' test of
 * u). Rings of up to 10 corners rather than 8 (a throwaway count had seen
 * about 5 % of the swept vertices with larger rings): 24,075 -> 24,043 at
 * 1/32 %, 4,876 -> 4,856 at 1/8 % before PASS_SHARE, and with it 23,977 ->
 * 23,955, 4,765 -> 4,753; 0.17 % fewer over the 28 single levels of the
 * quality tables, none with more. */
#define REMOVE_TRIED 14 /* triangulations certified per vertex at most (all of a hexagon's) */

typedef struct removal {
    uint32_t u;
    uint32_t ring[HOLEFILL_MAX_CORNERS];  /* x_0 .. x_{n-1}: face i is (u, x_i, x_{i+1}) */
    uint32_t face[HOLEFILL_MAX_CORNERS];
    uint32_t wedge[HOLEFILL_MAX_CORNERS]; /* x_i's wedge, the same in faces i - 1 and i */
    holefill_problem hole;                /* the ring polygon, hole.n corners */
    uint8_t near[HOLEFILL_MAX_CORNERS][HOLEFILL_MAX_CORNERS][HOLEFILL_MAX_CORNERS]; /* u within eps of (i, j, k) */
} removal;

/* u's ring in face order, when u is an interior manifold vertex whose n (4 ..
 * HOLEFILL_MAX_CORNERS) faces form one closed fan of one primitive, with
 * distinct ring vertices each carrying one wedge in both its faces (larger
 * rings are rarer where collapses are stuck, and each more corner triples
 * the triangulations to list: they are left). */
static int removal_ring(const sim *s, scratch *sc, uint32_t u, removal *rm)
{
    if (!s->vertex_alive[u] || s->w->vertex_kind[u] != WELD_MANIFOLD) return 0;
    if (gather_faces(s, u, &sc->faces_u)) return sc->oom = 1, 0;
    const uint32_t n = (uint32_t)sc->faces_u.size;
    if (n < 4 || n > HOLEFILL_MAX_CORNERS) return 0;
    rm->u = u;
    rm->hole.n = n;
    uint32_t f = sc->faces_u.data[0];
    for (uint32_t i = 0; i < n; ++i) {
        const uint32_t k = corner_of(s, f, u) - 3 * f;
        const uint32_t cx = 3 * f + (k + 1) % 3, cy = 3 * f + (k + 2) % 3;
        if (s->w->triangle_primitive[f] != s->w->triangle_primitive[sc->faces_u.data[0]]) return 0;
        rm->face[i] = f;
        rm->ring[i] = s->corner_vertex[cx];
        rm->wedge[i] = s->corner_wedge[cx];
        /* the next face: the one whose x is this face's y, with y's wedge */
        const uint32_t y = s->corner_vertex[cy];
        uint32_t next = NONE;
        for (size_t j = 0; j < n; ++j) {
            const uint32_t g = sc->faces_u.data[j], kg = corner_of(s, g, u) - 3 * g;
            if (s->corner_vertex[3 * g + (kg + 1) % 3] == y) next = g;
        }
        if (next == NONE) return 0;
        const uint32_t kn = corner_of(s, next, u) - 3 * next;
        if (s->corner_wedge[3 * next + (kn + 1) % 3] != s->corner_wedge[cy]) return 0; /* a seam at y */
        f = next;
    }
    if (f != sc->faces_u.data[0]) return 0; /* not one closed fan */
    for (uint32_t i = 0; i < n; ++i)
        for (uint32_t j = i + 1; j < n; ++j)
            if (rm->ring[i] == rm->ring[j]) return 0;
    return 1;
}

/* The hole's rules and costs, each triangle's decided once for all the
 * triangulations that use it. A diagonal x_i x_j may be made when it is no
 * edge of the mesh yet (else the edge would have four faces); with the ring
 * vertices' face floors (removal_degrees) that is the whole condition for
 * the surface to stay a manifold with the same borders: each ring vertex's
 * link keeps its ends and gets new middle vertices, which must not be in it
 * already (an existing edge), and stays a cycle of 3 or more (a path, and a
 * cycle through the border's cone vertex, on a border; a diagonal between
 * two border vertices is no border edge, so it is allowed). A triangle is
 * forbidden when it is degenerate or turns from an old face it shares a
 * corner with beyond the flip guard; else it costs its area times the
 * squared distance from u to its plane, so the cheapest triangulations keep
 * the surface closest to where u was. And near records whether u, a point
 * of the original, is within eps of it: a triangulation is tried only when
 * one of its faces is (else the originals around u would need faces farther
 * out; measured on the bunny at 1/16 %: 10,981 triangles against 10,989
 * without this test, and 1.4 s spent on removals against 2.4 s). */
static void removal_costs(const sim *s, removal *rm)
{
    const uint32_t n = rm->hole.n;
    const int32_t material = s->face_material[rm->face[0]];
    double pu[3];
    vertex_position(s, rm->u, pu);
    const vec3d at_u = geom_vec3d_from_doubles(pu);
    cert_tri old[HOLEFILL_MAX_CORNERS];
    for (uint32_t i = 0; i < n; ++i) triangle_of_vertices(s, rm->u, rm->ring[i], rm->ring[(i + 1) % n], material, &old[i]);
    const float *original_u = s->w->positions + 3 * (size_t)rm->u;
    const vec3d u = geom_vec3d(original_u[0], original_u[1], original_u[2]);
    const double accept = s->eps * (1.0 - CERT_MARGIN);
    for (uint32_t i = 0; i < n; ++i)
        for (uint32_t j = i + 1; j < n; ++j)
            rm->hole.allowed[i][j] = !has_edge(s, rm->ring[i], rm->ring[j]);
    for (uint32_t i = 0; i < n; ++i)
        for (uint32_t j = i + 1; j < n; ++j)
            for (uint32_t k = j + 1; k < n; ++k) {
                double *cost = &rm->hole.cost[i][j][k];
                *cost = INFINITY;
                rm->near[i][j][k] = 0;
                cert_tri t;
                triangle_of_vertices(s, rm->ring[i], rm->ring[j], rm->ring[k], material, &t);
                if (t.degenerate) continue;
                int turns = 0;
                for (uint32_t f = 0; f < n; ++f) {
                    const uint32_t next = (f + 1) % n;
                    const int shares = i == f || i == next || j == f || j == next || k == f || k == next;
                    turns |= shares && !old[f].degenerate && !(dot3(t.n, old[f].n) > s->flip_cos);
                }
                if (turns) continue;
                vec3d c[3];
                for (int a = 0; a < 3; ++a) c[a] = geom_vec3d_from_doubles(t.p[a]);
                rm->near[i][j][k] = geom_point_triangle_distance2(&u, &c[0], &c[1], &c[2], NULL) <= accept * accept;
                const vec3d x = geom_cross(geom_sub(c[1], c[0]), geom_sub(c[2], c[0]));
                const double twice_area = geom_length(x);
                const double h = geom_dot(x, geom_sub(at_u, c[0])); /* h = twice_area * distance */
                if (twice_area > 0.0) *cost = h * h / (2.0 * twice_area);
            }
}

/* 1 when u is within eps of one of t's faces (removal_costs). */
static int removal_near(const removal *rm, const holefill *t)
{
    int near = 0;
    for (uint32_t k = 0; k + 2 < rm->hole.n; ++k) near |= rm->near[t->tri[k][0]][t->tri[k][1]][t->tri[k][2]];
    return near;
}

/* 1 when every ring vertex keeps the faces a vertex must keep (link_ok's
 * floor: 3 inside, 1 on a border, where a triangulation of the hole always
 * leaves one). */
static int removal_degrees(const sim *s, const removal *rm, const holefill *t)
{
    for (uint32_t i = 0; i < rm->hole.n; ++i) {
        uint32_t gained = 0;
        for (uint32_t k = 0; k + 2 < rm->hole.n; ++k)
            gained += t->tri[k][0] == i || t->tri[k][1] == i || t->tri[k][2] == i;
        const uint32_t after = faces_around(s, rm->ring[i]) - 2 + gained;
        if (after < faces_left_floor(s, rm->ring[i]) || after > s->hub_faces) return 0; /* no new hub */
    }
    return 1;
}

/* Tries the removal of rm->u with triangulation t: made in place (faces
 * face[0 .. n-3] become t's triangles, the last two die), tested and
 * certified; kept and recorded, or undone. Returns 1 kept, 0 not, -1 out of
 * memory or a broken invariant. */
static int removal_try(sim *s, const removal *rm, const holefill *t)
{
    scratch *sc = &s->scratch[0];
    const uint32_t n = rm->hole.n, kept = n - 2;
    uint32_t saved_vertex[3 * HOLEFILL_MAX_CORNERS], saved_wedge[3 * HOLEFILL_MAX_CORNERS];
    sc->out_u32.size = sc->out_f64.size = 0;
    sc->changed.size = sc->faces_v.size = 0;
    for (uint32_t i = 0; i < n; ++i)
        if (u32_push(i < kept ? &sc->changed : &sc->faces_v, rm->face[i])) return sc->oom = 1, -1;
    if (grow((void **)&sc->after, &sc->after_cap, kept, sizeof *sc->after) ||
        grow((void **)&sc->before_box, &sc->before_box_cap, 6 * (size_t)n, sizeof *sc->before_box) ||
        grow((void **)&sc->replaced, &sc->replaced_cap, n, sizeof *sc->replaced))
        return sc->oom = 1, -1;
    sc->replaced_count = n; /* every face of the hole, for star_crosses */
    for (uint32_t i = 0; i < n; ++i) {
        cert_tri *b = &sc->replaced[i];
        face_box_after(s, rm->face[i], NULL, b);
        memcpy(sc->before_box + 6 * i, b->lo, sizeof b->lo);
        memcpy(sc->before_box + 6 * i + 3, b->hi, sizeof b->hi);
        for (int k = 0; k < 3; ++k) {
            saved_vertex[3 * i + k] = s->corner_vertex[3 * rm->face[i] + k];
            saved_wedge[3 * i + k] = s->corner_wedge[3 * rm->face[i] + k];
        }
    }
    /* made in place: the dying faces stay alive until the moves are done, so
     * no list prune drops their corners (an undo revives them) */
    for (uint32_t i = 0; i < kept; ++i)
        for (int k = 0; k < 3; ++k) {
            const uint32_t x = t->tri[i][k];
            move_corner(s, 3 * rm->face[i] + (uint32_t)k, rm->ring[x], rm->wedge[x]);
        }
    s->face_alive[rm->face[n - 2]] = s->face_alive[rm->face[n - 1]] = 0;
    for (uint32_t i = 0; i < kept; ++i) face_after(s, rm->face[i], NULL, &sc->after[i]);
    double lo[3], hi[3];
    union_box(sc->after, kept, lo, hi);
    candidate c = {.u = rm->u, .v = NONE, .thread = 0};
    const u32vec *changing[2] = {&sc->changed, &sc->faces_v};
    const int thin = s->strict || thin_map_box(&s->thin, lo, hi);
    int ok = !(thin && star_crosses(s, sc, NULL)) && !sc->oom && certify_change(s, sc, &c, NULL, changing, 2, NULL);
    if (sc->oom) ok = 0;
    if (!ok) {
        s->face_alive[rm->face[n - 2]] = s->face_alive[rm->face[n - 1]] = 1;
        for (uint32_t i = 0; i < kept; ++i)
            for (int k = 0; k < 3; ++k)
                move_corner(s, 3 * rm->face[i] + (uint32_t)k, saved_vertex[3 * i + k], saved_wedge[3 * i + k]);
        return sc->oom ? -1 : 0;
    }
    s->faces_alive -= 2;
    gridlog_start(&s->grid_log, &s->grid, 0);
    for (uint32_t i = 0; i < n; ++i) {
        if (i < kept)
            gridlog_move(&s->grid_log, rm->face[i], sc->before_box + 6 * i, sc->before_box + 6 * i + 3, sc->after[i].lo,
                         sc->after[i].hi);
        else gridlog_remove(&s->grid_log, rm->face[i]);
    }
    if (gridlog_finish(&s->grid_log)) return sc->oom = 1, -1;
    commit_records(s, &c, s->stats);
    /* u's quadric goes to its nearest ring vertex (the costs only order
     * candidates) */
    double pu[3], best = INFINITY;
    uint32_t nearest = 0;
    vertex_position(s, rm->u, pu);
    for (uint32_t i = 0; i < n; ++i) {
        double p[3], d2 = 0.0;
        vertex_position(s, rm->ring[i], p);
        for (int a = 0; a < 3; ++a) d2 += (p[a] - pu[a]) * (p[a] - pu[a]);
        if (d2 < best) best = d2, nearest = i;
    }
    retire_vertex(s, rm->u, rm->ring[nearest]);
    for (uint32_t i = 0; i < n; ++i) {
        prune_corner_list(s, rm->ring[i]);
        stamp_changes(s, rm->ring[i], &s->commit_clock);
    }
    s->stats->removals++;
    if (s->verify && verify_after_commit(s, &c) != 0) return -1;
    return 1;
}

/* One serial sweep over the movable vertices: each interior vertex whose
 * ring allows it is removed with the first certified of its cheapest
 * triangulations. Returns the number removed, or -1. */
static long removal_pass(sim *s)
{
    long removed = 0;
    const double t0 = lp_seconds();
    scratch *sc = &s->scratch[0];
    if (!s->removal_stamp) {
        s->removal_stamp = malloc(((size_t)s->nv + 1) * sizeof *s->removal_stamp);
        if (!s->removal_stamp) return sc->oom = 1, -1;
        memset(s->removal_stamp, 0xff, ((size_t)s->nv + 1) * sizeof *s->removal_stamp);
    }
    holefill *all = malloc(HOLEFILL_MAX * sizeof *all);
    removal *rm = malloc(sizeof *rm);
    if (!all || !rm) {
        free(all);
        free(rm);
        return sc->oom = 1, -1;
    }
    for (uint32_t i = 0; i < s->movable_count; ++i) {
        const uint32_t u = s->movable[i];
        if (s->removal_stamp[u] != NONE && !changed_since(s, u, s->removal_stamp[u])) continue;
        if (!removal_ring(s, sc, u, rm)) {
            if (sc->oom) break;
            continue;
        }
        removal_costs(s, rm);
        uint32_t left = holefill_heap(&rm->hole, all), tried = 0;
        while (left > 0 && tried < REMOVE_TRIED) {
            const holefill *t = holefill_pop(all, &left);
            if (!removal_degrees(s, rm, t) || !removal_near(rm, t)) continue;
            tried++;
            const int r = removal_try(s, rm, t);
            if (r < 0) {
                removed = -1;
                goto out;
            }
            if (r) {
                removed++;
                break;
            }
        }
        if (s->vertex_alive[u]) s->removal_stamp[u] = s->commit_clock;
    }
    if (sc->oom) removed = -1;
out:
    s->stats->seconds_removal += lp_seconds() - t0;
    free(all);
    free(rm);
    return removed;
}

/* ---- set-up -------------------------------------------------------------------- */

static void add_plane(sim *s, uint32_t f)
{
    const uint32_t *tv = s->w->triangle_vertices + 3 * (size_t)f;
    vec3d p[3], n;
    for (int k = 0; k < 3; ++k) {
        p[k] = geom_vec3d_from_floats(s->w->positions + 3 * (size_t)tv[k]);
        p[k] = geom_sub(p[k], geom_vec3d(s->origin[0], s->origin[1], s->origin[2]));
    }
    vec3d cr = geom_triangle_normal(&p[0], &p[1], &p[2]);
    double area2 = geom_length(cr);
    if (!geom_triangle_unit_normal(&p[0], &p[1], &p[2], &n)) return;
    const double nn[3] = {n.x, n.y, n.z};
    quadric q;
    quadric_from_plane(&q, nn, -geom_dot(n, p[0]), area2 * 0.5);
    for (int k = 0; k < 3; ++k) quadric_add(&s->quadrics[tv[k]], &q);
    /* border edges keep their place: a plane through the edge, perpendicular to the face */
    for (int k = 0; k < 3; ++k) {
        if (!(s->w->edge_flags[3 * (size_t)f + k] & WELD_FLAG_BORDER)) continue;
        vec3d e = geom_sub(p[(k + 1) % 3], p[k]);
        vec3d m = geom_cross(e, n);
        double len = geom_length(m);
        if (!(len > 0)) continue;
        m = geom_scale(m, 1.0 / len);
        const double mm[3] = {m.x, m.y, m.z};
        quadric_from_plane(&q, mm, -geom_dot(m, p[k]), geom_length2(e) * 4.0);
        quadric_add(&s->quadrics[tv[k]], &q);
        quadric_add(&s->quadrics[tv[(k + 1) % 3]], &q);
    }
}

/* Every face's plane quadric (add_plane), in face order. */
static void *add_planes(void *p)
{
    sim *s = p;
    for (uint32_t f = 0; f < s->nf; ++f) add_plane(s, f);
    return NULL;
}

static void sim_free(sim *s)
{
    workpool_free(&s->pool);
    thin_map tail;
    if (thin_ahead_take(s, s->ahead.radius, &tail)) thin_map_free(&tail);
    free(s->moved_positions);
    free(s->face_material);
    free(s->corner_vertex);
    free(s->corner_wedge);
    free(s->corner_next);
    free(s->face_alive);
    free(s->face_bound);
    free(s->unit_bound);
    free(s->unit_stamp);
    free(s->cluster_dirty);
    free(s->vertex_first);
    free(s->vertex_alive);
    free(s->movable);
    free(s->batch_stars.faces.data);
    free(s->batch_stars.end.data);
    free(s->batch_stars.box.data);
    free(s->region_of);
    free(s->face_owner);
    free(s->spatial);
    free(s->interior);
    free(s->queued);
    free(s->queued_to);
    region_scratch_free(s);
    free(s->change_stamp);
    free(s->reject_stamp);
    free(s->reject_faces);
    free(s->removal_stamp);
    free(s->cost);
    free(s->cost_clock);
    free(s->cost_faces);
    free(s->face_list);
    free(s->vertex_stamp);
    free(s->near_stamp);
    free(s->quadrics);
    facegrid_free(&s->grid);
    gridlog_free(&s->grid_log);
    thin_map_free(&s->thin);
    free(s->special);
    free(s->held);
    registry_free(&s->reg);
    cert_original_free(&s->orig);
    for (uint32_t t = 0; t <= MAX_THREADS; ++t) {
        scratch *sc = t < MAX_THREADS ? &s->scratch[t] : &s->serial;
        free(sc->faces_u.data);
        free(sc->faces_v.data);
        free(sc->nbr_v.data);
        free(sc->ring.data);
        free(sc->cand_faces.data);
        free(sc->recheck.data);
        free(sc->changed.data);
        free(sc->nb);
        free(sc->tris);
        free(sc->after);
        free(sc->replaced);
        free(sc->before_box);
        free(sc->vertex_seen);
        keymap_free(&sc->faces);
        keymap_free(&sc->origs);
        keymap_free(&sc->nb_index);
        free(sc->out_u32.data);
        free(sc->out_f64.data);
    }
}

static int scratch_init(scratch *sc, uint32_t nv)
{
    sc->vertex_seen = calloc((size_t)nv + 1, sizeof *sc->vertex_seen);
    sc->doomed_passed = NONE;
    return sc->vertex_seen ? 0 : -1;
}

static int compare_u64(const void *a, const void *b)
{
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* The certification group of a face with a back (weld.h): one per (front
 * material, back material), numbered -2, -3, ... in the order of those pairs,
 * so that no group is a material's (>= -1) or CERT_MIXED. A face with a back
 * is then certified only against originals with a back of the same two
 * materials, and what holds for it holds, mirrored, for its back face.
 * Faces without a back keep their material. Returns 0, or -1 (memory). */
static int back_groups(sim *s, const weld_result *w, const int64_t *primitive_material)
{
    const uint32_t nf = w->triangle_count;
    uint64_t *pair = malloc(((size_t)nf + 1) * sizeof *pair), *distinct = malloc(((size_t)nf + 1) * sizeof *distinct);
    if (!pair || !distinct) {
        free(pair);
        free(distinct);
        return -1;
    }
    size_t n = 0;
    for (uint32_t f = 0; f < nf; ++f) {
        const uint32_t b = w->triangle_back[f];
        if (b == WELD_NO_BACK) continue;
        const int64_t back = primitive_material[w->back_primitive[b]];
        const int32_t back_material = back < 0 ? -1 : (int32_t)(back > INT32_MAX ? INT32_MAX : back);
        pair[f] = (uint64_t)(uint32_t)s->face_material[f] << 32 | (uint32_t)back_material;
        distinct[n++] = pair[f];
    }
    qsort(distinct, n, sizeof *distinct, compare_u64);
    size_t groups = 0;
    for (size_t i = 0; i < n; ++i)
        if (!groups || distinct[i] != distinct[groups - 1]) distinct[groups++] = distinct[i];
    for (uint32_t f = 0; f < nf; ++f) {
        if (w->triangle_back[f] == WELD_NO_BACK) continue;
        size_t lo = 0, hi = groups;
        while (lo < hi) {
            const size_t mid = lo + (hi - lo) / 2;
            if (distinct[mid] < pair[f]) lo = mid + 1;
            else hi = mid;
        }
        s->face_material[f] = -2 - (int32_t)lo;
    }
    free(pair);
    free(distinct);
    return 0;
}

/* Marks the hubs (more than hub_faces faces around them) and their
 * neighbours held, from the corner lists as they start. The faces around a
 * hub change only by a collapse of a vertex of one of them, which are all
 * held, and no collapse makes a hub, so these are the ladder's hubs. */
static void hold_hubs(sim *s)
{
    for (uint32_t v = 0; v < s->nv; ++v) {
        uint32_t faces = 0;
        for (uint32_t c = s->vertex_first[v]; c != NONE && faces <= s->hub_faces; c = s->corner_next[c]) faces++;
        if (faces <= s->hub_faces) continue;
        s->held[v] = HELD_HUB;
        for (uint32_t c = s->vertex_first[v]; c != NONE; c = s->corner_next[c])
            for (int k = 0; k < 3; ++k) {
                const uint32_t x = s->corner_vertex[3 * (c / 3) + k];
                if (!s->held[x]) s->held[x] = HELD_NEIGHBOUR;
            }
    }
    for (uint32_t v = 0; v < s->nv; ++v) s->held_count += s->held[v] != 0;
}

static int sim_init(sim *s, weld_result *w, const int64_t *primitive_material, const simplify_options *o)
{
    const uint32_t nv = w->vertex_count, nf = w->triangle_count;
    s->w = w;
    s->nv = nv;
    s->nf = nf;
    s->flip_cos = o->flip_cos;
    s->verify = o->verify;
    s->full_edge_levels = o->full_edge_levels;
    s->region_vertices = o->region_vertices;
    s->hub_faces = o->hub_faces ? o->hub_faces : SIMPLIFY_HUB_FACES;
    s->patient_faces = o->patient_faces ? o->patient_faces : SIMPLIFY_PATIENT_FACES;
    s->positions = w->positions;
    if (o->full_edge_levels) {
        s->moved_positions = malloc((3 * (size_t)nv + 1) * sizeof *s->moved_positions);
        if (!s->moved_positions) return -1;
        memcpy(s->moved_positions, w->positions, 3 * (size_t)nv * sizeof *s->moved_positions);
        s->positions = s->moved_positions;
    }
    s->strict = o->strict_intersections;
    s->thread_count = lp_threads(o->threads, MAX_THREADS);
    s->face_material = malloc(((size_t)nf + 1) * sizeof *s->face_material);
    s->corner_vertex = malloc((3 * (size_t)nf + 1) * sizeof *s->corner_vertex);
    /* taken over, not copied: the weld's wedges are where the corners start,
     * and nothing else reads them (simplify.h) */
    s->corner_wedge = w->triangle_wedges;
    w->triangle_wedges = NULL;
    s->corner_next = malloc((3 * (size_t)nf + 1) * sizeof *s->corner_next);
    s->face_alive = malloc((size_t)nf + 1);
    s->face_bound = calloc((size_t)nf + 1, sizeof *s->face_bound);
    s->vertex_first = malloc(((size_t)nv + 1) * sizeof *s->vertex_first);
    s->vertex_alive = malloc((size_t)nv + 1);
    s->movable = malloc(((size_t)nv + 1) * sizeof *s->movable);
    s->change_stamp = calloc((size_t)nv + 1, sizeof *s->change_stamp);
    s->reject_stamp = malloc(((size_t)nv + 1) * sizeof *s->reject_stamp);
    s->reject_faces = malloc(((size_t)nv + 1) * sizeof *s->reject_faces);
    s->quadrics = calloc((size_t)nv + 1, sizeof *s->quadrics);
    s->held = calloc((size_t)nv + 1, 1);
    s->special = malloc((size_t)nv + 1);
    if (s->special)
        for (uint32_t v = 0; v < nv; ++v)
            s->special[v] = w->vertex_kind[v] == WELD_BORDER || w->vertex_kind[v] == WELD_LOCKED;
    if (!s->special || !s->held || !s->face_material || !s->corner_vertex || !s->corner_wedge || !s->corner_next ||
        !s->face_alive || !s->face_bound || !s->vertex_first || !s->vertex_alive || !s->movable || !s->change_stamp ||
        !s->reject_stamp || !s->reject_faces || !s->quadrics)
        return -1;
    if (workpool_init(&s->pool, s->thread_count)) return -1;
    for (uint32_t t = 0; t < s->thread_count; ++t)
        if (scratch_init(&s->scratch[t], nv)) return -1;
    if (scratch_init(&s->serial, nv)) return -1;
    if (gridlog_init(&s->grid_log, GRIDLOG_RING)) return -1;
    for (uint32_t f = 0; f < nf; ++f) {
        int64_t m = primitive_material[w->triangle_primitive[f]];
        s->face_material[f] = m < 0 ? -1 : (int32_t)(m > INT32_MAX ? INT32_MAX : m);
    }
    if (w->back_count && back_groups(s, w, primitive_material)) return -1;
    memcpy(s->corner_vertex, w->triangle_vertices, 3 * (size_t)nf * sizeof *s->corner_vertex);
    memset(s->face_alive, 1, nf);
    memset(s->vertex_alive, 1, nv);
    memset(s->vertex_first, 0xff, ((size_t)nv + 1) * sizeof *s->vertex_first);
    memset(s->reject_stamp, 0xff, ((size_t)nv + 1) * sizeof *s->reject_stamp);
    for (uint32_t c = 3 * nf; c-- > 0;) { /* lists in ascending corner order */
        uint32_t v = s->corner_vertex[c];
        s->corner_next[c] = s->vertex_first[v];
        s->vertex_first[v] = c;
    }
    hold_hubs(s);
    for (uint32_t v = 0; v < nv; ++v)
        if (!fixed_vertex(s, v)) s->movable[s->movable_count++] = v;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t v = 0; v < nv; ++v)
        for (int k = 0; k < 3; ++k) {
            double x = w->positions[3 * (size_t)v + k];
            if (x < lo[k]) lo[k] = x;
            if (x > hi[k]) hi[k] = x;
        }
    for (int k = 0; k < 3; ++k) s->origin[k] = nv ? 0.5 * (lo[k] + hi[k]) : 0.0;
    /* the quadrics and the certificate's original share nothing: with a
     * second thread the planes go in beside the certificate's serial steps
     * (its normals, the BVH's first split, the clusters) */
    lp_beside planes;
    lp_beside_start(&planes, s->thread_count > 1, add_planes, s);
    const int cert_rc = cert_original_init(&s->orig, w->positions, nv, w->triangle_vertices, nf, s->face_material,
                                           w->vertex_triangle_offsets, w->vertex_triangles, s->thread_count);
    lp_beside_join(&planes);
    if (cert_rc) return -1;
    const uint32_t clusters = s->orig.cluster_count;
    const size_t units = (size_t)nf + clusters;
    s->unit_bound = calloc(units + 1, sizeof *s->unit_bound);
    s->unit_stamp = calloc(units + 1, sizeof *s->unit_stamp);
    s->cluster_dirty = malloc(((size_t)clusters / 64 + 1) * sizeof *s->cluster_dirty);
    if (!s->unit_bound || !s->unit_stamp || !s->cluster_dirty) return -1;
    if (registry_init(&s->reg, nf, s->orig.cluster_of, clusters)) return -1;
    return 0;
}

/* ---- levels -------------------------------------------------------------------- */

/* A level's structures wait for their first use: the thin map for its eps
 * (unless strict) until thin_ready, being built meanwhile beside the first
 * region round's serial steps, unless the previous level built it ahead;
 * the face grid until the passes (grid_current). */
static void level_structures(sim *s)
{
    thin_map_free(&s->thin);
    s->thin_ready = 0;
    s->grid_current = 0;
    thin_ahead_start(s, 2.0 * s->eps);
}

/* Faces per level whose bound tighten_bounds may try to lower. */
#define TIGHTEN_MAX_FACES 1024

typedef struct bounded_face {
    double bound;
    uint32_t face;
} bounded_face;

/* Larger bound first, then lower face number: a total order, so the sort's
 * result does not depend on the algorithm. */
static int bound_order(const void *x, const void *y)
{
    const bounded_face *a = x, *b = y;
    if (a->bound != b->bound) return a->bound > b->bound ? -1 : 1;
    return (a->face > b->face) - (a->face < b->face);
}

/* A face's recorded bound is that of the proof cert_face found first: for a
 * face the corner ball could not settle, usually the subdivision's d + r,
 * above the overlay's (cert_face_overlay). Only the faces that set the
 * level's bound matter: from the largest recorded bound down, each face
 * takes the overlay's when that is smaller (both are proofs), until the next
 * face's recorded bound is no larger than the largest bound so far, which
 * starts at `floor` (what the originals' side of the certificate needs), or
 * TIGHTEN_MAX_FACES have been tried. The level's bound can only fall.
 * Serial, so deterministic. face_list must hold just the alive faces
 * (live_faces). Returns 0, or -1 when memory runs out. */
static int tighten_bounds(sim *s, double floor)
{
    size_t n = 0;
    for (uint32_t i = 0; i < s->face_list_count; ++i) n += s->face_bound[s->face_list[i]] > floor;
    bounded_face *top = malloc((n + 1) * sizeof *top);
    if (!top) return -1;
    n = 0;
    for (uint32_t i = 0; i < s->face_list_count; ++i) {
        const uint32_t f = s->face_list[i];
        if (s->face_bound[f] > floor) top[n++] = (bounded_face){s->face_bound[f], f};
    }
    qsort(top, n, sizeof *top, bound_order);
    double level = floor;
    for (size_t i = 0; i < n && i < TIGHTEN_MAX_FACES && top[i].bound > level; ++i) {
        const uint32_t f = top[i].face;
        cert_tri t;
        face_after(s, f, NULL, &t);
        double overlay;
        if (cert_face_overlay(&s->orig, &t, s->eps, &overlay) && overlay < s->face_bound[f]) {
            s->face_bound[f] = overlay;
            if (s->verify && verify_state(s, NULL, 0, &f, 1) != 0) { /* the face within its new bound */
                s->verify_failed = 1;
                free(top);
                return -1;
            }
        }
        if (s->face_bound[f] > level) level = s->face_bound[f];
    }
    free(top);
    return 0;
}

static int snapshot_level(sim *s, simplify_level *level)
{
    if (live_faces(s)) return -1;
    double bound = 0.0;
    /* the bounds of the certificates in force: an original's own, or its
     * cluster's when that is registered whole */
    for (uint32_t t = 0; t < s->nf; ++t)
        if (registry_cluster_face(&s->reg, s->orig.cluster_of[t]) == REGISTRY_NONE && s->unit_bound[t] > bound)
            bound = s->unit_bound[t];
    for (uint32_t c = 0; c < s->orig.cluster_count; ++c) {
        if (registry_cluster_face(&s->reg, c) == REGISTRY_NONE) continue;
        level->stats.clusters_whole++;
        if (s->unit_bound[s->nf + c] > bound) bound = s->unit_bound[s->nf + c];
    }
    if (tighten_bounds(s, bound)) return -1;
    const uint32_t alive = s->face_list_count;
    for (uint32_t i = 0; i < alive; ++i)
        if (s->face_bound[s->face_list[i]] > bound) bound = s->face_bound[s->face_list[i]];
    /* the dangling triangles (weld.h) follow the faces as they are: covered
     * by themselves, they add nothing to the bound */
    /* Every distance behind the bound was computed in double from exact
     * float coordinates, so it may be a few ulp short of the exact one (a
     * corpus sweep found recorded bounds up to 9.5e-15 below an original
     * vertex's exact distance, on 2CylinderEngine). Acceptance already
     * assumes such errors stay below CERT_MARGIN * eps (a value passes only
     * at <= eps (1 - CERT_MARGIN)); adding that allowance makes the recorded
     * bound an upper bound under the same assumption, still <= eps. A zero
     * bound is exact: no distance was computed (the level is the original). */
    if (bound > 0.0) bound = geom_fmin(s->eps, bound + CERT_MARGIN * s->eps);
    const weld_result *w = s->w;
    level->bound = bound;
    uint32_t backs = 0;
    for (uint32_t i = 0; i < alive && w->back_count; ++i) backs += w->triangle_back[s->face_list[i]] != WELD_NO_BACK;
    level->triangle_count = alive + backs + w->dangling_count;
    level->wedges = malloc(((size_t)level->triangle_count * 3 + 1) * sizeof *level->wedges);
    level->primitive = malloc(((size_t)level->triangle_count + 1) * sizeof *level->primitive);
    if (!level->wedges || !level->primitive) return -1;
    if (s->moved_any) {
        level->positions = malloc((3 * (size_t)s->nv + 1) * sizeof *level->positions);
        if (!level->positions) return -1;
        memcpy(level->positions, s->moved_positions, 3 * (size_t)s->nv * sizeof *level->positions);
    }
    uint32_t n = 0;
    for (uint32_t i = 0; i < alive; ++i) {
        const uint32_t f = s->face_list[i];
        memcpy(level->wedges + 3 * (size_t)n, s->corner_wedge + 3 * (size_t)f, 3 * sizeof *level->wedges);
        level->primitive[n++] = w->triangle_primitive[f];
    }
    /* the back faces (weld.h): the same corners in the other winding, each
     * with the back layer's wedge for the front's class there */
    for (uint32_t i = 0; i < alive && backs; ++i) {
        const uint32_t f = s->face_list[i], b = w->triangle_back[f];
        if (b == WELD_NO_BACK) continue;
        static const int reversed[3] = {0, 2, 1};
        for (int k = 0; k < 3; ++k) {
            const uint32_t front = s->corner_wedge[3 * (size_t)f + (size_t)reversed[k]];
            const uint32_t wedge = weld_back_wedge(w, w->wedge_class[front], w->back_primitive[b]);
            if (wedge == NONE) { /* weld.h's rules make this impossible */
                s->verify_failed = 1;
                snprintf(s->verify_msg, sizeof s->verify_msg, "face %u: no back wedge for class %u", f,
                         w->wedge_class[front]);
                return -1;
            }
            level->wedges[3 * (size_t)n + (size_t)k] = wedge;
        }
        level->primitive[n++] = w->back_primitive[b];
    }
    if (w->dangling_count) {
        memcpy(level->wedges + 3 * (size_t)n, w->dangling_wedges, 3 * (size_t)w->dangling_count * sizeof *level->wedges);
        memcpy(level->primitive + n, w->dangling_primitive, (size_t)w->dangling_count * sizeof *level->primitive);
    }
    return 0;
}

int simplify_mesh(weld_result *w, const int64_t *primitive_material, const simplify_options *options,
                  simplify_result *out, lp_error *err)
{
    memset(out, 0, sizeof *out);
    if (options->level_count > SIMPLIFY_MAX_LEVELS)
        return lp_fail(err, LP_USAGE, "at most %d levels", SIMPLIFY_MAX_LEVELS);
    const double setup_start = lp_seconds();
    sim *s = calloc(1, sizeof *s);
    ranked *ranks = NULL;
    candidate *batch = NULL;
    int rc = LP_OK;
    if (!s) return lp_no_memory(err, "out of memory");
    ranks = malloc(((size_t)w->vertex_count + 1) * sizeof *ranks);
    batch = calloc(BATCH_SIZE, sizeof *batch);
    if (!ranks || !batch || sim_init(s, w, primitive_material, options)) {
        rc = lp_no_memory(err, "out of memory for a mesh of %u triangles", w->triangle_count);
        goto done;
    }
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t v = 0; v < w->vertex_count; ++v)
        for (int k = 0; k < 3; ++k) {
            double x = w->positions[3 * (size_t)v + k];
            if (x < lo[k]) lo[k] = x;
            if (x > hi[k]) hi[k] = x;
        }
    double d2 = 0.0;
    for (int k = 0; k < 3 && w->vertex_count; ++k) d2 += (hi[k] - lo[k]) * (hi[k] - lo[k]);
    out->diagonal = sqrt(d2);
    for (int k = 0; k < 3 && w->vertex_count; ++k) s->extent = geom_fmax(s->extent, geom_fmax(fabs(lo[k]), fabs(hi[k])));
    out->level_count = options->level_count;
    out->seconds_setup = lp_seconds() - setup_start;
    out->held_vertices = s->held_count;
    for (uint32_t k = 0; k < options->level_count; ++k) {
        simplify_level *level = &out->levels[k];
        double t0 = lp_seconds();
        s->level = k;
        /* placement waits until half-edge collapses alone have converged:
         * then it can only remove more from this level, and the vertices
         * it moves are the few where half-edge collapses are stuck (placing
         * from the start, measured with the depth-6 certificate: fandisk 336
         * against 170 triangles at 1/2 %, the bunny 698 against 686 at 1/2 %
         * but 43,366 against 43,590 at 1/64 %) */
        int placing_pending = (s->full_edge_levels >> k) & 1u;
        s->full_edge = 0;
        s->patient = 1;
        s->stats = &level->stats;
        s->eps = options->fractions[k] * out->diagonal;
        level->eps = s->eps;
        memset(s->reject_stamp, 0xff, (size_t)w->vertex_count * sizeof *s->reject_stamp);
        if (s->removal_stamp) memset(s->removal_stamp, 0xff, (size_t)w->vertex_count * sizeof *s->removal_stamp);
        mark_clusters_dirty(s); /* a larger eps may hold more of them whole */
        level_structures(s);
        if (s->eps > 0.0 && region_phase(s)) {
            if (s->verify_failed) rc = lp_fail(err, LP_PROMISE, "invariant broken: %s", s->verify_msg);
            else rc = lp_no_memory(err, "out of memory while simplifying");
            goto done;
        }
        if (s->eps > 0.0 && thin_ready(s)) {
            rc = lp_no_memory(err, "out of memory");
            goto done;
        }
        if (k + 1 < options->level_count) thin_ahead_start(s, 2.0 * (options->fractions[k + 1] * out->diagonal));
        /* a mesh whose diagonal is zero (or eps zero) has nothing to remove */
        while (s->eps > 0.0 && level->stats.passes < MAX_PASSES) {
            size_t waiting = 0;
            long commits = run_pass(s, ranks, batch, &waiting);
            level->stats.passes++;
            if (commits < 0) {
                if (s->verify_failed) rc = lp_fail(err, LP_PROMISE, "invariant broken: %s", s->verify_msg);
                else rc = lp_no_memory(err, "out of memory while simplifying");
                goto done;
            }
            if (commits > 0) s->patient = 1;
            if (commits == 0 && waiting == 0 && s->patient && s->held_back > 0) {
                s->patient = 0; /* the ones patience held back get their try */
                continue;
            }
            if (commits == 0 && waiting == 0) {
                /* then the vertices no collapse could remove, with other
                 * triangulations of their holes; commits again after that */
                const long removed = removal_pass(s);
                if (removed < 0) {
                    if (s->verify_failed) rc = lp_fail(err, LP_PROMISE, "invariant broken: %s", s->verify_msg);
                    else rc = lp_no_memory(err, "out of memory while simplifying");
                    goto done;
                }
                if (removed > 0) {
                    s->patient = 1;
                    continue;
                }
                if (!placing_pending) break;
                placing_pending = 0;
                s->full_edge = 1; /* every candidate gets another chance, with placement */
                memset(s->reject_stamp, 0xff, (size_t)w->vertex_count * sizeof *s->reject_stamp);
            }
        }
        if (s->verify && level->stats.passes < MAX_PASSES && verify_settled(s) != 0) {
            rc = lp_fail(err, LP_PROMISE, "invariant broken: %s", s->verify_msg);
            goto done;
        }
        if (snapshot_level(s, level)) {
            if (s->verify_failed) rc = lp_fail(err, LP_PROMISE, "invariant broken: %s", s->verify_msg);
            else rc = lp_no_memory(err, "out of memory");
            goto done;
        }
        /* after the snapshot, so that the bounds it tightened are checked too */
        if (s->verify && verify_state(s, NULL, 0, NULL, 0) != 0) {
            rc = lp_fail(err, LP_PROMISE, "invariant broken: %s", s->verify_msg);
            goto done;
        }
        level->stats.seconds = lp_seconds() - t0;
    }
done:
    if (s) {
        sim_free(s);
        free(s);
    }
    free(ranks);
    free(batch);
    if (rc) simplify_result_free(out);
    return rc;
}

void simplify_result_free(simplify_result *r)
{
    for (uint32_t k = 0; k < SIMPLIFY_MAX_LEVELS; ++k) {
        free(r->levels[k].wedges);
        free(r->levels[k].primitive);
        free(r->levels[k].positions);
    }
    memset(r, 0, sizeof *r);
}
