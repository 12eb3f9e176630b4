/* config.h - lodpipe's configuration: defaults, pipeline.toml, CLI overrides.
 *
 * The effective configuration is built in three steps, each overriding the
 * previous one key by key:
 *
 *     config_defaults(&c);                      the values below
 *     config_load(&c, "pipeline.toml", &err);   the keys the file sets
 *     config_set(&c, "--levels", "1,3,7", &err); each CLI flag, in order
 *
 * The file's schema (the repository's pipeline.toml lists every key with its
 * default and meaning):
 *
 *   [lod]        levels         eps of each level, percent of the mesh's bbox
 *                               diagonal; 1..16 numbers, strictly increasing,
 *                               each in (0, 100]                 [1, 3, 7, 15]
 *                min_reduction  drop a level that removes less than this
 *                               fraction of the previous level's triangles;
 *                               [0, 1)                                   0.10
 *                flip_cos       reject a collapse when a changed face's
 *                               normal turns to cos <= this; [-1, 1)     0.25
 *                strict_intersections  test every collapse for
 *                               self-intersections, not only where the
 *                               original is thin                       false
 *                placement      "half-edge" (levels share one vertex
 *                               buffer) or "optimal" (full-edge
 *                               collapses may place the kept vertex)
 *                                                                 "half-edge"
 *                optimal_levels with "optimal": the level numbers (1-based)
 *                               that may place vertices; [] = every level []
 *   [switching]  pixel_error    p, pixels of screen error at the switching
 *                               distance; > 0, below viewport_height      1.0
 *                viewport_height  H, pixels; > 0                         1080
 *                fov_y          vertical field of view, radians; (0, pi)  pi/4
 *   [run]        threads        worker threads, 0 = one per core; 0..64     0
 *   [draco]      enabled        Draco-compress every level            false
 *                position_bits  quantization bits, 1..30                   14
 *                normal_bits    2..30 (Draco's octahedral coder needs 2)   10
 *                texcoord_bits  1..30                                      12
 *                color_bits     1..30                                       8
 *                generic_bits   1..30                                      12
 *                speed          encoder speed, 0 (smallest) .. 10 (fastest) 5
 *                fallback       also write an uncompressed fallback   false
 *
 * Number keys accept TOML integers or floats; integer keys (threads, *_bits,
 * speed) only integers; every number must be finite. The quantization ranges
 * are what Draco 1.5 accepts (AttributeQuantizationTransform: 1..30;
 * OctahedronToolBox for normals: 2..30; bits <= 0 would mean "lossless",
 * which lodpipe does not offer). The speed range is Encoder::SetSpeedOptions'.
 *
 * Errors (lp_error, one line):
 * - the file is missing or unreadable: LP_IO, "PATH: cannot read: REASON";
 * - the file is not TOML: LP_USAGE, "PATH: line L, column C: REASON";
 * - an unknown table or key, a wrong type, a value out of range: LP_USAGE,
 *   "PATH:LINE: KEY: PROBLEM", e.g.
 *   "pipeline.toml:7: lod.levels: must be strictly increasing (3 follows 3)";
 * - a bad config_set: LP_USAGE, "NAME VALUE: PROBLEM", NAME as the caller
 *   gave it ("--pixel-error 0: must be > 0").
 * A failing call leaves the configuration exactly as it was.
 *
 * The module holds no global state; the functions are thread-safe on distinct
 * configurations. */
#ifndef LODPIPE_CONFIG_H
#define LODPIPE_CONFIG_H

#include <stddef.h>

#include <stdint.h>

#include "status.h"

#define LP_CONFIG_MAX_LEVELS 16

typedef struct lp_config {
    struct {
        size_t level_count;
        double levels[LP_CONFIG_MAX_LEVELS]; /* percent of the bbox diagonal; slots past level_count are 0 */
        double min_reduction;
        double flip_cos;
        int strict_intersections; /* 0 or 1 */
        int placement;            /* 0 "half-edge", 1 "optimal" */
        uint32_t optimal_levels;  /* bit k-1: ladder level k may place vertices; 0 = every level */
    } lod;
    struct {
        double pixel_error;
        double viewport_height;
        double fov_y;
    } switching;
    struct {
        int threads;
    } run;
    struct {
        int enabled; /* 0 or 1 */
        int position_bits;
        int normal_bits;
        int texcoord_bits;
        int color_bits;
        int generic_bits;
        int speed;
        int fallback; /* 0 or 1 */
    } draco;
} lp_config;

/* Fills every field with its default (the table above). */
void config_defaults(lp_config *config);

/* Reads the TOML file at `path` and sets every key it contains; keys it does
 * not mention keep their current values (call config_defaults first). The
 * whole file is validated before anything is changed. Returns LP_OK, or
 * LP_USAGE / LP_IO with err filled (messages above; they start with path). */
int config_load(lp_config *config, const char *path, lp_error *err);

/* Sets one key from text, as a CLI flag does. `name` is either a dotted key
 * ("switching.pixel_error"; every key can be set this way) or one of the CLI
 * flags below. Value text: a number ("2", "0.5", "1e-3"), an integer ("8"),
 * a boolean ("true" / "false"), a choice ("optimal"), for lod.optimal_levels
 * comma-separated level numbers ("3,4"; "" for none), or for lod.levels a comma-separated list of
 * percentages ("1,3,7,15"). The value is validated like the file's.
 * Returns LP_OK, or LP_USAGE with err filled and the configuration unchanged.
 *
 *   --levels          lod.levels
 *   --placement       lod.placement
 *   --optimal-levels  lod.optimal_levels (comma-separated level numbers)
 *   --pixel-error     switching.pixel_error
 *   --viewport-height switching.viewport_height
 *   --fov-y           switching.fov_y
 *   --threads         run.threads
 *   --draco           draco.enabled   (a switch: the CLI passes "true")    */
int config_set(lp_config *config, const char *name, const char *value_text, lp_error *err);

/* The camera's switching distance per unit of a level's error (switching.h:
 * H / (2 tan(fov_y / 2) p)) may be at most this. A real camera gives about
 * 10^3 (1080 pixels, pi/4, 1 pixel); the bound keeps every written distance
 * finite, as a world transform is within float range (an error times a
 * scale below 10^77). */
#define SWITCHING_MAX_DISTANCE_PER_ERROR 1e100

/* The rules between keys, for the configuration in effect once the file and
 * every flag are applied: lod.optimal_levels only with lod.placement =
 * "optimal", and naming only levels lod.levels has; switching.pixel_error
 * below switching.viewport_height (else every node is culled), and the
 * camera's distance per unit of error at most
 * SWITCHING_MAX_DISTANCE_PER_ERROR (a field of view or pixel error near 0).
 * Returns LP_OK, or LP_USAGE with err filled. */
int config_check(const lp_config *config, lp_error *err);

/* The rules config_check tests, in its order, by the keys they are about. */
typedef enum config_rule {
    CONFIG_RULE_NONE = 0,
    CONFIG_RULE_OPTIMAL_NEEDS_PLACEMENT, /* lod.optimal_levels, lod.placement */
    CONFIG_RULE_OPTIMAL_LEVELS_EXIST,    /* lod.optimal_levels, lod.levels */
    CONFIG_RULE_PIXEL_BELOW_HEIGHT,      /* switching.pixel_error, switching.viewport_height */
    CONFIG_RULE_CAMERA_FINITE,           /* switching.viewport_height, fov_y, pixel_error */
    CONFIG_RULE_COUNT
} config_rule;

/* The first rule `config` breaks (CONFIG_RULE_NONE when it breaks none), with
 * config_check's message in err when err is not NULL. */
config_rule config_broken_rule(const lp_config *config, lp_error *err);

/* 1 when `config` breaks `rule`, else 0. */
int config_breaks(const lp_config *config, config_rule rule);

/* The line of the TOML file at `path` that sets the last (by line) of the
 * keys `rule` is about, for an error naming where the file breaks it; 0 when
 * the file sets none of them or cannot be read. */
uint32_t config_rule_line(const char *path, config_rule rule);

/* Is `flag` one of the flags above? Returns 0 if not; 1 for a flag that takes
 * the next argument as its value; 2 for a switch that takes none (--draco). */
int config_flag(const char *flag);

/* 1 when both configurations have the same effective values, else 0. */
int config_equal(const lp_config *a, const lp_config *b);

typedef enum config_format {
    CONFIG_TOML, /* the pipeline.toml schema; config_load reads it back to an equal config */
    CONFIG_JSON  /* {"lod":{"levels":[1, 3, 7, 15],...},"switching":{...},...} on one line */
} config_format;

/* Writes the effective configuration as canonical text: every key, in the
 * schema's order, fixed formatting, booleans as true/false, numbers exactly:
 * whole numbers below 2^53 as integers ("1080"), others in the shortest
 * "%.{1..17}g" that reads back to the same double ("0.1"); -0 as 0. The text
 * ends with a newline. Equal configurations give identical text and different ones
 * different text, so it can go into cache keys. snprintf-style: writes at most
 * cap bytes including the terminator (buf may be NULL when cap is 0) and
 * returns the full length, excluding the terminator. */
size_t config_write(const lp_config *config, config_format format, char *buf, size_t cap);

#endif
