#!/usr/bin/env python3
"""Seed corpora for the fuzz harnesses (tests/fuzz/fuzz_*.c).

usage: make_seeds.py SHARED_ASSETS OUT_DIR [EXTRA_DIR ...]

Writes OUT_DIR/load/ and OUT_DIR/pipeline/: every .glb / .gltf of the shared
corpus (valid and invalid) and of each EXTRA_DIR (the degenerate-geometry
files, tests/regressions/) that is at most MAX_BYTES long. The harnesses load
from memory, with no folder to read from, so a .gltf's external buffers are
embedded as data: uris and its external images replaced by a 4-byte stand-in
(images are passed through, never decoded). The pipeline corpus keeps only
files with at most PIPELINE_MAX_TRIANGLES triangles in the manifest (or no
count: invalid and generated files), matching the harness's own cap.
Each pipeline seed that is a GLB with indexed triangle primitives also gets
two-sided twins, so that the weld's back faces are fuzzed: '.double' with a
reversed copy of every triangle appended to its primitive, '.partial' with
reversed copies of the first half of each primitive's triangles (backs that
stop part-way). A twin is kept when it stays within the triangle cap.
File names are the source path with '/' as '__', so reruns overwrite.

Every seed naming EXT_meshopt_compression also gets KHR twins (the ratified
name, which the loader decodes the same way; no corpus file uses it): '.khr'
with the name replaced, and, for a GLB, '.khr-fallback' whose first attribute
stream claims version 1 (header 0xa1, which libmeshoptimizer 0.18 cannot
decode) and whose fallback buffer is a data: uri of zeros, so the loader's
fallback path (a second tinygltf pass, load_fallback_buffers) is fuzzed too."""
import base64
import json
import os
import struct
import sys

MAX_BYTES = 65536
PIPELINE_MAX_TRIANGLES = 2000
STAND_IN_IMAGE = 'data:image/png;base64,iVBORw=='


def embedded(path):
    """The file's bytes, a .gltf's external references made self-contained."""
    data = open(path, 'rb').read()
    if not path.lower().endswith('.gltf'):
        return data
    try:
        doc = json.loads(data)
    except (ValueError, RecursionError):  # not JSON, or nested too deep for Python: the bytes as they are
        return data
    if not isinstance(doc, dict):
        return data
    folder = os.path.dirname(path)
    for buf in doc.get('buffers', []) if isinstance(doc.get('buffers'), list) else []:
        uri = buf.get('uri') if isinstance(buf, dict) else None
        if isinstance(uri, str) and not uri.startswith('data:'):
            try:
                raw = open(os.path.join(folder, uri), 'rb').read()
            except OSError:
                continue  # a missing file is what the input is about: keep it
            buf['uri'] = 'data:application/octet-stream;base64,' + base64.b64encode(raw).decode()
    for img in doc.get('images', []) if isinstance(doc.get('images'), list) else []:
        uri = img.get('uri') if isinstance(img, dict) else None
        if isinstance(uri, str) and not uri.startswith('data:'):
            img['uri'] = STAND_IN_IMAGE
    return json.dumps(doc, separators=(',', ':')).encode()


EXT_MESHOPT = b'EXT_meshopt_compression'
KHR_MESHOPT = b'KHR_meshopt_compression'  # same length: a GLB's chunk lengths stay right


def glb_chunks(data):
    """A GLB's (type, bytes) chunks, or None when it is not a well-formed one."""
    if len(data) < 12 or data[:4] != b'glTF':
        return None
    chunks, pos = [], 12
    while pos + 8 <= len(data):
        length, kind = struct.unpack_from('<II', data, pos)
        if pos + 8 + length > len(data):
            return None
        chunks.append((kind, data[pos + 8:pos + 8 + length]))
        pos += 8 + length
    return chunks if chunks and pos == len(data) else None


def glb_of(chunks):
    body = b''.join(struct.pack('<II', len(c), kind) + c for kind, c in chunks)
    return struct.pack('<III', 0x46546C67, 2, 12 + len(body)) + body


def khr_fallback_variant(khr_glb):
    """The KHR twin with its first ATTRIBUTES stream's header set to version 1 and
    every fallback buffer given zeros as a data: uri (the loader reads the
    fallback then); None when the file has no such stream or fallback."""
    chunks = glb_chunks(khr_glb)
    if not chunks or len(chunks) < 2:
        return None
    try:
        doc = json.loads(chunks[0][1])
    except ValueError:
        return None
    name = KHR_MESHOPT.decode()
    buffers, views = doc.get('buffers'), doc.get('bufferViews')
    if not isinstance(buffers, list) or not isinstance(views, list):
        return None
    fallbacks = 0
    for buf in buffers:
        ext = buf.get('extensions', {}).get(name, {}) if isinstance(buf, dict) else {}
        length = buf.get('byteLength') if isinstance(buf, dict) else None
        if isinstance(ext, dict) and ext.get('fallback') is True and isinstance(length, int) and 0 < length <= MAX_BYTES:
            buf['uri'] = 'data:application/octet-stream;base64,' + base64.b64encode(bytes(length)).decode()
            fallbacks += 1
    streams = [v['extensions'][name] for v in views if isinstance(v, dict) and isinstance(v.get('extensions'), dict)
               and isinstance(v['extensions'].get(name), dict) and v['extensions'][name].get('mode') == 'ATTRIBUTES']
    if not fallbacks or not streams:
        return None
    if name in doc.get('extensionsRequired', []):
        doc['extensionsRequired'].remove(name)  # optional: a client without the codec reads the fallback
    bin_chunk = bytearray(chunks[1][1])
    offset = streams[0].get('byteOffset', 0)
    if not isinstance(offset, int) or offset >= len(bin_chunk):
        return None
    bin_chunk[offset] = 0xa1
    text = json.dumps(doc, separators=(',', ':')).encode()
    text += b' ' * (-len(text) % 4)
    return glb_of([(chunks[0][0], text), (chunks[1][0], bytes(bin_chunk))] + chunks[2:])


def khr_twins(data):
    """(suffix, bytes) of the KHR_meshopt_compression seeds made from one seed."""
    if EXT_MESHOPT not in data:
        return []
    khr = data.replace(EXT_MESHOPT, KHR_MESHOPT)
    twins = [('.khr', khr)]
    variant = khr_fallback_variant(khr)
    if variant and len(variant) <= MAX_BYTES:
        twins.append(('.khr-fallback', variant))
    return twins


INDEX_FORMATS = {5121: 'B', 5123: 'H', 5125: 'I'}


def two_sided_variant(data, share):
    """The GLB with, in every indexed triangle primitive, reversed copies of
    the first `share` (0..1] of its triangles appended as a new uint32
    index accessor, and the number of triangles it then has; None when the
    file is not such a GLB or has no such primitive."""
    chunks = glb_chunks(data)
    if not chunks or len(chunks) < 2 or chunks[1][0] != 0x004E4942:
        return None
    try:
        doc = json.loads(chunks[0][1])
        accessors, views = doc['accessors'], doc['bufferViews']
        bin_chunk = bytearray(chunks[1][1])
        triangles, changed = 0, 0
        for mesh in doc['meshes']:
            for prim in mesh['primitives']:
                acc = accessors[prim['indices']] if prim.get('mode', 4) == 4 and 'indices' in prim else None
                view = views[acc['bufferView']] if acc and 'bufferView' in acc and 'sparse' not in acc else None
                if not view or view.get('buffer') != 0 or 'byteStride' in view or acc['componentType'] not in INDEX_FORMATS:
                    continue
                fmt = INDEX_FORMATS[acc['componentType']]
                start = view.get('byteOffset', 0) + acc.get('byteOffset', 0)
                count = acc['count'] - acc['count'] % 3
                idx = list(struct.unpack_from('<%d%s' % (count, fmt), bin_chunk, start))
                tris = [idx[i:i + 3] for i in range(0, count, 3)]
                idx += [x for t in tris[:int(len(tris) * share)] for x in (t[0], t[2], t[1])]
                triangles += len(idx) // 3
                bin_chunk += bytes(-len(bin_chunk) % 4)
                views.append({'buffer': 0, 'byteOffset': len(bin_chunk), 'byteLength': 4 * len(idx)})
                bin_chunk += struct.pack('<%dI' % len(idx), *idx)
                accessors.append({'bufferView': len(views) - 1, 'componentType': 5125, 'count': len(idx),
                                  'type': 'SCALAR'})
                prim['indices'] = len(accessors) - 1
                changed += 1
        if not changed:
            return None
        doc['buffers'][0]['byteLength'] = len(bin_chunk)
    except (ValueError, KeyError, IndexError, TypeError, AttributeError, struct.error):
        return None  # not the plain shape this variant handles
    text = json.dumps(doc, separators=(',', ':')).encode()
    text += b' ' * (-len(text) % 4)
    return glb_of([(chunks[0][0], text), (chunks[1][0], bytes(bin_chunk))] + chunks[2:]), triangles


def two_sided_twins(data):
    """(suffix, bytes) of the two-sided seeds made from one pipeline seed."""
    twins = []
    for suffix, share in (('.double', 1.0), ('.partial', 0.5)):
        made = two_sided_variant(data, share)
        if made and made[1] <= PIPELINE_MAX_TRIANGLES and len(made[0]) <= MAX_BYTES:
            twins.append((suffix, made[0]))
    return twins


def triangle_counts(assets):
    try:
        manifest = json.load(open(os.path.join(assets, 'manifest.json')))
    except (OSError, ValueError):
        return {}
    return {f['path']: (f.get('stats') or {}).get('triangle_count') for f in manifest.get('files', [])}


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    assets, out = sys.argv[1], sys.argv[2]
    counts = triangle_counts(assets)
    for sub in ('load', 'pipeline'):
        os.makedirs(os.path.join(out, sub), exist_ok=True)
    written = {'load': 0, 'pipeline': 0}
    for root_dir in [assets] + sys.argv[3:]:
        for folder, _, names in sorted(os.walk(root_dir)):
            for name in sorted(names):
                if not name.lower().endswith(('.glb', '.gltf')):
                    continue
                path = os.path.join(folder, name)
                rel = os.path.relpath(path, root_dir)
                data = embedded(path)
                if len(data) > MAX_BYTES:
                    continue
                seed = os.path.basename(os.path.normpath(root_dir)) + '__' + rel.replace('/', '__')
                targets = ['load']
                tris = counts.get(rel) if root_dir == assets else None
                if tris is None or tris <= PIPELINE_MAX_TRIANGLES:
                    targets.append('pipeline')
                for sub in targets:
                    twins = khr_twins(data) + (two_sided_twins(data) if sub == 'pipeline' else [])
                    for suffix, seed_data in [('', data)] + twins:
                        with open(os.path.join(out, sub, seed + suffix), 'wb') as f:
                            f.write(seed_data)
                        written[sub] += 1
    print('seeds: %d for load, %d for pipeline' % (written['load'], written['pipeline']))


if __name__ == '__main__':
    main()
