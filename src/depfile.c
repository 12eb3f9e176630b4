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
            int before_special = p[run] == ' ' || p[run] == '#' || p[run] == ':';
            for (size_t k = 0; k < (before_special ? 2 * run : run); ++k) jsonw_raw(w, "\\");
            p += run;
            continue;
        }
        if (*p == ' ') jsonw_raw(w, "\\ ");
        else if (*p == '#') jsonw_raw(w, "\\#");
        else if (*p == ':') jsonw_raw(w, "\\:"); /* else Make reads a second rule separator */
        else if (*p == '$') jsonw_raw(w, "$$");
        else {
            char one[2] = {*p, 0};
            jsonw_raw(w, one);
        }
        p++;
    }
}

/* LP_OK when Make can read `name` back, else the error. Neither has an
 * escape: a line break ends the rule, and a backslash ending a name is a
 * line continuation at the end of the rule, while GNU Make 4.3 keeps a
 * doubled one there as two backslashes ("c\\" names c\\, tested). */
static int writable_name(const char *name, lp_error *err)
{
    size_t n = strlen(name);
    if (strpbrk(name, "\r\n"))
        return lp_fail(err, LP_USAGE, "%s: a name with a line break cannot be written to a depfile", name);
    if (n && name[n - 1] == '\\')
        return lp_fail(err, LP_USAGE, "%s: a name ending in a backslash cannot be written to a depfile", name);
    return LP_OK;
}

char *depfile_text(const char *target, const char *const *deps, size_t count, lp_error *err)
{
    if (writable_name(target, err)) return NULL;
    for (size_t i = 0; i < count; ++i)
        if (writable_name(deps[i], err)) return NULL;
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
        lp_no_memory(err, "out of memory");
        return NULL;
    }
    return w.text;
}
