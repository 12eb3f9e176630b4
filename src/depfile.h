/* depfile.h - the Make/Ninja dependency file of a single-file run
 * (lodpipe IN -o OUT --depfile FILE).
 *
 * The text is one rule, "OUT: IN dep1 dep2 ...\n", on one line, with every
 * name escaped as GNU Make reads it and Ninja's depfile parser accepts it:
 * a space becomes "\ ", '#' becomes "\#", ':' becomes "\:" (else Make sees
 * "multiple target patterns"), '$' becomes "$$", and the backslashes directly
 * before a space, '#' or ':' are doubled (so "a\ b", a name holding a
 * backslash and a space, is written "a\\\ b"). A name containing a line
 * break, or ending in a backslash (read as a line continuation), cannot be
 * written in this format: depfile_text refuses it. */
#ifndef LODPIPE_DEPFILE_H
#define LODPIPE_DEPFILE_H

#include <stddef.h>

#include "status.h"

/* The rule for `target` depending on deps[0..count) as malloc'd text (caller
 * frees), or NULL with err filled (LP_USAGE for a name with a line break or
 * ending in a backslash, LP_IO when memory runs out). */
char *depfile_text(const char *target, const char *const *deps, size_t count, lp_error *err);

#endif
