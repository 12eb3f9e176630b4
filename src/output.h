/* output.h - writing a set of files so that either all of them appear or none.
 *
 * Each file is written to a temp file in its final folder, then all are renamed
 * into place (the main file, files[0], last). On any failure every temp file is
 * removed, no existing file is touched, and the error (LP_IO) names the path and
 * the reason (missing folder, read-only folder, disk full, ...). An auxiliary
 * file (files[1..]) whose target already holds identical bytes is left alone, so
 * writing beside the input does not rewrite its textures. */
#ifndef LODPIPE_OUTPUT_H
#define LODPIPE_OUTPUT_H

#include <stddef.h>

#include "gltf_io/gltf_io.h"
#include "status.h"

/* A file the write must not replace: `path`, which `why` describes in the
 * error ("a file the input reads", "the --depfile"). */
typedef struct output_guard {
    const char *path;
    const char *why;
} output_guard;

/* `main_path` is the output path the user named; files[i].name are relative to
 * its folder, files[0] being the main file. Before anything is written, a
 * target that is one of the guarded files (output_same_path) and would
 * change is refused with LP_USAGE ("T (written with the output) is a file the
 * input reads; choose another output name"): a .gltf output's .bin must not
 * overwrite the buffer its input reads. */
int output_write_all(const char *main_path, const gltf_out_file *files, size_t count, const output_guard *guards,
                     size_t guard_count, lp_error *err);

/* LP_OK when the folder of main_path exists and may be written to, else the
 * error output_write_all would give (LP_IO). Callers check it before a long
 * job too, so that a mistyped folder fails at once rather than at the end;
 * output_write_all checks again. */
int output_check_folder(const char *main_path, lp_error *err);

/* 1 when a and b name the same existing file. */
int output_same_file(const char *a, const char *b);

/* 1 when a and b name the same file, existing or not: the same existing
 * file, or neither exists and both name the same entry of the same folder
 * (for a file about to be written). */
int output_same_path(const char *a, const char *b);

#endif
