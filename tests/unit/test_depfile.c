/* Unit tests for src/depfile: the rule's shape and Make's escaping (spaces,
 * '#', ':', '$', backslashes before a space, '#' or ':'), and refusal of line
 * breaks and trailing backslashes. */
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "depfile.h"

static void expect(const char *target, const char *const *deps, size_t count, const char *want)
{
    lp_error err = {0, "", 0};
    char *text = depfile_text(target, deps, count, &err);
    CHECK(text && strcmp(text, want) == 0, "got [%s], want [%s]", text ? text : "(null)", want);
    free(text);
}

static void plain_rule(void)
{
    const char *deps[] = {"in/a.gltf", "in/a.bin", "pipeline.toml"};
    expect("out/a.gltf", deps, 3, "out/a.gltf: in/a.gltf in/a.bin pipeline.toml\n");
    expect("out/a.glb", deps, 1, "out/a.glb: in/a.gltf\n");
}

static void escaping(void)
{
    const char *deps[] = {"my dir/a b.gltf", "x#1.bin", "cost$.png", "back\\slash.png", "tail\\ space", "two\\\\#hash"};
    expect("o u t.glb", deps, 6,
           "o\\ u\\ t.glb: my\\ dir/a\\ b.gltf x\\#1.bin cost$$.png back\\slash.png tail\\\\\\ space two\\\\\\\\\\#hash\n");
}

static void colons(void)
{
    const char *deps[] = {"C:/in/a.gltf", "x\\:y.bin"};
    expect("out:1.glb", deps, 2, "out\\:1.glb: C\\:/in/a.gltf x\\\\\\:y.bin\n");
}

static void trailing_backslash_refused(void)
{
    lp_error err = {0, "", 0};
    const char *deps[] = {"in.glb", "tex\\"};
    CHECK(depfile_text("out.glb", deps, 2, &err) == NULL, "a dependency ending in a backslash is refused");
    CHECK(err.code == LP_USAGE && strstr(err.msg, "ending in a backslash"), "message: %s", err.msg);
    CHECK(depfile_text("out\\", NULL, 0, &err) == NULL, "a target ending in a backslash is refused");
}

static void line_breaks_refused(void)
{
    lp_error err = {0, "", 0};
    const char *deps[] = {"a\nb.bin"};
    CHECK(depfile_text("out.glb", deps, 1, &err) == NULL, "a newline in a dependency is refused");
    CHECK(err.code == LP_USAGE && strstr(err.msg, "line break"), "message: %s", err.msg);
    CHECK(depfile_text("out\r.glb", NULL, 0, &err) == NULL, "a carriage return in the target is refused");
}

int main(void)
{
    RUN(plain_rule);
    RUN(escaping);
    RUN(colons);
    RUN(line_breaks_refused);
    RUN(trailing_backslash_refused);
    return check_summary();
}
