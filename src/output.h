/* output.h - writing a set of files so that either all of them appear or none.
 *
 * Each file is written to a temp file beside its target, then all are renamed
 * into place (the main file last). On any failure every temp file is removed
 * and the error (LP_IO) names the path and the reason (missing folder,
 * read-only folder, disk full, a folder where a file goes, ...). Every target
 * is checked before the first rename, so no existing file is touched unless
 * the file system fails between two renames (an I/O error then leaves the
 * files renamed so far). A stop signal
 * (stopsig.h) while the temp files are written removes them and ends the
 * process by that signal; one that comes while they are renamed takes effect
 * after the last rename, so the set is never left half renamed. An auxiliary
 * file whose target already holds identical bytes is left alone, so writing
 * beside the input does not rewrite its textures. */
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

/* A file to write at a path of its own (another folder than the output's). */
typedef struct output_file {
    const char *path;
    const uint8_t *bytes;
    size_t size;
} output_file;

/* `main_path` is the output path the user named; files[i].name are relative to
 * its folder, files[0] being the main file; also[0 .. also_count) are written
 * with them, all or none (the --depfile). Before anything is written, a
 * target that is one of the guarded files (output_same_path) and would
 * change is refused with LP_USAGE ("T (written with the output) is a file the
 * input reads; choose another output name"): a .gltf output's .bin must not
 * overwrite the buffer its input reads. */
int output_write_all(const char *main_path, const gltf_out_file *files, size_t count, const output_file *also,
                     size_t also_count, const output_guard *guards, size_t guard_count, lp_error *err);

/* The same all-or-nothing write for files produced one at a time (the
 * simplify command's OBJs): output_set_begin, then output_stage for each
 * file as it is ready (its temp file is written at once, so the bytes need
 * not be kept), then output_commit, which renames them in the order staged;
 * output_set_end always, which removes what was not renamed and restores the
 * signals. The target's folder must exist (output_check_folder). One set at
 * a time; stage and commit only while no other thread runs (the stop signals
 * are held by the calling thread's mask, and a worker thread taking one then
 * would find the set changing). */
typedef struct output_set output_set;
int output_set_begin(output_set **set, lp_error *err);
int output_stage(output_set *set, const char *target, const uint8_t *bytes, size_t size, lp_error *err);
int output_commit(output_set *set, lp_error *err);
void output_set_end(output_set *set);

/* LP_OK when the folder of main_path exists and may be written to, and
 * main_path is not a folder, else the error output_write_all would give
 * (LP_IO). Callers check it before a long job too, so that a mistyped folder
 * fails at once rather than at the end; output_write_all checks again. */
int output_check_folder(const char *main_path, lp_error *err);

/* 1 when a and b name the same existing file: the same identity (device,
 * inode), or names that differ only in ASCII case in a folder whose file
 * system ignores case (output_folder_ignores_case). */
int output_same_file(const char *a, const char *b);

/* 1 when a and b name the same file, existing or not: the same existing
 * file (as output_same_file), or neither exists and both name the same entry
 * of the same folder, case aside where the folder ignores case (for a file
 * about to be written). */
int output_same_path(const char *a, const char *b);

/* 1 when the folder's file system ignores case (exFAT, a Windows or macOS
 * share): a hidden file made there under a lower-case name
 * (.lodpipe-case-probe-PID, removed at once) is found under the upper-case
 * one. Probed, not guessed: such a volume can be mounted anywhere. 0 when
 * the probe cannot be made (a read-only folder). */
int output_folder_ignores_case(const char *folder);

#endif
