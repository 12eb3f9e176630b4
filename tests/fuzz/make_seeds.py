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
File names are the source path with '/' as '__', so reruns overwrite."""
import base64
import json
import os
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
                    with open(os.path.join(out, sub, seed), 'wb') as f:
                        f.write(data)
                    written[sub] += 1
    print('seeds: %d for load, %d for pipeline' % (written['load'], written['pipeline']))


if __name__ == '__main__':
    main()
