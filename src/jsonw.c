/* jsonw.c - see jsonw.h. */
#include "jsonw.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int reserve(jsonw *w, size_t extra)
{
    if (w->failed) return -1;
    if (w->length + extra + 1 <= w->capacity) return 0;
    size_t cap = w->capacity ? w->capacity : 256;
    while (cap < w->length + extra + 1) cap *= 2;
    char *p = realloc(w->text, cap);
    if (!p) {
        w->failed = 1;
        return -1;
    }
    w->text = p;
    w->capacity = cap;
    return 0;
}

void jsonw_raw(jsonw *w, const char *text)
{
    size_t n = strlen(text);
    if (reserve(w, n)) return;
    memcpy(w->text + w->length, text, n + 1);
    w->length += n;
}

void jsonw_printf(jsonw *w, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (n < 0 || reserve(w, (size_t)n)) return;
    va_start(ap, fmt);
    vsnprintf(w->text + w->length, (size_t)n + 1, fmt, ap);
    va_end(ap);
    w->length += (size_t)n;
}

void jsonw_string(jsonw *w, const char *s)
{
    jsonw_raw(w, "\"");
    for (; *s; ++s) {
        unsigned char c = (unsigned char)*s;
        if (c == '"') jsonw_raw(w, "\\\"");
        else if (c == '\\') jsonw_raw(w, "\\\\");
        else if (c < 0x20) jsonw_printf(w, "\\u%04x", c);
        else {
            char one[2] = {(char)c, 0};
            jsonw_raw(w, one);
        }
    }
    jsonw_raw(w, "\"");
}

void jsonw_number(jsonw *w, double value)
{
    if (isfinite(value)) jsonw_printf(w, "%.17g", value);
    else jsonw_raw(w, "null");
}

void jsonw_free(jsonw *w)
{
    free(w->text);
    memset(w, 0, sizeof *w);
}
