// gltf_io.cpp - the C bridge over tinygltf 2.7 and nlohmann json; see gltf_io.h.
//
// Loading keeps two views of one file: the JSON document exactly as read
// (nlohmann::ordered_json, so the writer gives back what came in) and tinygltf's
// Model, which resolves buffers and images (GLB chunk, data: URIs, external files).
// tinygltf trusts the file in places (it indexes bufferViews and buffers without
// checking, and its Draco path dereferences unchecked attributes), so everything it
// would index is checked here first, and Draco is decoded through
// third_party/draco_codec instead of tinygltf's own path.

#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_INCLUDE_STB_IMAGE
#define TINYGLTF_NO_INCLUDE_STB_IMAGE_WRITE
#define TINYGLTF_USE_CPP14
#include <tiny_gltf.h>

#include "gltf_io.h"
#include "../draco_codec/draco_codec.h"

#include <meshoptimizer.h>
#include <nlohmann/json.hpp>

#include <fcntl.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <new>
#include <set>
#include <sstream>
#include <string>
#include <vector>

using ojson = nlohmann::ordered_json;

namespace {

const uint64_t kDefaultMaxFileBytes = 2ull << 30; // 2 GiB
// JSON arrays/objects nested deeper than this are refused before parsing: nlohmann
// copies (and tinygltf walks) values recursively, and ~20,000 levels overflow the
// stack. glTF itself nests about 8 levels; extras get the rest.
const size_t kMaxJsonDepth = 512;
const size_t kMaxJsonMembers = 16384; // members of one JSON object (json_shape_problem)
// Largest decoded / compressed size ratio accepted from meshopt compression (the
// codecs of libmeshoptimizer 0.18 stay below 64; room left for later versions).
const uint64_t kMeshoptMaxExpansion = 4096;
const char *kDraco = "KHR_draco_mesh_compression";
const char *kMeshopt = "EXT_meshopt_compression";
// The ratified version of the same extension: the same bufferView and fallback
// objects, its version-0 streams EXT's very bitstream, so both names go through
// one decoder. It adds version-1 attribute streams and the COLOR filter, which
// only a newer libmeshoptimizer decodes (see meshopt_unsupported).
const char *kMeshoptKhr = "KHR_meshopt_compression";
const char *const kMeshoptNames[] = {kMeshopt, kMeshoptKhr};

// Extensions lodpipe can honour when a file lists them as required: the ones it
// decodes, the quantization it reads, those that only concern data it passes
// through untouched (materials, textures, lights, instancing), and those the LOD
// chain carries over to its levels (animation pointers, node visibility).
const char *const kSupportedRequired[] = {
    "KHR_draco_mesh_compression", "EXT_meshopt_compression", "KHR_meshopt_compression", "KHR_mesh_quantization",
    "KHR_texture_transform", "KHR_texture_basisu", "EXT_texture_webp", "EXT_texture_avif",
    "KHR_materials_unlit", "KHR_materials_pbrSpecularGlossiness", "KHR_materials_emissive_strength",
    "KHR_materials_clearcoat", "KHR_materials_transmission", "KHR_materials_volume",
    "KHR_materials_ior", "KHR_materials_specular", "KHR_materials_sheen",
    "KHR_materials_iridescence", "KHR_materials_anisotropy", "KHR_materials_dispersion",
    "KHR_materials_diffuse_transmission", "KHR_materials_variants", "KHR_lights_punctual",
    "EXT_mesh_gpu_instancing", "KHR_xmp_json_ld", "KHR_texture_procedurals", "KHR_animation_pointer",
    "KHR_node_visibility"};

struct Failure {
    int code;
    std::string msg;
};

[[noreturn]] void fail(int code, const std::string &msg) { throw Failure{code, msg}; }

std::string at(const char *array, size_t i) { return std::string(array) + "[" + std::to_string(i) + "]"; }

// Text from the file shown in a message, cut after `limit` bytes (at a UTF-8
// character's start) with "...": a uri may be a megabyte of base64 or a name
// thousands of bytes long, and an error is one readable line.
std::string clipped(const std::string &text, size_t limit)
{
    if (text.size() <= limit) return text;
    size_t n = limit;
    while (n > 0 && (static_cast<unsigned char>(text[n]) & 0xC0) == 0x80) --n;
    return text.substr(0, n) + "...";
}

// A string of the file (a uri, a pointer, a name) quoted in a message: its
// first 60 bytes, enough to recognise it.
std::string quoted(const std::string &text) { return "\"" + clipped(text, 60) + "\""; }

// ---- schema: the types of every property glTF 2.0 defines -----------------------

enum Kind { UINT, NUM, STR, BOOL, OBJ, ARR, ARR_UINT, ARR_NUM, ARR_STR, ARR_OBJ, ANY };

struct Prop {
    const char *name;
    Kind kind;
    const struct Shape *shape; // for OBJ / ARR_OBJ: the nested object's shape
    // for UINT / ARR_UINT: the root array the index (each element) refers to. Checked
    // here for every reference the C side does not read itself: lodpipe appends nodes,
    // meshes, accessors and bufferViews, so an index one past the end would otherwise
    // come out pointing at a LOD node or a LOD index accessor, silently valid
    const char *refers = nullptr;
};

struct Shape {
    std::vector<Prop> props;
};

bool is_uint(const ojson &v) { return v.is_number_unsigned() || (v.is_number_integer() && v.get<int64_t>() >= 0); }

const char *kind_name(Kind k)
{
    switch (k) {
    case UINT: return "a non-negative integer";
    case NUM: return "a number";
    case STR: return "a string";
    case BOOL: return "a boolean";
    case OBJ: return "an object";
    case ARR: return "an array";
    case ARR_UINT: return "an array of non-negative integers";
    case ARR_NUM: return "an array of numbers";
    case ARR_STR: return "an array of strings";
    case ARR_OBJ: return "an array of objects";
    case ANY: return "anything";
    }
    return "?";
}

bool kind_ok(const ojson &v, Kind k)
{
    switch (k) {
    case UINT: return is_uint(v);
    case NUM: return v.is_number();
    case STR: return v.is_string();
    case BOOL: return v.is_boolean();
    case OBJ: return v.is_object();
    case ARR: return v.is_array();
    case ARR_UINT:
        if (!v.is_array()) return false;
        for (auto &e : v) if (!is_uint(e)) return false;
        return true;
    case ARR_NUM:
        if (!v.is_array()) return false;
        for (auto &e : v) if (!e.is_number()) return false;
        return true;
    case ARR_STR:
        if (!v.is_array()) return false;
        for (auto &e : v) if (!e.is_string()) return false;
        return true;
    case ARR_OBJ:
        if (!v.is_array()) return false;
        for (auto &e : v) if (!e.is_object()) return false;
        return true;
    case ANY: return true;
    }
    return false;
}

void check_object(const ojson &root, const ojson &o, const Shape &shape, const std::string &path);

size_t root_count(const ojson &root, const char *array)
{
    auto it = root.find(array);
    return it != root.end() && it->is_array() ? it->size() : 0;
}

// Index v (a non-negative integer) must be below count; `what` names the counted things.
void check_index(const ojson &v, size_t count, const std::string &what, const std::string &path)
{
    if (v.get<uint64_t>() >= count)
        fail(GLTF_INVALID, path + " = " + std::to_string(v.get<uint64_t>()) + " does not exist (" + std::to_string(count) +
                               " " + what + ")");
}

void check_reference(const ojson &root, const ojson &v, const char *refers, const std::string &path)
{
    check_index(v, root_count(root, refers), refers, path);
}

void check_value(const ojson &root, const ojson &v, const Prop &p, const std::string &path)
{
    if (!kind_ok(v, p.kind)) fail(GLTF_INVALID, path + " must be " + kind_name(p.kind));
    if (p.refers && p.kind == UINT) check_reference(root, v, p.refers, path);
    if (p.refers && p.kind == ARR_UINT)
        for (size_t i = 0; i < v.size(); ++i) check_reference(root, v[i], p.refers, path + "[" + std::to_string(i) + "]");
    if (p.shape && p.kind == OBJ) check_object(root, v, *p.shape, path);
    if (p.shape && p.kind == ARR_OBJ)
        for (size_t i = 0; i < v.size(); ++i) check_object(root, v[i], *p.shape, path + "[" + std::to_string(i) + "]");
}

// "extensions" must be an object of objects; "extras" may be anything.
void check_common(const ojson &o, const std::string &path)
{
    auto ext = o.find("extensions");
    if (ext != o.end()) {
        const std::string where = path.empty() ? std::string("extensions") : path + ".extensions";
        if (!ext->is_object()) fail(GLTF_INVALID, where + " must be an object");
        for (auto it = ext->begin(); it != ext->end(); ++it)
            if (!it.value().is_object())
                fail(GLTF_INVALID, where + "." + it.key() + " must be an object");
    }
    auto name = o.find("name");
    if (name != o.end() && !name->is_string()) fail(GLTF_INVALID, path + ".name must be a string");
}

void check_object(const ojson &root, const ojson &o, const Shape &shape, const std::string &path)
{
    check_common(o, path);
    for (const Prop &p : shape.props) {
        auto it = o.find(p.name);
        if (it != o.end()) check_value(root, *it, p, path.empty() ? std::string(p.name) : path + "." + p.name);
    }
}

const Shape kTextureInfo{{{"index", UINT, nullptr, "textures"}, {"texCoord", UINT, nullptr}, {"scale", NUM, nullptr}, {"strength", NUM, nullptr}}};
const Shape kPbr{{{"baseColorFactor", ARR_NUM, nullptr}, {"baseColorTexture", OBJ, &kTextureInfo},
                  {"metallicFactor", NUM, nullptr}, {"roughnessFactor", NUM, nullptr},
                  {"metallicRoughnessTexture", OBJ, &kTextureInfo}}};
const Shape kMaterial{{{"pbrMetallicRoughness", OBJ, &kPbr}, {"normalTexture", OBJ, &kTextureInfo},
                       {"occlusionTexture", OBJ, &kTextureInfo}, {"emissiveTexture", OBJ, &kTextureInfo},
                       {"emissiveFactor", ARR_NUM, nullptr}, {"alphaMode", STR, nullptr},
                       {"alphaCutoff", NUM, nullptr}, {"doubleSided", BOOL, nullptr}}};
const Shape kSparseIndices{{{"bufferView", UINT, nullptr, "bufferViews"}, {"byteOffset", UINT, nullptr}, {"componentType", UINT, nullptr}}};
const Shape kSparseValues{{{"bufferView", UINT, nullptr, "bufferViews"}, {"byteOffset", UINT, nullptr}}};
const Shape kSparse{{{"count", UINT, nullptr}, {"indices", OBJ, &kSparseIndices}, {"values", OBJ, &kSparseValues}}};
const Shape kAccessor{{{"bufferView", UINT, nullptr, "bufferViews"}, {"byteOffset", UINT, nullptr}, {"componentType", UINT, nullptr},
                       {"normalized", BOOL, nullptr}, {"count", UINT, nullptr}, {"type", STR, nullptr},
                       {"max", ARR_NUM, nullptr}, {"min", ARR_NUM, nullptr}, {"sparse", OBJ, &kSparse}}};
const Shape kTarget{{{"node", UINT, nullptr, "nodes"}, {"path", STR, nullptr}}};
const Shape kChannel{{{"sampler", UINT, nullptr}, {"target", OBJ, &kTarget}}};
const Shape kAnimSampler{{{"input", UINT, nullptr, "accessors"}, {"output", UINT, nullptr, "accessors"}, {"interpolation", STR, nullptr}}};
const Shape kAnimation{{{"channels", ARR_OBJ, &kChannel}, {"samplers", ARR_OBJ, &kAnimSampler}}};
const Shape kAsset{{{"version", STR, nullptr}, {"minVersion", STR, nullptr}, {"generator", STR, nullptr}, {"copyright", STR, nullptr}}};
const Shape kBuffer{{{"uri", STR, nullptr}, {"byteLength", UINT, nullptr}}};
const Shape kBufferView{{{"buffer", UINT, nullptr}, {"byteOffset", UINT, nullptr}, {"byteLength", UINT, nullptr},
                         {"byteStride", UINT, nullptr}, {"target", UINT, nullptr}}};
const Shape kPerspective{{{"aspectRatio", NUM, nullptr}, {"yfov", NUM, nullptr}, {"zfar", NUM, nullptr}, {"znear", NUM, nullptr}}};
const Shape kOrthographic{{{"xmag", NUM, nullptr}, {"ymag", NUM, nullptr}, {"zfar", NUM, nullptr}, {"znear", NUM, nullptr}}};
const Shape kCamera{{{"type", STR, nullptr}, {"perspective", OBJ, &kPerspective}, {"orthographic", OBJ, &kOrthographic}}};
const Shape kImage{{{"uri", STR, nullptr}, {"mimeType", STR, nullptr}, {"bufferView", UINT, nullptr}}};
const Shape kPrimitive{{{"attributes", OBJ, nullptr}, {"indices", UINT, nullptr}, {"material", UINT, nullptr},
                        {"mode", UINT, nullptr}, {"targets", ARR_OBJ, nullptr}}};
const Shape kMesh{{{"primitives", ARR_OBJ, &kPrimitive}, {"weights", ARR_NUM, nullptr}}};
const Shape kNode{{{"camera", UINT, nullptr}, {"children", ARR_UINT, nullptr}, {"skin", UINT, nullptr},
                   {"matrix", ARR_NUM, nullptr}, {"mesh", UINT, nullptr}, {"rotation", ARR_NUM, nullptr},
                   {"scale", ARR_NUM, nullptr}, {"translation", ARR_NUM, nullptr}, {"weights", ARR_NUM, nullptr}}};
const Shape kSampler{{{"magFilter", UINT, nullptr}, {"minFilter", UINT, nullptr}, {"wrapS", UINT, nullptr}, {"wrapT", UINT, nullptr}}};
const Shape kScene{{{"nodes", ARR_UINT, nullptr}}};
const Shape kSkin{{{"inverseBindMatrices", UINT, nullptr, "accessors"}, {"skeleton", UINT, nullptr, "nodes"},
                   {"joints", ARR_UINT, nullptr, "nodes"}}};
const Shape kTexture{{{"sampler", UINT, nullptr, "samplers"}, {"source", UINT, nullptr, "images"}}};
const Shape kRoot{{{"extensionsUsed", ARR_STR, nullptr}, {"extensionsRequired", ARR_STR, nullptr},
                   {"accessors", ARR_OBJ, &kAccessor}, {"animations", ARR_OBJ, &kAnimation},
                   {"asset", OBJ, &kAsset}, {"buffers", ARR_OBJ, &kBuffer}, {"bufferViews", ARR_OBJ, &kBufferView},
                   {"cameras", ARR_OBJ, &kCamera}, {"images", ARR_OBJ, &kImage}, {"materials", ARR_OBJ, &kMaterial},
                   {"meshes", ARR_OBJ, &kMesh}, {"nodes", ARR_OBJ, &kNode}, {"samplers", ARR_OBJ, &kSampler},
                   {"scene", UINT, nullptr}, {"scenes", ARR_OBJ, &kScene}, {"skins", ARR_OBJ, &kSkin},
                   {"textures", ARR_OBJ, &kTexture}}};

// References the schema cannot declare: a channel's sampler indexes its own
// animation's samplers; KHR_materials_variants mappings name materials and the
// root's variants; EXT_mesh_gpu_instancing maps names to accessors; a
// KHR_animation_pointer pointer that names an element of an array lodpipe
// appends to (a pointer past the end would come out aiming at a LOD node).
bool has_ext(const ojson &o, const char *name);
const ojson &array_of(const ojson &root, const char *name);

void check_local_references(const ojson &root)
{
    const ojson &animations = array_of(root, "animations");
    for (size_t a = 0; a < animations.size(); ++a) {
        const size_t samplers = animations[a].value("samplers", ojson::array()).size();
        const ojson &channels = animations[a].value("channels", ojson::array());
        for (size_t c = 0; c < channels.size(); ++c) {
            const std::string path = at("animations", a) + ".channels[" + std::to_string(c) + "]";
            if (!channels[c].contains("sampler")) fail(GLTF_INVALID, path + ".sampler is missing");
            check_index(channels[c]["sampler"], samplers, "samplers in the animation", path + ".sampler");
            auto target = channels[c].find("target");
            if (target == channels[c].end() || !has_ext(*target, "KHR_animation_pointer")) continue;
            const ojson &pointer = (*target)["extensions"]["KHR_animation_pointer"].value("pointer", ojson());
            if (!pointer.is_string()) continue;
            const std::string ptr = pointer.get<std::string>();
            for (const char *array : {"nodes", "meshes", "accessors", "bufferViews"}) {
                const std::string prefix = std::string("/") + array + "/";
                if (ptr.compare(0, prefix.size(), prefix) != 0) continue;
                size_t end = prefix.size();
                uint64_t index = 0;
                while (end < ptr.size() && ptr[end] >= '0' && ptr[end] <= '9' && index < (uint64_t(1) << 40))
                    index = index * 10 + uint64_t(ptr[end++] - '0');
                if (end > prefix.size() && index >= root_count(root, array))
                    fail(GLTF_INVALID, path + ".target.extensions.KHR_animation_pointer.pointer " + quoted(ptr) +
                                           " names an element that does not exist (" +
                                           std::to_string(root_count(root, array)) + " " + array + ")");
            }
        }
    }
    // KHR_materials_variants: the mappings are copied onto every LOD primitive
    size_t variants = 0;
    if (has_ext(root, "KHR_materials_variants")) {
        const ojson &list = root["extensions"]["KHR_materials_variants"].value("variants", ojson::array());
        variants = list.is_array() ? list.size() : 0;
    }
    const ojson &meshes = array_of(root, "meshes");
    for (size_t m = 0; m < meshes.size(); ++m) {
        const ojson &prims = meshes[m].value("primitives", ojson::array());
        for (size_t p = 0; p < prims.size(); ++p) {
            if (!has_ext(prims[p], "KHR_materials_variants")) continue;
            const std::string path = at("meshes", m) + ".primitives[" + std::to_string(p) + "].extensions.KHR_materials_variants";
            const ojson &mappings = prims[p]["extensions"]["KHR_materials_variants"].value("mappings", ojson::array());
            if (!mappings.is_array()) fail(GLTF_INVALID, path + ".mappings must be an array");
            for (size_t k = 0; k < mappings.size(); ++k) {
                const std::string mp = path + ".mappings[" + std::to_string(k) + "]";
                if (!mappings[k].is_object()) fail(GLTF_INVALID, mp + " must be an object");
                auto material = mappings[k].find("material");
                if (material == mappings[k].end() || !is_uint(*material))
                    fail(GLTF_INVALID, mp + ".material is missing or not a non-negative integer");
                check_reference(root, *material, "materials", mp + ".material");
                const ojson &list = mappings[k].value("variants", ojson::array());
                if (!kind_ok(list, ARR_UINT)) fail(GLTF_INVALID, mp + ".variants must be an array of non-negative integers");
                for (size_t i = 0; i < list.size(); ++i)
                    check_index(list[i], variants, "variants", mp + ".variants[" + std::to_string(i) + "]");
            }
        }
    }
    const ojson &nodes = array_of(root, "nodes");
    for (size_t n = 0; n < nodes.size(); ++n) {
        if (!has_ext(nodes[n], "EXT_mesh_gpu_instancing")) continue;
        const ojson &attributes = nodes[n]["extensions"]["EXT_mesh_gpu_instancing"].value("attributes", ojson::object());
        if (!attributes.is_object()) continue;
        for (auto it = attributes.begin(); it != attributes.end(); ++it) {
            const std::string path = at("nodes", n) + ".extensions.EXT_mesh_gpu_instancing.attributes." + it.key();
            if (!is_uint(it.value())) fail(GLTF_INVALID, path + " must be a non-negative integer");
            check_reference(root, it.value(), "accessors", path);
        }
    }
}

// Primitive attributes and morph targets map names to accessor indices.
void check_attribute_maps(const ojson &root)
{
    auto meshes = root.find("meshes");
    if (meshes == root.end()) return;
    for (size_t m = 0; m < meshes->size(); ++m) {
        const ojson &prims = (*meshes)[m].value("primitives", ojson::array());
        for (size_t p = 0; p < prims.size(); ++p) {
            std::string path = at("meshes", m) + ".primitives[" + std::to_string(p) + "]";
            auto attrs = prims[p].find("attributes");
            if (attrs == prims[p].end()) fail(GLTF_INVALID, path + " has no attributes");
            for (auto it = attrs->begin(); it != attrs->end(); ++it)
                if (!is_uint(it.value()))
                    fail(GLTF_INVALID, path + ".attributes." + it.key() + " must be a non-negative integer");
            auto targets = prims[p].find("targets");
            if (targets == prims[p].end()) continue;
            for (size_t t = 0; t < targets->size(); ++t)
                for (auto it = (*targets)[t].begin(); it != (*targets)[t].end(); ++it)
                    if (!is_uint(it.value()))
                        fail(GLTF_INVALID, path + ".targets[" + std::to_string(t) + "]." + it.key() +
                                               " must be a non-negative integer");
        }
    }
}

// ---- small helpers ---------------------------------------------------------------

uint64_t u64(const ojson &o, const char *key, uint64_t def)
{
    auto it = o.find(key);
    return it == o.end() ? def : it->get<uint64_t>();
}

int64_t i64_or_none(const ojson &o, const char *key)
{
    auto it = o.find(key);
    return it == o.end() ? -1 : int64_t(it->get<uint64_t>() > (uint64_t(1) << 62) ? (uint64_t(1) << 62) : it->get<uint64_t>());
}

bool has_ext(const ojson &o, const char *name)
{
    auto e = o.find("extensions");
    return e != o.end() && e->is_object() && e->contains(name);
}

void erase_ext(ojson &o, const char *name)
{
    auto e = o.find("extensions");
    if (e == o.end()) return;
    e->erase(name);
    if (e->empty()) o.erase("extensions");
}

// Whether st is an anonymous pipe (what `cmd | lodpipe /dev/stdin` and
// `lodpipe <(cmd)` hand over): it lives on the kernel's pipe file system, the
// one a pipe() of our own lives on; a named pipe (mkfifo) lives in a folder's.
bool is_anonymous_pipe(const struct stat &st)
{
    if (!S_ISFIFO(st.st_mode)) return false;
    int fds[2];
    if (pipe(fds) != 0) return false;
    struct stat own;
    const bool same = fstat(fds[0], &own) == 0 && own.st_dev == st.st_dev;
    close(fds[0]);
    close(fds[1]);
    return same;
}

// Whether st is the file that this process's standard input holds open (when
// `own`, the descriptor the loader opened itself, is not it: that one must not
// vouch for the name it opened): `lodpipe /dev/stdin < fifo`, where the shell
// opened the named pipe, waiting for its writer, before lodpipe ran. Only the
// standard input: a named pipe that is lodpipe's stdout or stderr has lodpipe
// itself as its writer, and reading it would wait for bytes that never come.
bool is_standard_input(const struct stat &st, int own)
{
    struct stat held;
    return own != 0 && fstat(0, &held) == 0 && held.st_dev == st.st_dev && held.st_ino == st.st_ino;
}

// Why the input at st cannot be read as a file, or "" when it can: a regular
// file, an anonymous pipe, or a named pipe the shell already opened as
// lodpipe's standard input. Any other named pipe is refused: opening it
// waits for a writer, so a stray FIFO would hang a build forever; a device may
// never end (/dev/zero). own: the descriptor the loader opened, or -1.
std::string unreadable_kind(const struct stat &st, int own)
{
    if (S_ISREG(st.st_mode) || is_anonymous_pipe(st)) return "";
    if (S_ISFIFO(st.st_mode) && is_standard_input(st, own)) return "";
    if (S_ISDIR(st.st_mode)) return "is a directory";
    if (S_ISFIFO(st.st_mode)) return "is not a regular file (a named pipe, FIFO)";
    if (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode)) return "is not a regular file (a device)";
    return "is not a regular file";
}

// "cannot read (reason)" for errno; out of memory (fdopen's buffer) throws,
// to be told as such rather than as a file that cannot be read.
std::string read_error()
{
    if (errno == ENOMEM) throw std::bad_alloc();
    return std::string("cannot read (") + strerror(errno) + ")";
}

// Reads the input file whole into *out. A regular file, or an anonymous pipe
// (`lodpipe <(curl ...)`, `... | lodpipe /dev/stdin`) read to its end, are
// accepted; a directory, a named pipe or a device is refused without waiting
// (see unreadable_kind): the path is looked at before it is opened, and what
// was opened (without blocking) is looked at again, in case the name changed
// in between. On failure *why says what went wrong and *code its class,
// whatever errno an earlier call left: GLTF_IO when the file cannot be read
// as one, GLTF_INVALID when it is larger than cap (a loader limit, not an I/O
// error).
bool read_file(const std::string &path, uint64_t cap, std::vector<uint8_t> *out, std::string *why, int *code)
{
    *code = GLTF_IO;
    struct stat st;
    if (stat(path.c_str(), &st) != 0) {
        *why = read_error();
        return false;
    }
    if (!(*why = unreadable_kind(st, -1)).empty()) return false;
    const std::string too_large = "is larger than the " + std::to_string(cap) + "-byte limit";
    if (uint64_t(st.st_size) > cap) {
        *why = too_large;
        *code = GLTF_INVALID;
        return false;
    }
    const int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        *why = read_error();
        return false;
    }
    // closed on every way out, an allocation failure's exception included
    std::unique_ptr<FILE, int (*)(FILE *)> file(fdopen(fd, "rb"), fclose);
    FILE *f = file.get();
    if (!f) {
        const int error = errno;
        close(fd);
        errno = error;
        *why = read_error();
        return false;
    }
    if (fstat(fd, &st) != 0 || !(*why = unreadable_kind(st, fd)).empty()) {
        if (why->empty()) *why = read_error();
        return false;
    }
    // reads wait again: a pipe's writer may be slower than lodpipe
    if (fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) & ~O_NONBLOCK) != 0) {
        *why = read_error();
        return false;
    }
    out->clear();
    bool ok = true;
    uint8_t chunk[1 << 16];
    for (size_t got; ok && (got = fread(chunk, 1, sizeof chunk, f)) > 0;) {
        if (uint64_t(out->size()) + got > cap) {
            *why = too_large;
            *code = GLTF_INVALID;
            ok = false;
        } else {
            out->insert(out->end(), chunk, chunk + got);
        }
    }
    if (ok && ferror(f)) {
        *why = read_error();
        ok = false;
    }
    return ok;
}

// An external buffer or image must be a regular file: a directory would be
// "read" as an absurd size, a FIFO would block the run. Returns its size.
uint64_t require_regular_file(const std::string &full, const std::string &what, const std::string &uri)
{
    struct stat st;
    if (stat(full.c_str(), &st) != 0) fail(GLTF_IO, what + ": cannot read " + quoted(uri));
    if (!S_ISREG(st.st_mode)) fail(GLTF_IO, what + ": cannot read " + quoted(uri) + " (not a regular file)");
    return uint64_t(st.st_size);
}

// An external buffer's or image's size, refused when it is over the cap the
// reader keeps to (its bytes would not be read).
uint64_t require_file_within_cap(const std::string &full, const std::string &what, const std::string &uri,
                                 const gltf_load_options &opt)
{
    const uint64_t size = require_regular_file(full, what, uri);
    const uint64_t cap = opt.max_file_bytes ? opt.max_file_bytes : kDefaultMaxFileBytes;
    if (size > cap)
        fail(GLTF_INVALID, what + ": " + quoted(uri) + " is too large (" + std::to_string(size) + " bytes; at most " +
                               std::to_string(cap) + ")");
    return size;
}

std::string dir_of(const std::string &path)
{
    size_t slash = path.find_last_of('/');
    return slash == std::string::npos ? std::string(".") : path.substr(0, slash);
}

std::string base_of(const std::string &path)
{
    size_t slash = path.find_last_of('/');
    return slash == std::string::npos ? path : path.substr(slash + 1);
}

bool ends_with_ci(const std::string &s, const char *suffix)
{
    size_t n = strlen(suffix);
    if (s.size() < n) return false;
    for (size_t i = 0; i < n; ++i)
        if (tolower((unsigned char)s[s.size() - n + i]) != tolower((unsigned char)suffix[i])) return false;
    return true;
}

bool is_data_uri(const std::string &uri) { return uri.compare(0, 5, "data:") == 0; }

// glTF's data uris carry base64 ("data:[<mediatype>];base64,<data>"); one
// without it is malformed input (tinygltf would look for a file of that name).
void require_base64_data_uri(const std::string &where, const std::string &uri)
{
    const size_t comma = uri.find(',');
    if (comma == std::string::npos || comma < 12 || uri.compare(comma - 7, 7, ";base64") != 0)
        fail(GLTF_INVALID, where + ".uri is a data: uri without \";base64,\" (glTF data uris are base64)");
}

// A scheme ("file:", "http:") is a ':' of the uri itself before any '/'; an
// encoded one (%3A) is part of a file name, as lodpipe writes "x:y.bin".
bool uri_has_scheme(const std::string &uri)
{
    const size_t colon = uri.find(':'), slash = uri.find('/');
    return colon != std::string::npos && (slash == std::string::npos || colon < slash);
}

// An external uri must stay inside the input's folder: relative, no "..", no scheme.
bool uri_escapes(const std::string &uri, const std::string &decoded)
{
    if (decoded.empty() || decoded[0] == '/' || decoded[0] == '\\') return true;
    if (uri_has_scheme(uri)) return true;
    if (decoded.size() >= 2 && decoded[1] == ':' && isalpha((unsigned char)decoded[0])) return true; // C:
    std::stringstream ss(decoded);
    std::string seg;
    while (std::getline(ss, seg, '/'))
        if (seg == "..") return true;
    return false;
}

// A file name, or with keep_slash a path, as a uri reference (RFC 3986):
// unreserved characters and the sub-delimiters stay, everything else (space,
// %, #, ?, :, non-ASCII bytes of UTF-8) is percent-encoded, so "a%20b.gltf"
// refers to "a%2520b.bin" and a reader decodes it back to the file's name.
std::string uri_of_name(const std::string &name, bool keep_slash = false)
{
    static const char *const kHex = "0123456789ABCDEF";
    std::string out;
    for (unsigned char ch : name) {
        const bool alnum = (ch >= '0' && ch <= '9') || (ch >= 'A' && ch <= 'Z') || (ch >= 'a' && ch <= 'z');
        if (alnum || (ch && strchr("-._~!$&'()*+,;=@", ch)) || (keep_slash && ch == '/')) {
            out.push_back(char(ch));
        } else {
            out.push_back('%');
            out.push_back(kHex[ch >> 4]);
            out.push_back(kHex[ch & 15]);
        }
    }
    return out;
}

// The file an external uri names: the input's folder joined with the decoded
// uri; an absolute path or a file:// uri as it is (the load refuses those
// without --allow-external-uris); "" for any other scheme (http:, ...) or a
// file:// uri of another host: not a file lodpipe can read.
std::string resolve_uri(const std::string &dir, const std::string &uri)
{
    if (uri.size() >= 7 && strncasecmp(uri.c_str(), "file://", 7) == 0) {
        std::string rest = uri.substr(7);
        if (rest.compare(0, 9, "localhost") == 0) rest = rest.substr(9);
        return !rest.empty() && rest[0] == '/' ? tinygltf::dlib::urldecode(rest) : std::string();
    }
    if (uri_has_scheme(uri)) return std::string();
    const std::string decoded = tinygltf::dlib::urldecode(uri);
    if (!decoded.empty() && decoded[0] == '/') return decoded;
    return dir == "." ? decoded : tinygltf::JoinPath(dir, decoded);
}

uint32_t rd32(const uint8_t *p) { return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24; }

void wr32(std::vector<uint8_t> &v, uint32_t x)
{
    for (int i = 0; i < 4; ++i) v.push_back(uint8_t(x >> (8 * i)));
}

int component_size(int ctype)
{
    switch (ctype) {
    case 5120: case 5121: return 1;
    case 5122: case 5123: return 2;
    case 5125: case 5126: return 4;
    default: return 0;
    }
}

int type_components(const std::string &t, int *is_matrix)
{
    *is_matrix = 0;
    if (t == "SCALAR") return 1;
    if (t == "VEC2") return 2;
    if (t == "VEC3") return 3;
    if (t == "VEC4") return 4;
    *is_matrix = 1;
    if (t == "MAT2") return 4;
    if (t == "MAT3") return 9;
    if (t == "MAT4") return 16;
    *is_matrix = 0;
    return 0;
}

bool load_image_as_is(tinygltf::Image *image, const int, std::string *, std::string *, int, int,
                      const unsigned char *bytes, int size, void *)
{
    image->image.assign(bytes, bytes + (size > 0 ? size : 0));
    image->as_is = true;
    return true;
}

} // namespace

// ---- the document ----------------------------------------------------------------

struct ViewBytes {
    const uint8_t *ptr = nullptr; // into a loaded buffer, or into owned
    size_t size = 0;
    int slot = 0; // output buffer: 0 the main one, 1 the side buffer (gltf_add_view_in)
    int64_t replaces = -1; // the view this one takes the place of (gltf_view_replaces)
    std::vector<uint8_t> owned;
};

struct CPrimitive {
    std::vector<gltf_attribute> attributes;
    std::vector<std::vector<gltf_attribute>> targets;
    std::vector<size_t> target_counts;
    std::vector<const gltf_attribute *> target_ptrs;
    std::vector<std::string> names; // storage for attribute names
    gltf_primitive rec;
};

struct __attribute__((visibility("default"))) gltf_doc;
struct gltf_doc {
    ojson json;
    std::string path, dir;
    tinygltf::Model model; // owns the loaded buffer and image bytes
    std::vector<ViewBytes> views; // one per bufferViews[] entry, same order
    // Views something pointed at when the file was read: one of them that
    // nothing points at any more (a decoded Draco stream, vertex data that
    // was rewritten elsewhere) is dropped on writing; views the input itself
    // left unused are kept, as everything else is.
    std::vector<uint8_t> referenced_at_load;
    std::map<size_t, std::vector<uint8_t>> external_images; // image index -> file bytes

    // C records, built after loading
    std::vector<std::vector<CPrimitive>> prims;
    std::vector<std::pair<size_t, size_t>> draco_decoded; // (mesh, primitive) decoded from KHR_draco_mesh_compression
    std::vector<std::vector<int64_t>> node_children, node_lods, scene_nodes;
    std::vector<std::string> names[GLTF_KIND_COUNT];
    std::vector<std::string> ext_used, ext_required;
    std::vector<std::string> external_files; // files the load read besides the input (gltf_external_file)
    std::vector<uint8_t> fallback_read; // per buffer: a meshopt fallback whose data a view uses (resolve_views)
    bool binary_released = false; // gltf_release_binary was called: no bytes to read or write

    // gltf_accessor_refs' counts for every accessor, computed in one walk of
    // the document when asked after a change: a walk per call made a scene of
    // N meshes cost N^2 (2,000 small meshes: minutes). Every C API function
    // that edits `json` goes through before_edit, which keeps them right
    // (edit_keeps_counts; a primitive's reference, with after_reference_set)
    // or drops them (json_changed).
    mutable std::vector<size_t> accessor_ref_counts;
    mutable bool accessor_ref_counts_valid = false;
    void json_changed() const { accessor_ref_counts_valid = false; }
    // A call of the C API ran out of memory: an edit may be missing or half
    // made, so the document is never written (gltf_serialize refuses it).
    mutable bool out_of_memory = false;
    std::vector<size_t> accessor_refs_at_load; // the same counts as the load left the document
};

static std::vector<size_t> walk_accessor_refs(const gltf_doc *doc); // (editing, below)

// Out of memory. nlohmann::json allocates while it destroys a value (a stack
// for its children), and an exception cannot leave a destructor: a failed
// allocation there would end the process with std::terminate. So a reserve is
// set aside when the program starts and given back at the first allocation
// that fails; the allocation is then tried again, and the unwinding and the
// error report after a later failure have memory to run in. Once the reserve
// is spent, a failure throws std::bad_alloc as usual.
static constexpr size_t kMemoryReserveBytes = size_t(8) << 20;
static std::atomic<void *> g_memory_reserve{nullptr};

static void give_back_reserve()
{
    void *reserve = g_memory_reserve.exchange(nullptr);
    if (!reserve) throw std::bad_alloc();
    std::free(reserve);
}

static const bool g_memory_reserve_set = [] {
    g_memory_reserve.store(std::malloc(kMemoryReserveBytes));
    std::set_new_handler(give_back_reserve);
    return true;
}();

// Runs `body` for a C API call: nothing is thrown into C. Any exception gives
// `failed`; one from an edit may have left it half made, so the accessor
// counts are dropped, and an allocation failure marks the document (see
// out_of_memory).
template <typename R, typename F> static R guarded(const gltf_doc *doc, R failed, F &&body) noexcept
{
    try {
        return body();
    } catch (const std::bad_alloc &) {
        doc->out_of_memory = true;
    } catch (...) {
    }
    doc->json_changed();
    return failed;
}

namespace {

const char *const kKindArrays[GLTF_KIND_COUNT] = {"accessors", "animations", "buffers", "bufferViews", "cameras",
                                                  "images", "materials", "meshes", "nodes", "samplers",
                                                  "scenes", "skins", "textures"};

const ojson &array_of(const ojson &root, const char *name)
{
    static const ojson empty = ojson::array();
    auto it = root.find(name);
    return it == root.end() ? empty : *it;
}

// Splits a GLB into its JSON text and BIN chunk, checking every length and the
// chunk order the GLB spec fixes: JSON first, at most one BIN and only second,
// other chunk types skipped. A second JSON chunk or a misplaced BIN is refused
// rather than ignored: which one a reader takes is a guess, and the other's data
// would be lost.
void parse_glb(const std::vector<uint8_t> &file, std::string *json_text, const uint8_t **bin, size_t *bin_size)
{
    if (file.size() < 20) fail(GLTF_INVALID, "GLB file too short for a header (" + std::to_string(file.size()) + " bytes)");
    if (rd32(&file[4]) != 2) fail(GLTF_INVALID, "GLB version " + std::to_string(rd32(&file[4])) + " is not 2");
    if (rd32(&file[8]) != file.size())
        fail(GLTF_INVALID, "GLB header says " + std::to_string(rd32(&file[8])) + " bytes but the file has " +
                               std::to_string(file.size()));
    size_t pos = 12;
    *bin = nullptr;
    *bin_size = 0;
    bool have_json = false;
    for (int chunk = 0; pos < file.size(); ++chunk) {
        if (file.size() - pos < 8) fail(GLTF_INVALID, "GLB chunk " + std::to_string(chunk) + " header is truncated");
        uint64_t len = rd32(&file[pos]);
        uint32_t type = rd32(&file[pos + 4]);
        pos += 8;
        if (len > file.size() - pos)
            fail(GLTF_INVALID, "GLB chunk " + std::to_string(chunk) + " runs past the end of the file");
        const std::string which = "GLB chunk " + std::to_string(chunk);
        if (chunk == 0) {
            if (type != 0x4E4F534Au) fail(GLTF_INVALID, "GLB first chunk is not JSON");
            json_text->assign(reinterpret_cast<const char *>(&file[pos]), size_t(len));
            have_json = true;
        } else if (type == 0x4E4F534Au) {
            fail(GLTF_INVALID, which + " is a second JSON chunk (a GLB has one, the first)");
        } else if (type == 0x004E4942u) {
            if (chunk != 1) fail(GLTF_INVALID, which + " is a BIN chunk (a GLB has at most one, the second)");
            *bin = &file[pos];
            *bin_size = size_t(len);
        }
        pos += size_t(len);
    }
    if (!have_json) fail(GLTF_INVALID, "GLB has no JSON chunk");
}

void check_asset_and_extensions(const ojson &root)
{
    auto asset = root.find("asset");
    if (asset == root.end() || !asset->is_object()) fail(GLTF_INVALID, "asset is missing (not a glTF 2.0 file?)");
    auto ver = asset->find("version");
    if (ver == asset->end()) fail(GLTF_INVALID, "asset.version is missing");
    if (!ver->is_string()) fail(GLTF_INVALID, "asset.version must be a string such as \"2.0\"");
    const std::string v = ver->get<std::string>();
    if (v.size() < 2 || v[0] != '2' || v[1] != '.')
        fail(GLTF_INVALID, "asset.version is " + quoted(v) + "; only glTF 2.0 is supported");
    auto required = root.find("extensionsRequired");
    if (required == root.end()) return;
    if (!kind_ok(*required, ARR_STR)) fail(GLTF_INVALID, "extensionsRequired must be an array of strings");
    for (auto &name : *required) {
        const std::string n = name.get<std::string>();
        bool known = false;
        for (const char *s : kSupportedRequired) known = known || n == s;
        if (!known) fail(GLTF_INVALID, "extensionsRequired lists " + quoted(n) + ", which lodpipe does not support");
    }
}

// Whether a buffer is marked as a meshopt fallback (under either name): only
// compressed views read it, and it may hold no data. Compared, not converted: a
// "fallback" that is not a boolean is no mark (value<bool> threw on it).
bool is_meshopt_fallback(const ojson &buffer)
{
    auto e = buffer.find("extensions");
    if (e == buffer.end() || !e->is_object()) return false;
    for (const char *name : kMeshoptNames) {
        auto m = e->find(name);
        if (m != e->end() && m->is_object() && m->contains("fallback") && (*m)["fallback"] == true) return true;
    }
    return false;
}

// The meshopt extension a bufferView carries (EXT or KHR), or nullptr.
const char *meshopt_name(const ojson &view)
{
    for (const char *name : kMeshoptNames)
        if (has_ext(view, name)) return name;
    return nullptr;
}

// The file external uri `uri` of object `where` names, refused when it is
// empty, decodes to a name with a NUL byte (the file system would read the
// name only up to it: another file), leaves the input's folder without
// --allow-external-uris, or is not a local file.
std::string external_file_of(const std::string &where, const std::string &uri, const gltf_load_options &opt,
                             const std::string &dir)
{
    if (uri.empty()) fail(GLTF_INVALID, where + ".uri is empty");
    const std::string decoded = tinygltf::dlib::urldecode(uri);
    if (decoded.find('\0') != std::string::npos)
        fail(GLTF_INVALID, where + ".uri " + quoted(uri) + " decodes to a name with a NUL byte (%00)");
    if (!opt.allow_external_uris && uri_escapes(uri, decoded))
        fail(GLTF_INVALID, where + ".uri " + quoted(uri) + " points outside the input's folder (use --allow-external-uris)");
    const std::string full = resolve_uri(dir, uri);
    if (full.empty()) fail(GLTF_IO, where + ": cannot read " + quoted(uri) + " (not a local file)");
    return full;
}

[[noreturn]] void fail_byte_length(const std::string &where, uint64_t holds, uint64_t declared)
{
    fail(GLTF_INVALID, where + " holds " + std::to_string(holds) + " bytes, not the declared byteLength " +
                           std::to_string(declared));
}

// The bytes the base64 payload of a data: uri decodes to, or -1 when it is not
// base64 (a character outside the alphabet, '=' other than one or two at the
// end, a length no base64 text has): tinygltf's decoder would stop at the
// first such character and hand over a shorter buffer. *bad is the offset of
// the first wrong character in the payload.
int64_t base64_decoded_size(const std::string &payload, size_t *bad)
{
    size_t n = payload.size(), pad = 0;
    while (pad < 2 && n > 0 && payload[n - 1] == '=') --n, ++pad;
    for (size_t i = 0; i < n; ++i) {
        const char c = payload[i];
        const bool alnum = (c >= '0' && c <= '9') || (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z');
        if (!alnum && c != '+' && c != '/') {
            *bad = i;
            return -1;
        }
    }
    *bad = n;
    if (n % 4 == 1 || (pad && (n + pad) % 4)) return -1;
    return int64_t(n / 4 * 3 + (n % 4 ? n % 4 - 1 : 0));
}

// The data: uri prefixes tinygltf decodes for a buffer (any other it fails on
// with its own message, the whole uri in it).
const char *const kBufferDataUriPrefixes[] = {
    "data:application/octet-stream;base64,", "data:application/gltf-buffer;base64,", "data:image/jpeg;base64,",
    "data:image/png;base64,", "data:image/bmp;base64,", "data:image/gif;base64,", "data:text/plain;base64,"};

// The bytes a data: uri's base64 payload decodes to; a payload that is not
// base64 is refused here (tinygltf failed on it with the whole uri in its
// message, or for an image without saying which character).
uint64_t data_uri_bytes(const std::string &where, const std::string &uri)
{
    require_base64_data_uri(where, uri);
    const size_t start = uri.find(',') + 1;
    size_t bad = 0;
    const int64_t size = base64_decoded_size(uri.substr(start), &bad);
    if (size < 0) fail(GLTF_INVALID, where + ".uri is not valid base64 (at character " + std::to_string(start + bad) + ")");
    return uint64_t(size);
}

// A buffer's data: uri must be of a type tinygltf decodes and hold exactly
// byteLength bytes, as tinygltf requires.
void check_buffer_data_uri(const std::string &where, const std::string &uri, uint64_t declared)
{
    const uint64_t size = data_uri_bytes(where, uri);
    bool known = false;
    for (const char *p : kBufferDataUriPrefixes) known = known || uri.compare(0, strlen(p), p) == 0;
    // the media type is quoted with its parameters, up to ";base64," (a type cut at its
    // first ';' read as one of the accepted ones: `application/octet-stream;charset=x`)
    if (!known)
        fail(GLTF_INVALID, where + ".uri is a data: uri of type " + quoted(uri.substr(5, uri.find(',') - 12)) +
                               " (a buffer's is application/octet-stream or application/gltf-buffer)");
    if (size != declared) fail_byte_length(where + ".uri", size, declared);
}

// Checks that every buffer's source gives tinygltf exactly what it declares
// (tinygltf indexes an empty buffer unchecked and words its refusals with the
// whole uri): a byteLength of at least 1 (the schema's minimum); for a buffer
// without a uri, a GLB whose BIN chunk holds at least byteLength bytes (the
// spec gives the chunk to buffers[0] alone, but tinygltf and the validator
// read it for any such buffer, and so does lodpipe); a base64 data: uri
// decoding to byteLength bytes; an external file of byteLength bytes.
// The source of buffers[b] (a uri, or the BIN chunk when it has none) against its byteLength.
void check_buffer_source(const ojson &buffer, size_t b, bool glb, const uint8_t *bin, size_t bin_size,
                         const gltf_load_options &opt, const std::string &dir)
{
    const std::string where = at("buffers", b);
    const uint64_t declared = u64(buffer, "byteLength", 0);
    if (!buffer.contains("uri")) {
        if (!glb) fail(GLTF_INVALID, where + " has no uri (only a GLB's buffer may omit it, for the BIN chunk)");
        if (!bin) fail(GLTF_INVALID, where + " refers to the GLB BIN chunk, but there is none");
        if (bin_size < declared)
            fail(GLTF_INVALID, where + " declares " + std::to_string(declared) + " bytes, but the GLB BIN chunk holds " +
                                   std::to_string(bin_size));
        return;
    }
    const std::string uri = buffer["uri"].get<std::string>();
    if (is_data_uri(uri)) {
        check_buffer_data_uri(where, uri, declared);
    } else {
        const std::string full = external_file_of(where, uri, opt, dir);
        const uint64_t size = require_file_within_cap(full, where, uri, opt);
        if (size != declared) fail_byte_length(where + ": " + quoted(uri), size, declared);
    }
}

void check_buffer_sources(const ojson &root, bool glb, const uint8_t *bin, size_t bin_size,
                          const gltf_load_options &opt, const std::string &dir)
{
    const ojson &buffers = array_of(root, "buffers");
    for (size_t b = 0; b < buffers.size(); ++b) {
        const std::string where = at("buffers", b);
        if (!buffers[b].contains("byteLength")) fail(GLTF_INVALID, where + ".byteLength is missing");
        const uint64_t declared = u64(buffers[b], "byteLength", 0);
        if (declared == 0) fail(GLTF_INVALID, where + ".byteLength is 0 (a buffer holds at least 1 byte)");
        // a fallback buffer is read (and checked) only when a view needs it: load_fallback_buffers
        if (is_meshopt_fallback(buffers[b])) continue;
        check_buffer_source(buffers[b], b, glb, bin, bin_size, opt, dir);
    }
}

// Checks everything else tinygltf would index: bufferView ranges against their
// buffers, images against bufferViews.
void check_buffers_and_views(const ojson &root, const gltf_load_options &opt, const std::string &dir)
{
    const ojson &buffers = array_of(root, "buffers");
    const ojson &views = array_of(root, "bufferViews");
    for (size_t v = 0; v < views.size(); ++v) {
        const ojson &view = views[v];
        const std::string path = at("bufferViews", v);
        if (!view.contains("buffer")) fail(GLTF_INVALID, path + ".buffer is missing");
        if (!view.contains("byteLength")) fail(GLTF_INVALID, path + ".byteLength is missing");
        uint64_t buffer = u64(view, "buffer", 0);
        if (buffer >= buffers.size()) fail(GLTF_INVALID, path + ".buffer " + std::to_string(buffer) + " does not exist");
        uint64_t offset = u64(view, "byteOffset", 0), length = u64(view, "byteLength", 0);
        uint64_t buffer_len = u64(buffers[buffer], "byteLength", 0);
        if (offset > buffer_len || length > buffer_len - offset)
            fail(GLTF_INVALID, path + " (bytes " + std::to_string(offset) + ".." + std::to_string(offset + length) +
                                   ") runs past the end of buffers[" + std::to_string(buffer) + "] (" +
                                   std::to_string(buffer_len) + " bytes)");
        uint64_t stride = u64(view, "byteStride", 0);
        if (view.contains("byteStride") && (stride < 4 || stride > 252 || stride % 4))
            fail(GLTF_INVALID, path + ".byteStride " + std::to_string(stride) + " is not a multiple of 4 in 4..252");
        if (const char *name = meshopt_name(view)) {
            // the KHR specification forbids both on one view: which stream would hold the data?
            if (has_ext(view, kMeshopt) && has_ext(view, kMeshoptKhr))
                fail(GLTF_INVALID, path + " has both EXT_meshopt_compression and KHR_meshopt_compression (one is allowed)");
            const ojson &m = view["extensions"][name];
            const std::string where = path + ".extensions." + name;
            if (!m.is_object()) fail(GLTF_INVALID, where + " is not an object");
            for (const char *key : {"buffer", "byteLength", "byteStride", "count"})
                if (!m.contains(key) || !is_uint(m[key])) fail(GLTF_INVALID, where + "." + key + " is missing or not a non-negative integer");
            if (m.contains("byteOffset") && !is_uint(m["byteOffset"])) fail(GLTF_INVALID, where + ".byteOffset must be a non-negative integer");
            // decode_meshopt_view reads these as strings (a number there threw nlohmann's type_error)
            if (!m.contains("mode") || !m["mode"].is_string()) fail(GLTF_INVALID, where + ".mode is missing or not a string");
            if (m.contains("filter") && !m["filter"].is_string()) fail(GLTF_INVALID, where + ".filter must be a string");
            uint64_t mb = u64(m, "buffer", 0), mo = u64(m, "byteOffset", 0), ml = u64(m, "byteLength", 0);
            if (mb >= buffers.size() || is_meshopt_fallback(buffers[mb]))
                fail(GLTF_INVALID, path + ": the compressed data's buffer " + std::to_string(mb) + " is missing");
            uint64_t blen = u64(buffers[mb], "byteLength", 0);
            if (mo > blen || ml > blen - mo) fail(GLTF_INVALID, path + ": the compressed data runs past the end of its buffer");
        } else if (is_meshopt_fallback(buffers[buffer])) {
            fail(GLTF_INVALID, path + " reads a meshopt fallback buffer but is not compressed");
        }
    }
    const ojson &images = array_of(root, "images");
    for (size_t i = 0; i < images.size(); ++i) {
        const std::string path = at("images", i);
        if (images[i].contains("bufferView")) {
            uint64_t v = u64(images[i], "bufferView", 0);
            if (v >= views.size()) fail(GLTF_INVALID, path + ".bufferView " + std::to_string(v) + " does not exist");
            if (meshopt_name(views[v])) fail(GLTF_INVALID, path + " is stored in a meshopt-compressed bufferView");
        } else if (images[i].contains("uri")) {
            const std::string uri = images[i]["uri"].get<std::string>();
            if (!is_data_uri(uri)) require_file_within_cap(external_file_of(path, uri, opt, dir), path, uri, opt);
            else if (data_uri_bytes(path, uri) == 0) fail(GLTF_INVALID, path + ".uri holds no data");
        }
    }
}

// tinygltf is asked only for what it is used for: resolving buffers and images
// (GLB chunk, data: URIs, external files). The rest of the document is read
// here, so tinygltf's own rules for meshes and accessors (which reject valid
// Draco files) never apply. A meshopt fallback buffer has no data by design, so
// it gets a one-word stand-in; the views that read it are decoded instead.
// Every external uri is handed over as the file resolve_uri names (tinygltf is
// given no folder of its own), so an absolute or file:// uri reads what the
// checks above looked at.
void resolve_file_uri(ojson &o, const std::string &dir)
{
    if (!o.contains("uri") || !o["uri"].is_string()) return;
    const std::string uri = o["uri"].get<std::string>();
    if (!is_data_uri(uri)) o["uri"] = uri_of_name(resolve_uri(dir, uri), true);
}

ojson json_for_tinygltf(const ojson &root, const std::string &dir)
{
    ojson reduced = ojson::object();
    for (const char *key : {"asset", "buffers", "bufferViews", "images"})
        if (root.contains(key)) reduced[key] = root[key];
    auto file_uri = [&](ojson &o) { resolve_file_uri(o, dir); };
    auto buffers = reduced.find("buffers");
    if (buffers != reduced.end())
        for (auto &b : *buffers) {
            if (is_meshopt_fallback(b)) b = ojson{{"byteLength", 4}, {"uri", "data:application/octet-stream;base64,AAAAAA=="}};
            else file_uri(b);
        }
    auto images = reduced.find("images");
    if (images != reduced.end())
        for (auto &i : *images)
            if (!i.contains("bufferView")) file_uri(i);
    return reduced;
}

// tinygltf's refusal as one line: its first, clipped.
[[noreturn]] void fail_tinygltf(const std::string &err)
{
    std::string first = err.substr(0, err.find('\n'));
    // tinygltf catches what its JSON parser throws and hands back its text
    if (first == std::bad_alloc().what()) throw std::bad_alloc();
    bool io = first.find("File not found") != std::string::npos || first.find("Failed to load") != std::string::npos ||
              first.find("File open error") != std::string::npos || first.find("not found") != std::string::npos;
    fail(io ? GLTF_IO : GLTF_INVALID, first.empty() ? "tinygltf could not load the file" : clipped(first, 160));
}

// tinygltf's reader of an external file, through read_file: tinygltf's own
// says "File open error" for any failure, out of memory included, which must
// be told as such (read_file throws std::bad_alloc).
bool read_external_file(std::vector<unsigned char> *out, std::string *err, const std::string &path, void *)
{
    std::string why;
    int code;
    if (read_file(path, kDefaultMaxFileBytes, out, &why, &code)) return true;
    if (err) *err = why;
    return false;
}

// tinygltf's test whether a referenced file is there, without allocating:
// its own opens a FILE (malloc), and a failed allocation came out as "File
// not found" (exit 4) instead of out of memory. Like its fopen "rb", a path
// that can be opened for reading is there.
bool external_file_exists(const std::string &path, void *)
{
    const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return false;
    close(fd);
    return true;
}

// tinygltf's size of a referenced file, without allocating but for an error
// text (tinygltf 2.8 and later ask for it before reading, to refuse a file
// over their limit). Unused with an older tinygltf: clang would say so.
[[maybe_unused]] bool external_file_size(size_t *size, std::string *err, const std::string &path, void *)
{
    struct stat st;
    if (stat(path.c_str(), &st) != 0) {
        if (err) *err = std::strerror(errno);
        return false;
    }
    *size = size_t(st.st_size);
    return true;
}

// Fills the size callback where this tinygltf has one (2.8 and later; Debian
// 12 has 2.7, Debian 13 2.9), and does nothing where it has none.
template <typename Fs>
auto set_file_size_callback(Fs &fs, int) -> decltype(void(fs.GetFileSizeInBytes = &external_file_size))
{
    fs.GetFileSizeInBytes = &external_file_size;
}
template <typename Fs>
void set_file_size_callback(Fs &, long)
{
}

// tinygltf's file system, with read_external_file as its reader. Members are
// set by name: tinygltf has added members between versions, and 2.9 ignores
// the whole set (keeping its own reader) when one of them is null.
tinygltf::FsCallbacks file_system()
{
    tinygltf::FsCallbacks fs{};
    fs.FileExists = &external_file_exists;
    fs.ExpandFilePath = &tinygltf::ExpandFilePath;
    fs.ReadWholeFile = &read_external_file;
    fs.WriteWholeFile = &tinygltf::WriteWholeFile;
    set_file_size_callback(fs, 0);
    return fs;
}

void load_with_tinygltf(gltf_doc *doc, const ojson &root, bool glb, const uint8_t *bin, size_t bin_size)
{
    tinygltf::TinyGLTF loader;
    loader.SetImageLoader(load_image_as_is, nullptr);
    loader.SetFsCallbacks(file_system());
    std::string err, warn;
    const std::string text = json_for_tinygltf(root, doc->dir).dump();
    bool ok;
    if (glb) {
        std::vector<uint8_t> glb_bytes;
        size_t json_len = (text.size() + 3) & ~size_t(3);
        size_t total = 12 + 8 + json_len + (bin ? 8 + ((bin_size + 3) & ~size_t(3)) : 0);
        if (total > 0xFFFFFFFFu) fail(GLTF_INVALID, "GLB is too large");
        glb_bytes.reserve(total);
        for (char c : std::string("glTF")) glb_bytes.push_back(uint8_t(c));
        wr32(glb_bytes, 2);
        wr32(glb_bytes, uint32_t(total));
        wr32(glb_bytes, uint32_t(json_len));
        wr32(glb_bytes, 0x4E4F534Au);
        glb_bytes.insert(glb_bytes.end(), text.begin(), text.end());
        glb_bytes.resize(20 + json_len, ' ');
        if (bin) {
            wr32(glb_bytes, uint32_t((bin_size + 3) & ~size_t(3)));
            wr32(glb_bytes, 0x004E4942u);
            glb_bytes.insert(glb_bytes.end(), bin, bin + bin_size);
            glb_bytes.resize(total, 0);
        }
        ok = loader.LoadBinaryFromMemory(&doc->model, &err, &warn, glb_bytes.data(), unsigned(glb_bytes.size()), "");
    } else {
        ok = loader.LoadASCIIFromString(&doc->model, &err, &warn, text.data(), unsigned(text.size()), "");
    }
    if (!ok) fail_tinygltf(err);
    const ojson &buffers = array_of(root, "buffers");
    if (doc->model.buffers.size() != buffers.size()) fail(GLTF_INVALID, "buffers could not all be loaded");
    for (size_t b = 0; b < buffers.size(); ++b) {
        if (is_meshopt_fallback(buffers[b])) continue;
        if (doc->model.buffers[b].data.size() != u64(buffers[b], "byteLength", 0))
            fail(GLTF_INVALID, at("buffers", b) + " holds " + std::to_string(doc->model.buffers[b].data.size()) +
                                   " bytes, not the declared byteLength " + std::to_string(u64(buffers[b], "byteLength", 0)));
    }
    const ojson &images = array_of(root, "images");
    for (size_t i = 0; i < images.size() && i < doc->model.images.size(); ++i) {
        if (!images[i].contains("uri") || images[i].contains("bufferView")) continue;
        const std::string uri = images[i]["uri"].get<std::string>();
        if (is_data_uri(uri)) continue;
        if (doc->model.images[i].image.empty())
            fail(GLTF_IO, at("images", i) + ": cannot read " + quoted(uri));
        doc->external_images[i] = doc->model.images[i].image;
    }
}

// libmeshoptimizer's version as its releases name it ("0.18"), for refusals.
std::string meshopt_library_version()
{
    return std::to_string(MESHOPTIMIZER_VERSION / 1000) + "." + std::to_string(MESHOPTIMIZER_VERSION % 1000 / 10);
}

bool extension_required(const ojson &root, const char *name)
{
    for (const ojson &n : array_of(root, "extensionsRequired"))
        if (n == name) return true;
    return false;
}

// Decodes bufferView v's meshopt stream (extension `name`) into its own bytes and
// drops the extension object. Returns "" when done, or why this build cannot decode
// a KHR_meshopt_compression stream it has no codec for (a version-1 attribute stream,
// the COLOR filter): the caller then uses the file's fallback data or refuses.
// Anything else wrong with the stream is refused here.
std::string decode_meshopt_view(gltf_doc *doc, size_t v, ojson &view, const char *name)
{
    const ojson &m = view["extensions"][name];
    const bool khr = strcmp(name, kMeshoptKhr) == 0;
    const std::string path = at("bufferViews", v);
    uint64_t stride = u64(m, "byteStride", 0), count = u64(m, "count", 0);
    uint64_t length = u64(view, "byteLength", 0);
    const std::string mode = m.value("mode", std::string());
    const std::string filter = m.value("filter", std::string("NONE"));
    if (stride == 0 || count > length / stride || count * stride != length)
        fail(GLTF_INVALID, path + ": meshopt count * byteStride does not match byteLength");
    const std::vector<uint8_t> &src = doc->model.buffers[u64(m, "buffer", 0)].data;
    const uint8_t *in = src.data() + u64(m, "byteOffset", 0);
    size_t in_len = size_t(u64(m, "byteLength", 0));
    // The decoded size is only declared; the stream bounds it (the vertex codec needs at
    // least 2 header bits per 16 bytes, the index codecs a byte per triangle or index), so a
    // declaration far beyond that is refused before the output is allocated.
    if (length > kMeshoptMaxExpansion * uint64_t(in_len) + 4096)
        fail(GLTF_INVALID, path + ": meshopt declares " + std::to_string(length) + " decoded bytes from " +
                               std::to_string(in_len) + " compressed bytes (no stream expands that much)");
    // The mode, filter and stride are checked before anything is decoded: a stream this
    // build cannot decode (its fallback data used instead) is held to them too.
    if (mode == "ATTRIBUTES") {
        if (stride % 4 || stride > 256) fail(GLTF_INVALID, path + ": meshopt ATTRIBUTES byteStride must be a multiple of 4 up to 256");
        if (filter == "OCTAHEDRAL" && stride != 4 && stride != 8) fail(GLTF_INVALID, path + ": OCTAHEDRAL filter needs byteStride 4 or 8");
        if (filter == "QUATERNION" && stride != 8) fail(GLTF_INVALID, path + ": QUATERNION filter needs byteStride 8");
        if (khr && filter == "COLOR" && stride != 4 && stride != 8) fail(GLTF_INVALID, path + ": COLOR filter needs byteStride 4 or 8");
        if (filter != "NONE" && filter != "OCTAHEDRAL" && filter != "QUATERNION" && filter != "EXPONENTIAL" && !(khr && filter == "COLOR"))
            fail(GLTF_INVALID, path + ": unknown meshopt filter " + quoted(filter));
    } else if (mode == "TRIANGLES" || mode == "INDICES") {
        if (stride != 2 && stride != 4) fail(GLTF_INVALID, path + ": meshopt index byteStride must be 2 or 4");
        if (mode == "TRIANGLES" && count % 3) fail(GLTF_INVALID, path + ": meshopt TRIANGLES count is not a multiple of 3");
        if (filter != "NONE") fail(GLTF_INVALID, path + ": meshopt " + mode + " data cannot have a filter (" + quoted(filter) + ")");
    } else {
        fail(GLTF_INVALID, path + ": unknown meshopt mode " + quoted(mode));
    }
    // the accessors read the decoded bytes with the view's stride
    if (view.contains("byteStride") && u64(view, "byteStride", 0) != stride)
        fail(GLTF_INVALID, path + ": byteStride " + std::to_string(u64(view, "byteStride", 0)) +
                               " differs from its meshopt byteStride " + std::to_string(stride));
    // KHR's colour filter came after libmeshoptimizer 0.18, which has no decoder for it
    if (khr && mode == "ATTRIBUTES" && filter == "COLOR")
        return "the COLOR filter (libmeshoptimizer " + meshopt_library_version() + " has no decoder for it)";
    ViewBytes &out = doc->views[v];
    out.owned.assign(size_t(length), 0);
    int rc = -1;
    if (mode == "ATTRIBUTES") {
        rc = meshopt_decodeVertexBuffer(out.owned.data(), size_t(count), size_t(stride), in, in_len);
        // KHR allows version-1 streams (header 0xa1), which a library before 0.23 refuses
        // like a corrupt one; a newer library decodes them here
        if (rc != 0 && khr && in_len > 0 && in[0] == 0xa1) {
            std::vector<uint8_t>().swap(out.owned);
            return "a version-1 attribute stream (libmeshoptimizer " + meshopt_library_version() + " decodes version 0 only)";
        }
        if (rc == 0 && filter == "OCTAHEDRAL") meshopt_decodeFilterOct(out.owned.data(), size_t(count), size_t(stride));
        else if (rc == 0 && filter == "QUATERNION") meshopt_decodeFilterQuat(out.owned.data(), size_t(count), size_t(stride));
        else if (rc == 0 && filter == "EXPONENTIAL") meshopt_decodeFilterExp(out.owned.data(), size_t(count), size_t(stride));
    } else if (mode == "TRIANGLES") {
        rc = meshopt_decodeIndexBuffer(out.owned.data(), size_t(count), size_t(stride), in, in_len);
    } else {
        rc = meshopt_decodeIndexSequence(out.owned.data(), size_t(count), size_t(stride), in, in_len);
    }
    if (rc != 0) fail(GLTF_INVALID, path + ": " + name + " data does not decode (corrupt stream)");
    out.ptr = out.owned.data();
    out.size = out.owned.size();
    erase_ext(view, name);
    return "";
}

// Reads the meshopt fallback buffers in `wanted` (each has a uri), which the first
// pass stood in for: views whose stream this build cannot decode use their data.
// Each is checked against its byteLength first, as every other buffer was.
void load_fallback_buffers(gltf_doc *doc, const std::vector<size_t> &wanted, const gltf_load_options &opt)
{
    const ojson &buffers = array_of(doc->json, "buffers");
    ojson reduced = ojson::object();
    reduced["asset"] = doc->json["asset"];
    reduced["buffers"] = ojson::array();
    for (size_t b : wanted) {
        check_buffer_source(buffers[b], b, false, nullptr, 0, opt, doc->dir);
        ojson one = ojson::object();
        one["byteLength"] = buffers[b]["byteLength"];
        one["uri"] = buffers[b]["uri"];
        resolve_file_uri(one, doc->dir);
        reduced["buffers"].push_back(one);
    }
    tinygltf::TinyGLTF loader;
    loader.SetFsCallbacks(file_system());
    tinygltf::Model model;
    std::string err, warn;
    const std::string text = reduced.dump();
    if (!loader.LoadASCIIFromString(&model, &err, &warn, text.data(), unsigned(text.size()), "")) fail_tinygltf(err);
    if (model.buffers.size() != wanted.size()) fail(GLTF_INVALID, "buffers could not all be loaded");
    doc->fallback_read.assign(buffers.size(), 0);
    for (size_t i = 0; i < wanted.size(); ++i) {
        const uint64_t declared = u64(buffers[wanted[i]], "byteLength", 0);
        if (model.buffers[i].data.size() != declared)
            fail_byte_length(at("buffers", wanted[i]), model.buffers[i].data.size(), declared);
        doc->model.buffers[wanted[i]].data = std::move(model.buffers[i].data);
        doc->fallback_read[wanted[i]] = 1;
    }
}

// Bytes for every bufferView: meshopt views decoded (either extension), the others
// (and a KHR view this build cannot decode, when the file has its uncompressed
// fallback) pointing into their loaded buffer.
void resolve_views(gltf_doc *doc, const gltf_load_options &opt)
{
    ojson &views = doc->json["bufferViews"];
    if (views.is_null()) {
        doc->json.erase("bufferViews");
        return;
    }
    const ojson &buffers = array_of(doc->json, "buffers");
    doc->views.resize(views.size());
    std::vector<uint8_t> use_fallback(views.size(), 0);
    std::vector<size_t> wanted;
    for (size_t v = 0; v < views.size(); ++v) {
        const char *name = meshopt_name(views[v]);
        if (!name) continue;
        const std::string why = decode_meshopt_view(doc, v, views[v], name);
        if (why.empty()) continue;
        const std::string head = at("bufferViews", v) + ": cannot decode its " + name + " data: " + why;
        if (extension_required(doc->json, name))
            fail(GLTF_INVALID, head + "; the extension is required, so the file has no uncompressed copy");
        const size_t b = size_t(u64(views[v], "buffer", 0));
        if (is_meshopt_fallback(buffers[b])) {
            if (!buffers[b].contains("uri"))
                fail(GLTF_INVALID, head + "; its fallback " + at("buffers", b) + " has no uri (no uncompressed copy)");
            if (std::find(wanted.begin(), wanted.end(), b) == wanted.end()) wanted.push_back(b);
        }
        // the fallback holds the data now: the extension would describe bytes the output no longer has
        erase_ext(views[v], name);
        use_fallback[v] = 1;
    }
    if (!wanted.empty()) load_fallback_buffers(doc, wanted, opt);
    for (size_t v = 0; v < views.size(); ++v) {
        if (doc->views[v].ptr && !use_fallback[v]) continue; // decoded
        const std::vector<uint8_t> &data = doc->model.buffers[u64(views[v], "buffer", 0)].data;
        doc->views[v].ptr = data.data() + u64(views[v], "byteOffset", 0);
        doc->views[v].size = size_t(u64(views[v], "byteLength", 0));
    }
}

size_t add_owned_view(gltf_doc *doc, std::vector<uint8_t> bytes, int target)
{
    // a new bufferView: no accessor reference changes (edit_keeps_counts)
    ojson view = ojson::object();
    view["buffer"] = 0;
    view["byteLength"] = bytes.size();
    if (target) view["target"] = target;
    if (!doc->json.contains("bufferViews")) doc->json["bufferViews"] = ojson::array();
    doc->json["bufferViews"].push_back(view);
    ViewBytes vb;
    vb.owned = std::move(bytes);
    vb.ptr = vb.owned.data();
    vb.size = vb.owned.size();
    doc->views.push_back(std::move(vb));
    return doc->views.size() - 1;
}

// Decodes one Draco primitive: every accessor it names gets a bufferView of its
// own with the decoded values, in the accessor's declared component type.
void decode_draco_primitive(gltf_doc *doc, ojson &prim, const std::string &path)
{
    const ojson &ext = prim["extensions"][kDraco];
    if (!ext.contains("bufferView") || !is_uint(ext["bufferView"]))
        fail(GLTF_INVALID, path + "." + kDraco + ".bufferView is missing");
    if (!ext.contains("attributes") || !ext["attributes"].is_object())
        fail(GLTF_INVALID, path + "." + kDraco + ".attributes is missing");
    uint64_t v = ext["bufferView"].get<uint64_t>();
    if (v >= doc->views.size()) fail(GLTF_INVALID, path + "." + kDraco + ".bufferView " + std::to_string(v) + " does not exist");
    // find, not []: in a file without "accessors", [] would add the member, and the root
    // object's members (an ordered_map, copied when it grows) would move: prim and ext,
    // references into "meshes", would then point at freed memory
    auto found = doc->json.find("accessors");
    ojson *accessors = found != doc->json.end() && found->is_array() ? &*found : nullptr;
    const size_t accessor_count = accessors ? accessors->size() : 0;
    char why[256] = "";
    draco_mesh *mesh = nullptr;
    const int decoded = draco_decode_mesh(doc->views[v].ptr, doc->views[v].size, &mesh, why, sizeof why);
    if (decoded == DRACO_OUT_OF_MEMORY) throw std::bad_alloc();
    if (decoded != 0) fail(GLTF_INVALID, path + ": " + why);
    std::unique_ptr<draco_mesh, void (*)(draco_mesh *)> hold(mesh, draco_mesh_free);
    const uint64_t points = draco_mesh_num_points(mesh), faces = draco_mesh_num_faces(mesh);

    if (prim.contains("indices")) {
        uint64_t a = prim["indices"].get<uint64_t>();
        if (a >= accessor_count) fail(GLTF_INVALID, path + ".indices " + std::to_string(a) + " does not exist");
        ojson &acc = (*accessors)[a];
        int ctype = int(u64(acc, "componentType", 0));
        int size = component_size(ctype);
        if (ctype != 5121 && ctype != 5123 && ctype != 5125) fail(GLTF_INVALID, at("accessors", a) + " has an invalid index componentType");
        if (u64(acc, "count", 0) != faces * 3)
            fail(GLTF_INVALID, at("accessors", a) + ".count " + std::to_string(u64(acc, "count", 0)) +
                                   " differs from the Draco stream's " + std::to_string(faces * 3) + " indices");
        std::vector<uint32_t> idx(size_t(faces * 3));
        draco_mesh_read_indices(mesh, idx.data());
        std::vector<uint8_t> bytes(idx.size() * size_t(size));
        for (size_t i = 0; i < idx.size(); ++i) {
            if (idx[i] >= points || (size < 4 && idx[i] >= (1u << (8 * size))))
                fail(GLTF_INVALID, path + ": a Draco index is out of range");
            memcpy(&bytes[i * size_t(size)], &idx[i], size_t(size)); // little-endian host
        }
        acc["bufferView"] = add_owned_view(doc, std::move(bytes), 34963);
        acc.erase("byteOffset");
    }
    for (auto it = ext["attributes"].begin(); it != ext["attributes"].end(); ++it) {
        if (!is_uint(it.value())) fail(GLTF_INVALID, path + "." + kDraco + ".attributes." + it.key() + " must be an integer");
        auto attr = prim["attributes"].find(it.key());
        if (attr == prim["attributes"].end())
            fail(GLTF_INVALID, path + ": Draco attribute " + it.key() + " is not an attribute of the primitive");
        uint64_t a = attr->get<uint64_t>();
        if (a >= accessor_count) fail(GLTF_INVALID, path + ".attributes." + it.key() + " accessor does not exist");
        ojson &acc = (*accessors)[a];
        if (acc.contains("bufferView")) continue; // already decoded (accessor shared by primitives)
        int ctype = int(u64(acc, "componentType", 0)), is_matrix = 0;
        int comps = type_components(acc.value("type", std::string()), &is_matrix);
        if (!component_size(ctype) || comps < 1 || comps > 4 || is_matrix)
            fail(GLTF_INVALID, at("accessors", a) + " has a type Draco cannot fill");
        if (u64(acc, "count", 0) != points)
            fail(GLTF_INVALID, at("accessors", a) + ".count " + std::to_string(u64(acc, "count", 0)) +
                                   " differs from the Draco stream's " + std::to_string(points) + " points");
        std::vector<uint8_t> bytes(size_t(points) * size_t(comps) * size_t(component_size(ctype)));
        if (draco_mesh_read_attribute(mesh, uint32_t(it.value().get<uint64_t>()), ctype, comps, bytes.data(), why, sizeof why) != 0)
            fail(GLTF_INVALID, path + ": Draco attribute " + it.key() + ": " + why);
        // Vertex data: keep each element 4-byte aligned as the spec wants.
        int esize = comps * component_size(ctype);
        if (esize % 4) {
            int stride = (esize + 3) & ~3;
            std::vector<uint8_t> padded(size_t(points) * size_t(stride), 0);
            for (size_t p = 0; p < points; ++p) memcpy(&padded[p * size_t(stride)], &bytes[p * size_t(esize)], size_t(esize));
            size_t view = add_owned_view(doc, std::move(padded), 34962);
            doc->json["bufferViews"][view]["byteStride"] = stride;
            acc["bufferView"] = view;
        } else {
            acc["bufferView"] = add_owned_view(doc, std::move(bytes), 34962);
        }
        acc.erase("byteOffset");
    }
    erase_ext(prim, kDraco);
}

void remove_extension_name(ojson &root, const char *name)
{
    for (const char *list : {"extensionsUsed", "extensionsRequired"}) {
        auto it = root.find(list);
        if (it == root.end()) continue;
        ojson kept = ojson::array();
        for (auto &n : *it) if (n != name) kept.push_back(n);
        if (kept.empty()) root.erase(list);
        else *it = kept;
    }
}

void decode_compression(gltf_doc *doc)
{
    bool had_draco = false;
    auto meshes = doc->json.find("meshes");
    if (meshes != doc->json.end())
        for (size_t m = 0; m < meshes->size(); ++m) {
            // find, not []: a mesh without primitives (invalid, but kept as it is) must not gain "primitives": null
            auto found = (*meshes)[m].is_object() ? (*meshes)[m].find("primitives") : (*meshes)[m].end();
            if (found == (*meshes)[m].end() || !found->is_array()) continue;
            ojson &prims = *found;
            for (size_t p = 0; p < prims.size(); ++p)
                if (has_ext(prims[p], kDraco)) {
                    decode_draco_primitive(doc, prims[p], at("meshes", m) + ".primitives[" + std::to_string(p) + "]");
                    doc->draco_decoded.emplace_back(m, p);
                    had_draco = true;
                }
        }
    if (had_draco) remove_extension_name(doc->json, kDraco);
    // every meshopt view was decoded in resolve_views, or now holds its fallback's data
    for (const char *name : kMeshoptNames) remove_extension_name(doc->json, name);
}

// ---- C records -------------------------------------------------------------------

// The C records of mesh m's primitives (names, attributes, targets).
void build_mesh_records(gltf_doc *doc, size_t m)
{
    const ojson &meshes = array_of(doc->json, "meshes");
    {
        const ojson &prims = array_of(meshes[m], "primitives");
        doc->prims[m].resize(prims.size());
        for (size_t p = 0; p < prims.size(); ++p) {
            CPrimitive &cp = doc->prims[m][p];
            const ojson &pr = prims[p];
            size_t name_count = pr["attributes"].size();
            for (auto &t : array_of(pr, "targets")) name_count += t.size();
            cp.names.reserve(name_count); // names must not move once pointed at
            for (auto it = pr["attributes"].begin(); it != pr["attributes"].end(); ++it) {
                cp.names.push_back(it.key());
                cp.attributes.push_back({nullptr, int64_t(std::min<uint64_t>(it.value().get<uint64_t>(), uint64_t(1) << 62))});
            }
            for (size_t i = 0; i < cp.attributes.size(); ++i) cp.attributes[i].name = cp.names[i].c_str();
            for (auto &t : array_of(pr, "targets")) {
                std::vector<gltf_attribute> ta;
                for (auto it = t.begin(); it != t.end(); ++it) {
                    cp.names.push_back(it.key());
                    ta.push_back({cp.names.back().c_str(), int64_t(std::min<uint64_t>(it.value().get<uint64_t>(), uint64_t(1) << 62))});
                }
                cp.targets.push_back(std::move(ta));
            }
            for (auto &t : cp.targets) {
                cp.target_counts.push_back(t.size());
                cp.target_ptrs.push_back(t.data());
            }
            gltf_primitive &r = cp.rec;
            r.mode = int32_t(std::min<uint64_t>(u64(pr, "mode", 4), 1u << 30));
            r.indices = i64_or_none(pr, "indices");
            r.material = i64_or_none(pr, "material");
            r.attribute_count = cp.attributes.size();
            r.attributes = cp.attributes.data();
            r.target_count = cp.targets.size();
            r.target_attribute_counts = cp.target_counts.data();
            r.target_attributes = cp.target_ptrs.data();
            r.was_draco = std::find(doc->draco_decoded.begin(), doc->draco_decoded.end(), std::make_pair(m, p)) !=
                          doc->draco_decoded.end();
        }
    }
}

void build_records(gltf_doc *doc)
{
    const ojson &root = doc->json;
    for (int k = 0; k < GLTF_KIND_COUNT; ++k) {
        const ojson &arr = array_of(root, kKindArrays[k]);
        doc->names[k].resize(arr.size());
        for (size_t i = 0; i < arr.size(); ++i) doc->names[k][i] = arr[i].value("name", std::string());
    }
    const ojson &meshes = array_of(root, "meshes");
    doc->prims.resize(meshes.size());
    for (size_t m = 0; m < meshes.size(); ++m) build_mesh_records(doc, m);
    const ojson &nodes = array_of(root, "nodes");
    doc->node_children.resize(nodes.size());
    doc->node_lods.resize(nodes.size());
    for (size_t n = 0; n < nodes.size(); ++n) {
        for (auto &c : array_of(nodes[n], "children")) doc->node_children[n].push_back(int64_t(std::min<uint64_t>(c.get<uint64_t>(), uint64_t(1) << 62)));
        auto ext = nodes[n].find("extensions");
        if (ext != nodes[n].end() && ext->contains("MSFT_lod")) {
            const ojson &lod = (*ext)["MSFT_lod"];
            auto ids = lod.find("ids");
            if (ids != lod.end() && !ids->is_array())
                fail(GLTF_INVALID, at("nodes", n) + ".extensions.MSFT_lod.ids must be an array of node indices");
            if (ids != lod.end())
                for (auto &id : *ids) doc->node_lods[n].push_back(is_uint(id) ? int64_t(std::min<uint64_t>(id.get<uint64_t>(), uint64_t(1) << 62)) : int64_t(-2));
        }
    }
    const ojson &scenes = array_of(root, "scenes");
    doc->scene_nodes.resize(scenes.size());
    for (size_t s = 0; s < scenes.size(); ++s)
        for (auto &n : array_of(scenes[s], "nodes")) doc->scene_nodes[s].push_back(int64_t(std::min<uint64_t>(n.get<uint64_t>(), uint64_t(1) << 62)));
    for (auto &n : array_of(root, "extensionsUsed")) doc->ext_used.push_back(n.get<std::string>());
    for (auto &n : array_of(root, "extensionsRequired")) doc->ext_required.push_back(n.get<std::string>());
}

void mark_referenced_views(gltf_doc *doc);

// The files tinygltf read for buffers and images named by an external uri, as
// the process opened them (the input's folder joined with the decoded uri),
// each once, buffers first.
void list_external_files(gltf_doc *doc)
{
    auto add = [&](const std::string &uri) {
        if (is_data_uri(uri)) return;
        const std::string full = resolve_uri(doc->dir, uri);
        for (const std::string &f : doc->external_files)
            if (f == full) return;
        doc->external_files.push_back(full);
    };
    const ojson &buffers = array_of(doc->json, "buffers");
    for (size_t b = 0; b < buffers.size(); ++b) {
        const bool read = !is_meshopt_fallback(buffers[b]) || (b < doc->fallback_read.size() && doc->fallback_read[b]);
        if (buffers[b].contains("uri") && read) add(buffers[b]["uri"].get<std::string>());
    }
    for (const ojson &i : array_of(doc->json, "images"))
        if (i.contains("uri") && !i.contains("bufferView")) add(i["uri"].get<std::string>());
}


// Why the JSON text is refused before it is parsed, or "": arrays and objects
// nested deeper than kMaxJsonDepth, or an object with more than
// kMaxJsonMembers members (the parser's ordered objects find each new key by
// a linear search, so an object of n keys costs n^2: 500k keys took minutes).
// A syntax error is left to the parser, which says where.
std::string json_shape_problem(const std::string &text)
{
    std::vector<size_t> members; // per open container: members so far, or SIZE_MAX for an array
    bool in_string = false;
    for (size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (in_string) {
            if (c == '\\') ++i;
            else if (c == '"') in_string = false;
        } else if (c == '"') {
            in_string = true;
        } else if (c == '[' || c == '{') {
            if (members.size() == kMaxJsonDepth)
                return "JSON nests arrays and objects deeper than " + std::to_string(kMaxJsonDepth) + " levels";
            members.push_back(c == '{' ? 0 : SIZE_MAX);
        } else if ((c == ']' || c == '}') && !members.empty()) {
            members.pop_back();
        } else if (c == ':' && !members.empty() && members.back() != SIZE_MAX && ++members.back() > kMaxJsonMembers) {
            return "JSON has an object with more than " + std::to_string(kMaxJsonMembers) + " members (at byte " +
                   std::to_string(i) + ")";
        }
    }
    return "";
}

// A SAX consumer that accepts everything and keeps where the parse failed:
// ojson::parse reports a number beyond a double's range (406) without it.
struct ParseFailure {
    size_t byte = 0;
    std::string token;
    bool null() { return true; }
    bool boolean(bool) { return true; }
    bool number_integer(ojson::number_integer_t) { return true; }
    bool number_unsigned(ojson::number_unsigned_t) { return true; }
    bool number_float(ojson::number_float_t, const std::string &) { return true; }
    bool string(std::string &) { return true; }
    bool binary(ojson::binary_t &) { return true; }
    bool start_object(size_t) { return true; }
    bool key(std::string &) { return true; }
    bool end_object() { return true; }
    bool start_array(size_t) { return true; }
    bool end_array() { return true; }
    bool parse_error(size_t position, const std::string &last_token, const nlohmann::detail::exception &)
    {
        byte = position;
        token = last_token;
        return false;
    }
};

// Parses the bytes of a file that was read from (or stands for) `path`; the
// path names the folder external uris are resolved against.
void load_bytes(gltf_doc *doc, const std::string &path, const std::vector<uint8_t> &file, const gltf_load_options &opt)
{
    if (file.empty()) fail(GLTF_INVALID, "file is empty");
    doc->path = path;
    doc->dir = dir_of(path);

    const bool glb = file.size() >= 4 && memcmp(file.data(), "glTF", 4) == 0;
    if (!glb && ends_with_ci(path, ".glb")) fail(GLTF_INVALID, "not a GLB file (the first 4 bytes are not \"glTF\")");
    std::string text;
    const uint8_t *bin = nullptr;
    size_t bin_size = 0;
    if (glb) parse_glb(file, &text, &bin, &bin_size);
    else text.assign(file.begin(), file.end());

    const std::string shape = json_shape_problem(text);
    if (!shape.empty()) fail(GLTF_INVALID, shape);
    try {
        doc->json = ojson::parse(text);
    } catch (const ojson::parse_error &e) {
        fail(GLTF_INVALID, std::string("JSON does not parse (byte ") + std::to_string(e.byte) + ")");
    } catch (const ojson::out_of_range &) {
        // A number no double holds (1e400): the document keeps numbers as
        // doubles, so it could only come out changed. Refused, saying where.
        ParseFailure at;
        ojson::sax_parse(text, &at);
        std::string number = clipped(at.token, 40);
        fail(GLTF_INVALID, "JSON has a number beyond the range of a double (" + number + ") at byte " +
                               std::to_string(at.byte - at.token.size()) + " of the JSON");
    }
    if (!doc->json.is_object()) fail(GLTF_INVALID, "the JSON document is not an object");
    check_asset_and_extensions(doc->json);
    check_object(doc->json, doc->json, kRoot, "");
    check_local_references(doc->json);
    check_attribute_maps(doc->json);
    check_buffer_sources(doc->json, glb, bin, bin_size, opt, doc->dir);
    check_buffers_and_views(doc->json, opt, doc->dir);
    // An empty BIN chunk holds nothing a buffer could use (the checks above
    // refuse buffers[0] reading it); tinygltf refuses one, so it is left out.
    if (bin_size == 0) bin = nullptr;
    load_with_tinygltf(doc, doc->json, glb, bin, bin_size);
    resolve_views(doc, opt);
    mark_referenced_views(doc);
    decode_compression(doc);
    mark_referenced_views(doc);
    build_records(doc);
    list_external_files(doc);
    doc->accessor_refs_at_load = doc->accessor_ref_counts = walk_accessor_refs(doc);
    doc->accessor_ref_counts_valid = true;
}

void load(gltf_doc *doc, const std::string &path, const gltf_load_options &opt)
{
    const uint64_t cap = opt.max_file_bytes ? opt.max_file_bytes : kDefaultMaxFileBytes;
    std::vector<uint8_t> file;
    std::string why;
    int code = GLTF_OK;
    if (!read_file(path, cap, &file, &why, &code)) fail(code, why);
    load_bytes(doc, path, file, opt);
}

// Runs one of the loaders above, turning every failure into a status and a message.
template <typename F> int guarded_load(F &&run, gltf_doc **out, char *err, size_t errlen)
{
    *out = nullptr;
    gltf_doc *doc = nullptr;
    try {
        doc = new gltf_doc;
        run(doc);
        *out = doc;
        return GLTF_OK;
    } catch (const Failure &f) {
        snprintf(err, errlen, "%s", f.msg.c_str());
        delete doc;
        return f.code;
    } catch (const std::bad_alloc &) {
        snprintf(err, errlen, "out of memory while loading");
        delete doc;
        return GLTF_INVALID;
    } catch (const std::out_of_range &) {
        // vector::at and friends: a check above missed an index; their text
        // (_M_range_check) means nothing to the user
        snprintf(err, errlen, "malformed glTF (an index or size out of range)");
        delete doc;
        return GLTF_INVALID;
    } catch (const std::exception &e) {
        // nlohmann's type errors start with "[json.exception.type_error.302] "
        std::string what = e.what();
        if (what.compare(0, 16, "[json.exception.") == 0 && what.find("] ") != std::string::npos)
            what = what.substr(what.find("] ") + 2);
        snprintf(err, errlen, "malformed glTF (%s)", clipped(what, 160).c_str());
        delete doc;
        return GLTF_INVALID;
    }
}

} // namespace

// ---- C API: loading and reading ----------------------------------------------------

extern "C" int gltf_load(const char *path, const gltf_load_options *options, gltf_doc **out, char *err, size_t errlen)
{
    gltf_load_options opt{};
    if (options) opt = *options;
    return guarded_load([&](gltf_doc *doc) { load(doc, path, opt); }, out, err, errlen);
}

extern "C" int gltf_load_memory(const void *bytes, size_t size, const char *path, const gltf_load_options *options,
                                gltf_doc **out, char *err, size_t errlen)
{
    gltf_load_options opt{};
    if (options) opt = *options;
    return guarded_load(
        [&](gltf_doc *doc) {
            const uint64_t cap = opt.max_file_bytes ? opt.max_file_bytes : kDefaultMaxFileBytes;
            if (size > cap) fail(GLTF_INVALID, "is larger than the " + std::to_string(cap) + "-byte limit");
            const uint8_t *b = static_cast<const uint8_t *>(bytes);
            load_bytes(doc, path, std::vector<uint8_t>(b, b + size), opt);
        },
        out, err, errlen);
}

extern "C" void gltf_free(gltf_doc *doc) { delete doc; }

extern "C" void gltf_release_binary(gltf_doc *doc)
{
    // swap with an empty vector: clear() would keep the capacity
    for (auto &b : doc->model.buffers) std::vector<unsigned char>().swap(b.data);
    for (auto &i : doc->model.images) std::vector<unsigned char>().swap(i.image);
    doc->external_images.clear();
    for (auto &v : doc->views) {
        std::vector<uint8_t>().swap(v.owned);
        v.ptr = nullptr;
        v.size = 0;
    }
    doc->binary_released = true;
}

extern "C" size_t gltf_external_file_count(const gltf_doc *doc) { return doc->external_files.size(); }

extern "C" const char *gltf_external_file(const gltf_doc *doc, size_t index)
{
    return index < doc->external_files.size() ? doc->external_files[index].c_str() : "";
}

extern "C" size_t gltf_count(const gltf_doc *doc, gltf_kind kind)
{
    if (kind < 0 || kind >= GLTF_KIND_COUNT) return 0;
    if (kind == GLTF_BUFFER_VIEWS) return doc->views.size();
    return array_of(doc->json, kKindArrays[kind]).size();
}

extern "C" const char *gltf_name(const gltf_doc *doc, gltf_kind kind, size_t index)
{
    if (kind < 0 || kind >= GLTF_KIND_COUNT || index >= doc->names[kind].size()) return "";
    return doc->names[kind][index].c_str();
}

extern "C" int gltf_get_view(const gltf_doc *doc, size_t index, gltf_view *out)
{
    return guarded(doc, -1, [&] {
        if (index >= doc->views.size() || doc->binary_released) return -1;
        out->data = doc->views[index].ptr;
        out->byte_length = doc->views[index].size;
        out->byte_stride = u64(doc->json["bufferViews"][index], "byteStride", 0);
        return 0;
    });
}

extern "C" int gltf_get_accessor(const gltf_doc *doc, size_t index, gltf_accessor *out)
{
    return guarded(doc, -1, [&] {
        const ojson &arr = array_of(doc->json, "accessors");
        if (index >= arr.size()) return -1;
        const ojson &a = arr[index];
        memset(out, 0, sizeof *out);
        out->buffer_view = i64_or_none(a, "bufferView");
        out->byte_offset = u64(a, "byteOffset", 0);
        out->component_type = int32_t(std::min<uint64_t>(u64(a, "componentType", 0), 1u << 30));
        out->normalized = a.value("normalized", false) ? 1 : 0;
        out->count = u64(a, "count", 0);
        int is_matrix = 0;
        out->components = type_components(a.value("type", std::string()), &is_matrix);
        out->is_matrix = is_matrix;
        auto sp = a.find("sparse");
        out->sparse_indices_view = out->sparse_values_view = -1;
        if (sp != a.end()) {
            out->has_sparse = 1;
            out->sparse_count = u64(*sp, "count", 0);
            const ojson &si = sp->value("indices", ojson::object());
            const ojson &sv = sp->value("values", ojson::object());
            out->sparse_indices_view = i64_or_none(si, "bufferView");
            out->sparse_indices_offset = u64(si, "byteOffset", 0);
            out->sparse_indices_type = int32_t(std::min<uint64_t>(u64(si, "componentType", 0), 1u << 30));
            out->sparse_values_view = i64_or_none(sv, "bufferView");
            out->sparse_values_offset = u64(sv, "byteOffset", 0);
        }
        return 0;
    });
}

extern "C" size_t gltf_primitive_count(const gltf_doc *doc, size_t mesh)
{
    return mesh < doc->prims.size() ? doc->prims[mesh].size() : 0;
}

extern "C" int gltf_get_primitive(const gltf_doc *doc, size_t mesh, size_t prim, gltf_primitive *out)
{
    if (mesh >= doc->prims.size() || prim >= doc->prims[mesh].size()) return -1;
    *out = doc->prims[mesh][prim].rec;
    return 0;
}

extern "C" int64_t gltf_primitive_attribute(const gltf_primitive *g, const char *name)
{
    for (size_t a = 0; a < g->attribute_count; ++a)
        if (strcmp(g->attributes[a].name, name) == 0) return g->attributes[a].accessor;
    return -1;
}

extern "C" int gltf_get_node(const gltf_doc *doc, size_t index, gltf_node *out)
{
    return guarded(doc, -1, [&] {
        const ojson &nodes = array_of(doc->json, "nodes");
        if (index >= nodes.size()) return -1;
        const ojson &n = nodes[index];
        memset(out, 0, sizeof *out);
        out->mesh = i64_or_none(n, "mesh");
        out->skin = i64_or_none(n, "skin");
        out->camera = i64_or_none(n, "camera");
        out->child_count = doc->node_children[index].size();
        out->children = doc->node_children[index].data();
        for (int i = 0; i < 16; ++i) out->matrix[i] = (i % 5 == 0) ? 1.0 : 0.0;
        out->rotation[3] = 1.0;
        out->scale[0] = out->scale[1] = out->scale[2] = 1.0;
        auto copy = [&](const char *key, double *dst, size_t want) {
            auto it = n.find(key);
            if (it == n.end()) return;
            for (size_t i = 0; i < want && i < it->size(); ++i) dst[i] = (*it)[i].get<double>();
        };
        if (n.contains("matrix")) {
            out->has_matrix = 1;
            copy("matrix", out->matrix, 16);
        }
        copy("translation", out->translation, 3);
        copy("rotation", out->rotation, 4);
        copy("scale", out->scale, 3);
        out->weight_count = n.contains("weights") ? n["weights"].size() : 0;
        out->lod_count = doc->node_lods[index].size();
        out->lod_ids = doc->node_lods[index].data();
        auto extras = n.find("extras");
        out->has_screencoverage = extras != n.end() && extras->is_object() && extras->contains("MSFT_screencoverage");
        auto extensions = n.find("extensions");
        out->extension_count = extensions != n.end() && extensions->is_object() ? extensions->size() : 0;
        return 0;
    });
}

extern "C" int gltf_get_scene(const gltf_doc *doc, size_t index, gltf_scene *out)
{
    if (index >= doc->scene_nodes.size()) return -1;
    out->node_count = doc->scene_nodes[index].size();
    out->nodes = doc->scene_nodes[index].data();
    return 0;
}

extern "C" int64_t gltf_default_scene(const gltf_doc *doc) { return i64_or_none(doc->json, "scene"); }

extern "C" size_t gltf_extension_count(const gltf_doc *doc, int required)
{
    return required ? doc->ext_required.size() : doc->ext_used.size();
}

extern "C" const char *gltf_extension_name(const gltf_doc *doc, int required, size_t index)
{
    const std::vector<std::string> &v = required ? doc->ext_required : doc->ext_used;
    return index < v.size() ? v[index].c_str() : "";
}

// ---- C API: editing ----------------------------------------------------------------

// The tokens of a JSON pointer; {"~"} for one with an escape, which no rule
// below matches (lodpipe builds its pointers from plain names).
static std::vector<std::string> pointer_tokens(const std::string &pointer)
{
    std::vector<std::string> t;
    if (pointer.find('~') != std::string::npos) return {"~"};
    size_t at = 1;
    while (at <= pointer.size()) {
        const size_t slash = pointer.find('/', at);
        const size_t end = slash == std::string::npos ? pointer.size() : slash;
        t.push_back(pointer.substr(at, end - at));
        at = end + 1;
    }
    return t;
}

// An edit at these tokens after which every accessor reference count stands
// (count_accessor_refs counts nothing there): inside one accessor or
// bufferView (their own keys: bufferView, count, min, ...), a new one
// appended ("-": nothing refers to it yet, and a count past the cached ones
// is 0), the removal of the last accessor (no renumbering; lodpipe removes so
// only a scratch accessor nothing refers to), anything inside a
// KHR_draco_mesh_compression extension (its "attributes" are stream ids, not
// counted), a primitive's mode, and the lists of extension names.
static bool edit_keeps_counts(const gltf_doc *doc, const std::vector<std::string> &t, bool removal)
{
    if (!t.empty() && (t[0] == "extensionsUsed" || t[0] == "extensionsRequired")) return true;
    if (t.size() >= 2 && (t[0] == "accessors" || t[0] == "bufferViews")) {
        if (t.size() >= 3 || t[1] == "-") return true;
        const size_t last = array_of(doc->json, "accessors").size();
        if (removal && t[0] == "accessors" && last && t[1] == std::to_string(last - 1)) return true;
    }
    for (size_t i = 0; i + 1 < t.size(); ++i)
        if (t[i] == "extensions" && t[i + 1] == kDraco) return true;
    return t.size() == 5 && t[0] == "meshes" && t[2] == "primitives" && t[4] == "mode";
}

// A primitive's accessor reference: .../indices, .../attributes/NAME or
// .../targets/T/NAME of /meshes/M/primitives/P.
static bool primitive_reference(const std::vector<std::string> &t)
{
    if (t.size() < 5 || t[0] != "meshes" || t[2] != "primitives") return false;
    return (t.size() == 5 && t[4] == "indices") || (t.size() == 6 && t[4] == "attributes") ||
           (t.size() == 7 && t[4] == "targets");
}

// Before an edit at `pointer` (its tokens t; removal: the value there goes):
// the counts are kept right, or dropped to be made again. For a primitive's
// reference the old value's count goes down here, and after_reference_set
// raises the new one's.
static void before_edit(gltf_doc *doc, const char *pointer, const std::vector<std::string> &t, bool removal)
{
    if (!doc->accessor_ref_counts_valid || edit_keeps_counts(doc, t, removal)) return;
    if (!primitive_reference(t)) return doc->json_changed();
    const ojson::json_pointer ptr(pointer);
    if (!doc->json.contains(ptr)) return;
    const ojson &old = doc->json[ptr];
    if (!is_uint(old) || old.get<uint64_t>() >= doc->accessor_ref_counts.size() ||
        doc->accessor_ref_counts[size_t(old.get<uint64_t>())] == 0)
        return doc->json_changed();
    doc->accessor_ref_counts[size_t(old.get<uint64_t>())]--;
}

// After a primitive's reference was set to `value`: its count goes up.
static void after_reference_set(gltf_doc *doc, const std::vector<std::string> &t, const ojson &value)
{
    if (!doc->accessor_ref_counts_valid || !primitive_reference(t)) return;
    if (!is_uint(value) || value.get<uint64_t>() > (uint64_t(1) << 40)) return doc->json_changed();
    const size_t a = size_t(value.get<uint64_t>());
    if (a >= doc->accessor_ref_counts.size()) doc->accessor_ref_counts.resize(a + 1, 0);
    doc->accessor_ref_counts[a]++;
}

extern "C" int64_t gltf_add_view(gltf_doc *doc, const void *bytes, size_t size, uint64_t byte_stride, int target)
{
    return gltf_add_view_in(doc, bytes, size, byte_stride, target, 0);
}

extern "C" int64_t gltf_add_view_in(gltf_doc *doc, const void *bytes, size_t size, uint64_t byte_stride, int target,
                                    int slot)
{
    return guarded(doc, int64_t(-1), [&] {
        const uint8_t *b = static_cast<const uint8_t *>(bytes);
        size_t v = add_owned_view(doc, std::vector<uint8_t>(b, b + size), target);
        if (byte_stride) doc->json["bufferViews"][v]["byteStride"] = byte_stride;
        doc->views[v].slot = slot == 1 ? 1 : 0;
        return int64_t(v);
    });
}

extern "C" int gltf_view_replaces(gltf_doc *doc, int64_t view, int64_t old_view)
{
    if (old_view < 0 || view <= old_view || size_t(view) >= doc->views.size()) return -1;
    doc->views[size_t(view)].replaces = old_view; // older: a chain of replacements ends
    return 0;
}

extern "C" void gltf_sync_mesh_records(gltf_doc *doc)
{
    guarded(doc, 0, [&] {
        const ojson &meshes = array_of(doc->json, "meshes");
        for (size_t m = doc->prims.size(); m < meshes.size(); ++m) {
            doc->prims.emplace_back();
            build_mesh_records(doc, m);
        }
        return 0;
    });
}

extern "C" int64_t gltf_append_json(gltf_doc *doc, const char *array, const char *json)
{
    return guarded(doc, int64_t(-1), [&]() -> int64_t {
        before_edit(doc, "", {array, "-"}, false);
        ojson value = ojson::parse(json);
        if (!value.is_object()) return -1;
        if (!doc->json.contains(array)) doc->json[array] = ojson::array();
        ojson &arr = doc->json[array];
        if (!arr.is_array()) return -1;
        arr.push_back(std::move(value));
        return int64_t(arr.size() - 1);
    });
}

extern "C" int gltf_set_json(gltf_doc *doc, const char *pointer, const char *json)
{
    return guarded(doc, -1, [&] {
        ojson value = ojson::parse(json);
        const std::vector<std::string> t = pointer_tokens(pointer);
        before_edit(doc, pointer, t, false);
        ojson &slot = doc->json[ojson::json_pointer(pointer)];
        slot = std::move(value);
        after_reference_set(doc, t, slot);
        return 0;
    });
}

extern "C" int gltf_remove_json(gltf_doc *doc, const char *pointer)
{
    return guarded(doc, -1, [&] {
        before_edit(doc, pointer, pointer_tokens(pointer), true);
        ojson::json_pointer ptr(pointer);
        if (ptr.empty() || !doc->json.contains(ptr)) return -1;
        ojson &parent = doc->json[ptr.parent_pointer()];
        const std::string key = ptr.back();
        if (parent.is_object()) parent.erase(key);
        else if (parent.is_array()) parent.erase(size_t(std::stoul(key)));
        else return -1;
        return 0;
    });
}

// A printf-style JSON pointer in `out` (256 bytes); false when it does not fit.
static bool format_pointer(char (&out)[256], const char *format, va_list ap)
{
    const int n = vsnprintf(out, sizeof out, format, ap);
    return n >= 0 && size_t(n) < sizeof out;
}

extern "C" int gltf_set_jsonf(gltf_doc *doc, const char *json, const char *pointer_format, ...)
{
    char pointer[256];
    va_list ap;
    va_start(ap, pointer_format);
    const bool ok = format_pointer(pointer, pointer_format, ap);
    va_end(ap);
    return ok ? gltf_set_json(doc, pointer, json) : -1;
}

extern "C" int gltf_remove_jsonf(gltf_doc *doc, const char *pointer_format, ...)
{
    char pointer[256];
    va_list ap;
    va_start(ap, pointer_format);
    const bool ok = format_pointer(pointer, pointer_format, ap);
    va_end(ap);
    return ok ? gltf_remove_json(doc, pointer) : -1;
}

extern "C" int gltf_copy_json(gltf_doc *doc, const char *from, const char *to)
{
    return guarded(doc, -1, [&] {
        ojson::json_pointer src(from);
        if (!doc->json.contains(src)) return -1;
        ojson value = doc->json[src];
        const std::vector<std::string> t = pointer_tokens(to);
        before_edit(doc, to, t, false);
        ojson &slot = doc->json[ojson::json_pointer(to)];
        slot = std::move(value);
        after_reference_set(doc, t, slot);
        return 0;
    });
}

static const ojson *channels_of(const gltf_doc *doc, size_t animation)
{
    const ojson &animations = array_of(doc->json, "animations");
    if (animation >= animations.size() || !animations[animation].is_object()) return nullptr;
    auto it = animations[animation].find("channels");
    return it == animations[animation].end() || !it->is_array() ? nullptr : &*it;
}

extern "C" size_t gltf_channel_count(const gltf_doc *doc, size_t animation)
{
    const ojson *channels = channels_of(doc, animation);
    return channels ? channels->size() : 0;
}

extern "C" int gltf_get_channel(const gltf_doc *doc, size_t animation, size_t channel, gltf_channel *out)
{
    const ojson *channels = channels_of(doc, animation);
    if (!channels || channel >= channels->size()) return -1;
    out->node = -1;
    out->path = "";
    out->pointer = nullptr;
    const ojson &c = (*channels)[channel];
    auto target = c.is_object() ? c.find("target") : c.end();
    if (!c.is_object() || target == c.end() || !target->is_object()) return 0;
    auto node = target->find("node");
    if (node != target->end() && node->is_number_unsigned()) out->node = i64_or_none(*target, "node");
    auto path = target->find("path");
    if (path != target->end() && path->is_string()) out->path = path->get_ref<const std::string &>().c_str();
    auto ext = target->find("extensions");
    if (ext == target->end() || !ext->is_object()) return 0;
    auto ptr_ext = ext->find("KHR_animation_pointer");
    if (ptr_ext == ext->end() || !ptr_ext->is_object()) return 0;
    auto pointer = ptr_ext->find("pointer");
    if (pointer != ptr_ext->end() && pointer->is_string()) out->pointer = pointer->get_ref<const std::string &>().c_str();
    return 0;
}

extern "C" char *gltf_get_json(const gltf_doc *doc, const char *pointer)
{
    return guarded(doc, static_cast<char *>(nullptr), [&]() -> char * {
        ojson::json_pointer ptr(pointer);
        if (!doc->json.contains(ptr)) return nullptr;
        char *text = strdup(doc->json[ptr].dump().c_str());
        if (!text) throw std::bad_alloc();
        return text;
    });
}

// Adds one to counts[i] for every reference to accessor i in the document (the
// places gltf_accessor_refs lists; counts has one entry per accessor).
static void count_accessor_refs(const ojson &root, std::vector<size_t> &counts)
{
    auto count = [&](const ojson &v) {
        if (is_uint(v) && v.get<uint64_t>() < counts.size()) counts[size_t(v.get<uint64_t>())]++;
    };
    for (auto &mesh : array_of(root, "meshes"))
        for (auto &prim : array_of(mesh, "primitives")) {
            if (prim.contains("indices")) count(prim["indices"]);
            if (prim.contains("attributes"))
                for (auto &a : prim["attributes"]) count(a);
            for (auto &t : array_of(prim, "targets"))
                for (auto &a : t) count(a);
        }
    for (auto &skin : array_of(root, "skins"))
        if (skin.contains("inverseBindMatrices")) count(skin["inverseBindMatrices"]);
    for (auto &anim : array_of(root, "animations"))
        for (auto &sampler : array_of(anim, "samplers")) {
            if (sampler.contains("input")) count(sampler["input"]);
            if (sampler.contains("output")) count(sampler["output"]);
        }
    std::function<void(const ojson &, bool)> walk = [&](const ojson &o, bool in_ext) {
        if (o.is_object()) {
            for (auto it = o.begin(); it != o.end(); ++it) {
                if (it.key() == "extras") continue;
                // its "attributes" are ids inside the Draco stream, not accessors
                if (in_ext && it.key() == kDraco) continue;
                if (in_ext && (it.key() == "accessor" || it.key() == "attributes")) {
                    if (it.value().is_object())
                        for (auto &a : it.value()) count(a);
                    else
                        count(it.value());
                }
                walk(it.value(), in_ext || it.key() == "extensions");
            }
        } else if (o.is_array()) {
            for (auto &e : o) walk(e, in_ext);
        }
    };
    walk(root, false);
}

// Every accessor's reference count, by one walk of the document as it is.
static std::vector<size_t> walk_accessor_refs(const gltf_doc *doc)
{
    std::vector<size_t> counts(array_of(doc->json, "accessors").size(), 0);
    count_accessor_refs(doc->json, counts);
    return counts;
}

extern "C" size_t gltf_accessor_refs(const gltf_doc *doc, size_t index)
{
    return guarded(doc, size_t(0), [&] {
        if (!doc->accessor_ref_counts_valid) {
            doc->accessor_ref_counts = walk_accessor_refs(doc);
            doc->accessor_ref_counts_valid = true;
        }
        return index < doc->accessor_ref_counts.size() ? doc->accessor_ref_counts[index] : 0;
    });
}

extern "C" size_t gltf_accessor_refs_walk(const gltf_doc *doc, size_t index)
{
    return guarded(doc, size_t(0), [&] {
        const std::vector<size_t> counts = walk_accessor_refs(doc);
        return index < counts.size() ? counts[index] : 0;
    });
}

extern "C" size_t gltf_accessor_refs_at_load(const gltf_doc *doc, size_t index)
{
    return index < doc->accessor_refs_at_load.size() ? doc->accessor_refs_at_load[index] : 0;
}

extern "C" void gltf_use_extension(gltf_doc *doc, const char *name, int required)
{
    guarded(doc, 0, [&] {
        before_edit(doc, "", {"extensionsUsed", "-"}, false);
        for (const char *list : {"extensionsUsed", "extensionsRequired"}) {
            if (list[10] == 'R' && !required) continue;
            ojson &arr = doc->json[list];
            if (!arr.is_array()) arr = ojson::array();
            bool present = false;
            for (auto &n : arr) present = present || n == name;
            if (!present) arr.push_back(name);
        }
        return 0;
    });
}

extern "C" int gltf_out_of_memory(const gltf_doc *doc) { return doc->out_of_memory ? 1 : 0; }

// ---- writing -----------------------------------------------------------------------

namespace {

// Every place a bufferView index can stand: accessors, sparse, images, and any
// "bufferView" inside an extension object (extensions we do not know may point
// at views too).
template <typename F> void for_each_view_ref(ojson &root, F &&f)
{
    auto each = [&](ojson &o) {
        auto it = o.find("bufferView");
        if (it != o.end() && is_uint(*it)) f(*it);
    };
    if (root.contains("accessors"))
        for (auto &a : root["accessors"]) {
            each(a);
            if (a.contains("sparse")) {
                if (a["sparse"].contains("indices")) each(a["sparse"]["indices"]);
                if (a["sparse"].contains("values")) each(a["sparse"]["values"]);
            }
        }
    if (root.contains("images"))
        for (auto &i : root["images"]) each(i);
    std::function<void(ojson &, bool)> walk = [&](ojson &o, bool in_ext) {
        if (o.is_object()) {
            if (in_ext) each(o);
            for (auto it = o.begin(); it != o.end(); ++it) {
                if (it.key() == "extras") continue;
                walk(it.value(), in_ext || it.key() == "extensions");
            }
        } else if (o.is_array()) {
            for (auto &e : o) walk(e, in_ext);
        }
    };
    walk(root, false);
}

std::vector<uint8_t> bytes_of(const std::string &s) { return std::vector<uint8_t>(s.begin(), s.end()); }

} // namespace

namespace {
// Called before and after decoding: the compressed streams and the decoded
// views both count as "referenced when read".
void mark_referenced_views(gltf_doc *doc)
{
    doc->referenced_at_load.resize(doc->views.size(), 0);
    for_each_view_ref(doc->json, [&](ojson &ref) {
        uint64_t v = ref.get<uint64_t>();
        if (v < doc->referenced_at_load.size()) doc->referenced_at_load[v] = 1;
    });
}

void add_file(std::vector<gltf_out_file> &files, const std::string &name, const std::vector<uint8_t> &bytes)
{
    gltf_out_file f{};
    f.name = strdup(name.c_str());
    f.size = bytes.size();
    f.bytes = static_cast<uint8_t *>(malloc(bytes.empty() ? 1 : bytes.size()));
    if (!f.name || !f.bytes) {
        free(f.name);
        free(f.bytes);
        throw std::bad_alloc();
    }
    if (!bytes.empty()) memcpy(f.bytes, bytes.data(), bytes.size());
    files.push_back(f);
}

// The path of `file` as seen from folder `from` ("../textures/a.png"), both
// resolved through symbolic links; `file` itself when either cannot be.
std::string relative_path(const std::string &from, const std::string &file)
{
    std::unique_ptr<char, decltype(&free)> a(realpath(from.c_str(), nullptr), free), b(realpath(file.c_str(), nullptr), free);
    if (!a || !b) return file;
    auto parts = [](const char *path) {
        std::vector<std::string> out;
        std::stringstream ss(path);
        for (std::string seg; std::getline(ss, seg, '/');)
            if (!seg.empty()) out.push_back(seg);
        return out;
    };
    const std::vector<std::string> pa = parts(a.get()), pb = parts(b.get());
    size_t common = 0;
    while (common < pa.size() && common + 1 < pb.size() && pa[common] == pb[common]) ++common;
    std::string out;
    for (size_t i = common; i < pa.size(); ++i) out += "../";
    for (size_t i = common; i < pb.size(); ++i) out += pb[i] + (i + 1 < pb.size() ? "/" : "");
    return out;
}

void serialize(const gltf_doc *doc, const std::string &out_path, std::vector<gltf_out_file> &files)
{
    ojson root = doc->json;
    const bool glb = ends_with_ci(out_path, ".glb");
    std::string stem = base_of(out_path);
    size_t dot = stem.find_last_of('.');
    if (dot != std::string::npos && dot > 0) stem = stem.substr(0, dot);

    // Which views survive: all, except decoded Draco streams nothing points at now.
    std::vector<int> used(doc->views.size(), 0);
    for_each_view_ref(root, [&](ojson &ref) {
        uint64_t v = ref.get<uint64_t>();
        if (v < used.size()) used[v] = 1;
    });
    // dropped: a view nothing points at any more, unless the input itself left it unused
    auto dropped = [&](size_t v) {
        return !used[v] && (v >= doc->referenced_at_load.size() || doc->referenced_at_load[v]);
    };
    std::vector<int64_t> remap(doc->views.size(), -1);
    std::vector<uint8_t> bin, side;
    ojson views = ojson::array();
    for (size_t v = 0; v < doc->views.size(); ++v) {
        if (dropped(v)) continue;
        ojson view = doc->json["bufferViews"][v];
        // A view that took the place of one the file no longer has carries
        // what described it: rewriting data must not lose its metadata.
        for (int64_t r = doc->views[v].replaces; r >= 0 && dropped(size_t(r)); r = doc->views[size_t(r)].replaces)
            for (const char *key : {"name", "extras", "extensions"}) {
                const ojson &old = doc->json["bufferViews"][size_t(r)];
                if (old.contains(key) && !view.contains(key)) view[key] = old[key];
            }
        std::vector<uint8_t> &out = doc->views[v].slot ? side : bin;
        while (out.size() % 4) out.push_back(0);
        view["buffer"] = doc->views[v].slot;
        view["byteOffset"] = out.size();
        view["byteLength"] = doc->views[v].size;
        if (view["byteOffset"] == 0) view.erase("byteOffset");
        // keep the key order of the original object: re-insert in place
        ojson ordered = ojson::object();
        for (auto it = doc->json["bufferViews"][v].begin(); it != doc->json["bufferViews"][v].end(); ++it)
            if (view.contains(it.key())) ordered[it.key()] = view[it.key()];
        for (auto it = view.begin(); it != view.end(); ++it)
            if (!ordered.contains(it.key())) ordered[it.key()] = it.value();
        out.insert(out.end(), doc->views[v].ptr, doc->views[v].ptr + doc->views[v].size);
        remap[v] = int64_t(views.size());
        views.push_back(ordered);
    }
    for_each_view_ref(root, [&](ojson &ref) {
        uint64_t v = ref.get<uint64_t>();
        if (v < remap.size() && remap[v] >= 0) ref = remap[v];
    });
    if (views.empty()) root.erase("bufferViews");
    else root["bufferViews"] = views;

    // One buffer: it keeps the first original buffer's name, extras and extensions.
    if (bin.empty() && views.empty()) {
        root.erase("buffers");
    } else {
        ojson buffer = ojson::object();
        const ojson &old = array_of(doc->json, "buffers");
        if (!old.empty() && !is_meshopt_fallback(old[0])) buffer = old[0];
        buffer.erase("uri");
        for (const char *name : kMeshoptNames) erase_ext(buffer, name);
        if (!glb) buffer["uri"] = uri_of_name(stem + ".bin");
        buffer["byteLength"] = bin.size();
        root["buffers"] = ojson::array({buffer});
    }
    // The side buffer (e.g. Draco's uncompressed fallback) is always a file of
    // its own, so a client that does not need it never fetches it.
    const std::string side_name = stem + ".fallback.bin";
    if (!side.empty()) {
        ojson buffer = ojson::object();
        buffer["uri"] = uri_of_name(side_name);
        buffer["byteLength"] = side.size();
        root["buffers"].push_back(buffer);
    }

    // External images travel beside the output under their own relative uri.
    // One outside the input's folder (--allow-external-uris) stays where it is:
    // an absolute or file:// uri is kept, a relative one ("../tex.png") is
    // rewritten to reach the same file from the output's folder.
    std::vector<std::pair<std::string, const std::vector<uint8_t> *>> images;
    for (auto &kv : doc->external_images) {
        const std::string uri = doc->json["images"][kv.first]["uri"].get<std::string>();
        const std::string decoded = tinygltf::dlib::urldecode(uri);
        if (!uri_escapes(uri, decoded)) images.push_back({decoded, &kv.second});
        else if (!uri_has_scheme(uri) && decoded[0] != '/')
            root["images"][kv.first]["uri"] = uri_of_name(relative_path(dir_of(out_path), resolve_uri(doc->dir, uri)), true);
    }

    if (glb) {
        std::string text = root.dump(-1, ' ', false, ojson::error_handler_t::strict);
        while (text.size() % 4) text.push_back(' ');
        size_t bin_padded = (bin.size() + 3) & ~size_t(3);
        uint64_t total = 12 + 8 + text.size() + (bin.empty() ? 0 : 8 + bin_padded);
        if (total > 0xFFFFFFFFull) fail(GLTF_INVALID, "output is larger than the 4 GiB a GLB can hold");
        std::vector<uint8_t> out;
        out.reserve(size_t(total));
        for (char c : std::string("glTF")) out.push_back(uint8_t(c));
        wr32(out, 2);
        wr32(out, uint32_t(total));
        wr32(out, uint32_t(text.size()));
        wr32(out, 0x4E4F534Au);
        out.insert(out.end(), text.begin(), text.end());
        if (!bin.empty()) {
            wr32(out, uint32_t(bin_padded));
            wr32(out, 0x004E4942u);
            out.insert(out.end(), bin.begin(), bin.end());
            out.resize(size_t(total), 0);
        }
        add_file(files, base_of(out_path), out);
    } else {
        std::string text = root.dump(2, ' ', false, ojson::error_handler_t::strict);
        text.push_back('\n');
        add_file(files, base_of(out_path), bytes_of(text));
        if (!bin.empty() || !views.empty()) add_file(files, stem + ".bin", bin);
    }
    if (!side.empty()) add_file(files, side_name, side);
    for (auto &img : images) add_file(files, img.first, *img.second);
}

} // namespace

extern "C" int gltf_serialize(const gltf_doc *doc, const char *out_path, gltf_out_file **files, size_t *file_count,
                              char *err, size_t errlen)
{
    *files = nullptr;
    *file_count = 0;
    std::vector<gltf_out_file> out;
    if (doc->binary_released) {
        snprintf(err, errlen, "the document's binary data was released (gltf_release_binary)");
        return GLTF_IO;
    }
    if (doc->out_of_memory) {
        snprintf(err, errlen, "out of memory while building the document");
        return GLTF_INVALID;
    }
    try {
        serialize(doc, out_path, out);
    } catch (const Failure &f) {
        gltf_free_files(out.data(), out.size());
        snprintf(err, errlen, "%s", f.msg.c_str());
        return f.code;
    } catch (const std::bad_alloc &) {
        gltf_free_files(out.data(), out.size());
        snprintf(err, errlen, "out of memory while writing");
        return GLTF_INVALID;
    } catch (const std::exception &e) {
        gltf_free_files(out.data(), out.size());
        snprintf(err, errlen, "cannot serialize (%s)", e.what());
        return GLTF_IO;
    }
    *files = static_cast<gltf_out_file *>(malloc(sizeof(gltf_out_file) * (out.empty() ? 1 : out.size())));
    if (!*files) {
        gltf_free_files(out.data(), out.size());
        snprintf(err, errlen, "out of memory while writing");
        return GLTF_INVALID;
    }
    if (!out.empty()) memcpy(*files, out.data(), sizeof(gltf_out_file) * out.size());
    *file_count = out.size();
    return GLTF_OK;
}

extern "C" void gltf_free_files(gltf_out_file *files, size_t file_count)
{
    if (!files) return;
    for (size_t i = 0; i < file_count; ++i) {
        free(files[i].name);
        free(files[i].bytes);
    }
}
