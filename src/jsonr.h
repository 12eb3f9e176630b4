/* jsonr.h - a small JSON reader: what lodpipe reads back of its own JSON (the
 * batch cache manifest, the main job's --json summary).
 *
 * jsonr_parse checks the whole text against the JSON grammar (RFC 8259; depth
 * at most JSONR_MAX_DEPTH) and turns it into a flat array of tokens in document
 * order: token 0 is the root value; a container's children follow it (an
 * object's as key, value, key, value, ...), and every token knows where its
 * subtree ends, so siblings are reached without recursion. Nothing points into
 * freed memory: tokens hold offsets into the caller's text, which must stay
 * alive (and NUL-terminated) while the reader is used. Lookups of a missing
 * member, a wrong type or an index out of range return JSONR_NONE / fallbacks,
 * never crash: the text may come from a damaged file. */
#ifndef LODPIPE_JSONR_H
#define LODPIPE_JSONR_H

#include <stddef.h>
#include <stdint.h>

#define JSONR_MAX_DEPTH 64
#define JSONR_NONE UINT32_MAX

typedef enum jsonr_type {
    JSONR_NULL, JSONR_FALSE, JSONR_TRUE, JSONR_NUMBER, JSONR_STRING, JSONR_ARRAY, JSONR_OBJECT
} jsonr_type;

typedef struct jsonr_token {
    jsonr_type type;
    size_t start, end; /* the value's text; for a string, inside the quotes (still escaped) */
    uint32_t end_token; /* the first token after this value's subtree */
    uint32_t size;      /* array: elements; object: members; else 0 */
} jsonr_token;

typedef struct jsonr {
    const char *text;
    jsonr_token *tokens;
    uint32_t count, capacity;
} jsonr;

/* Parses text[0..length) (text[length] must be readable and is not used).
 * Returns 0, -1 when the text is not one JSON value, or -2 when memory ran
 * out; on failure nothing needs freeing. */
int jsonr_parse(jsonr *r, const char *text, size_t length);
void jsonr_free(jsonr *r);

/* The value of member `key` of object token `object`, or JSONR_NONE. */
uint32_t jsonr_member(const jsonr *r, uint32_t object, const char *key);
/* Element `index` of array token `array`, or JSONR_NONE. */
uint32_t jsonr_element(const jsonr *r, uint32_t array, uint32_t index);
/* Number of elements/members of a container token, 0 for anything else. */
uint32_t jsonr_size(const jsonr *r, uint32_t token);

/* A string token unescaped into malloc'd UTF-8 (caller frees), or NULL when
 * the token is not a string, holds a \u0000, or memory ran out. */
char *jsonr_string(const jsonr *r, uint32_t token);
/* A number token's value, or `fallback` for anything else. */
double jsonr_number(const jsonr *r, uint32_t token, double fallback);

#endif
