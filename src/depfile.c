/* depfile.c - see depfile.h. */
#include "depfile.h"

#include <stdlib.h>
#include <string.h>

#include "jsonw.h"

/* Appends one name, escaped. */
static void put_name(jsonw *w, const char *name)
{
    for (const char *p = name; *p;) {
        if (*p == '\\') {
            size_t run = strspn(p, "\\");
            int before_special = p[run] == ' ' || p[run] == '#';
            for (size_t k = 0; k < (before_special ? 2 * run : run); ++k) jsonw_raw(w, "\\");
            p += run;
            continue;
        }
        if (*p == ' ') jsonw_raw(w, "\\ ");
        else if (*p == '#') jsonw_raw(w, "\\#");
        else if (*p == '$') jsonw_raw(w, "$$");
        else {
            char one[2] = {*p, 0};
            jsonw_raw(w, one);
        }
        p++;
    }
}

char *depfile_text(const char *target, const char *const *deps, size_t count, lp_error *err)
{
    if (strpbrk(target, "\r\n")) {
        lp_fail(err, LP_USAGE, "%s: a name with a line break cannot be written to a depfile", target);
        return NULL;
    }
    for (size_t i = 0; i < count; ++i)
        if (strpbrk(deps[i], "\r\n")) {
            lp_fail(err, LP_USAGE, "%s: a name with a line break cannot be written to a depfile", deps[i]);
            return NULL;
        }
    jsonw w = {0};
    put_name(&w, target);
    jsonw_raw(&w, ":");
    for (size_t i = 0; i < count; ++i) {
        jsonw_raw(&w, " ");
        put_name(&w, deps[i]);
    }
    jsonw_raw(&w, "\n");
    if (w.failed) {
        jsonw_free(&w);
        lp_fail(err, LP_IO, "out of memory");
        return NULL;
    }
    return w.text;
}
