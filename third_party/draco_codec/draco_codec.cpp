// draco_codec.cpp - the C bridge over Draco; see draco_codec.h.
#include "draco_codec.h"

#include <cstdio>
#include <cstring>
#include <memory>

#include <draco/compression/decode.h>
#include <draco/mesh/mesh.h>

struct draco_mesh {
    std::unique_ptr<draco::Mesh> mesh;
};

static void set_err(char *err, size_t errlen, const char *msg)
{
    if (err && errlen) snprintf(err, errlen, "%s", msg);
}

extern "C" int draco_decode_mesh(const void *data, size_t size, draco_mesh **out,
                                 char *err, size_t errlen)
{
    *out = nullptr;
    try {
        draco::DecoderBuffer buffer;
        buffer.Init(static_cast<const char *>(data), size);
        auto type = draco::Decoder::GetEncodedGeometryType(&buffer);
        if (!type.ok() || type.value() != draco::TRIANGULAR_MESH) {
            set_err(err, errlen, "not a Draco triangle mesh stream");
            return -1;
        }
        draco::Decoder decoder;
        auto result = decoder.DecodeMeshFromBuffer(&buffer);
        if (!result.ok() || !result.value()) {
            char msg[256];
            snprintf(msg, sizeof msg, "Draco stream does not decode (%s)",
                     result.ok() ? "empty" : result.status().error_msg());
            set_err(err, errlen, msg);
            return -1;
        }
        draco_mesh *m = new draco_mesh;
        m->mesh = std::move(result).value();
        *out = m;
        return 0;
    } catch (...) {
        set_err(err, errlen, "Draco decoder failed (out of memory?)");
        return -1;
    }
}

extern "C" void draco_mesh_free(draco_mesh *mesh) { delete mesh; }

extern "C" uint32_t draco_mesh_num_points(const draco_mesh *m)
{
    return m->mesh->num_points();
}

extern "C" uint32_t draco_mesh_num_faces(const draco_mesh *m)
{
    return m->mesh->num_faces();
}

extern "C" int draco_mesh_read_indices(const draco_mesh *m, uint32_t *out)
{
    const uint32_t faces = m->mesh->num_faces();
    for (uint32_t f = 0; f < faces; ++f) {
        const draco::Mesh::Face &face = m->mesh->face(draco::FaceIndex(f));
        for (int c = 0; c < 3; ++c) out[3 * size_t(f) + c] = face[c].value();
    }
    return 0;
}

template <typename T>
static bool read_all(const draco::PointAttribute *att, uint32_t points, int components,
                     void *out)
{
    T *dst = static_cast<T *>(out);
    for (uint32_t p = 0; p < points; ++p) {
        draco::AttributeValueIndex avi = att->mapped_index(draco::PointIndex(p));
        if (avi.value() >= att->size()) return false;
        if (!att->ConvertValue<T>(avi, int8_t(components), dst + size_t(p) * components))
            return false;
    }
    return true;
}

extern "C" int draco_mesh_read_attribute(const draco_mesh *m, uint32_t unique_id,
                                         int ctype, int components, void *out,
                                         char *err, size_t errlen)
{
    const draco::PointAttribute *att = m->mesh->GetAttributeByUniqueId(unique_id);
    if (!att) {
        set_err(err, errlen, "the Draco stream has no attribute with that id");
        return -1;
    }
    if (components < 1 || components > 4 || att->num_components() < components) {
        set_err(err, errlen, "the Draco attribute has fewer components than the accessor");
        return -1;
    }
    const uint32_t points = m->mesh->num_points();
    bool ok = false;
    switch (ctype) {
    case 5120: ok = read_all<int8_t>(att, points, components, out); break;
    case 5121: ok = read_all<uint8_t>(att, points, components, out); break;
    case 5122: ok = read_all<int16_t>(att, points, components, out); break;
    case 5123: ok = read_all<uint16_t>(att, points, components, out); break;
    case 5125: ok = read_all<uint32_t>(att, points, components, out); break;
    case 5126: ok = read_all<float>(att, points, components, out); break;
    default: break;
    }
    if (!ok) {
        set_err(err, errlen, "a Draco attribute value does not fit the accessor's component type");
        return -1;
    }
    return 0;
}
