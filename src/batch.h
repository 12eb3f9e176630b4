/* batch.h - lodpipe batch SRC_DIR -o OUT_DIR: the main job on every glTF file
 * of a folder tree, in parallel, incrementally, optionally one shard of it.
 *
 * What it promises
 * - Files: every regular file ending in .gltf or .glb (any case) below
 *   SRC_DIR, recursively, in byte order of the path relative to SRC_DIR.
 *   Names starting with '.' are skipped, and so is OUT_DIR when it lies
 *   inside SRC_DIR; symbolic links to files are followed, to folders not.
 * - Each file SRC_DIR/R is written to OUT_DIR/R (folders created as needed)
 *   by exactly the single-file run `lodpipe SRC_DIR/R -o OUT_DIR/R` with the
 *   same effective configuration, so the bytes are those of a single-file run
 *   (external .bin and images land beside it as that run writes them).
 * - Two files that would write the same file in OUT_DIR (a.gltf and a.GLTF
 *   both write a.bin; b/m.glb and a/m.glb when OUT_DIR/b links to a; Foo.glb
 *   and foo.glb on a case-insensitive volume) are refused before the launch:
 *   the later one in file order fails, naming the earlier; a texture replaced
 *   by another file's output with other bytes, found after the jobs, fails
 *   the later file, and the earlier one when its file was replaced (batch.c).
 *   An output that reaches a file inside SRC_DIR through a link in OUT_DIR
 *   fails its file before the launch: no source is replaced.
 * - A failing file is reported with the job's own one-line error; the other
 *   files complete. batch_run returns LP_OK when no file failed,
 *   LP_SOME_FAILED (5) when at least one did, and LP_USAGE / LP_IO when the
 *   batch itself cannot run (SRC_DIR unreadable, OUT_DIR not creatable, OUT_DIR
 *   equal to SRC_DIR).
 * - Cache: OUT_DIR/.lodpipe-cache.json records for each built file a SHA-256
 *   key over the tool version, the effective configuration (config_write's
 *   canonical text, run.threads left out: the output does not depend on it),
 *   the --allow-external-uris switch, the file's relative path and the bytes
 *   of the file and of every file it referenced (buffers, images), plus the
 *   SHA-256 of every file the job wrote (of the bytes it wrote, as its --json
 *   report gives them). A file is skipped ("cached") when its
 *   key is unchanged AND every output it wrote is still there with the
 *   recorded bytes; `force` rebuilds everything. A file whose inputs changed
 *   while its job ran (hash before the launch vs after, or a change time not
 *   before the launch) is built but not recorded, with a warning. The manifest is written
 *   all-or-nothing (src/output.c) at the end; entries of files outside the
 *   shard are kept, entries of failed or vanished files dropped. One batch at a
 *   time per OUT_DIR.
 * - Shards: with shard K/N only the files whose shard (batch_shard_of) is K-1
 *   run; the N shards are disjoint and together are the whole batch, whatever
 *   the machine, and a file keeps its shard when others are added or removed.
 * - Progress (files done / total, current file, ETA) only when stderr is a
 *   terminal and not `quiet`; a summary table on stdout, or with `json` one
 *   JSON object (README "Batch mode" lists its fields). */
#ifndef LODPIPE_BATCH_H
#define LODPIPE_BATCH_H

#include <stdint.h>

#include "config.h"

typedef struct batch_options {
    const char *source_dir;
    const char *output_dir;
    int jobs;                 /* files processed at once; 0 = one per core */
    uint32_t shard_index;     /* K of --shard K/N, 1-based; 0 with shard_count 0: everything */
    uint32_t shard_count;
    int force;                /* ignore the cache */
    int json;                 /* summary as JSON on stdout */
    int quiet;                /* no warnings or progress on stderr */
    int allow_external_uris;  /* passed to every job */
    const lp_config *config;  /* the effective configuration every job gets */
} batch_options;

/* Runs the batch; returns the exit code described above. */
int batch_run(const batch_options *options);

/* The shard, 0..shard_count-1, of a path relative to SRC_DIR: the first 8
 * bytes of SHA-256(path), big-endian, modulo shard_count. */
uint32_t batch_shard_of(const char *relative_path, uint32_t shard_count);

#endif
