/* jsonw.h - a tiny JSON text builder: what lodpipe writes into glTF extras and
 * its summaries. Numbers are printed with %.17g (exact round trip) and
 * deterministic; strings are escaped; a failed allocation sets `failed` and
 * makes every later call a no-op. */
#ifndef LODPIPE_JSONW_H
#define LODPIPE_JSONW_H

#include <stddef.h>

typedef struct jsonw {
    char *text; /* NUL-terminated */
    size_t length, capacity;
    int failed;
} jsonw;

void jsonw_raw(jsonw *w, const char *text);
void jsonw_printf(jsonw *w, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
void jsonw_string(jsonw *w, const char *s);
/* A finite number (%.17g), or null. */
void jsonw_number(jsonw *w, double value);
void jsonw_free(jsonw *w);

#endif
