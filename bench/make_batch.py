#!/usr/bin/env python3
"""Builds a batch of distinct glTF files for `lodpipe batch` benchmarks and tests.

Every asset named in ASSETS (valid files of ../shared/assets, small enough that the whole batch
runs in about a minute per core) is written VARIANTS times, variant v into DEST/<asset>/v<v>/,
keeping its storage form: a .gltf with its external .bin and images beside it, a .glb (with any
external image it names). Variant 0 keeps the positions; variant v > 0 applies the affine map

    x' = (1 + 0.03 v) x + 0.02 v y,   y' = (1 - 0.01 v) y,   z' = z + 0.015 v x

to every uncompressed float POSITION accessor (and the linear part to morph-target POSITION
deltas), with min/max updated, so the variants are different meshes, not just different bytes.
Positions inside Draco or meshopt streams, or in sparse accessors, cannot be rewritten here;
those variants differ by an `asset.extras.lodpipe_batch_variant` tag only. Every variant gets
that tag, so no two files of the batch are byte-identical.

usage: python3 bench/make_batch.py DEST [--variants N] [--assets LIST] [--shared DIR]
prints the number of files written. Plain python3 (no numpy).
"""
import argparse
import base64
import json
import os
import shutil
import struct
import sys
import urllib.parse

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Relative to ../shared/assets. About 0.01-1 s each for the main job on one core.
ASSETS = [
    "scans/suzanne.glb",
    "scans/cow.glb",
    "scenes/Duck.glb",
    "scenes/CesiumMilkTruck/CesiumMilkTruck.gltf",
    "scenes/SpheresScaledInstances/spheres_scaled_instances.gltf",
    "scenes/DuplicateMeshes/duplicate_meshes.gltf",
    "scenes/one_face_123_mirror/one_face_123_mirror.gltf",
    "scenes/kenney/building-small-a.glb",
    "scenes/kenney/building-garage.glb",
    "scenes/kenney/road-intersection.glb",
    "scenes/kenney/pavement-fountain.glb",
    "scenes/kenney/grass-trees.glb",
    "scenes/kenney/pavement.glb",
    "primitive_modes/Mesh_PrimitiveMode_00.gltf",
    "primitive_modes/Mesh_PrimitiveMode_04.gltf",
    "primitive_modes/Mesh_PrimitiveMode_05.gltf",
    "primitive_modes/Mesh_PrimitiveMode_06.gltf",
    "primitive_modes/Mesh_PrimitiveMode_11.gltf",
    "animated/CesiumMan.glb",
    "animated/AnimatedMorphCube/AnimatedMorphCube.gltf",
    "animated/simple_skin.gltf",
    "animated/InterpolationTest/InterpolationTest.gltf",
    "compressed/BoxDraco/BoxDraco.gltf",
    "compressed/BoxMeshopt.glb",
    "compressed/pirate.glb",
]

FLOAT = 5126
GLB_JSON = 0x4E4F534A
GLB_BIN = 0x004E4942


def read_glb(data):
    magic, version, length = struct.unpack_from("<III", data, 0)
    if magic != 0x46546C67:
        raise ValueError("not a GLB")
    pos, doc, bin_chunk = 12, None, None
    while pos + 8 <= length:
        clen, ctype = struct.unpack_from("<II", data, pos)
        chunk = data[pos + 8:pos + 8 + clen]
        if ctype == GLB_JSON:
            doc = json.loads(chunk.decode("utf-8"))
        elif ctype == GLB_BIN and bin_chunk is None:
            bin_chunk = bytearray(chunk)
        pos += 8 + clen
    return doc, bin_chunk


def write_glb(doc, bin_chunk):
    text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    out = bytearray(struct.pack("<III", 0x46546C67, 2, 0))
    out += struct.pack("<II", len(text), GLB_JSON) + text
    if bin_chunk is not None:
        padded = bytes(bin_chunk) + b"\0" * (-len(bin_chunk) % 4)
        out += struct.pack("<II", len(padded), GLB_BIN) + padded
    struct.pack_into("<I", out, 8, len(out))
    return bytes(out)


def affine(v):
    """(matrix rows, translation) of variant v; v = 0 is the identity."""
    return ([1 + 0.03 * v, 0.02 * v, 0.0], [0.0, 1 - 0.01 * v, 0.0], [0.015 * v, 0.0, 1.0]), [0.0, 0.0, 0.0]


def position_accessors(doc):
    """{accessor index: is_morph_delta} for every POSITION of every primitive and target."""
    found = {}
    for mesh in doc.get("meshes", []):
        for prim in mesh.get("primitives", []):
            if "KHR_draco_mesh_compression" in prim.get("extensions", {}):
                continue
            a = prim.get("attributes", {}).get("POSITION")
            if a is not None:
                found[a] = found.get(a, False)
            for target in prim.get("targets", []):
                t = target.get("POSITION")
                if t is not None:
                    found[t] = True
    return found


def transform_positions(doc, buffers, v):
    """Rewrites the float POSITION accessors in buffers (bytearrays by buffer index)."""
    if v == 0:
        return
    rows, _ = affine(v)
    views = doc.get("bufferViews", [])
    for index, is_delta in sorted(position_accessors(doc).items()):
        acc = doc["accessors"][index]
        if acc.get("componentType") != FLOAT or acc.get("type") != "VEC3" or "sparse" in acc:
            continue
        if "bufferView" not in acc:
            continue
        view = views[acc["bufferView"]]
        if "EXT_meshopt_compression" in view.get("extensions", {}):
            continue
        data = buffers.get(view["buffer"])
        if data is None:
            continue
        stride = view.get("byteStride", 12)
        base = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        lo, hi = [float("inf")] * 3, [float("-inf")] * 3
        for i in range(acc["count"]):
            off = base + i * stride
            x, y, z = struct.unpack_from("<fff", data, off)
            p = [rows[r][0] * x + rows[r][1] * y + rows[r][2] * z for r in range(3)]
            struct.pack_into("<fff", data, off, *p)
            q = struct.unpack_from("<fff", data, off)  # min/max of the float32 values written
            lo = [min(lo[k], q[k]) for k in range(3)]
            hi = [max(hi[k], q[k]) for k in range(3)]
        if acc["count"]:
            acc["min"], acc["max"] = lo, hi


def uri_path(uri):
    return urllib.parse.unquote(uri)


def make_variant(src, dest_dir, v):
    """Writes variant v of the asset at src into dest_dir; returns the main file's path."""
    os.makedirs(dest_dir, exist_ok=True)
    src_dir = os.path.dirname(src)
    name = os.path.basename(src)
    with open(src, "rb") as f:
        raw = f.read()
    is_glb = raw[:4] == b"glTF"
    if is_glb:
        doc, bin_chunk = read_glb(raw)
    else:
        doc, bin_chunk = json.loads(raw.decode("utf-8")), None
    buffers = {}  # buffer index -> bytearray, for the buffers we may rewrite
    external = {}  # buffer index -> relative path
    for i, b in enumerate(doc.get("buffers", [])):
        uri = b.get("uri")
        if uri is None:
            if is_glb and i == 0 and bin_chunk is not None:
                buffers[i] = bin_chunk
        elif uri.startswith("data:"):
            head, _, payload = uri.partition(",")
            if head.endswith(";base64"):
                buffers[i] = bytearray(base64.b64decode(payload))
        else:
            with open(os.path.join(src_dir, uri_path(uri)), "rb") as f:
                buffers[i] = bytearray(f.read())
            external[i] = uri_path(uri)
    transform_positions(doc, buffers, v)
    for i, b in enumerate(doc.get("buffers", [])):
        uri = b.get("uri")
        if uri is not None and uri.startswith("data:") and i in buffers:
            head = uri.partition(",")[0]
            b["uri"] = head + "," + base64.b64encode(bytes(buffers[i])).decode("ascii")
    for i, rel in external.items():
        os.makedirs(os.path.dirname(os.path.join(dest_dir, rel)) or dest_dir, exist_ok=True)
        with open(os.path.join(dest_dir, rel), "wb") as f:
            f.write(bytes(buffers[i]))
    for img in doc.get("images", []):
        uri = img.get("uri")
        if uri and not uri.startswith("data:"):
            target = os.path.join(dest_dir, uri_path(uri))
            os.makedirs(os.path.dirname(target), exist_ok=True)
            shutil.copyfile(os.path.join(src_dir, uri_path(uri)), target)
    doc.setdefault("asset", {}).setdefault("extras", {})["lodpipe_batch_variant"] = v
    out = os.path.join(dest_dir, name)
    with open(out, "wb") as f:
        if is_glb:
            f.write(write_glb(doc, buffers.get(0) if bin_chunk is not None else None))
        else:
            f.write(json.dumps(doc, indent=1).encode("utf-8"))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dest")
    ap.add_argument("--variants", type=int, default=12)
    ap.add_argument("--assets", default=",".join(ASSETS), help="comma-separated paths below the assets folder")
    ap.add_argument("--shared", default=os.environ.get("LODPIPE_SHARED", os.path.join(ROOT, "..", "shared")))
    args = ap.parse_args()
    assets_dir = os.path.join(args.shared, "assets")
    if os.path.exists(args.dest):
        shutil.rmtree(args.dest)
    count = 0
    for rel in [a for a in args.assets.split(",") if a]:
        stem = os.path.splitext(rel)[0].replace("/", "_")
        for v in range(args.variants):
            make_variant(os.path.join(assets_dir, rel), os.path.join(args.dest, stem, "v%02d" % v), v)
            count += 1
    print(count)
    return 0


if __name__ == "__main__":
    sys.exit(main())
