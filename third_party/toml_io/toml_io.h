/* toml_io.h - plain C face of the TOML parser (toml++ 3.3, Debian libtomlplusplus-dev).
 *
 * What it promises
 * - toml_io_parse_file reads one TOML 1.0 file and turns it into a flat list of
 *   entries in document order (by the position of each entry's key). Every table
 *   below the root is an entry of type TOML_IO_TABLE, listed before its contents,
 *   with the number of keys it holds (0 for an empty table such as a lone
 *   "[draco]"); every other value is a leaf entry. Each entry carries its full
 *   dotted key path ("lod.levels"; a key segment that is not a bare key is written
 *   as a quoted TOML string: lod."a.b"), its type, the 1-based line and column of
 *   its key, and its value.
 * - An array is one entry; its elements are given one level deep (type and value
 *   of each). Elements that are themselves arrays or tables (including arrays of
 *   tables, "[[x]]") are reported by type only, without their contents.
 * - Dates and times are TOML_IO_OTHER, without a value.
 * - Every pointer handed out lives until toml_io_free.
 * - It holds no logic of lodpipe's: it parses and reports, the caller validates.
 */
#ifndef LODPIPE_TOML_IO_H
#define LODPIPE_TOML_IO_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct toml_io_doc toml_io_doc;

/* Status codes of toml_io_parse_file. */
enum {
    TOML_IO_OK = 0,
    TOML_IO_SYNTAX = 1, /* the file is not valid TOML (or not valid UTF-8) */
    TOML_IO_READ = 2,   /* the file could not be opened or read */
    TOML_IO_NOMEM = 3   /* out of memory */
};

typedef enum toml_io_type {
    TOML_IO_INTEGER,
    TOML_IO_FLOAT,
    TOML_IO_BOOLEAN,
    TOML_IO_STRING,
    TOML_IO_ARRAY,
    TOML_IO_TABLE,
    TOML_IO_OTHER /* date, time, date-time */
} toml_io_type;

/* One value: a leaf entry's value, or one element of an array entry. */
typedef struct toml_io_value {
    toml_io_type type;
    double number;         /* INTEGER (converted, may round above 2^53) or FLOAT; else 0 */
    int64_t integer;       /* INTEGER exactly; else 0 */
    int boolean;           /* BOOLEAN: 0 or 1; else 0 */
    const char *string;    /* STRING: UTF-8, NUL-terminated; else NULL */
    size_t string_length;  /* STRING: bytes before the terminator (a TOML string may hold "\u0000") */
} toml_io_value;

typedef struct toml_io_entry {
    const char *key;       /* full dotted path, e.g. "lod.levels" */
    uint32_t line;         /* 1-based position of the entry's key in the file */
    uint32_t column;
    toml_io_value value;   /* for ARRAY and TABLE only .type is set */
    size_t element_count;  /* ARRAY: number of elements; TABLE: number of keys; else 0 */
    const toml_io_value *elements; /* ARRAY: element_count values; else NULL */
} toml_io_entry;

/* Parses the file at `path`. Returns TOML_IO_OK and a document in *out, or an
 * error code with *out = NULL and a one-line reason in err (without the file
 * name; the caller adds it): for TOML_IO_SYNTAX "line 7, column 3: expected ...",
 * for TOML_IO_READ the system's reason ("No such file or directory"). */
int toml_io_parse_file(const char *path, toml_io_doc **out, char *err, size_t errlen);

/* Frees the document and everything it handed out; NULL is allowed. */
void toml_io_free(toml_io_doc *doc);

/* Number of entries. */
size_t toml_io_count(const toml_io_doc *doc);

/* Fills *out with entry `index` (0-based, document order). Returns 0, or -1 if
 * index is out of range. */
int toml_io_get(const toml_io_doc *doc, size_t index, toml_io_entry *out);

#ifdef __cplusplus
}
#endif

#endif
