/* config.c - see config.h.
 *
 * One table (kKeys) describes every key: its dotted name, its CLI flag, its
 * kind, where it lives in lp_config and its range. Loading, config_set, the
 * canonical writer and config_equal all walk that table, so a new key is one
 * line here plus its field and its line in pipeline.toml. */
#include "config.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "simplify.h"
#include "toml_io/toml_io.h"

_Static_assert(LP_CONFIG_MAX_LEVELS <= SIMPLIFY_MAX_LEVELS,
               "every configured level must fit the simplifier's ladder");

typedef enum key_kind {
    KIND_LEVELS,  /* lod.levels: array of percentages */
    KIND_NUMBER,  /* double */
    KIND_INTEGER, /* int */
    KIND_BOOLEAN, /* int, 0 or 1 */
    KIND_CHOICE,  /* int: index into the key's choices (a string in the file) */
    KIND_LEVEL_SET /* uint32_t: bit k-1 for ladder level k (an array of level numbers) */
} key_kind;

typedef struct key_spec {
    const char *key;   /* "table.name" */
    const char *flag;  /* CLI flag, or NULL */
    key_kind kind;
    size_t offset;     /* of the field in lp_config */
    double lo, hi;     /* NUMBER and INTEGER: the range ... */
    int lo_open, hi_open; /* ... with open or closed ends */
    const char *range; /* how the range reads in a message */
    const char *const *choices; /* KIND_CHOICE: the strings, NULL-terminated */
} key_spec;

static const char *const kPlacements[] = {"half-edge", "optimal", NULL};

#define PI_ 3.14159265358979323846

/* The schema, in canonical order (the order of pipeline.toml). Tables are
 * contiguous; a table's name is the part of the key before the dot. */
static const key_spec kKeys[] = {
    {"lod.levels", "--levels", KIND_LEVELS, offsetof(lp_config, lod.levels), 0, 100, 1, 0,
     "(0, 100]", NULL},
    {"lod.min_reduction", NULL, KIND_NUMBER, offsetof(lp_config, lod.min_reduction), 0, 1, 0, 1,
     "in [0, 1)", NULL},
    {"lod.flip_cos", NULL, KIND_NUMBER, offsetof(lp_config, lod.flip_cos), -1, 1, 0, 1,
     "in [-1, 1)", NULL},
    {"lod.strict_intersections", NULL, KIND_BOOLEAN, offsetof(lp_config, lod.strict_intersections), 0, 1, 0, 0,
     NULL, NULL},
    {"lod.placement", "--placement", KIND_CHOICE, offsetof(lp_config, lod.placement), 0, 0, 0, 0,
     "\"half-edge\" or \"optimal\"", kPlacements},
    {"lod.optimal_levels", "--optimal-levels", KIND_LEVEL_SET, offsetof(lp_config, lod.optimal_levels), 1,
     LP_CONFIG_MAX_LEVELS, 0, 0, "level numbers in 1..16", NULL},
    {"switching.pixel_error", "--pixel-error", KIND_NUMBER,
     offsetof(lp_config, switching.pixel_error), 0, INFINITY, 1, 1, "> 0", NULL},
    {"switching.viewport_height", "--viewport-height", KIND_NUMBER,
     offsetof(lp_config, switching.viewport_height), 0, INFINITY, 1, 1, "> 0", NULL},
    {"switching.fov_y", "--fov-y", KIND_NUMBER, offsetof(lp_config, switching.fov_y), 0, PI_, 1,
     1, "in (0, pi) radians", NULL},
    {"run.threads", "--threads", KIND_INTEGER, offsetof(lp_config, run.threads), 0, 64, 0, 0,
     "in 0..64 (0 = one per core)", NULL},
    {"draco.enabled", "--draco", KIND_BOOLEAN, offsetof(lp_config, draco.enabled), 0, 1, 0, 0,
     NULL, NULL},
    {"draco.position_bits", NULL, KIND_INTEGER, offsetof(lp_config, draco.position_bits), 1, 30,
     0, 0, "in 1..30", NULL},
    {"draco.normal_bits", NULL, KIND_INTEGER, offsetof(lp_config, draco.normal_bits), 2, 30, 0, 0,
     "in 2..30", NULL},
    {"draco.texcoord_bits", NULL, KIND_INTEGER, offsetof(lp_config, draco.texcoord_bits), 1, 30,
     0, 0, "in 1..30", NULL},
    {"draco.color_bits", NULL, KIND_INTEGER, offsetof(lp_config, draco.color_bits), 1, 30, 0, 0,
     "in 1..30", NULL},
    {"draco.generic_bits", NULL, KIND_INTEGER, offsetof(lp_config, draco.generic_bits), 1, 30, 0,
     0, "in 1..30", NULL},
    {"draco.speed", NULL, KIND_INTEGER, offsetof(lp_config, draco.speed), 0, 10, 0, 0,
     "in 0..10", NULL},
    {"draco.fallback", NULL, KIND_BOOLEAN, offsetof(lp_config, draco.fallback), 0, 1, 0, 0, NULL, NULL},
};
#define KEY_COUNT (sizeof kKeys / sizeof kKeys[0])

void config_defaults(lp_config *c)
{
    static const double levels[] = {1, 3, 7, 15};
    memset(c, 0, sizeof *c);
    c->lod.level_count = sizeof levels / sizeof levels[0];
    memcpy(c->lod.levels, levels, sizeof levels);
    c->lod.min_reduction = 0.10;
    c->lod.flip_cos = 0.25;
    c->lod.strict_intersections = 0;
    c->lod.placement = 0;
    c->lod.optimal_levels = 0;
    c->switching.pixel_error = 1.0;
    c->switching.viewport_height = 1080;
    c->switching.fov_y = 0.7853981633974483; /* pi / 4 */
    c->run.threads = 0;
    c->draco.enabled = 0;
    c->draco.position_bits = 14;
    c->draco.normal_bits = 10;
    c->draco.texcoord_bits = 12;
    c->draco.color_bits = 8;
    c->draco.generic_bits = 12;
    c->draco.speed = 5;
    c->draco.fallback = 0;
}

/* ---- small helpers -------------------------------------------------------- */

static double *number_field(lp_config *c, const key_spec *k)
{
    return (double *)((char *)c + k->offset);
}

static int *int_field(lp_config *c, const key_spec *k)
{
    return (int *)((char *)c + k->offset);
}

static uint32_t *set_field(lp_config *c, const key_spec *k)
{
    return (uint32_t *)((char *)c + k->offset);
}

/* v as text that reads back to exactly v: whole numbers below 2^53 as
 * integers ("1080"), others in the shortest "%.Ng" ("0.1", "1e-05"); -0 is
 * written as 0. Valid in TOML and JSON alike (v is finite). */
static void format_number(char *out, size_t n, double v)
{
    if (v == 0) v = 0; /* -0 -> +0 */
    if (v == floor(v) && fabs(v) < 9007199254740992.0) {
        snprintf(out, n, "%.0f", v);
        return;
    }
    for (int precision = 1; precision <= 17; ++precision) {
        snprintf(out, n, "%.*g", precision, v);
        if (strtod(out, NULL) == v) return;
    }
    snprintf(out, n, "%.17g", v);
}

/* The index of text among k's choices, or -1 with a problem. */
static int find_choice(const key_spec *k, const char *text, char *problem, size_t n)
{
    for (int i = 0; k->choices[i]; ++i)
        if (strcmp(k->choices[i], text) == 0) return i;
    snprintf(problem, n, "must be %s, got \"%.60s\"", k->range, text);
    return -1;
}

/* Adds level number v to *set, or returns -1 with a problem. */
static int add_level_number(const key_spec *k, double v, uint32_t *set, char *problem, size_t n)
{
    char got[40];
    format_number(got, sizeof got, v);
    if (!(v >= k->lo && v <= k->hi) || v != floor(v)) {
        snprintf(problem, n, "must list %s, got %s", k->range, got);
        return -1;
    }
    *set |= 1u << ((unsigned)v - 1u);
    return 0;
}

/* Length of the table part of a dotted key ("lod" in "lod.levels"). */
static size_t table_length(const char *key)
{
    const char *dot = strchr(key, '.');
    return dot ? (size_t)(dot - key) : strlen(key);
}

static const key_spec *find_key(const char *key)
{
    for (size_t i = 0; i < KEY_COUNT; ++i)
        if (strcmp(kKeys[i].key, key) == 0) return &kKeys[i];
    return NULL;
}

static const key_spec *find_name(const char *name)
{
    for (size_t i = 0; i < KEY_COUNT; ++i)
        if ((kKeys[i].flag && strcmp(kKeys[i].flag, name) == 0) || strcmp(kKeys[i].key, name) == 0)
            return &kKeys[i];
    return NULL;
}

static int is_table(const char *name, size_t len)
{
    for (size_t i = 0; i < KEY_COUNT; ++i)
        if (table_length(kKeys[i].key) == len && strncmp(kKeys[i].key, name, len) == 0) return 1;
    return 0;
}

/* ---- validation: one function per kind, shared by the file and the flags --
 * Each returns 0, or -1 with a phrase in `problem` ("must be > 0, got 0"). */

static int check_number(const key_spec *k, double v, char *problem, size_t n)
{
    char got[40];
    format_number(got, sizeof got, v);
    if (!isfinite(v)) {
        snprintf(problem, n, "must be a finite number %s, got %s", k->range, got);
        return -1;
    }
    int below = k->lo_open ? !(v > k->lo) : !(v >= k->lo);
    int above = k->hi_open ? !(v < k->hi) : !(v <= k->hi);
    if (below || above) {
        snprintf(problem, n, "must be %s, got %s", k->range, got);
        return -1;
    }
    return 0;
}

static int check_integer(const key_spec *k, int64_t v, char *problem, size_t n)
{
    if ((double)v < k->lo || (double)v > k->hi) {
        snprintf(problem, n, "must be %s, got %lld", k->range, (long long)v);
        return -1;
    }
    return 0;
}

static int check_levels(const key_spec *k, const double *v, size_t count, char *problem,
                        size_t n)
{
    if (count < 1 || count > LP_CONFIG_MAX_LEVELS) {
        snprintf(problem, n, "must have 1 to %d values, got %zu", LP_CONFIG_MAX_LEVELS, count);
        return -1;
    }
    for (size_t i = 0; i < count; ++i) {
        if (!(v[i] > 0 && v[i] <= 100)) { /* also rejects NaN */
            char got[40];
            format_number(got, sizeof got, v[i]);
            snprintf(problem, n, "value %zu must be in %s percent of the diagonal, got %s", i + 1,
                     k->range, got);
            return -1;
        }
        if (i > 0 && !(v[i] > v[i - 1])) {
            char a[40], b[40];
            format_number(a, sizeof a, v[i]);
            format_number(b, sizeof b, v[i - 1]);
            snprintf(problem, n, "must be strictly increasing (%s follows %s)", a, b);
            return -1;
        }
    }
    return 0;
}

static void store_levels(lp_config *c, const double *v, size_t count)
{
    memset(c->lod.levels, 0, sizeof c->lod.levels);
    for (size_t i = 0; i < count; ++i) c->lod.levels[i] = v[i];
    c->lod.level_count = count;
}

/* ---- the file ------------------------------------------------------------- */

/* The type with its article, as it reads after "not". */
static const char *type_name(toml_io_type t)
{
    switch (t) {
    case TOML_IO_INTEGER: return "an integer";
    case TOML_IO_FLOAT: return "a float";
    case TOML_IO_BOOLEAN: return "a boolean";
    case TOML_IO_STRING: return "a string";
    case TOML_IO_ARRAY: return "an array";
    case TOML_IO_TABLE: return "a table";
    default: return "a date/time";
    }
}

/* "did you mean run.threads?" when another table has a key of that name, else
 * the table's known keys. */
static void unknown_key_problem(const char *key, char *problem, size_t n)
{
    const char *leaf = strrchr(key, '.');
    leaf = leaf ? leaf + 1 : key;
    for (size_t i = 0; i < KEY_COUNT; ++i) {
        const char *known_leaf = kKeys[i].key + table_length(kKeys[i].key) + 1;
        if (strcmp(known_leaf, leaf) == 0) {
            snprintf(problem, n, "unknown key; did you mean %s?", kKeys[i].key);
            return;
        }
    }
    size_t tlen = strchr(key, '.') ? table_length(key) : 0;
    if (!tlen || !is_table(key, tlen)) {
        snprintf(problem, n, "unknown key (keys belong in [lod], [switching], [run] or [draco])");
        return;
    }
    size_t used = (size_t)snprintf(problem, n, "unknown key (known in [%.*s]:", (int)tlen, key);
    const char *sep = " ";
    for (size_t i = 0; i < KEY_COUNT && used < n; ++i) {
        if (table_length(kKeys[i].key) != tlen || strncmp(kKeys[i].key, key, tlen) != 0) continue;
        used += (size_t)snprintf(problem + used, n - used, "%s%s", sep, kKeys[i].key + tlen + 1);
        sep = ", ";
    }
    if (used < n) snprintf(problem + used, n - used, ")");
}

/* Applies one entry of the file to c, or returns -1 with a problem. */
static int apply_entry(lp_config *c, const toml_io_entry *e, char *problem, size_t n)
{
    const toml_io_value *v = &e->value;
    if (!strchr(e->key, '.')) { /* a top-level name: must be one of our tables */
        if (is_table(e->key, strlen(e->key))) {
            if (v->type == TOML_IO_TABLE) return 0;
            snprintf(problem, n, "must be a table, not %s", type_name(v->type));
            return -1;
        }
        if (v->type == TOML_IO_TABLE) {
            snprintf(problem, n, "unknown table (known: lod, switching, run, draco)");
            return -1;
        }
        unknown_key_problem(e->key, problem, n);
        return -1;
    }
    const key_spec *k = find_key(e->key);
    if (!k && v->type == TOML_IO_TABLE) {
        snprintf(problem, n, "unknown table (lodpipe's tables do not nest)");
        return -1;
    }
    if (!k) {
        unknown_key_problem(e->key, problem, n);
        return -1;
    }
    switch (k->kind) {
    case KIND_LEVELS: {
        if (v->type != TOML_IO_ARRAY) {
            snprintf(problem, n, "must be an array of numbers, not %s", type_name(v->type));
            return -1;
        }
        double levels[LP_CONFIG_MAX_LEVELS];
        if (e->element_count < 1 || e->element_count > LP_CONFIG_MAX_LEVELS)
            return check_levels(k, levels, e->element_count, problem, n);
        for (size_t i = 0; i < e->element_count; ++i) {
            const toml_io_value *el = &e->elements[i];
            if (el->type != TOML_IO_INTEGER && el->type != TOML_IO_FLOAT) {
                snprintf(problem, n, "value %zu must be a number, not %s", i + 1,
                         type_name(el->type));
                return -1;
            }
            levels[i] = el->number;
        }
        if (check_levels(k, levels, e->element_count, problem, n)) return -1;
        store_levels(c, levels, e->element_count);
        return 0;
    }
    case KIND_NUMBER:
        if (v->type != TOML_IO_INTEGER && v->type != TOML_IO_FLOAT) {
            snprintf(problem, n, "must be a number, not %s", type_name(v->type));
            return -1;
        }
        if (check_number(k, v->number, problem, n)) return -1;
        *number_field(c, k) = v->number == 0 ? 0.0 : v->number;
        return 0;
    case KIND_INTEGER:
        if (v->type != TOML_IO_INTEGER) {
            snprintf(problem, n, "must be an integer, not %s", type_name(v->type));
            return -1;
        }
        if (check_integer(k, v->integer, problem, n)) return -1;
        *int_field(c, k) = (int)v->integer;
        return 0;
    case KIND_BOOLEAN:
        if (v->type != TOML_IO_BOOLEAN) {
            snprintf(problem, n, "must be true or false, not %s", type_name(v->type));
            return -1;
        }
        *int_field(c, k) = v->boolean ? 1 : 0;
        return 0;
    case KIND_CHOICE: {
        if (v->type != TOML_IO_STRING) {
            snprintf(problem, n, "must be a string (%s), not %s", k->range, type_name(v->type));
            return -1;
        }
        int i = find_choice(k, v->string, problem, n);
        if (i < 0) return -1;
        *int_field(c, k) = i;
        return 0;
    }
    case KIND_LEVEL_SET: {
        if (v->type != TOML_IO_ARRAY) {
            snprintf(problem, n, "must be an array of %s, not %s", k->range, type_name(v->type));
            return -1;
        }
        uint32_t set = 0;
        for (size_t i = 0; i < e->element_count; ++i) {
            const toml_io_value *el = &e->elements[i];
            if (el->type != TOML_IO_INTEGER) {
                snprintf(problem, n, "value %zu must be an integer level number, not %s", i + 1, type_name(el->type));
                return -1;
            }
            if (add_level_number(k, (double)el->integer, &set, problem, n)) return -1;
        }
        *set_field(c, k) = set;
        return 0;
    }
    }
    return 0;
}

int config_load(lp_config *config, const char *path, lp_error *err)
{
    char why[400];
    toml_io_doc *doc = NULL;
    int rc = toml_io_parse_file(path, &doc, why, sizeof why);
    if (rc == TOML_IO_READ) return lp_fail(err, LP_IO, "%.200s: cannot read: %s", path, why);
    if (rc == TOML_IO_NOMEM) return lp_fail(err, LP_IO, "%.200s: %s", path, why);
    if (rc != TOML_IO_OK) return lp_fail(err, LP_USAGE, "%.200s: %s", path, why);

    lp_config next = *config; /* committed only when every entry is valid */
    size_t count = toml_io_count(doc);
    for (size_t i = 0; i < count; ++i) {
        toml_io_entry e;
        char problem[300];
        toml_io_get(doc, i, &e);
        if (apply_entry(&next, &e, problem, sizeof problem)) {
            rc = lp_fail(err, LP_USAGE, "%.150s:%u: %.100s: %s", path, (unsigned)e.line, e.key,
                         problem);
            toml_io_free(doc);
            return rc;
        }
    }
    toml_io_free(doc);
    *config = next;
    return LP_OK;
}

/* ---- flags ---------------------------------------------------------------- */

/* A decimal number at p after any spaces ([+-] digits [. digits] [e [+-] digits], as TOML
 * writes them), its end in *end; 0, or -1 when p holds none. strtod alone
 * would also take "0x10", "inf" and "nan". */
static int scan_decimal(const char *p, char **end, double *out)
{
    while (*p == ' ') ++p;
    const char *q = p;
    if (*q == '+' || *q == '-') ++q;
    size_t digits = 0;
    while (*q >= '0' && *q <= '9') ++q, ++digits;
    if (*q == '.') {
        ++q;
        while (*q >= '0' && *q <= '9') ++q, ++digits;
    }
    if (!digits) return -1;
    if (*q == 'e' || *q == 'E') {
        const char *e = q + 1;
        if (*e == '+' || *e == '-') ++e;
        if (*e < '0' || *e > '9') return -1;
        while (*e >= '0' && *e <= '9') ++e;
        q = e;
    }
    char *stop;
    *out = strtod(p, &stop);
    if (stop != q) return -1;
    *end = stop;
    return 0;
}

/* Whole-text parses; each returns 0 or -1. */
static int parse_double(const char *text, double *out)
{
    char *end;
    errno = 0;
    double v;
    if (scan_decimal(text, &end, &v)) return -1;
    while (*end == ' ') ++end;
    if (*end) return -1;
    *out = v;
    return 0;
}

static int parse_int64(const char *text, int64_t *out)
{
    char *end;
    errno = 0;
    long long v = strtoll(text, &end, 10);
    if (end == text || errno == ERANGE) return -1;
    while (*end == ' ') ++end;
    if (*end) return -1;
    *out = (int64_t)v;
    return 0;
}

int config_flag(const char *flag)
{
    for (size_t i = 0; i < KEY_COUNT; ++i)
        if (kKeys[i].flag && strcmp(kKeys[i].flag, flag) == 0)
            return kKeys[i].kind == KIND_BOOLEAN ? 2 : 1;
    return 0;
}

int config_set(lp_config *config, const char *name, const char *text, lp_error *err)
{
    const key_spec *k = find_name(name);
    char problem[300];
    if (!k) return lp_fail(err, LP_USAGE, "%.100s: unknown option or key", name);
    if (!text) text = "";
    switch (k->kind) {
    case KIND_LEVELS: {
        double levels[LP_CONFIG_MAX_LEVELS];
        size_t count = 0;
        const char *p = text;
        for (;;) {
            char *end;
            double v;
            if (scan_decimal(p, &end, &v)) {
                snprintf(problem, sizeof problem,
                         "expected comma-separated percentages of the diagonal, e.g. 1,3,7,15");
                goto fail;
            }
            if (count == LP_CONFIG_MAX_LEVELS) {
                snprintf(problem, sizeof problem, "must have 1 to %d values",
                         LP_CONFIG_MAX_LEVELS);
                goto fail;
            }
            levels[count++] = v;
            p = end;
            while (*p == ' ') ++p;
            if (*p == '\0') break;
            if (*p != ',') {
                snprintf(problem, sizeof problem,
                         "expected comma-separated percentages of the diagonal, e.g. 1,3,7,15");
                goto fail;
            }
            ++p;
        }
        if (check_levels(k, levels, count, problem, sizeof problem)) goto fail;
        store_levels(config, levels, count);
        return LP_OK;
    }
    case KIND_NUMBER: {
        double v;
        if (parse_double(text, &v)) {
            snprintf(problem, sizeof problem, "must be a number");
            goto fail;
        }
        if (check_number(k, v, problem, sizeof problem)) goto fail;
        *number_field(config, k) = v == 0 ? 0.0 : v;
        return LP_OK;
    }
    case KIND_INTEGER: {
        int64_t v;
        if (parse_int64(text, &v)) {
            snprintf(problem, sizeof problem, "must be an integer %s", k->range);
            goto fail;
        }
        if (check_integer(k, v, problem, sizeof problem)) goto fail;
        *int_field(config, k) = (int)v;
        return LP_OK;
    }
    case KIND_BOOLEAN:
        if (strcmp(text, "true") == 0) *int_field(config, k) = 1;
        else if (strcmp(text, "false") == 0) *int_field(config, k) = 0;
        else {
            snprintf(problem, sizeof problem, "must be true or false");
            goto fail;
        }
        return LP_OK;
    case KIND_CHOICE: {
        int i = find_choice(k, text, problem, sizeof problem);
        if (i < 0) goto fail;
        *int_field(config, k) = i;
        return LP_OK;
    }
    case KIND_LEVEL_SET: {
        uint32_t set = 0;
        const char *p = text;
        while (*p == ' ') ++p;
        while (*p) { /* "" is the empty set */
            char *end;
            double v;
            if (scan_decimal(p, &end, &v)) {
                snprintf(problem, sizeof problem, "expected comma-separated level numbers, e.g. 3,4");
                goto fail;
            }
            if (add_level_number(k, v, &set, problem, sizeof problem)) goto fail;
            p = end;
            while (*p == ' ') ++p;
            if (*p == ',') ++p;
            else if (*p) {
                snprintf(problem, sizeof problem, "expected comma-separated level numbers, e.g. 3,4");
                goto fail;
            }
        }
        *set_field(config, k) = set;
        return LP_OK;
    }
    }
    return LP_OK;
fail:
    return lp_fail(err, LP_USAGE, "%.100s %.100s: %s", name, text, problem);
}

/* The keys each rule is about, for config_rule_line (NULL-terminated). */
static const char *const kRuleKeys[][4] = {
    [CONFIG_RULE_NONE] = {NULL},
    [CONFIG_RULE_OPTIMAL_NEEDS_PLACEMENT] = {"lod.optimal_levels", "lod.placement", NULL},
    [CONFIG_RULE_OPTIMAL_LEVELS_EXIST] = {"lod.optimal_levels", "lod.levels", NULL},
    [CONFIG_RULE_PIXEL_BELOW_HEIGHT] = {"switching.pixel_error", "switching.viewport_height", NULL},
    [CONFIG_RULE_CAMERA_FINITE] = {"switching.viewport_height", "switching.fov_y", "switching.pixel_error", NULL},
};

/* 1 when config breaks `rule`, its message then in err (when not NULL). */
static int rule_broken(const lp_config *config, config_rule rule, lp_error *err)
{
    lp_error ignored;
    if (!err) err = &ignored;
    const uint32_t set = config->lod.optimal_levels;
    const double p = config->switching.pixel_error, h = config->switching.viewport_height;
    switch (rule) {
    case CONFIG_RULE_NONE:
    case CONFIG_RULE_COUNT:
        return 0;
    case CONFIG_RULE_OPTIMAL_NEEDS_PLACEMENT:
        if (!set || config->lod.placement == 1) return 0;
        lp_fail(err, LP_USAGE, "lod.optimal_levels (--optimal-levels) applies only with lod.placement = "
                               "\"optimal\" (--placement optimal)");
        return 1;
    case CONFIG_RULE_OPTIMAL_LEVELS_EXIST:
        for (uint32_t k = (uint32_t)config->lod.level_count; k < 32; ++k)
            if (set >> k & 1u) {
                lp_fail(err, LP_USAGE, "lod.optimal_levels (--optimal-levels) names level %u, but lod.levels has %zu",
                        k + 1, config->lod.level_count);
                return 1;
            }
        return 0;
    /* the camera must give every level a finite switching distance and a
     * cull coverage below 1 (switching.h), or the written thresholds would
     * not run from the finest level to the coarsest */
    case CONFIG_RULE_PIXEL_BELOW_HEIGHT:
        if (p < h) return 0;
        lp_fail(err, LP_USAGE, "switching.pixel_error (--pixel-error) %g must be below switching.viewport_height "
                               "(--viewport-height) %g: every node would be culled", p, h);
        return 1;
    case CONFIG_RULE_CAMERA_FINITE:
        if (h / (2.0 * tan(config->switching.fov_y / 2.0) * p) <= SWITCHING_MAX_DISTANCE_PER_ERROR) return 0;
        lp_fail(err, LP_USAGE, "switching.viewport_height (--viewport-height) %g with switching.fov_y (--fov-y) "
                               "%g and switching.pixel_error (--pixel-error) %g puts the switching distance "
                               "beyond %g times a level's error",
                h, config->switching.fov_y, p, SWITCHING_MAX_DISTANCE_PER_ERROR);
        return 1;
    }
    return 0;
}

config_rule config_broken_rule(const lp_config *config, lp_error *err)
{
    for (int r = CONFIG_RULE_NONE + 1; r < CONFIG_RULE_COUNT; ++r)
        if (rule_broken(config, (config_rule)r, err)) return (config_rule)r;
    return CONFIG_RULE_NONE;
}

int config_breaks(const lp_config *config, config_rule rule)
{
    return rule_broken(config, rule, NULL);
}

int config_check(const lp_config *config, lp_error *err)
{
    return config_broken_rule(config, err) == CONFIG_RULE_NONE ? LP_OK : LP_USAGE;
}

uint32_t config_rule_line(const char *path, config_rule rule)
{
    char why[400];
    toml_io_doc *doc = NULL;
    if ((unsigned)rule >= CONFIG_RULE_COUNT || toml_io_parse_file(path, &doc, why, sizeof why) != TOML_IO_OK) return 0;
    uint32_t line = 0;
    const size_t count = toml_io_count(doc);
    for (size_t i = 0; i < count; ++i) {
        toml_io_entry e;
        toml_io_get(doc, i, &e);
        for (const char *const *key = kRuleKeys[rule]; *key; ++key)
            if (strcmp(e.key, *key) == 0 && e.line > line) line = e.line;
    }
    toml_io_free(doc);
    return line;
}

/* ---- comparing and writing ------------------------------------------------ */

int config_equal(const lp_config *a, const lp_config *b)
{
    for (size_t i = 0; i < KEY_COUNT; ++i) {
        const key_spec *k = &kKeys[i];
        switch (k->kind) {
        case KIND_LEVELS:
            if (a->lod.level_count != b->lod.level_count) return 0;
            for (size_t j = 0; j < a->lod.level_count && j < LP_CONFIG_MAX_LEVELS; ++j)
                if (a->lod.levels[j] != b->lod.levels[j]) return 0;
            break;
        case KIND_NUMBER:
            if (*number_field((lp_config *)a, k) != *number_field((lp_config *)b, k)) return 0;
            break;
        case KIND_INTEGER:
        case KIND_CHOICE:
            if (*int_field((lp_config *)a, k) != *int_field((lp_config *)b, k)) return 0;
            break;
        case KIND_LEVEL_SET:
            if (*set_field((lp_config *)a, k) != *set_field((lp_config *)b, k)) return 0;
            break;
        case KIND_BOOLEAN:
            if (!*int_field((lp_config *)a, k) != !*int_field((lp_config *)b, k)) return 0;
            break;
        }
    }
    return 1;
}

/* An snprintf-style appender: counts every byte, stores what fits. */
typedef struct text_out {
    char *buf;
    size_t cap, len;
} text_out;

static void put(text_out *o, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void put(text_out *o, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    char *dst = o->len < o->cap ? o->buf + o->len : NULL;
    size_t room = o->len < o->cap ? o->cap - o->len : 0;
    int n = vsnprintf(dst, room, fmt, ap);
    va_end(ap);
    if (n > 0) o->len += (size_t)n;
}

static void put_value(text_out *o, const lp_config *c, const key_spec *k)
{
    char num[40];
    switch (k->kind) {
    case KIND_LEVELS:
        put(o, "[");
        for (size_t j = 0; j < c->lod.level_count && j < LP_CONFIG_MAX_LEVELS; ++j) {
            format_number(num, sizeof num, c->lod.levels[j]);
            put(o, "%s%s", j ? ", " : "", num);
        }
        put(o, "]");
        break;
    case KIND_NUMBER:
        format_number(num, sizeof num, *number_field((lp_config *)c, k));
        put(o, "%s", num);
        break;
    case KIND_INTEGER:
        put(o, "%d", *int_field((lp_config *)c, k));
        break;
    case KIND_BOOLEAN:
        put(o, "%s", *int_field((lp_config *)c, k) ? "true" : "false");
        break;
    case KIND_CHOICE:
        put(o, "\"%s\"", k->choices[*int_field((lp_config *)c, k)]);
        break;
    case KIND_LEVEL_SET: {
        const uint32_t set = *set_field((lp_config *)c, k);
        int first = 1;
        put(o, "[");
        for (unsigned j = 0; j < LP_CONFIG_MAX_LEVELS; ++j)
            if (set & (1u << j)) {
                put(o, "%s%u", first ? "" : ", ", j + 1);
                first = 0;
            }
        put(o, "]");
        break;
    }
    }
}

size_t config_write(const lp_config *config, config_format format, char *buf, size_t cap)
{
    text_out o = {buf, cap, 0};
    if (buf && cap) buf[0] = '\0';
    const char *table = NULL;
    size_t tlen = 0;
    if (format == CONFIG_JSON) put(&o, "{");
    for (size_t i = 0; i < KEY_COUNT; ++i) {
        const key_spec *k = &kKeys[i];
        size_t len = table_length(k->key);
        int new_table = !table || len != tlen || strncmp(k->key, table, len) != 0;
        const char *leaf = k->key + len + 1;
        if (format == CONFIG_JSON) {
            if (new_table) put(&o, "%s\"%.*s\":{", table ? "}," : "", (int)len, k->key);
            else put(&o, ",");
            put(&o, "\"%s\":", leaf);
        } else {
            if (new_table) put(&o, "%s[%.*s]\n", table ? "\n" : "", (int)len, k->key);
            put(&o, "%s = ", leaf);
        }
        put_value(&o, config, k);
        if (format != CONFIG_JSON) put(&o, "\n");
        table = k->key;
        tlen = len;
    }
    if (format == CONFIG_JSON) put(&o, "}}\n");
    return o.len;
}
