/* status.h - lodpipe's exit codes and the one error record every module fills.
 *
 * A failing call fills an lp_error with the exit code it stands for and a
 * one-line message that names the offending object ("accessors[3]: ..."); the
 * CLI prints it as "lodpipe: FILE: message" and exits with the code. Nothing
 * below the CLI prints or exits. */
#ifndef LODPIPE_STATUS_H
#define LODPIPE_STATUS_H

#include <stddef.h>

enum {
    LP_OK = 0,
    LP_USAGE = 1,   /* the command line is wrong */
    LP_INVALID = 2, /* the input is not valid glTF 2.0, or not usable */
    LP_PROMISE = 3, /* a promise could not be kept (e.g. a bound could not be certified) */
    LP_IO = 4,      /* a file could not be read or written */
    LP_SOME_FAILED = 5 /* lodpipe batch: at least one file failed (the others completed) */
};

typedef struct lp_error {
    int code;
    char msg[512];
    int out_of_memory; /* the failure was memory running out (lp_no_memory) */
} lp_error;

/* Records code and a printf-style message; returns code, so callers can write
 * `return lp_fail(err, LP_INVALID, "accessors[%zu]: ...", i);`. */
int lp_fail(lp_error *err, int code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* lp_fail for memory running out: LP_INVALID (exit 2, as the README's table
 * says), the message (which says "out of memory") and out_of_memory set, so
 * that a caller that goes on after a failure it tolerates can still tell
 * this one apart and stop. */
int lp_no_memory(lp_error *err, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Formats one message line into out (at most cap - 1 bytes, always
 * terminated, no newline added), showing every control character of the
 * result as an escape (\n, \t, \r or \xHH): a file or mesh name that holds a
 * newline cannot split "one line per message". Returns out. */
char *lp_line(char *out, size_t cap, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

/* Prints "lodpipe: " and the message (as lp_line formats it) plus a newline to
 * stderr in one write, so lines of concurrent jobs do not interleave. */
void lp_say(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

#endif
