/* fuzz_load.c - libFuzzer harness for the loader: any byte string through
 * scene_load_memory (GLB/JSON parsing, schema checks, buffer and view ranges,
 * Draco and meshopt decoding, accessor reading, node graph checks), then, when
 * it loads, through the writer (gltf_serialize, both formats, in memory).
 * A crash, a sanitizer report or a leak is a bug; a refusal is not. */
#include <stdlib.h>

#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    scene s;
    if (fuzz_load(data, size, &s) != LP_OK) return 0;
    static const char *const outputs[2] = {FUZZ_FOLDER "output.glb", FUZZ_FOLDER "output.gltf"};
    for (int k = 0; k < 2; ++k) {
        gltf_out_file *files = NULL;
        size_t count = 0;
        char msg[512];
        if (gltf_serialize(s.doc, outputs[k], &files, &count, msg, sizeof msg) == GLTF_OK) {
            gltf_free_files(files, count);
            free(files);
        }
    }
    scene_free(&s);
    return 0;
}
