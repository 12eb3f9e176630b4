/* check.h - the unit tests' only framework.
 *
 * Each tests/unit/test_*.c is its own program: it calls RUN(fn) for each test
 * function and returns check_summary(). A test function uses CHECK(cond, fmt, ...)
 * which records a failure with file, line and message but keeps going, so one
 * run reports every broken expectation. Output is TAP-like ("ok 3 - name",
 * "not ok 4 - name"), the exit status is non-zero when anything failed, and the
 * test runner (tests/run_unit.test.mjs) turns each program into a subtest. */
#ifndef LODPIPE_CHECK_H
#define LODPIPE_CHECK_H

#include <stdio.h>

static int check_failures_in_test;
static int check_tests_run;
static int check_tests_failed;

#define CHECK(cond, ...)                                                      \
    do {                                                                      \
        if (!(cond)) {                                                        \
            check_failures_in_test++;                                         \
            fprintf(stdout, "#   %s:%d: CHECK(%s) failed: ", __FILE__,        \
                    __LINE__, #cond);                                         \
            fprintf(stdout, __VA_ARGS__);                                     \
            fputc('\n', stdout);                                              \
        }                                                                     \
    } while (0)

#define RUN(fn)                                                               \
    do {                                                                      \
        check_failures_in_test = 0;                                           \
        fn();                                                                 \
        check_tests_run++;                                                    \
        if (check_failures_in_test) check_tests_failed++;                     \
        fprintf(stdout, "%sok %d - %s\n", check_failures_in_test ? "not " : "",\
                check_tests_run, #fn);                                        \
        fflush(stdout);                                                       \
    } while (0)

static inline int check_summary(void)
{
    fprintf(stdout, "1..%d\n# %d passed, %d failed\n", check_tests_run,
            check_tests_run - check_tests_failed, check_tests_failed);
    return check_tests_failed ? 1 : 0;
}

#endif
