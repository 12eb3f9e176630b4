/* status.c - see status.h. */
#include "status.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Fills err (when not NULL), for lp_fail and lp_no_memory. */
static void record(lp_error *err, int code, int out_of_memory, const char *fmt, va_list ap)
{
    if (!err) return;
    vsnprintf(err->msg, sizeof err->msg, fmt, ap);
    err->code = code;
    err->out_of_memory = out_of_memory;
}

int lp_fail(lp_error *err, int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    record(err, code, 0, fmt, ap);
    va_end(ap);
    return code;
}

int lp_no_memory(lp_error *err, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    record(err, LP_INVALID, 1, fmt, ap);
    va_end(ap);
    return LP_INVALID;
}

/* Copies text into out with its control characters escaped; stops before an
 * escape that would not fit whole. */
static void escape_controls(char *out, size_t cap, const char *text)
{
    size_t n = 0;
    for (const unsigned char *p = (const unsigned char *)text; *p; ++p) {
        char esc[5];
        size_t len = 1;
        esc[0] = (char)*p;
        if (*p == '\n' || *p == '\t' || *p == '\r') {
            esc[0] = '\\';
            esc[1] = *p == '\n' ? 'n' : *p == '\t' ? 't' : 'r';
            len = 2;
        } else if (*p < 0x20 || *p == 0x7f) {
            snprintf(esc, sizeof esc, "\\x%02x", *p);
            len = 4;
        }
        if (n + len + 1 > cap) break;
        for (size_t i = 0; i < len; ++i) out[n++] = esc[i];
    }
    out[n] = 0;
}

static char *format_line(char *out, size_t cap, const char *fmt, va_list ap)
{
    if (!cap) return out;
    va_list again;
    va_copy(again, ap);
    int need = vsnprintf(NULL, 0, fmt, ap);
    char small[1024];
    char *text = need >= 0 && (size_t)need < sizeof small ? small : need >= 0 ? malloc((size_t)need + 1) : NULL;
    if (!text) {
        /* Out of memory (or a format error): the message is cut, not lost. */
        text = small;
        need = (int)sizeof small - 1;
    }
    vsnprintf(text, (size_t)need + 1, fmt, again);
    va_end(again);
    escape_controls(out, cap, text);
    if (text != small) free(text);
    return out;
}

char *lp_line(char *out, size_t cap, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    format_line(out, cap, fmt, ap);
    va_end(ap);
    return out;
}

void lp_say(const char *fmt, ...)
{
    /* Paths reach PATH_MAX and every byte may grow to four. */
    enum { PREFIX = 9, CAP = 4 * 4096 + 1024 };
    char *line = malloc(CAP + 2);
    char fallback[1024];
    char *buf = line ? line : fallback;
    size_t cap = line ? CAP : sizeof fallback - 2;
    memcpy(buf, "lodpipe: ", PREFIX);
    va_list ap;
    va_start(ap, fmt);
    format_line(buf + PREFIX, cap - PREFIX, fmt, ap);
    va_end(ap);
    size_t n = strlen(buf);
    buf[n++] = '\n';
    fwrite(buf, 1, n, stderr);
    free(line);
}
