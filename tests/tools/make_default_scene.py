#!/usr/bin/env python3
"""Generate lodpipe's small default scene as one binary glTF 2.0 file (.glb).

Usage:
    python3 tests/tools/make_default_scene.py assets/default_scene.glb

Standard library only and fully deterministic: no randomness and no
timestamps, so every run writes the same bytes. The file is written to a
temporary file in the output folder and then renamed into place.

Every mesh is built here from closed-form formulas (sums of sines and
Gaussian bumps); nothing is copied from an existing model. Each feature is
there to exercise one part of the LOD pipeline:

  terrain   A finely tessellated height field with smooth hills: an OPEN
            surface (it has a border) that carries most of the triangles, so
            simplification is easy to see, and checks that borders are kept.

  rock      A closed lat-long sphere displaced by sums of sines, made of TWO
            primitives with two materials: the upper cap is "moss", the lower
            part is "stone", split along a latitude line. Both primitives
            repeat the boundary vertex positions bit for bit, so the mesh,
            welded by position, is one watertight manifold. It checks that the
            LODs stay watertight across a material boundary (no cracks open
            along the seam) and that the boundary itself is preserved.
            Its u = 0 / u = 1 meridian is also a UV seam.

  vase      A surface of revolution with a wavy profile, open at the mouth,
            with a flat bottom cap. Its u wrap is a UV seam (vertices with the
            same position but different UVs) and the rim of the cap is a hard
            edge (same position, different normals). It checks that attribute
            seams do not tear and that a border (the lip) is kept.

  (the vase carries one morph target, a bulge, so morph handling is exercised)
  torus     A closed torus with a wavy tube radius, with UV seams in both
            directions. It is INSTANCED by two nodes at different scales
            (1 and 2.5), translations and rotations: it checks that a mesh used by
            several nodes is simplified once and shared, and that error bounds
            are scaled by the node transform.

Nodes form a small hierarchy: "terrain" is the only root (scene 0) and the
other four nodes are its children, so world transforms must be composed.

Every primitive has POSITION (exact float32 min/max), unit NORMAL and
TEXCOORD_0, is indexed TRIANGLES (UNSIGNED_SHORT indices below 65536
vertices, UNSIGNED_INT otherwise) and is wound counter-clockwise seen from
outside. All data lives in one buffer with 4-byte aligned buffer views.
Materials are pbrMetallicRoughness factors times one tiny checker texture
(an 8x8 PNG written here, embedded in the buffer). The texture is what makes
TEXCOORD_0 used (without it the Khronos validator flags the UVs as unused),
and it makes UV seams and UV stretching visible when a LOD is rendered.
"""

import json
import math
import os
import struct
import sys
import zlib

GENERATOR = "lodpipe make_default_scene.py"

ARRAY_BUFFER = 34962
ELEMENT_ARRAY_BUFFER = 34963
FLOAT = 5126
UNSIGNED_SHORT = 5123
UNSIGNED_INT = 5125
TRIANGLES = 4
NEAREST = 9728
LINEAR_MIPMAP_LINEAR = 9987
REPEAT = 10497
CHECKER_SIZE = 8

TAU = 2.0 * math.pi

MATERIALS = [
    # name, base colour RGBA, metallic, roughness
    ("moss", (0.24, 0.42, 0.12, 1.0), 0.0, 0.9),
    ("stone", (0.46, 0.44, 0.41, 1.0), 0.0, 0.75),
    ("glaze", (0.12, 0.30, 0.62, 1.0), 0.1, 0.3),
]
MOSS, STONE, GLAZE = 0, 1, 2

# Tessellation (total is about 63k triangles).
TERRAIN_CELLS = 112          # 112 x 112 quads
TERRAIN_HALF_SIZE = 12.0
ROCK_SEGMENTS = 128          # around the vertical axis
ROCK_RINGS = 80              # pole to pole
ROCK_MOSS_RINGS = 36         # rings above the material boundary
VASE_SEGMENTS = 96
VASE_ROWS = 64
TORUS_SEGMENTS = 96          # around the main axis
TORUS_SIDES = 32             # around the tube


# ---------------------------------------------------------------- numbers

def to_float32(x):
    """Round to the nearest float32; -0.0 becomes 0.0 so equal points have equal bits."""
    return struct.unpack("<f", struct.pack("<f", x))[0] + 0.0


def vec3_float32(v):
    return (to_float32(v[0]), to_float32(v[1]), to_float32(v[2]))


def subtract(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0])


def normalize(v):
    length = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if length == 0.0:
        raise ValueError("cannot normalize a zero vector")
    return (v[0] / length, v[1] / length, v[2] / length)


def unit_float32(v):
    """Normalize, round to float32, and renormalize once more if rounding moved the length."""
    n = vec3_float32(normalize(v))
    if abs(math.sqrt(n[0] ** 2 + n[1] ** 2 + n[2] ** 2) - 1.0) > 1e-6:
        n = vec3_float32(normalize(n))
    return n


# ---------------------------------------------------------------- surfaces

class Surface:
    """Triangles over shared vertices, each triangle tagged with a material slot.

    A vertex's smoothing group decides which vertices at the same position
    average their normals: vertices in different groups make a hard edge.
    """

    def __init__(self):
        self.positions = []
        self.uvs = []
        self.smoothing_groups = []
        self.triangles = []
        self.triangle_materials = []

    def add_vertex(self, position, uv, smoothing_group=0):
        self.positions.append(vec3_float32(position))
        self.uvs.append((to_float32(uv[0]), to_float32(uv[1])))
        self.smoothing_groups.append(smoothing_group)
        return len(self.positions) - 1

    def add_triangle(self, a, b, c, material):
        self.triangles.append((a, b, c))
        self.triangle_materials.append(material)

    def add_quad(self, a, b, c, d, material):
        """Quad a-b-c-d, counter-clockwise seen from the front."""
        self.add_triangle(a, b, c, material)
        self.add_triangle(a, c, d, material)


def add_grid(surface, columns, rows, point_at, uv_at, material_of_row, flip=False):
    """Add a (columns x rows)-quad grid of vertices point_at(i, j), i <= columns, j <= rows.

    The front side is the one where d/di x d/dj points; flip=True turns it around.
    Returns the vertex index grid as grid[j][i].
    """
    grid = []
    for j in range(rows + 1):
        grid.append([surface.add_vertex(point_at(i, j), uv_at(i, j)) for i in range(columns + 1)])
    for j in range(rows):
        material = material_of_row(j)
        for i in range(columns):
            a, b = grid[j][i], grid[j][i + 1]
            c, d = grid[j + 1][i + 1], grid[j + 1][i]
            if flip:
                surface.add_quad(a, d, c, b, material)
            else:
                surface.add_quad(a, b, c, d, material)
    return grid


def smooth_normals(surface):
    """Area-weighted face normals, summed over all vertices with the same position and group."""
    sums = {}
    for a, b, c in surface.triangles:
        pa, pb, pc = surface.positions[a], surface.positions[b], surface.positions[c]
        face = cross(subtract(pb, pa), subtract(pc, pa))
        for v in (a, b, c):
            key = (surface.smoothing_groups[v], surface.positions[v])
            s = sums.get(key, (0.0, 0.0, 0.0))
            sums[key] = (s[0] + face[0], s[1] + face[1], s[2] + face[2])
    return [unit_float32(sums[(g, p)]) for g, p in zip(surface.smoothing_groups, surface.positions)]


class Primitive:
    def __init__(self, material, positions, normals, uvs, indices):
        self.material = material
        self.positions = positions
        self.normals = normals
        self.uvs = uvs
        self.indices = indices
        self.targets = []  # morph targets: per target, a POSITION delta per vertex


def split_into_primitives(surface):
    """One primitive per material slot, each with its own copy of the vertices it uses.

    Vertices on a material boundary are copied into both primitives with
    identical position, normal and UV, so the parts weld back together exactly.
    """
    normals = smooth_normals(surface)
    primitives = []
    for material in sorted(set(surface.triangle_materials)):
        triangles = [t for t, m in zip(surface.triangles, surface.triangle_materials) if m == material]
        used = sorted({v for t in triangles for v in t})
        new_index = {old: new for new, old in enumerate(used)}
        primitives.append(Primitive(
            material,
            [surface.positions[v] for v in used],
            [normals[v] for v in used],
            [surface.uvs[v] for v in used],
            [new_index[v] for t in triangles for v in t]))
    return primitives


# ---------------------------------------------------------------- shapes

def terrain_height(x, z):
    """Smooth rolling hills: a few long sines plus two Gaussian bumps."""
    return (0.9 * math.sin(0.35 * x + 0.4) * math.cos(0.30 * z - 0.2)
            + 0.45 * math.sin(0.80 * x + 0.55 * z + 1.0)
            + 0.18 * math.sin(1.70 * x - 0.3) * math.sin(1.30 * z + 0.7)
            + 1.8 * math.exp(-((x - 5.0) ** 2 + (z + 4.0) ** 2) / 12.0)
            - 1.1 * math.exp(-((x + 4.0) ** 2 + (z - 5.0) ** 2) / 9.0))


def make_terrain():
    n, half = TERRAIN_CELLS, TERRAIN_HALF_SIZE
    surface = Surface()

    def coordinate(k):
        return -half + 2.0 * half * k / n

    # i runs along z and j along x, so d/di x d/dj = z x x = +y: the front faces up.
    def point_at(i, j):
        x, z = coordinate(j), coordinate(i)
        return (x, terrain_height(x, z), z)

    add_grid(surface, n, n, point_at, lambda i, j: (j / n, i / n), lambda j: MOSS)
    return surface


def rock_direction(ring, segment):
    """Unit direction of a lat-long vertex; segment is taken modulo the count so the
    u seam repeats its positions bit for bit."""
    theta = math.pi * ring / ROCK_RINGS
    phi = TAU * (segment % ROCK_SEGMENTS) / ROCK_SEGMENTS
    s = math.sin(theta)
    return (s * math.cos(phi), math.cos(theta), s * math.sin(phi))


def rock_point(direction):
    """A sphere pushed in and out by a few sums of sines, squashed into a rock shape."""
    dx, dy, dz = direction
    radius = (1.0
              + 0.10 * math.sin(2.3 * dx + 3.1 * dy + 0.5)
              + 0.07 * math.sin(4.7 * dy - 3.3 * dz + 1.7)
              + 0.04 * math.sin(7.9 * dz + 5.1 * dx + 0.3)
              + 0.02 * math.sin(11.0 * dx - 9.0 * dy + 6.0 * dz))
    return (1.15 * radius * dx, 0.8 * radius * dy, 0.95 * radius * dz)


def make_rock():
    """Closed lat-long sphere: pole fans plus a grid of rings, moss above the boundary ring."""
    segments, rings = ROCK_SEGMENTS, ROCK_RINGS
    surface = Surface()

    def material_of_band(band):  # band k lies between ring k and ring k + 1
        return MOSS if band < ROCK_MOSS_RINGS else STONE

    # Inner rings 1 .. rings-1. Grid row j is ring j + 1; d/di (east) x d/dj (south)
    # points outward.
    grid = add_grid(
        surface, segments, rings - 2,
        lambda i, j: rock_point(rock_direction(j + 1, i)),
        lambda i, j: (i / segments, (j + 1) / rings),
        lambda j: material_of_band(j + 1))

    # Poles: one vertex per fan triangle, so each can carry its own u.
    north, south = rock_point((0.0, 1.0, 0.0)), rock_point((0.0, -1.0, 0.0))
    first_ring, last_ring = grid[0], grid[-1]
    for i in range(segments):
        u = (i + 0.5) / segments
        top = surface.add_vertex(north, (u, 0.0))
        surface.add_triangle(top, first_ring[i + 1], first_ring[i], material_of_band(0))
        bottom = surface.add_vertex(south, (u, 1.0))
        surface.add_triangle(last_ring[i], last_ring[i + 1], bottom, material_of_band(rings - 1))
    return surface


def vase_radius(t):
    """Wavy profile, t = 0 at the bottom and 1 at the mouth."""
    return (0.45 + 0.35 * math.sin(math.pi * (0.15 + 0.85 * t))
            + 0.06 * math.sin(5.0 * math.pi * t)
            + 0.15 * t * t * t)


def vase_point(segment, row):
    t = row / VASE_ROWS
    phi = TAU * (segment % VASE_SEGMENTS) / VASE_SEGMENTS
    # A gentle ripple around the axis as well, so the surface is not a plain lathe.
    r = vase_radius(t) * (1.0 + 0.03 * math.sin(6.0 * phi) * math.sin(math.pi * t))
    return (r * math.cos(phi), 1.6 * t, r * math.sin(phi))


def make_vase():
    """Open-mouthed surface of revolution with a flat bottom cap on a hard edge."""
    segments, rows = VASE_SEGMENTS, VASE_ROWS
    surface = Surface()
    # d/di (around) x d/dj (up) points inward, so flip to face outward.
    add_grid(surface, segments, rows, vase_point,
             lambda i, j: (i / segments, 1.0 - j / rows), lambda j: GLAZE, flip=True)

    # Bottom cap: its own smoothing group, so the rim keeps a sharp crease.
    cap_group = 1
    max_radius = vase_radius(0.0) * 1.03
    center = surface.add_vertex((0.0, 0.0, 0.0), (0.5, 0.5), cap_group)

    def cap_uv(p):
        return (0.5 + 0.5 * p[0] / max_radius, 0.5 + 0.5 * p[2] / max_radius)

    rim = []
    for i in range(segments):
        p = vase_point(i, 0)
        rim.append(surface.add_vertex(p, cap_uv(p), cap_group))
    for i in range(segments):
        surface.add_triangle(center, rim[i], rim[(i + 1) % segments], GLAZE)
    return surface


def torus_point(segment, side):
    phi = TAU * (segment % TORUS_SEGMENTS) / TORUS_SEGMENTS
    theta = TAU * (side % TORUS_SIDES) / TORUS_SIDES
    tube = 0.32 * (1.0 + 0.18 * math.sin(5.0 * phi + 2.0 * theta))
    ring = 1.0 + tube * math.cos(theta)
    return (ring * math.cos(phi), tube * math.sin(theta), ring * math.sin(phi))


def make_torus():
    surface = Surface()
    # d/di (around the main axis) x d/dj (around the tube) points inward: flip.
    add_grid(surface, TORUS_SEGMENTS, TORUS_SIDES, torus_point,
             lambda i, j: (i / TORUS_SEGMENTS, j / TORUS_SIDES), lambda j: GLAZE, flip=True)
    return surface


# ---------------------------------------------------------------- glTF writing

class BufferBuilder:
    """Accumulates one binary buffer, its buffer views and accessors."""

    def __init__(self):
        self.data = bytearray()
        self.buffer_views = []
        self.accessors = []

    def add_view(self, payload, target=None):
        self.data.extend(b"\0" * (-len(self.data) % 4))
        view = {"buffer": 0, "byteOffset": len(self.data), "byteLength": len(payload)}
        if target is not None:
            view["target"] = target
        self.buffer_views.append(view)
        self.data.extend(payload)
        return len(self.buffer_views) - 1

    def add_accessor(self, view, component_type, count, kind, extra=None):
        accessor = {"bufferView": view, "componentType": component_type,
                    "count": count, "type": kind}
        accessor.update(extra or {})
        self.accessors.append(accessor)
        return len(self.accessors) - 1

    def add_float_attribute(self, rows, kind, with_bounds=False):
        flat = [x for row in rows for x in row]
        view = self.add_view(struct.pack("<%df" % len(flat), *flat), ARRAY_BUFFER)
        extra = None
        if with_bounds:
            columns = list(zip(*rows))  # values are already float32-exact
            extra = {"min": [min(c) for c in columns], "max": [max(c) for c in columns]}
        return self.add_accessor(view, FLOAT, len(rows), kind, extra)

    def add_indices(self, indices, vertex_count):
        if vertex_count < 65536:
            fmt, component_type = "<%dH", UNSIGNED_SHORT
        else:
            fmt, component_type = "<%dI", UNSIGNED_INT
        view = self.add_view(struct.pack(fmt % len(indices), *indices), ELEMENT_ARRAY_BUFFER)
        return self.add_accessor(view, component_type, len(indices), "SCALAR")

    def padded_data(self):
        return bytes(self.data) + b"\0" * (-len(self.data) % 4)


def mesh_json(name, primitives, builder):
    entries = []
    for p in primitives:
        attributes = {
            "POSITION": builder.add_float_attribute(p.positions, "VEC3", with_bounds=True),
            "NORMAL": builder.add_float_attribute(p.normals, "VEC3"),
            "TEXCOORD_0": builder.add_float_attribute(p.uvs, "VEC2"),
        }
        entry = {
            "attributes": attributes,
            "indices": builder.add_indices(p.indices, len(p.positions)),
            "material": p.material,
            "mode": TRIANGLES,
        }
        if p.targets:
            entry["targets"] = [{"POSITION": builder.add_float_attribute(t, "VEC3", with_bounds=True)}
                                for t in p.targets]
        entries.append(entry)
    mesh = {"name": name, "primitives": entries}
    target_count = max(len(p.targets) for p in primitives)
    if target_count:
        mesh["weights"] = [0.0] * target_count
    return mesh


def add_bulge_target(primitives):
    """A morph target that swells the middle of a surface of revolution about the y axis.

    It exists so the LOD chain's morph-target handling (the bound holds for the base
    shape; each target's extra deviation is measured and recorded) has something to do.
    """
    for p in primitives:
        ys = [v[1] for v in p.positions]
        low, high = min(ys), max(ys)
        deltas = []
        for x, y, z in p.positions:
            r = math.hypot(x, z)
            t = (y - low) / (high - low) if high > low else 0.0
            amount = 0.12 * math.sin(math.pi * t)
            if r > 1e-6:
                deltas.append(vec3_float32((amount * x / r, 0.0, amount * z / r)))
            else:
                deltas.append((0.0, 0.0, 0.0))
        p.targets.append(deltas)
    return primitives


def material_json(name, color, metallic, roughness):
    return {"name": name, "pbrMetallicRoughness": {
        "baseColorFactor": list(color),
        "baseColorTexture": {"index": 0, "texCoord": 0},
        "metallicFactor": metallic,
        "roughnessFactor": roughness}}


def png_chunk(kind, payload):
    return (struct.pack(">I", len(payload)) + kind + payload
            + struct.pack(">I", zlib.crc32(kind + payload) & 0xFFFFFFFF))


def stored_zlib_stream(raw):
    """A zlib stream of uncompressed (stored) deflate blocks: the bytes do not depend
    on the zlib build, unlike zlib.compress."""
    out = bytearray(b"\x78\x01")
    for start in range(0, len(raw), 65535):
        block = raw[start:start + 65535]
        final = 1 if start + 65535 >= len(raw) else 0
        out += struct.pack("<BHH", final, len(block), len(block) ^ 0xFFFF) + block
    out += struct.pack(">I", zlib.adler32(raw) & 0xFFFFFFFF)
    return bytes(out)


def checker_png(size):
    """A light grey checker, one texel per square, as an RGB PNG."""
    rows = bytearray()
    for y in range(size):
        rows.append(0)  # filter type: none
        for x in range(size):
            level = 255 if (x + y) % 2 == 0 else 200
            rows += bytes((level, level, level))
    header = struct.pack(">IIBBBBB", size, size, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + png_chunk(b"IHDR", header)
            + png_chunk(b"IDAT", stored_zlib_stream(bytes(rows))) + png_chunk(b"IEND", b""))


def on_terrain(x, z, lift):
    """A translation that sets an object on the terrain surface."""
    return [x, round(terrain_height(x, z) + lift, 4), z]


def build_gltf(meshes):
    """meshes: list of (name, primitives). Returns (json dict, binary chunk)."""
    builder = BufferBuilder()
    mesh_index = {}
    mesh_entries = []
    for name, primitives in meshes:
        mesh_index[name] = len(mesh_entries)
        mesh_entries.append(mesh_json(name, primitives, builder))

    # A small hierarchy: the terrain is the root and carries the props.
    nodes = [
        {"name": "terrain", "mesh": mesh_index["terrain"], "children": [1, 2, 3, 4]},
        {"name": "rock", "mesh": mesh_index["rock"], "translation": on_terrain(-3.0, 2.0, 0.55)},
        {"name": "vase", "mesh": mesh_index["vase"], "translation": on_terrain(3.0, 3.0, -0.05)},
        {"name": "torus_small", "mesh": mesh_index["torus"],
         "translation": on_terrain(-1.0, -5.0, 0.3)},
        {"name": "torus_large", "mesh": mesh_index["torus"],
         "translation": on_terrain(6.0, -6.0, 1.5),
         "rotation": [0.0, 0.0, math.sin(math.radians(15.0)), math.cos(math.radians(15.0))],
         "scale": [2.5, 2.5, 2.5]},
    ]
    checker_view = builder.add_view(checker_png(CHECKER_SIZE))
    binary = builder.padded_data()
    gltf = {
        "asset": {"version": "2.0", "generator": GENERATOR},
        "scene": 0,
        "scenes": [{"name": "default_scene", "nodes": [0]}],
        "nodes": nodes,
        "meshes": mesh_entries,
        "materials": [material_json(*m) for m in MATERIALS],
        "textures": [{"name": "checker", "sampler": 0, "source": 0}],
        "samplers": [{"magFilter": NEAREST, "minFilter": LINEAR_MIPMAP_LINEAR,
                      "wrapS": REPEAT, "wrapT": REPEAT}],
        "images": [{"name": "checker", "bufferView": checker_view, "mimeType": "image/png"}],
        "accessors": builder.accessors,
        "bufferViews": builder.buffer_views,
        "buffers": [{"byteLength": len(binary)}],
    }
    return gltf, binary


def glb_bytes(gltf, binary):
    text = json.dumps(gltf, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    total = 12 + 8 + len(text) + 8 + len(binary)
    return b"".join([
        struct.pack("<4sII", b"glTF", 2, total),
        struct.pack("<I4s", len(text), b"JSON"), text,
        struct.pack("<I4s", len(binary), b"BIN\0"), binary,
    ])


def write_atomically(path, data):
    """Write next to the destination, then rename, so readers never see a partial file."""
    temporary = path + ".tmp"
    try:
        with open(temporary, "wb") as f:
            f.write(data)
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise


def main(argv):
    if len(argv) != 2:
        sys.stderr.write("usage: %s OUTPUT.glb\n" % os.path.basename(argv[0]))
        return 2
    meshes = [
        ("terrain", split_into_primitives(make_terrain())),
        ("rock", split_into_primitives(make_rock())),
        ("vase", add_bulge_target(split_into_primitives(make_vase()))),
        ("torus", split_into_primitives(make_torus())),
    ]
    data = glb_bytes(*build_gltf(meshes))
    write_atomically(argv[1], data)

    total = 0
    for name, primitives in meshes:
        triangles = sum(len(p.indices) // 3 for p in primitives)
        vertices = sum(len(p.positions) for p in primitives)
        total += triangles
        print("%-8s %2d primitive(s) %6d triangles %6d vertices"
              % (name, len(primitives), triangles, vertices))
    print("total    %6d triangles, %d bytes -> %s" % (total, len(data), argv[1]))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
