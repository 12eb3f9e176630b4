// draco_codec.cpp - the C bridge over Draco; see draco_codec.h.
#include "draco_codec.h"

#include <new>

#include <cstdio>
#include <cstring>
#include <memory>

#include <cstdlib>

#include <draco/compression/decode.h>
#include <draco/compression/expert_encode.h>
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
    } catch (const std::bad_alloc &) {
        set_err(err, errlen, "out of memory decoding Draco");
        return DRACO_OUT_OF_MEMORY;
    } catch (...) {
        set_err(err, errlen, "Draco decoder failed");
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

// ---- encoding --------------------------------------------------------------------

static bool data_type_of(int ctype, draco::DataType *dt, int *size)
{
    switch (ctype) {
    case 5120: *dt = draco::DT_INT8; *size = 1; return true;
    case 5121: *dt = draco::DT_UINT8; *size = 1; return true;
    case 5122: *dt = draco::DT_INT16; *size = 2; return true;
    case 5123: *dt = draco::DT_UINT16; *size = 2; return true;
    case 5125: *dt = draco::DT_UINT32; *size = 4; return true;
    case 5126: *dt = draco::DT_FLOAT32; *size = 4; return true;
    default: return false;
    }
}

static draco::GeometryAttribute::Type type_of(draco_semantic s)
{
    switch (s) {
    case DRACO_SEMANTIC_POSITION: return draco::GeometryAttribute::POSITION;
    case DRACO_SEMANTIC_NORMAL: return draco::GeometryAttribute::NORMAL;
    case DRACO_SEMANTIC_COLOR: return draco::GeometryAttribute::COLOR;
    case DRACO_SEMANTIC_TEXCOORD: return draco::GeometryAttribute::TEX_COORD;
    default: return draco::GeometryAttribute::GENERIC;
    }
}

extern "C" int draco_encode_mesh(uint32_t point_count, const uint32_t *indices, uint32_t face_count,
                                 const draco_encode_attribute *attributes, size_t attribute_count,
                                 const draco_encode_options *options, uint8_t **out, size_t *out_size,
                                 uint32_t *unique_ids, char *err, size_t errlen)
{
    *out = nullptr;
    *out_size = 0;
    try {
        draco::Mesh mesh;
        mesh.set_num_points(point_count);
        mesh.SetNumFaces(face_count);
        for (uint32_t f = 0; f < face_count; ++f) {
            draco::Mesh::Face face;
            for (int c = 0; c < 3; ++c) {
                uint32_t i = indices[3 * size_t(f) + c];
                if (i >= point_count) {
                    set_err(err, errlen, "a face index is out of range");
                    return -1;
                }
                face[c] = draco::PointIndex(i);
            }
            mesh.SetFace(draco::FaceIndex(f), face);
        }
        std::vector<int> ids(attribute_count);
        for (size_t a = 0; a < attribute_count; ++a) {
            const draco_encode_attribute &in = attributes[a];
            draco::DataType dt;
            int size;
            if (!data_type_of(in.gltf_component_type, &dt, &size) || in.components < 1 || in.components > 4) {
                set_err(err, errlen, "an attribute has a type Draco cannot store");
                return -1;
            }
            const int64_t stride = int64_t(size) * in.components;
            draco::GeometryAttribute ga;
            ga.Init(type_of(in.semantic), nullptr, uint8_t(in.components), dt, in.normalized != 0, stride, 0);
            ids[a] = mesh.AddAttribute(ga, true, point_count);
            if (ids[a] < 0) {
                set_err(err, errlen, "Draco refused an attribute");
                return -1;
            }
            if (point_count)
                mesh.attribute(ids[a])->buffer()->Write(0, in.values, size_t(stride) * point_count);
        }
        if (options->deduplicate && !options->sequential) {
            if (!mesh.DeduplicateAttributeValues()) {
                set_err(err, errlen, "Draco could not deduplicate the attribute values");
                return -1;
            }
            mesh.DeduplicatePointIds();
        }
        draco::ExpertEncoder encoder(mesh);
        encoder.SetSpeedOptions(options->speed, options->speed);
        encoder.SetEncodingMethod(options->sequential ? draco::MESH_SEQUENTIAL_ENCODING : draco::MESH_EDGEBREAKER_ENCODING);
        for (size_t a = 0; a < attribute_count; ++a) {
            const draco_encode_attribute &in = attributes[a];
            if (in.gltf_component_type != 5126 || in.quantization_bits == 0) continue; // lossless
            if (in.explicit_grid)
                encoder.SetAttributeExplicitQuantization(ids[a], in.quantization_bits, in.components, in.origin, in.range);
            else
                encoder.SetAttributeQuantization(ids[a], in.quantization_bits);
        }
        draco::EncoderBuffer buffer;
        draco::Status status = encoder.EncodeToBuffer(&buffer);
        if (!status.ok()) {
            char msg[256];
            snprintf(msg, sizeof msg, "Draco encoding failed (%s)", status.error_msg());
            set_err(err, errlen, msg);
            return -1;
        }
        *out = static_cast<uint8_t *>(malloc(buffer.size() ? buffer.size() : 1));
        if (!*out) {
            set_err(err, errlen, "out of memory encoding Draco");
            return DRACO_OUT_OF_MEMORY;
        }
        memcpy(*out, buffer.data(), buffer.size());
        *out_size = buffer.size();
        for (size_t a = 0; a < attribute_count; ++a) unique_ids[a] = mesh.attribute(ids[a])->unique_id();
        return 0;
    } catch (const std::bad_alloc &) {
        set_err(err, errlen, "out of memory encoding Draco");
        return DRACO_OUT_OF_MEMORY;
    } catch (...) {
        set_err(err, errlen, "Draco encoder failed");
        return -1;
    }
}
