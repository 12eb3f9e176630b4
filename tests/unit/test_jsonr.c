/* Unit tests for src/jsonr: members and elements of nested values, string
 * unescaping (UTF-8 from \u escapes and surrogate pairs), member lookup by
 * escaped keys, and rejection of text that is not exactly one JSON value. */
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "jsonr.h"

static void nested_lookups(void)
{
    const char *text = " {\"a\": [1, {\"b\": -2.5e1}, \"x\"], \"name\": \"q\\\"\\\\\\n\", \"t\": true, \"e\": {}} ";
    jsonr r;
    CHECK(jsonr_parse(&r, text, strlen(text)) == 0, "parses");
    if (!r.count) return;
    uint32_t a = jsonr_member(&r, 0, "a");
    CHECK(jsonr_size(&r, a) == 3, "a has 3 elements");
    CHECK(jsonr_number(&r, jsonr_element(&r, a, 0), 0) == 1, "a[0] = 1");
    CHECK(jsonr_number(&r, jsonr_member(&r, jsonr_element(&r, a, 1), "b"), 0) == -25, "a[1].b = -25");
    char *x = jsonr_string(&r, jsonr_element(&r, a, 2));
    CHECK(x && strcmp(x, "x") == 0, "a[2] = x");
    free(x);
    CHECK(jsonr_element(&r, a, 3) == JSONR_NONE, "a[3] is absent");
    char *name = jsonr_string(&r, jsonr_member(&r, 0, "name"));
    CHECK(name && strcmp(name, "q\"\\\n") == 0, "escapes");
    free(name);
    CHECK(r.tokens[jsonr_member(&r, 0, "t")].type == JSONR_TRUE, "t is true");
    CHECK(jsonr_size(&r, jsonr_member(&r, 0, "e")) == 0, "e is empty");
    CHECK(jsonr_member(&r, 0, "missing") == JSONR_NONE, "a missing key");
    CHECK(jsonr_number(&r, jsonr_member(&r, 0, "name"), 7) == 7, "a string is not a number");
    CHECK(jsonr_member(&r, a, "b") == JSONR_NONE, "an array has no members");
    jsonr_free(&r);
}

static void unicode_escapes(void)
{
    const char *text = "[\"\\u00e9\\u20ac\\ud83d\\ude00\", \"\\u0000\"]";
    jsonr r;
    CHECK(jsonr_parse(&r, text, strlen(text)) == 0, "parses");
    if (!r.count) return;
    char *s = jsonr_string(&r, jsonr_element(&r, 0, 0));
    CHECK(s && strcmp(s, "\xc3\xa9\xe2\x82\xac\xf0\x9f\x98\x80") == 0, "UTF-8 of e-acute, euro, emoji");
    free(s);
    CHECK(jsonr_string(&r, jsonr_element(&r, 0, 1)) == NULL, "a NUL character is refused");
    jsonr_free(&r);
}

/* jsonr_member compares keys as they decode, without allocating: escaped
 * keys match their decoded text, and a key is not matched by its prefix,
 * by a longer key, or through a \u0000. */
static void escaped_keys(void)
{
    const char *text = "{\"le\\u0076els\": 1, \"q\\\"\\\\\": 2, \"\\u00e9\\ud83d\\ude00\": 3, \"ab\": 4, \"a\\u0000\": 5}";
    jsonr r;
    CHECK(jsonr_parse(&r, text, strlen(text)) == 0, "parses");
    if (!r.count) return;
    CHECK(jsonr_number(&r, jsonr_member(&r, 0, "levels"), 0) == 1, "\\u0076 matches v");
    CHECK(jsonr_number(&r, jsonr_member(&r, 0, "q\"\\"), 0) == 2, "escaped quote and backslash");
    CHECK(jsonr_number(&r, jsonr_member(&r, 0, "\xc3\xa9\xf0\x9f\x98\x80"), 0) == 3, "UTF-8 and a surrogate pair");
    CHECK(jsonr_member(&r, 0, "level") == JSONR_NONE, "a prefix of a key");
    CHECK(jsonr_member(&r, 0, "levelss") == JSONR_NONE, "a key longer than any");
    CHECK(jsonr_number(&r, jsonr_member(&r, 0, "ab"), 0) == 4, "ab");
    CHECK(jsonr_member(&r, 0, "a") == JSONR_NONE, "a\\u0000 is not a");
    jsonr_free(&r);
}

static void rejects_non_json(void)
{
    static const char *const kBad[] = {"", "{", "[1,]", "{\"a\" 1}", "01", "1.", "-", "tru", "\"a", "\"\\x\"",
                                       "[1] 2", "{\"a\":1,}", "\"\x01\"", "nul", "[\"\\u12\"]"};
    for (size_t i = 0; i < sizeof kBad / sizeof kBad[0]; ++i) {
        jsonr r;
        CHECK(jsonr_parse(&r, kBad[i], strlen(kBad[i])) == -1, "accepted %s", kBad[i]);
    }
    char deep[2 * JSONR_MAX_DEPTH + 3];
    size_t n = 0;
    for (int i = 0; i <= JSONR_MAX_DEPTH; ++i) deep[n++] = '[';
    for (int i = 0; i <= JSONR_MAX_DEPTH; ++i) deep[n++] = ']';
    deep[n] = 0;
    jsonr r;
    CHECK(jsonr_parse(&r, deep, n) == -1, "nesting deeper than the cap is refused");
}

int main(void)
{
    RUN(nested_lookups);
    RUN(unicode_escapes);
    RUN(escaped_keys);
    RUN(rejects_non_json);
    return check_summary();
}
