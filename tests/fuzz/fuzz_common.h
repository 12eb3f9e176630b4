/* fuzz_common.h - what the libFuzzer harnesses share (tests/fuzz/fuzz_*.c).
 *
 * An input is a whole glTF file. It is loaded from memory under a name in a
 * folder that does not exist, so an external uri can never read a real file
 * (and one that climbs out is refused, as for the CLI). The name's extension
 * follows the input's first bytes, as a user would name the file. */
#ifndef LODPIPE_FUZZ_COMMON_H
#define LODPIPE_FUZZ_COMMON_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "scene.h"

#define FUZZ_FOLDER "/nonexistent-lodpipe-fuzz/"

/* Inputs above this size are not interesting for a loader that reads them in
 * one piece: the caps are tested by the CLI tests. */
#define FUZZ_MAX_INPUT_BYTES (1u << 20)

static inline const char *fuzz_input_name(const uint8_t *data, size_t size)
{
    return size >= 4 && memcmp(data, "glTF", 4) == 0 ? FUZZ_FOLDER "input.glb" : FUZZ_FOLDER "input.gltf";
}

static inline int fuzz_load(const uint8_t *data, size_t size, scene *s)
{
    scene_options opt;
    memset(&opt, 0, sizeof opt);
    opt.load.max_file_bytes = FUZZ_MAX_INPUT_BYTES;
    lp_error err = {0, "", 0};
    return scene_load_memory(data, size, fuzz_input_name(data, size), &opt, s, &err);
}

#endif
