/* lodchain.h - a mesh's certified levels written into the glTF document as an
 * MSFT_lod chain (DESIGN.md §7, §8).
 *
 * For one mesh and its simplify_result, lodchain_write edits the document:
 * - levels are kept in ladder order, dropping a level that is empty or that
 *   removes less than min_reduction of the previous kept level's triangles;
 * - each triangle primitive's vertices are reordered by the level at which
 *   they die (last to die first), so kept level k uses a prefix of the vertex
 *   buffer; the reorder rewrites the primitive's own vertex accessors in place
 *   (same accessor numbers, so skins, animations and morph targets keep
 *   pointing at them) and is skipped for a primitive whose accessors another
 *   object shares;
 * - one new mesh per kept level: the same primitives (material, attributes,
 *   morph targets, extensions: the ORIGINAL vertex accessors) with only a new
 *   index accessor (16-bit when it fits) holding the level's triangles; points
 *   and lines primitives are copied as they are;
 * - every node that uses the mesh gets extensions.MSFT_lod.ids naming one new
 *   node per level (same transform, skin and morph weights, not in any scene),
 *   extras.MSFT_screencoverage and extras.lodpipe (README: "Output format"),
 *   or, when a LOD node in its place would lose part of it (children, a
 *   camera, extras, an extension it does not copy), hands its mesh to a new
 *   child, the carrier, that gets them instead;
 * - morph targets: the bound holds for the base shape; for each target the
 *   level's distance to LOD0 with that target applied at weight 1 is MEASURED
 *   (dense sampling, measure.h) and written beside the bound; the distinct
 *   targets are measured on options->threads threads, each result into its
 *   own slot, so the bytes written do not depend on the thread count.
 * Nothing else in the document changes. A node that already carries MSFT_lod
 * is left alone (with a warning). */
#ifndef LODPIPE_LODCHAIN_H
#define LODPIPE_LODCHAIN_H

#include <stdint.h>

#include "scene.h"
#include "simplify.h"
#include "measure.h"
#include "status.h"
#include "switching.h"
#include "weld.h"

typedef struct lodchain_options {
    switching_camera camera;
    double min_reduction;
    /* 1: leave every vertex accessor in its order (Draco output: the encoder
     * orders vertices itself, so the death-order reorder would be wasted). */
    int keep_vertex_order;
    /* NULL, or per ladder level an error added to the level's certified bound
     * by a later lossy stage (Draco's position quantization, dracoout.h):
     * added_error[0] is LOD0's, added_error[k] ladder level k's (1-based).
     * The recorded error becomes bound + added (so distances and coverages
     * use the sum), LOD0's recorded error becomes added_error[0], and each
     * level's extras.lodpipe entry gets "quantization_error". */
    const double *added_error;
    /* threads measuring the morph targets, 0: one per online core; the
     * numbers written do not depend on it */
    uint32_t threads;
} lodchain_options;

typedef struct lodchain_level {
    uint32_t ladder_level; /* 1-based position in the eps ladder */
    int64_t mesh;          /* new glTF mesh */
    uint32_t triangles;
    double eps, error;     /* mesh units; error = certified bound + added error */
    double added_error;    /* options->added_error's share of error (0 without) */
} lodchain_level;

typedef struct lodchain_summary {
    uint32_t level_count; /* kept */
    lodchain_level levels[SIMPLIFY_MAX_LEVELS];
    /* morph targets: per kept level, the measured (not certified) two-sided
     * distance between level and LOD0 with target t at weight 1 */
    uint32_t target_count;
    double *morph_errors; /* level_count * target_count, freed by lodchain_summary_free */
    uint32_t nodes;       /* nodes that got MSFT_lod */
    uint32_t primitives_not_reordered;
    uint32_t warning_count;
    char warnings[4][200];
} lodchain_summary;

/* The ladder levels lodchain_write keeps (0-based indices into r->levels, in
 * order): not empty, and removing at least min_reduction of the previous kept
 * level's triangles. Returns how many. */
uint32_t lodchain_kept_levels(const weld_result *w, const simplify_result *r, double min_reduction,
                              uint32_t kept[SIMPLIFY_MAX_LEVELS]);

int lodchain_write(scene *s, uint32_t mesh, const weld_result *w, const simplify_result *r,
                   const lodchain_options *options, lodchain_summary *out, lp_error *err);
void lodchain_summary_free(lodchain_summary *summary);

/* Mesh m's triangle primitives (mesh space) as one triangle set for measure.h:
 * LOD0's triangles when level is NULL (w may then be NULL too), else the
 * level's; with morph target t applied at weight 1 when t >= 0. *positions
 * and *triangles are the caller's to free, also after a failure. */
int lodchain_mesh_triangles(const scene *s, uint32_t m, const weld_result *w, const simplify_level *level, int t,
                            float **positions, uint32_t **triangles, measure_mesh *out, lp_error *err);

#endif
