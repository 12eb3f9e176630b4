/* jsonr.c - see jsonr.h. A recursive-descent parser with an explicit depth
 * cap, appending one token per value. */
#include "jsonr.h"

#include <stdlib.h>
#include <string.h>

typedef struct parser {
    jsonr *r;
    const char *s;
    size_t n, pos;
    int out_of_memory;
} parser;

static void skip_space(parser *p)
{
    while (p->pos < p->n && (p->s[p->pos] == ' ' || p->s[p->pos] == '\t' || p->s[p->pos] == '\n' || p->s[p->pos] == '\r'))
        p->pos++;
}

static uint32_t add_token(parser *p, jsonr_type type, size_t start)
{
    jsonr *r = p->r;
    if (r->count == UINT32_MAX - 1) return JSONR_NONE;
    if (r->count == r->capacity) {
        uint32_t cap = r->capacity ? (r->capacity > UINT32_MAX / 4 ? UINT32_MAX - 1 : r->capacity * 2) : 64;
        jsonr_token *t = realloc(r->tokens, (size_t)cap * sizeof *t);
        if (!t) {
            p->out_of_memory = 1;
            return JSONR_NONE;
        }
        r->tokens = t;
        r->capacity = cap;
    }
    jsonr_token *t = &r->tokens[r->count];
    t->type = type;
    t->start = start;
    t->end = start;
    t->size = 0;
    t->end_token = r->count + 1;
    return r->count++;
}

static int is_hex(char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F'); }
static int is_digit(char c) { return c >= '0' && c <= '9'; }

/* A string starting at the opening quote; the token spans its contents. */
static int parse_string(parser *p)
{
    size_t start = ++p->pos;
    while (p->pos < p->n) {
        unsigned char c = (unsigned char)p->s[p->pos];
        if (c == '"') {
            uint32_t t = add_token(p, JSONR_STRING, start);
            if (t == JSONR_NONE) return -1;
            p->r->tokens[t].end = p->pos++;
            return 0;
        }
        if (c < 0x20) return -1;
        if (c == '\\') {
            if (++p->pos >= p->n) return -1;
            char e = p->s[p->pos];
            if (e == 'u') {
                for (int k = 1; k <= 4; ++k)
                    if (p->pos + k >= p->n || !is_hex(p->s[p->pos + k])) return -1;
                p->pos += 4;
            } else if (!strchr("\"\\/bfnrt", e) || e == 0) {
                return -1;
            }
        }
        p->pos++;
    }
    return -1;
}

static int parse_number(parser *p)
{
    size_t start = p->pos;
    if (p->pos < p->n && p->s[p->pos] == '-') p->pos++;
    if (p->pos >= p->n || !is_digit(p->s[p->pos])) return -1;
    if (p->s[p->pos] == '0') p->pos++;
    else
        while (p->pos < p->n && is_digit(p->s[p->pos])) p->pos++;
    if (p->pos < p->n && p->s[p->pos] == '.') {
        p->pos++;
        if (p->pos >= p->n || !is_digit(p->s[p->pos])) return -1;
        while (p->pos < p->n && is_digit(p->s[p->pos])) p->pos++;
    }
    if (p->pos < p->n && (p->s[p->pos] == 'e' || p->s[p->pos] == 'E')) {
        p->pos++;
        if (p->pos < p->n && (p->s[p->pos] == '+' || p->s[p->pos] == '-')) p->pos++;
        if (p->pos >= p->n || !is_digit(p->s[p->pos])) return -1;
        while (p->pos < p->n && is_digit(p->s[p->pos])) p->pos++;
    }
    uint32_t t = add_token(p, JSONR_NUMBER, start);
    if (t == JSONR_NONE) return -1;
    p->r->tokens[t].end = p->pos;
    return 0;
}

static int parse_literal(parser *p, const char *word, jsonr_type type)
{
    size_t len = strlen(word);
    if (p->n - p->pos < len || memcmp(p->s + p->pos, word, len) != 0) return -1;
    uint32_t t = add_token(p, type, p->pos);
    if (t == JSONR_NONE) return -1;
    p->pos += len;
    p->r->tokens[t].end = p->pos;
    return 0;
}

static int parse_value(parser *p, int depth);

/* An array or object starting at its bracket. */
static int parse_container(parser *p, int depth, int is_object)
{
    if (depth >= JSONR_MAX_DEPTH) return -1;
    uint32_t t = add_token(p, is_object ? JSONR_OBJECT : JSONR_ARRAY, p->pos);
    if (t == JSONR_NONE) return -1;
    const char close = is_object ? '}' : ']';
    p->pos++;
    skip_space(p);
    uint32_t size = 0;
    if (p->pos < p->n && p->s[p->pos] == close) {
        p->pos++;
    } else {
        for (;;) {
            skip_space(p);
            if (is_object) {
                if (p->pos >= p->n || p->s[p->pos] != '"' || parse_string(p)) return -1;
                skip_space(p);
                if (p->pos >= p->n || p->s[p->pos] != ':') return -1;
                p->pos++;
            }
            if (parse_value(p, depth + 1)) return -1;
            size++;
            skip_space(p);
            if (p->pos >= p->n) return -1;
            if (p->s[p->pos] == ',') {
                p->pos++;
                continue;
            }
            if (p->s[p->pos] != close) return -1;
            p->pos++;
            break;
        }
    }
    p->r->tokens[t].end = p->pos;
    p->r->tokens[t].size = size;
    p->r->tokens[t].end_token = p->r->count;
    return 0;
}

static int parse_value(parser *p, int depth)
{
    skip_space(p);
    if (p->pos >= p->n) return -1;
    switch (p->s[p->pos]) {
    case '{': return parse_container(p, depth, 1);
    case '[': return parse_container(p, depth, 0);
    case '"': return parse_string(p);
    case 't': return parse_literal(p, "true", JSONR_TRUE);
    case 'f': return parse_literal(p, "false", JSONR_FALSE);
    case 'n': return parse_literal(p, "null", JSONR_NULL);
    default: return parse_number(p);
    }
}

int jsonr_parse(jsonr *r, const char *text, size_t length)
{
    memset(r, 0, sizeof *r);
    r->text = text;
    parser p = {r, text, length, 0, 0};
    int rc = parse_value(&p, 0);
    skip_space(&p);
    if (rc || p.pos != length) {
        jsonr_free(r);
        return p.out_of_memory ? -2 : -1;
    }
    return 0;
}

void jsonr_free(jsonr *r)
{
    free(r->tokens);
    memset(r, 0, sizeof *r);
}

uint32_t jsonr_size(const jsonr *r, uint32_t token)
{
    if (token >= r->count) return 0;
    jsonr_type type = r->tokens[token].type;
    return type == JSONR_ARRAY || type == JSONR_OBJECT ? r->tokens[token].size : 0;
}

uint32_t jsonr_element(const jsonr *r, uint32_t array, uint32_t index)
{
    if (array >= r->count || r->tokens[array].type != JSONR_ARRAY || index >= r->tokens[array].size) return JSONR_NONE;
    uint32_t t = array + 1;
    for (uint32_t i = 0; i < index; ++i) t = r->tokens[t].end_token;
    return t;
}

static int string_is(const jsonr *r, uint32_t token, const char *key);

uint32_t jsonr_member(const jsonr *r, uint32_t object, const char *key)
{
    if (object >= r->count || r->tokens[object].type != JSONR_OBJECT) return JSONR_NONE;
    uint32_t t = object + 1;
    for (uint32_t i = 0; i < r->tokens[object].size; ++i) {
        uint32_t value = t + 1;
        if (r->tokens[t].type == JSONR_STRING && string_is(r, t, key)) return value;
        t = r->tokens[value].end_token;
    }
    return JSONR_NONE;
}

static unsigned hex_value(char c)
{
    if (c >= '0' && c <= '9') return (unsigned)(c - '0');
    if (c >= 'a' && c <= 'f') return (unsigned)(c - 'a' + 10);
    return (unsigned)(c - 'A' + 10);
}

static unsigned read_hex4(const char *s)
{
    return hex_value(s[0]) << 12 | hex_value(s[1]) << 8 | hex_value(s[2]) << 4 | hex_value(s[3]);
}

static size_t put_utf8(char *out, unsigned cp)
{
    if (cp < 0x80) {
        out[0] = (char)cp;
        return 1;
    }
    if (cp < 0x800) {
        out[0] = (char)(0xC0 | cp >> 6);
        out[1] = (char)(0x80 | (cp & 0x3F));
        return 2;
    }
    if (cp < 0x10000) {
        out[0] = (char)(0xE0 | cp >> 12);
        out[1] = (char)(0x80 | (cp >> 6 & 0x3F));
        out[2] = (char)(0x80 | (cp & 0x3F));
        return 3;
    }
    out[0] = (char)(0xF0 | cp >> 18);
    out[1] = (char)(0x80 | (cp >> 12 & 0x3F));
    out[2] = (char)(0x80 | (cp >> 6 & 0x3F));
    out[3] = (char)(0x80 | (cp & 0x3F));
    return 4;
}

/* Decodes the character of string text s[0..n) at *i into out (1 to 4 UTF-8
 * bytes; the parser guaranteed a valid escape) and moves *i past it. Returns
 * the byte count, or 0 for \u0000, which no C string can hold. */
static size_t decode_char(const char *s, size_t n, size_t *i, char out[4])
{
    size_t at = *i;
    *i = at + 1;
    if (s[at] != '\\') {
        out[0] = s[at];
        return 1;
    }
    const char e = s[++at];
    *i = at + 1;
    switch (e) {
    case 'b': out[0] = '\b'; return 1;
    case 'f': out[0] = '\f'; return 1;
    case 'n': out[0] = '\n'; return 1;
    case 'r': out[0] = '\r'; return 1;
    case 't': out[0] = '\t'; return 1;
    case 'u': {
        unsigned cp = read_hex4(s + at + 1);
        at += 4;
        if (cp >= 0xD800 && cp < 0xDC00 && at + 6 < n && s[at + 1] == '\\' && s[at + 2] == 'u') {
            unsigned low = read_hex4(s + at + 3);
            if (low >= 0xDC00 && low < 0xE000) {
                cp = 0x10000 + ((cp - 0xD800) << 10) + (low - 0xDC00);
                at += 6;
            }
        }
        *i = at + 1;
        return cp ? put_utf8(out, cp) : 0;
    }
    default: out[0] = e; return 1; /* " \ / */
    }
}

char *jsonr_string(const jsonr *r, uint32_t token)
{
    if (token >= r->count || r->tokens[token].type != JSONR_STRING) return NULL;
    const char *s = r->text + r->tokens[token].start;
    size_t n = r->tokens[token].end - r->tokens[token].start;
    char *out = malloc(n + 1); /* unescaping never lengthens: \uXXXX (6) -> at most 3, a pair (12) -> 4 */
    if (!out) return NULL;
    size_t o = 0;
    for (size_t i = 0; i < n;) {
        const size_t k = decode_char(s, n, &i, out + o);
        if (!k) {
            free(out);
            return NULL;
        }
        o += k;
    }
    out[o] = 0;
    return out;
}

/* 1 when string token `token` decodes to key: compared as it is decoded, so
 * that looking up a member allocates nothing (and cannot fail). */
static int string_is(const jsonr *r, uint32_t token, const char *key)
{
    const char *s = r->text + r->tokens[token].start;
    const size_t n = r->tokens[token].end - r->tokens[token].start, length = strlen(key);
    size_t matched = 0;
    for (size_t i = 0; i < n;) {
        char bytes[4];
        const size_t k = decode_char(s, n, &i, bytes);
        if (!k || matched + k > length || memcmp(key + matched, bytes, k) != 0) return 0;
        matched += k;
    }
    return matched == length;
}

double jsonr_number(const jsonr *r, uint32_t token, double fallback)
{
    if (token >= r->count || r->tokens[token].type != JSONR_NUMBER) return fallback;
    return strtod(r->text + r->tokens[token].start, NULL);
}
