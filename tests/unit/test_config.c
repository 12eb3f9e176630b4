/* test_config.c - config.h: defaults, pipeline.toml, CLI overrides, errors,
 * canonical text; and the toml_io bridge underneath. Runs from the repository
 * root (or $LODPIPE_ROOT); temporary files go to /tmp and are removed. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "config.h"
#include "toml_io/toml_io.h"

/* ---- helpers -------------------------------------------------------------- */

/* Writes text to a fresh /tmp file; path receives its name. */
static int write_temp(const char *text, char path[64])
{
    snprintf(path, 64, "/tmp/lodpipe_config_XXXXXX");
    int fd = mkstemp(path);
    if (fd < 0) return -1;
    FILE *f = fdopen(fd, "w");
    if (!f) {
        close(fd);
        unlink(path);
        return -1;
    }
    fputs(text, f);
    fclose(f);
    return 0;
}

/* Loads text as a config file on top of defaults; the file is removed again. */
static int load_text(const char *text, lp_config *c, lp_error *err, char path_out[64])
{
    char path[64];
    config_defaults(c);
    err->code = 0;
    err->msg[0] = '\0';
    if (write_temp(text, path)) return -100;
    int rc = config_load(c, path, err);
    unlink(path);
    if (path_out) memcpy(path_out, path, 64);
    return rc;
}

static void repo_path(char *out, size_t n, const char *name)
{
    const char *root = getenv("LODPIPE_ROOT");
    snprintf(out, n, "%s/%s", root && *root ? root : ".", name);
}

static char *canonical(const lp_config *c, config_format f)
{
    size_t n = config_write(c, f, NULL, 0);
    char *s = malloc(n + 1);
    if (!s) return NULL;
    size_t m = config_write(c, f, s, n + 1);
    (void)m;
    return s;
}

/* ---- defaults and the repository's file ---------------------------------- */

static void test_defaults(void)
{
    lp_config c;
    memset(&c, 0xAB, sizeof c);
    config_defaults(&c);
    CHECK(c.lod.level_count == 4, "%zu", c.lod.level_count);
    CHECK(c.lod.levels[0] == 1 && c.lod.levels[1] == 3 && c.lod.levels[2] == 7 &&
              c.lod.levels[3] == 15,
          "levels");
    for (size_t i = 4; i < LP_CONFIG_MAX_LEVELS; ++i) CHECK(c.lod.levels[i] == 0, "slot %zu", i);
    CHECK(c.lod.min_reduction == 0.10, "%g", c.lod.min_reduction);
    CHECK(c.lod.flip_cos == 0.25, "%g", c.lod.flip_cos);
    CHECK(c.switching.pixel_error == 1.0, "%g", c.switching.pixel_error);
    CHECK(c.switching.viewport_height == 1080, "%g", c.switching.viewport_height);
    CHECK(c.switching.fov_y == 0.7853981633974483, "%.17g", c.switching.fov_y);
    CHECK(c.run.threads == 0, "%d", c.run.threads);
    CHECK(c.draco.enabled == 0 && c.draco.fallback == 0, "draco switches");
    CHECK(c.draco.position_bits == 14 && c.draco.normal_bits == 10 &&
              c.draco.texcoord_bits == 12 && c.draco.color_bits == 8 &&
              c.draco.generic_bits == 12 && c.draco.speed == 5,
          "draco numbers");
}

static void test_repo_file_equals_defaults(void)
{
    char path[1024];
    repo_path(path, sizeof path, "pipeline.toml");
    lp_config d, c;
    lp_error err = {0, "", 0};
    config_defaults(&d);
    /* Start from something else, so every key must come from the file. */
    config_defaults(&c);
    c.lod.level_count = 1;
    c.lod.levels[0] = 50;
    c.lod.levels[1] = c.lod.levels[2] = c.lod.levels[3] = 0;
    c.lod.min_reduction = 0.5;
    c.lod.flip_cos = 0;
    c.lod.placement = 1;
    c.lod.optimal_levels = 0x5;
    c.switching.pixel_error = 3;
    c.switching.viewport_height = 720;
    c.switching.fov_y = 1;
    c.run.threads = 7;
    c.draco.enabled = 1;
    c.draco.position_bits = c.draco.normal_bits = c.draco.texcoord_bits = 20;
    c.draco.color_bits = c.draco.generic_bits = 20;
    c.draco.speed = 0;
    c.draco.fallback = 1;
    int rc = config_load(&c, path, &err);
    CHECK(rc == LP_OK, "%s: rc %d %s", path, rc, err.msg);
    CHECK(config_equal(&c, &d), "the repository's pipeline.toml differs from the defaults");

    /* The file lists exactly the schema's keys, in the schema's order. */
    char *text = canonical(&d, CONFIG_TOML);
    char tmp[64];
    CHECK(text && write_temp(text, tmp) == 0, "temp");
    toml_io_doc *a = NULL, *b = NULL;
    char why[256];
    CHECK(toml_io_parse_file(path, &a, why, sizeof why) == TOML_IO_OK, "%s", why);
    CHECK(toml_io_parse_file(tmp, &b, why, sizeof why) == TOML_IO_OK, "%s", why);
    unlink(tmp);
    if (a && b) {
        CHECK(toml_io_count(a) == toml_io_count(b), "%zu entries vs %zu", toml_io_count(a),
              toml_io_count(b));
        for (size_t i = 0; i < toml_io_count(a) && i < toml_io_count(b); ++i) {
            toml_io_entry ea, eb;
            toml_io_get(a, i, &ea);
            toml_io_get(b, i, &eb);
            CHECK(strcmp(ea.key, eb.key) == 0, "entry %zu: %s vs %s", i, ea.key, eb.key);
        }
    }
    toml_io_free(a);
    toml_io_free(b);
    free(text);
}

/* ---- the bridge ------------------------------------------------------------ */

static void test_toml_io_entries(void)
{
    char path[64];
    const char *text = "# comment\n"
                       "top = 1\n"
                       "[t]\n"
                       "b = true\n"
                       "a = \"x\\u0000y\"\n"
                       "n = [1, 2.5, \"s\", [3], {k = 1}]\n"
                       "\"q.k\" = -7\n"
                       "d = 1979-05-27\n"
                       "[empty]\n";
    CHECK(write_temp(text, path) == 0, "temp");
    toml_io_doc *doc = NULL;
    char why[256];
    int rc = toml_io_parse_file(path, &doc, why, sizeof why);
    unlink(path);
    CHECK(rc == TOML_IO_OK, "%s", why);
    if (rc) return;
    /* Document order, not toml++'s sorted order. */
    static const char *keys[] = {"top", "t", "t.b", "t.a", "t.n", "t.\"q.k\"", "t.d", "empty"};
    static const uint32_t lines[] = {2, 3, 4, 5, 6, 7, 8, 9};
    static const toml_io_type types[] = {TOML_IO_INTEGER, TOML_IO_TABLE, TOML_IO_BOOLEAN,
                                         TOML_IO_STRING,  TOML_IO_ARRAY, TOML_IO_INTEGER,
                                         TOML_IO_OTHER,   TOML_IO_TABLE};
    CHECK(toml_io_count(doc) == 8, "%zu", toml_io_count(doc));
    for (size_t i = 0; i < 8 && i < toml_io_count(doc); ++i) {
        toml_io_entry e;
        CHECK(toml_io_get(doc, i, &e) == 0, "get");
        CHECK(strcmp(e.key, keys[i]) == 0, "%zu: %s", i, e.key);
        CHECK(e.line == lines[i], "%s: line %u", e.key, e.line);
        CHECK(e.value.type == types[i], "%s: type %d", e.key, (int)e.value.type);
        if (i == 1) CHECK(e.element_count == 5, "t has %zu keys", e.element_count);
        if (i == 3)
            CHECK(e.value.string_length == 3 && memcmp(e.value.string, "x\0y", 3) == 0,
                  "string with NUL");
        if (i == 4) {
            CHECK(e.element_count == 5, "%zu", e.element_count);
            if (e.element_count == 5) {
                CHECK(e.elements[0].type == TOML_IO_INTEGER && e.elements[0].number == 1 &&
                          e.elements[0].integer == 1,
                      "el 0");
                CHECK(e.elements[1].type == TOML_IO_FLOAT && e.elements[1].number == 2.5, "el 1");
                CHECK(e.elements[2].type == TOML_IO_STRING &&
                          strcmp(e.elements[2].string, "s") == 0,
                      "el 2");
                CHECK(e.elements[3].type == TOML_IO_ARRAY, "el 3");
                CHECK(e.elements[4].type == TOML_IO_TABLE, "el 4");
            }
        }
        if (i == 5) CHECK(e.value.integer == -7 && e.value.number == -7, "int");
        if (i == 7) CHECK(e.element_count == 0, "empty table");
    }
    toml_io_entry e;
    CHECK(toml_io_get(doc, 8, &e) == -1, "out of range");
    toml_io_free(doc);
    toml_io_free(NULL);

    doc = (toml_io_doc *)1;
    CHECK(toml_io_parse_file("/nonexistent/x.toml", &doc, why, sizeof why) == TOML_IO_READ &&
              doc == NULL,
          "missing file");
    CHECK(toml_io_parse_file("/tmp", &doc, why, sizeof why) == TOML_IO_READ, "directory");

    CHECK(write_temp("a = 1\n\n[b]\nc = = 2\n", path) == 0, "temp");
    rc = toml_io_parse_file(path, &doc, why, sizeof why);
    unlink(path);
    CHECK(rc == TOML_IO_SYNTAX && doc == NULL, "rc %d", rc);
    CHECK(strncmp(why, "line 4, column ", 15) == 0 && !strchr(why, '\n'), "%s", why);
}

/* ---- the file: every key, one at a time ----------------------------------- */

typedef struct override_case {
    const char *text;
    void (*expect)(lp_config *);
} override_case;

static void e_levels(lp_config *c)
{
    c->lod.level_count = 3;
    c->lod.levels[0] = 0.5;
    c->lod.levels[1] = 2;
    c->lod.levels[2] = 100;
    c->lod.levels[3] = 0;
}
static void e_min_reduction(lp_config *c) { c->lod.min_reduction = 0; }
static void e_placement(lp_config *c) { c->lod.placement = 1; }
static void e_optimal_levels(lp_config *c) { c->lod.optimal_levels = (1u << 2) | (1u << 3) | (1u << 15); }
static void e_flip_cos(lp_config *c) { c->lod.flip_cos = -1; }
static void e_pixel_error(lp_config *c) { c->switching.pixel_error = 2; }
static void e_viewport_height(lp_config *c) { c->switching.viewport_height = 2160.5; }
static void e_fov_y(lp_config *c) { c->switching.fov_y = 1.25; }
static void e_threads(lp_config *c) { c->run.threads = 64; }
static void e_enabled(lp_config *c) { c->draco.enabled = 1; }
static void e_position_bits(lp_config *c) { c->draco.position_bits = 30; }
static void e_normal_bits(lp_config *c) { c->draco.normal_bits = 2; }
static void e_texcoord_bits(lp_config *c) { c->draco.texcoord_bits = 1; }
static void e_color_bits(lp_config *c) { c->draco.color_bits = 16; }
static void e_generic_bits(lp_config *c) { c->draco.generic_bits = 9; }
static void e_speed(lp_config *c) { c->draco.speed = 0; }
static void e_fallback(lp_config *c) { c->draco.fallback = 1; }

static const override_case kOverrides[] = {
    {"[lod]\nlevels = [0.5, 2, 100]\n", e_levels},
    {"[lod]\nmin_reduction = 0\n", e_min_reduction},
    {"[lod]\nplacement = \"optimal\"\n", e_placement},
    {"[lod]\noptimal_levels = [4, 3, 16, 3]\n", e_optimal_levels}, /* a set: order and repeats do not matter */
    {"[lod]\nflip_cos = -1.0\n", e_flip_cos},
    {"[switching]\npixel_error = 2\n", e_pixel_error},
    {"[switching]\nviewport_height = 2160.5\n", e_viewport_height},
    {"switching.fov_y = 1.25\n", e_fov_y}, /* dotted key at the root */
    {"[run]\nthreads = 64\n", e_threads},
    {"[draco]\nenabled = true\n", e_enabled},
    {"[draco]\nposition_bits = 30\n", e_position_bits},
    {"[draco]\nnormal_bits = 2\n", e_normal_bits},
    {"[draco]\ntexcoord_bits = 1\n", e_texcoord_bits},
    {"[draco]\ncolor_bits = 16\n", e_color_bits},
    {"[draco]\ngeneric_bits = 9\n", e_generic_bits},
    {"draco = { speed = 0 }\n", e_speed}, /* inline table */
    {"[draco]\nfallback = true\n", e_fallback},
};

static void test_each_key_from_file(void)
{
    for (size_t i = 0; i < sizeof kOverrides / sizeof kOverrides[0]; ++i) {
        lp_config c, want, d;
        lp_error err;
        int rc = load_text(kOverrides[i].text, &c, &err, NULL);
        CHECK(rc == LP_OK, "%s: rc %d %s", kOverrides[i].text, rc, err.msg);
        config_defaults(&want);
        kOverrides[i].expect(&want);
        config_defaults(&d);
        CHECK(config_equal(&c, &want), "%s: not applied", kOverrides[i].text);
        CHECK(!config_equal(&c, &d), "%s: equals the defaults", kOverrides[i].text);
    }
}

static void test_all_keys_in_one_file(void)
{
    const char *text = "[lod]\nlevels = [2, 4]\nmin_reduction = 0.2\nflip_cos = 0.5\n"
                       "[switching]\npixel_error = 0.5\nviewport_height = 720\nfov_y = 1\n"
                       "[run]\nthreads = 3\n"
                       "[draco]\nenabled = true\nposition_bits = 16\nnormal_bits = 12\n"
                       "texcoord_bits = 14\ncolor_bits = 10\ngeneric_bits = 11\nspeed = 7\n"
                       "fallback = true\n";
    lp_config c;
    lp_error err;
    CHECK(load_text(text, &c, &err, NULL) == LP_OK, "%s", err.msg);
    CHECK(c.lod.level_count == 2 && c.lod.levels[0] == 2 && c.lod.levels[1] == 4 &&
              c.lod.levels[2] == 0,
          "levels");
    CHECK(c.lod.min_reduction == 0.2 && c.lod.flip_cos == 0.5, "lod");
    CHECK(c.switching.pixel_error == 0.5 && c.switching.viewport_height == 720 &&
              c.switching.fov_y == 1,
          "switching");
    CHECK(c.run.threads == 3, "run");
    CHECK(c.draco.enabled == 1 && c.draco.position_bits == 16 && c.draco.normal_bits == 12 &&
              c.draco.texcoord_bits == 14 && c.draco.color_bits == 10 &&
              c.draco.generic_bits == 11 && c.draco.speed == 7 && c.draco.fallback == 1,
          "draco");

    /* An empty file and empty known tables change nothing. */
    lp_config d;
    config_defaults(&d);
    CHECK(load_text("", &c, &err, NULL) == LP_OK && config_equal(&c, &d), "empty file");
    CHECK(load_text("[lod]\n[switching]\n[run]\n[draco]\n", &c, &err, NULL) == LP_OK &&
              config_equal(&c, &d),
          "empty tables: %s", err.msg);
}

/* ---- the file: every error class ------------------------------------------ */

typedef struct error_case {
    const char *text;
    int code;
    int line;          /* expected "PATH:LINE: " prefix; 0 = no line (syntax) */
    const char *piece; /* must appear in the message */
} error_case;

static const error_case kErrors[] = {
    /* unknown key, unknown table */
    {"[lod]\nlevels = [1]\nlevel = 3\n", LP_USAGE, 3, ": lod.level: unknown key (known in [lod]: levels, min_reduction, flip_cos, strict_intersections, placement, optimal_levels)"},
    {"[lod]\nplacement = \"best\"\n", LP_USAGE, 2, ": lod.placement: must be \"half-edge\" or \"optimal\", got \"best\""},
    {"[lod]\nplacement = 1\n", LP_USAGE, 2, ": lod.placement: must be a string (\"half-edge\" or \"optimal\"), not an integer"},
    {"[lod]\noptimal_levels = 3\n", LP_USAGE, 2, ": lod.optimal_levels: must be an array of level numbers in 1..16, not an integer"},
    {"[lod]\noptimal_levels = [0]\n", LP_USAGE, 2, ": lod.optimal_levels: must list level numbers in 1..16, got 0"},
    {"[lod]\noptimal_levels = [17]\n", LP_USAGE, 2, ": lod.optimal_levels: must list level numbers in 1..16, got 17"},
    {"[lod]\noptimal_levels = [2.5]\n", LP_USAGE, 2, ": lod.optimal_levels: value 1 must be an integer level number, not a float"},
    {"threads = 4\n", LP_USAGE, 1, ": threads: unknown key; did you mean run.threads?"},
    {"[draco]\nbits = 4\n", LP_USAGE, 2, ": draco.bits: unknown key"},
    {"\n[lods]\nlevels = [1]\n", LP_USAGE, 2, ": lods: unknown table"},
    {"[extra]\n", LP_USAGE, 1, ": extra: unknown table"},
    {"[lod.sub]\nx = 1\n", LP_USAGE, 1, ": lod.sub: unknown table"},
    {"[[lod]]\nlevels = [1]\n", LP_USAGE, 1, ": lod: must be a table, not an array"},
    /* wrong type */
    {"lod = 3\n", LP_USAGE, 1, ": lod: must be a table"},
    {"[lod]\nmin_reduction = \"0.1\"\n", LP_USAGE, 2, ": lod.min_reduction: must be a number, not a string"},
    {"[lod]\nlevels = 5\n", LP_USAGE, 2, ": lod.levels: must be an array of numbers, not an integer"},
    {"[lod]\nlevels = [1, \"3\"]\n", LP_USAGE, 2, ": lod.levels: value 2 must be a number, not a string"},
    {"[lod.levels]\n", LP_USAGE, 1, ": lod.levels: must be an array of numbers, not a table"},
    {"[run]\nthreads = 4.0\n", LP_USAGE, 2, ": run.threads: must be an integer, not a float"},
    {"[draco]\nenabled = 1\n", LP_USAGE, 2, ": draco.enabled: must be true or false, not an integer"},
    {"[switching]\nfov_y = 1979-05-27\n", LP_USAGE, 2, ": switching.fov_y: must be a number, not a date/time"},
    /* out of range, each bound */
    {"[lod]\nmin_reduction = 1\n", LP_USAGE, 2, ": lod.min_reduction: must be in [0, 1), got 1"},
    {"[lod]\nmin_reduction = -0.01\n", LP_USAGE, 2, ": lod.min_reduction: must be in [0, 1), got -0.01"},
    {"[lod]\nflip_cos = 1.0\n", LP_USAGE, 2, ": lod.flip_cos: must be in [-1, 1)"},
    {"[lod]\nflip_cos = -1.5\n", LP_USAGE, 2, ": lod.flip_cos: must be in [-1, 1)"},
    {"[lod]\nflip_cos = nan\n", LP_USAGE, 2, ": lod.flip_cos: must be a finite number"},
    {"[switching]\npixel_error = 0\n", LP_USAGE, 2, ": switching.pixel_error: must be > 0, got 0"},
    {"[switching]\npixel_error = inf\n", LP_USAGE, 2, ": switching.pixel_error: must be a finite number > 0, got inf"},
    {"[switching]\nviewport_height = -1080\n", LP_USAGE, 2, ": switching.viewport_height: must be > 0"},
    {"[switching]\nfov_y = 0\n", LP_USAGE, 2, ": switching.fov_y: must be in (0, pi)"},
    {"[switching]\nfov_y = 3.1416\n", LP_USAGE, 2, ": switching.fov_y: must be in (0, pi)"},
    {"[run]\nthreads = 65\n", LP_USAGE, 2, ": run.threads: must be in 0..64"},
    {"[run]\nthreads = -1\n", LP_USAGE, 2, ": run.threads: must be in 0..64"},
    {"[run]\nthreads = 9223372036854775807\n", LP_USAGE, 2, ": run.threads: must be in 0..64"},
    {"[draco]\nposition_bits = 0\n", LP_USAGE, 2, ": draco.position_bits: must be in 1..30, got 0"},
    {"[draco]\nposition_bits = 31\n", LP_USAGE, 2, ": draco.position_bits: must be in 1..30, got 31"},
    {"[draco]\nnormal_bits = 1\n", LP_USAGE, 2, ": draco.normal_bits: must be in 2..30"},
    {"[draco]\ntexcoord_bits = 31\n", LP_USAGE, 2, ": draco.texcoord_bits: must be in 1..30"},
    {"[draco]\ncolor_bits = 0\n", LP_USAGE, 2, ": draco.color_bits: must be in 1..30"},
    {"[draco]\ngeneric_bits = 40\n", LP_USAGE, 2, ": draco.generic_bits: must be in 1..30"},
    {"[draco]\nspeed = 11\n", LP_USAGE, 2, ": draco.speed: must be in 0..10"},
    {"[draco]\nspeed = -1\n", LP_USAGE, 2, ": draco.speed: must be in 0..10"},
    /* levels */
    {"[lod]\nlevels = []\n", LP_USAGE, 2, ": lod.levels: must have 1 to 16 values, got 0"},
    {"[lod]\nlevels = [1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16,17]\n", LP_USAGE, 2, ": lod.levels: must have 1 to 16 values, got 17"},
    {"[lod]\nlevels = [0, 1]\n", LP_USAGE, 2, ": lod.levels: value 1 must be in (0, 100]"},
    {"[lod]\nlevels = [1, 100.5]\n", LP_USAGE, 2, ": lod.levels: value 2 must be in (0, 100]"},
    {"[lod]\nlevels = [1, nan]\n", LP_USAGE, 2, ": lod.levels: value 2 must be in (0, 100]"},
    {"# the ladder\n\n[lod]\nmin_reduction = 0.1\n\n\nlevels = [1, 3, 3, 15]\n", LP_USAGE, 7, ": lod.levels: must be strictly increasing (3 follows 3)"},
    {"[lod]\nlevels = [\n  7,\n  3,\n]\n", LP_USAGE, 2, ": lod.levels: must be strictly increasing (3 follows 7)"},
    /* syntax */
    {"[lod]\nlevels = [1, 3\nflip_cos = 0.2\n", LP_USAGE, 0, ": line 3, column "},
    {"[lod]\nmin_reduction = 0.1\nmin_reduction = 0.2\n", LP_USAGE, 0, ": line 3, column "},
    {"[lod\n", LP_USAGE, 0, ": line 1, column "},
    {"a = \"\xff\"\n", LP_USAGE, 0, ": line 1, column "},
};

static void test_file_errors(void)
{
    for (size_t i = 0; i < sizeof kErrors / sizeof kErrors[0]; ++i) {
        const error_case *t = &kErrors[i];
        lp_config c;
        lp_error err;
        char path[64], want[128];
        int rc = load_text(t->text, &c, &err, path);
        CHECK(rc == t->code, "case %zu: rc %d, want %d (%s)", i, rc, t->code, err.msg);
        CHECK(err.code == t->code, "case %zu: err.code %d", i, err.code);
        if (t->line) snprintf(want, sizeof want, "%s:%d: ", path, t->line);
        else snprintf(want, sizeof want, "%s: ", path);
        CHECK(strncmp(err.msg, want, strlen(want)) == 0, "case %zu: '%s' does not start with '%s'",
              i, err.msg, want);
        CHECK(strstr(err.msg, t->piece) != NULL, "case %zu: '%s' lacks '%s'", i, err.msg,
              t->piece);
        CHECK(!strchr(err.msg, '\n'), "case %zu: message spans lines: %s", i, err.msg);
        lp_config d;
        config_defaults(&d);
        CHECK(config_equal(&c, &d), "case %zu: a failed load changed the configuration", i);
    }
}

static void test_missing_file(void)
{
    lp_config c, d;
    lp_error err = {0, "", 0};
    config_defaults(&c);
    config_defaults(&d);
    int rc = config_load(&c, "/nonexistent/dir/pipeline.toml", &err);
    CHECK(rc == LP_IO && err.code == LP_IO, "rc %d", rc);
    CHECK(strstr(err.msg, "/nonexistent/dir/pipeline.toml: cannot read: ") == err.msg, "%s",
          err.msg);
    rc = config_load(&c, "/tmp", &err);
    CHECK(rc == LP_IO, "directory: rc %d %s", rc, err.msg);
    CHECK(config_equal(&c, &d), "changed");
}

static void test_failed_load_keeps_previous_values(void)
{
    /* The first key is fine and the second is not: nothing is applied. */
    lp_config c, before;
    lp_error err;
    char path[64];
    config_defaults(&c);
    CHECK(config_set(&c, "--pixel-error", "4", &err) == LP_OK, "%s", err.msg);
    before = c;
    CHECK(write_temp("[switching]\npixel_error = 2\n[run]\nthreads = 100\n", path) == 0, "temp");
    CHECK(config_load(&c, path, &err) == LP_USAGE, "rc");
    unlink(path);
    CHECK(config_equal(&c, &before) && c.switching.pixel_error == 4, "partially applied");
    /* A good file on top of flags set earlier keeps what it does not mention. */
    CHECK(write_temp("[run]\nthreads = 2\n", path) == 0, "temp");
    CHECK(config_load(&c, path, &err) == LP_OK, "%s", err.msg);
    unlink(path);
    CHECK(c.run.threads == 2 && c.switching.pixel_error == 4, "merge");
}

/* ---- CLI flags ------------------------------------------------------------- */

static void test_flags(void)
{
    lp_config c;
    lp_error err = {0, "", 0};
    config_defaults(&c);
    CHECK(config_flag("--levels") == 1 && config_flag("--pixel-error") == 1 &&
              config_flag("--viewport-height") == 1 && config_flag("--fov-y") == 1 &&
              config_flag("--threads") == 1,
          "value flags");
    CHECK(config_flag("--draco") == 2, "switch");
    CHECK(config_flag("--placement") == 1 && config_flag("--optimal-levels") == 1, "placement flags");
    CHECK(config_flag("--config") == 0 && config_flag("--quiet") == 0 &&
              config_flag("lod.levels") == 0 && config_flag("--flip-cos") == 0,
          "not config flags");

    CHECK(config_set(&c, "--levels", "0.5,2, 4 ,100", &err) == LP_OK, "%s", err.msg);
    CHECK(c.lod.level_count == 4 && c.lod.levels[0] == 0.5 && c.lod.levels[1] == 2 &&
              c.lod.levels[2] == 4 && c.lod.levels[3] == 100,
          "levels");
    CHECK(config_set(&c, "--levels", "5", &err) == LP_OK && c.lod.level_count == 1 &&
              c.lod.levels[0] == 5 && c.lod.levels[1] == 0,
          "one level; unused slots cleared");
    CHECK(config_set(&c, "--pixel-error", "2", &err) == LP_OK && c.switching.pixel_error == 2,
          "pixel error");
    CHECK(config_set(&c, "--viewport-height", "720", &err) == LP_OK &&
              c.switching.viewport_height == 720,
          "viewport");
    CHECK(config_set(&c, "--fov-y", "1.0471975511965976", &err) == LP_OK &&
              c.switching.fov_y == 1.0471975511965976,
          "fov");
    CHECK(config_set(&c, "--threads", "8", &err) == LP_OK && c.run.threads == 8, "threads");
    CHECK(config_set(&c, "--threads", "0", &err) == LP_OK && c.run.threads == 0, "threads 0");
    CHECK(config_set(&c, "--draco", "true", &err) == LP_OK && c.draco.enabled == 1, "draco");
    CHECK(config_set(&c, "--placement", "optimal", &err) == LP_OK && c.lod.placement == 1, "placement");
    CHECK(config_set(&c, "--placement", "half-edge", &err) == LP_OK && c.lod.placement == 0, "placement back");
    CHECK(config_set(&c, "--optimal-levels", "3, 4", &err) == LP_OK && c.lod.optimal_levels == 0xc, "optimal levels");
    CHECK(config_set(&c, "lod.optimal_levels", "", &err) == LP_OK && c.lod.optimal_levels == 0, "no optimal levels");
    /* Every key by its dotted name. */
    CHECK(config_set(&c, "lod.min_reduction", "0", &err) == LP_OK && c.lod.min_reduction == 0,
          "min_reduction");
    CHECK(config_set(&c, "lod.flip_cos", "-0.5", &err) == LP_OK && c.lod.flip_cos == -0.5,
          "flip_cos");
    CHECK(config_set(&c, "lod.levels", "1,2", &err) == LP_OK && c.lod.level_count == 2,
          "levels key");
    CHECK(config_set(&c, "draco.position_bits", "20", &err) == LP_OK &&
              c.draco.position_bits == 20,
          "position bits");
    CHECK(config_set(&c, "draco.normal_bits", "8", &err) == LP_OK && c.draco.normal_bits == 8,
          "normal bits");
    CHECK(config_set(&c, "draco.texcoord_bits", "10", &err) == LP_OK &&
              c.draco.texcoord_bits == 10,
          "texcoord bits");
    CHECK(config_set(&c, "draco.color_bits", "6", &err) == LP_OK && c.draco.color_bits == 6,
          "color bits");
    CHECK(config_set(&c, "draco.generic_bits", "14", &err) == LP_OK &&
              c.draco.generic_bits == 14,
          "generic bits");
    CHECK(config_set(&c, "draco.speed", "10", &err) == LP_OK && c.draco.speed == 10, "speed");
    CHECK(config_set(&c, "draco.fallback", "true", &err) == LP_OK && c.draco.fallback == 1,
          "fallback");
    CHECK(config_set(&c, "draco.enabled", "false", &err) == LP_OK && c.draco.enabled == 0,
          "enabled");
    CHECK(config_set(&c, "switching.pixel_error", "0.25", &err) == LP_OK &&
              c.switching.pixel_error == 0.25,
          "pixel error key");
    CHECK(config_set(&c, "run.threads", "64", &err) == LP_OK && c.run.threads == 64,
          "threads key");
}

typedef struct flag_error {
    const char *name, *text, *message; /* the whole expected message */
} flag_error;

static const flag_error kFlagErrors[] = {
    {"--levels", "1,3,3", "--levels 1,3,3: must be strictly increasing (3 follows 3)"},
    {"--levels", "7,3", "--levels 7,3: must be strictly increasing (3 follows 7)"},
    {"--levels", "0,1", "--levels 0,1: value 1 must be in (0, 100] percent of the diagonal, got 0"},
    {"--levels", "1,101", "--levels 1,101: value 2 must be in (0, 100] percent of the diagonal, got 101"},
    {"--levels", "", "--levels : expected comma-separated percentages of the diagonal, e.g. 1,3,7,15"},
    {"--levels", "1,,3", "--levels 1,,3: expected comma-separated percentages of the diagonal, e.g. 1,3,7,15"},
    {"--levels", "1,3,", "--levels 1,3,: expected comma-separated percentages of the diagonal, e.g. 1,3,7,15"},
    {"--levels", "1;3", "--levels 1;3: expected comma-separated percentages of the diagonal, e.g. 1,3,7,15"},
    {"--levels", "1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16,17", "--levels 1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16,17: must have 1 to 16 values"},
    {"--levels", "nan", "--levels nan: expected comma-separated percentages of the diagonal, e.g. 1,3,7,15"},
    {"--pixel-error", "0", "--pixel-error 0: must be > 0, got 0"},
    {"--pixel-error", "-1", "--pixel-error -1: must be > 0, got -1"},
    {"--pixel-error", "two", "--pixel-error two: must be a number"},
    {"--pixel-error", "2px", "--pixel-error 2px: must be a number"},
    {"--pixel-error", "inf", "--pixel-error inf: must be a number"},
    {"--pixel-error", "nan", "--pixel-error nan: must be a number"},
    {"--pixel-error", "0x10", "--pixel-error 0x10: must be a number"},
    {"--pixel-error", "1e", "--pixel-error 1e: must be a number"},
    {"--levels", "0x10", "--levels 0x10: expected comma-separated percentages of the diagonal, e.g. 1,3,7,15"},
    {"--levels", "1,inf", "--levels 1,inf: expected comma-separated percentages of the diagonal, e.g. 1,3,7,15"},
    {"--optimal-levels", "0x2", "--optimal-levels 0x2: expected comma-separated level numbers, e.g. 3,4"},
    {"--viewport-height", "0", "--viewport-height 0: must be > 0, got 0"},
    {"--viewport-height", "", "--viewport-height : must be a number"},
    {"--fov-y", "3.2", "--fov-y 3.2: must be in (0, pi) radians, got 3.2"},
    {"--fov-y", "0", "--fov-y 0: must be in (0, pi) radians, got 0"},
    {"--threads", "65", "--threads 65: must be in 0..64 (0 = one per core), got 65"},
    {"--threads", "-1", "--threads -1: must be in 0..64 (0 = one per core), got -1"},
    {"--threads", "2.5", "--threads 2.5: must be an integer in 0..64 (0 = one per core)"},
    {"--threads", "99999999999999999999", "--threads 99999999999999999999: must be an integer in 0..64 (0 = one per core)"},
    {"--draco", "yes", "--draco yes: must be true or false"},
    {"--placement", "Optimal", "--placement Optimal: must be \"half-edge\" or \"optimal\", got \"Optimal\""},
    {"--optimal-levels", "3;4", "--optimal-levels 3;4: expected comma-separated level numbers, e.g. 3,4"},
    {"--optimal-levels", "0", "--optimal-levels 0: must list level numbers in 1..16, got 0"},
    {"--optimal-levels", "1.5", "--optimal-levels 1.5: must list level numbers in 1..16, got 1.5"},
    {"draco.normal_bits", "1", "draco.normal_bits 1: must be in 2..30, got 1"},
    {"draco.speed", "11", "draco.speed 11: must be in 0..10, got 11"},
    {"lod.min_reduction", "1", "lod.min_reduction 1: must be in [0, 1), got 1"},
    {"--flip-cos", "0.5", "--flip-cos: unknown option or key"},
    {"lod.nope", "1", "lod.nope: unknown option or key"},
};

static void test_flag_errors(void)
{
    for (size_t i = 0; i < sizeof kFlagErrors / sizeof kFlagErrors[0]; ++i) {
        const flag_error *t = &kFlagErrors[i];
        lp_config c, d;
        lp_error err = {0, "", 0};
        config_defaults(&c);
        config_defaults(&d);
        int rc = config_set(&c, t->name, t->text, &err);
        CHECK(rc == LP_USAGE && err.code == LP_USAGE, "%s %s: rc %d", t->name, t->text, rc);
        CHECK(strcmp(err.msg, t->message) == 0, "got '%s', want '%s'", err.msg, t->message);
        CHECK(config_equal(&c, &d), "%s %s: changed the configuration", t->name, t->text);
    }
}

/* The rules between keys: lod.optimal_levels needs placement "optimal" and
 * may name only levels lod.levels has. */
static void test_config_check(void)
{
    lp_config c;
    lp_error err = {0, "", 0};
    config_defaults(&c);
    CHECK(config_check(&c, &err) == LP_OK, "the defaults pass: %s", err.msg);
    CHECK(config_set(&c, "--optimal-levels", "3,4", &err) == LP_OK, "set");
    CHECK(config_check(&c, &err) == LP_USAGE && strstr(err.msg, "applies only with lod.placement"), "half-edge: %s",
          err.msg);
    CHECK(config_set(&c, "--placement", "optimal", &err) == LP_OK, "set");
    CHECK(config_check(&c, &err) == LP_OK, "levels 3,4 of 4: %s", err.msg);
    CHECK(config_set(&c, "--levels", "1,3", &err) == LP_OK, "set");
    CHECK(config_check(&c, &err) == LP_USAGE &&
              strcmp(err.msg, "lod.optimal_levels (--optimal-levels) names level 3, but lod.levels has 2") == 0,
          "levels 3,4 of 2: %s", err.msg);
    CHECK(config_set(&c, "--optimal-levels", "2", &err) == LP_OK && config_check(&c, &err) == LP_OK, "level 2 of 2: %s",
          err.msg);

    /* which rule, and where a file breaks it: the line of the last of its keys */
    CHECK(config_broken_rule(&c, NULL) == CONFIG_RULE_NONE, "no rule broken");
    CHECK(config_set(&c, "--pixel-error", "2000", &err) == LP_OK, "set");
    CHECK(config_broken_rule(&c, &err) == CONFIG_RULE_PIXEL_BELOW_HEIGHT && strstr(err.msg, "every node would be culled") &&
              config_breaks(&c, CONFIG_RULE_PIXEL_BELOW_HEIGHT) && !config_breaks(&c, CONFIG_RULE_OPTIMAL_LEVELS_EXIST),
          "pixel error above the height: %s", err.msg);
    char path[64];
    if (write_temp("[switching]\nviewport_height = 720\n\n[lod]\nlevels = [1, 3]\n\n[switching.x]\n", path) == 0) {
        CHECK(config_rule_line(path, CONFIG_RULE_PIXEL_BELOW_HEIGHT) == 2, "viewport_height on line 2: %u",
              config_rule_line(path, CONFIG_RULE_PIXEL_BELOW_HEIGHT));
        CHECK(config_rule_line(path, CONFIG_RULE_OPTIMAL_LEVELS_EXIST) == 5, "levels on line 5: %u",
              config_rule_line(path, CONFIG_RULE_OPTIMAL_LEVELS_EXIST));
        CHECK(config_rule_line(path, CONFIG_RULE_OPTIMAL_NEEDS_PLACEMENT) == 0, "neither key set: %u",
              config_rule_line(path, CONFIG_RULE_OPTIMAL_NEEDS_PLACEMENT));
        unlink(path);
    }
    CHECK(config_rule_line("/nonexistent/pipeline.toml", CONFIG_RULE_PIXEL_BELOW_HEIGHT) == 0, "unreadable: 0");
}

/* ---- canonical text --------------------------------------------------------- */

static const char kDefaultToml[] =
    "[lod]\n"
    "levels = [1, 3, 7, 15]\n"
    "min_reduction = 0.1\n"
    "flip_cos = 0.25\n"
    "strict_intersections = false\n"
    "placement = \"half-edge\"\n"
    "optimal_levels = []\n"
    "\n"
    "[switching]\n"
    "pixel_error = 1\n"
    "viewport_height = 1080\n"
    "fov_y = 0.7853981633974483\n"
    "\n"
    "[run]\n"
    "threads = 0\n"
    "\n"
    "[draco]\n"
    "enabled = false\n"
    "position_bits = 14\n"
    "normal_bits = 10\n"
    "texcoord_bits = 12\n"
    "color_bits = 8\n"
    "generic_bits = 12\n"
    "speed = 5\n"
    "fallback = false\n";

static const char kDefaultJson[] =
    "{\"lod\":{\"levels\":[1, 3, 7, 15],\"min_reduction\":0.1,\"flip_cos\":0.25,\"strict_intersections\":false,\"placement\":\"half-edge\",\"optimal_levels\":[]},"
    "\"switching\":{\"pixel_error\":1,\"viewport_height\":1080,\"fov_y\":0.7853981633974483},"
    "\"run\":{\"threads\":0},"
    "\"draco\":{\"enabled\":false,\"position_bits\":14,\"normal_bits\":10,\"texcoord_bits\":12,"
    "\"color_bits\":8,\"generic_bits\":12,\"speed\":5,\"fallback\":false}}\n";

static void test_canonical_text_of_defaults(void)
{
    lp_config c;
    config_defaults(&c);
    char *t = canonical(&c, CONFIG_TOML), *j = canonical(&c, CONFIG_JSON);
    CHECK(t && strcmp(t, kDefaultToml) == 0, "TOML:\n%s", t ? t : "(null)");
    CHECK(j && strcmp(j, kDefaultJson) == 0, "JSON:\n%s", j ? j : "(null)");
    /* snprintf contract: size query, truncation, terminator. */
    char small[10];
    size_t n = config_write(&c, CONFIG_TOML, small, sizeof small);
    CHECK(n == strlen(kDefaultToml), "%zu", n);
    CHECK(strcmp(small, "[lod]\nlev") == 0, "truncated: %s", small);
    free(t);
    free(j);
}

/* Each change to one key, from defaults. */
static const char *const kChanges[][2] = {
    {"lod.levels", "1,3,7"},          {"lod.levels", "1,3,7,15.000000000000002"},
    {"lod.min_reduction", "0.10000000000000002"}, {"lod.flip_cos", "0.3"},
    {"lod.placement", "optimal"},     {"lod.optimal_levels", "16"},
    {"switching.pixel_error", "1.5"}, {"switching.viewport_height", "1081"},
    {"switching.fov_y", "0.78539816339744839"},   {"run.threads", "1"},
    {"draco.enabled", "true"},        {"draco.position_bits", "15"},
    {"draco.normal_bits", "11"},      {"draco.texcoord_bits", "13"},
    {"draco.color_bits", "9"},        {"draco.generic_bits", "13"},
    {"draco.speed", "6"},             {"draco.fallback", "true"},
};

static void test_canonical_text_identity(void)
{
    lp_config a, b;
    lp_error err;
    config_defaults(&a);
    config_defaults(&b);
    /* Equal configs reached differently give identical text. */
    CHECK(config_set(&b, "--levels", "2", &err) == LP_OK, "%s", err.msg);
    CHECK(config_set(&b, "--levels", "1,3,7,15", &err) == LP_OK, "%s", err.msg);
    CHECK(config_set(&b, "lod.flip_cos", "-0", &err) == LP_OK, "%s", err.msg);
    CHECK(config_set(&b, "lod.flip_cos", "0.25", &err) == LP_OK, "%s", err.msg);
    for (int f = 0; f < 2; ++f) {
        char *ta = canonical(&a, (config_format)f), *tb = canonical(&b, (config_format)f);
        CHECK(ta && tb && strcmp(ta, tb) == 0, "equal configs, different text");
        free(ta);
        free(tb);
    }
    /* -0 and +0 are the same value and the same text. */
    config_set(&a, "lod.flip_cos", "-0.0", &err);
    config_set(&b, "lod.flip_cos", "0", &err);
    CHECK(config_equal(&a, &b), "-0 vs 0");
    char *za = canonical(&a, CONFIG_TOML), *zb = canonical(&b, CONFIG_TOML);
    CHECK(za && zb && strcmp(za, zb) == 0 && strstr(za, "flip_cos = 0\n"), "-0 text");
    free(za);
    free(zb);

    /* Any single change gives different text, in both formats, and the TOML
     * text loads back to an equal configuration. */
    lp_config d;
    config_defaults(&d);
    char *dt = canonical(&d, CONFIG_TOML), *dj = canonical(&d, CONFIG_JSON);
    for (size_t i = 0; i < sizeof kChanges / sizeof kChanges[0]; ++i) {
        lp_config c;
        config_defaults(&c);
        int rc = config_set(&c, kChanges[i][0], kChanges[i][1], &err);
        CHECK(rc == LP_OK, "%s %s: %s", kChanges[i][0], kChanges[i][1], err.msg);
        CHECK(!config_equal(&c, &d), "%s: equal to defaults", kChanges[i][0]);
        char *t = canonical(&c, CONFIG_TOML), *j = canonical(&c, CONFIG_JSON);
        CHECK(t && dt && strcmp(t, dt) != 0, "%s: same TOML text", kChanges[i][0]);
        CHECK(j && dj && strcmp(j, dj) != 0, "%s: same JSON text", kChanges[i][0]);
        lp_config back;
        lp_error lerr;
        CHECK(t && load_text(t, &back, &lerr, NULL) == LP_OK, "%s: reload: %s", kChanges[i][0],
              lerr.msg);
        CHECK(config_equal(&back, &c), "%s: reload differs", kChanges[i][0]);
        free(t);
        free(j);
    }
    free(dt);
    free(dj);
}

int main(void)
{
    RUN(test_defaults);
    RUN(test_repo_file_equals_defaults);
    RUN(test_toml_io_entries);
    RUN(test_each_key_from_file);
    RUN(test_all_keys_in_one_file);
    RUN(test_file_errors);
    RUN(test_missing_file);
    RUN(test_failed_load_keeps_previous_values);
    RUN(test_flags);
    RUN(test_flag_errors);
    RUN(test_config_check);
    RUN(test_canonical_text_of_defaults);
    RUN(test_canonical_text_identity);
    return check_summary();
}
