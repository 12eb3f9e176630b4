#!/usr/bin/env python3
"""Degenerate-geometry inputs for the hostile-input tests and the fuzz seeds.

usage: make_degenerate.py OUT_DIR

Writes one small .glb per case below into OUT_DIR and OUT_DIR/cases.json
({"file": {"what": ..., "expect": "handle" | "reject", "warning": text the
main job's warning must contain, or null}}). Every file is valid
glTF in its structure (buffers, views and accessors in range); what is odd is
the geometry. Most cases put the oddity next to a bumpy grid, a surface the
simplifier can reduce, so that the ladder really runs past the oddity.
"handle" means the main job must succeed (exit 0, warnings allowed) with every
bound still holding; "reject" means a one-line error and exit 2 is right."""
import json
import math
import os
import struct
import sys

FLOAT, USHORT, UINT = 5126, 5123, 5125


class Glb:
    """One buffer, a view per accessor, one mesh per add_mesh, a node per mesh."""

    def __init__(self):
        self.bin = bytearray()
        self.json = {'asset': {'version': '2.0', 'generator': 'lodpipe tests/tools/make_degenerate.py'},
                     'buffers': [], 'bufferViews': [], 'accessors': [], 'meshes': [], 'nodes': [],
                     'scenes': [{'nodes': []}], 'scene': 0}

    def accessor(self, values, components, ctype=FLOAT, target=None):
        fmt = {FLOAT: 'f', USHORT: 'H', UINT: 'I'}[ctype]
        while len(self.bin) % 4:
            self.bin.append(0)
        offset = len(self.bin)
        self.bin += struct.pack('<%d%s' % (len(values), fmt), *values)
        view = {'buffer': 0, 'byteOffset': offset, 'byteLength': len(self.bin) - offset}
        if target:
            view['target'] = target
        self.json['bufferViews'].append(view)
        acc = {'bufferView': len(self.json['bufferViews']) - 1, 'componentType': ctype,
               'count': len(values) // components, 'type': {1: 'SCALAR', 2: 'VEC2', 3: 'VEC3'}[components]}
        if components == 3 and ctype == FLOAT and values:
            finite = [v for v in values if math.isfinite(v)]
            if len(finite) == len(values):
                acc['min'] = [min(values[k::3]) for k in range(3)]
                acc['max'] = [max(values[k::3]) for k in range(3)]
        self.json['accessors'].append(acc)
        return len(self.json['accessors']) - 1

    def primitive(self, positions, indices=None, normals=None, uvs=None, mode=None):
        prim = {'attributes': {'POSITION': self.accessor(positions, 3, target=34962)}}
        if normals is not None:
            prim['attributes']['NORMAL'] = self.accessor(normals, 3, target=34962)
        if uvs is not None:
            prim['attributes']['TEXCOORD_0'] = self.accessor(uvs, 2, target=34962)
        if indices is not None:
            ctype = USHORT if len(positions) // 3 <= 65535 else UINT
            prim['indices'] = self.accessor(indices, 1, ctype, target=34963)
        if mode is not None:
            prim['mode'] = mode
        return prim

    def add_mesh(self, name, primitives, translation=None):
        self.json['meshes'].append({'name': name, 'primitives': primitives})
        node = {'name': name, 'mesh': len(self.json['meshes']) - 1}
        if translation:
            node['translation'] = translation
        self.json['nodes'].append(node)
        self.json['scenes'][0]['nodes'].append(len(self.json['nodes']) - 1)

    def write(self, path):
        while len(self.bin) % 4:
            self.bin.append(0)
        self.json['buffers'] = [{'byteLength': len(self.bin)}]
        text = json.dumps(self.json, separators=(',', ':')).encode()
        text += b' ' * (-len(text) % 4)
        total = 12 + 8 + len(text) + 8 + len(self.bin)
        with open(path, 'wb') as f:
            f.write(struct.pack('<4sII', b'glTF', 2, total))
            f.write(struct.pack('<I4s', len(text), b'JSON') + text)
            f.write(struct.pack('<I4s', len(self.bin), b'BIN\0') + bytes(self.bin))


def grid(n=12, scale=1.0):
    """A bumpy n x n grid in [0, scale]^2 with normals and uvs: something to simplify."""
    pos, nor, uv, idx = [], [], [], []
    for j in range(n):
        for i in range(n):
            x, y = i / (n - 1), j / (n - 1)
            z = 0.04 * math.sin(3.1 * x) * math.cos(2.3 * y)
            pos += [x * scale, y * scale, z * scale]
            nor += [0.0, 0.0, 1.0]
            uv += [x, y]
    for j in range(n - 1):
        for i in range(n - 1):
            a, b, c, d = j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1
            idx += [a, b, d, a, d, c]
    return pos, nor, uv, idx


def case_zero_area(g):
    pos, nor, uv, idx = grid()
    n = len(pos) // 3
    # A vertex at the midpoint of grid edge (0, 1): triangle (0, 1, mid) has no area and makes the
    # edge non-manifold. A second copy of vertex 5 (same position, new index): (5, 6, copy) is
    # degenerate by index after welding. Three distinct collinear points on the diagonal of a cell.
    mid = [(pos[k] + pos[3 + k]) / 2 for k in range(3)]
    a, b = pos[13 * 3:13 * 3 + 3], pos[26 * 3:26 * 3 + 3]
    third = [a[k] + (b[k] - a[k]) / 3 for k in range(3)]
    pos += mid + pos[15:18] + third
    nor += [0.0, 0.0, 1.0] * 3
    uv += [0.5, 0.5] * 3
    idx += [0, 1, n, 5, 6, n + 1, 13, 26, n + 2]
    g.add_mesh('zero_area', [g.primitive(pos, idx, nor, uv)])


def case_duplicate_triangles(g):
    pos, nor, uv, idx = grid()
    tris = [idx[3 * t:3 * t + 3] for t in range(len(idx) // 3)]
    extra = []
    for t in range(0, len(tris), 7):
        extra += tris[t]                      # the same triangle again
    for t in range(3, len(tris), 11):
        a, b, c = tris[t]
        extra += [a, c, b]                    # again, facing the other way
    g.add_mesh('duplicates', [g.primitive(pos, idx + extra, nor, uv)])


def case_unreferenced_vertices(g):
    pos, nor, uv, idx = grid()
    for k in range(40):                       # far away, used by nothing: not in the bbox
        pos += [1000.0 + k, -500.0, 250.0 * k]
        nor += [1.0, 0.0, 0.0]
        uv += [0.0, 0.0]
    g.add_mesh('unreferenced', [g.primitive(pos, idx, nor, uv)])


def case_nonfinite_attributes(g):
    pos, nor, uv, idx = grid()
    nan, inf = float('nan'), float('inf')
    for v in range(0, len(pos) // 3, 5):
        nor[3 * v:3 * v + 3] = [nan, nan, nan]
    for v in range(2, len(pos) // 3, 7):
        uv[2 * v:2 * v + 2] = [inf, -inf]
    g.add_mesh('nonfinite_attributes', [g.primitive(pos, idx, nor, uv)])


def case_one_triangle(g):
    g.add_mesh('one_triangle', [g.primitive([0, 0, 0, 1, 0, 0, 0, 1, 0], [0, 1, 2], [0, 0, 1] * 3)])


def case_empty_primitives(g):
    pos, nor, uv, idx = grid()
    prims = [g.primitive(pos, idx, nor, uv),
             g.primitive([0, 0, 0, 1, 0, 0, 0, 1, 0], [0, 1]),          # 2 indices: no triangle
             g.primitive([0, 0, 0, 1, 0, 0]),                           # 2 vertices, not indexed
             g.primitive([0, 0, 0, 1, 0, 0, 0, 1, 0], [0, 1, 2, 0], mode=5)]  # strip of 4: 2 triangles
    g.add_mesh('empty_primitives', prims)
    g.add_mesh('only_empty', [g.primitive([0, 0, 0, 1, 1, 1, 2, 0, 0], [2, 1])], translation=[3, 0, 0])


def case_zero_diagonal(g):
    p = [0.5, 0.5, 0.5]
    g.add_mesh('point', [g.primitive(p * 4, [0, 1, 2, 2, 1, 3])])
    pos, nor, uv, idx = grid()
    g.add_mesh('grid', [g.primitive(pos, idx, nor, uv)], translation=[2, 0, 0])


def case_collinear_mesh(g):
    pos = [float(k) for v in range(6) for k in (v, 2 * v, 0)]     # six points on one line
    g.add_mesh('collinear', [g.primitive(pos, [0, 1, 2, 1, 2, 3, 2, 3, 4, 3, 4, 5, 0, 5, 3])])


def case_tiny_scale(g):
    pos, nor, uv, idx = grid(scale=1e-30)
    g.add_mesh('tiny', [g.primitive(pos, idx, nor, uv)])


def case_huge_scale(g):
    pos, nor, uv, idx = grid(scale=1e30)
    g.add_mesh('huge', [g.primitive(pos, idx, nor, uv)])


def case_degenerate_strip(g):
    # Two strips joined by repeated indices (the classic "restart"), which yields zero-area triangles.
    n = 10
    pos = []
    for j in range(3):
        for i in range(n):
            pos += [i / (n - 1), j / 2, 0.05 * math.sin(i)]
    strip = []
    for j in range(2):
        row = []
        for i in range(n):
            row += [j * n + i, (j + 1) * n + i]
        if strip:
            strip += [strip[-1], row[0]]
        strip += row
    g.add_mesh('strip', [g.primitive(pos, strip, mode=5)])


def case_hub(g):
    # A cone of 20,000 faces around its apex, and the grid as a second mesh: more than 4,096 faces
    # around one vertex make it a hub, held with its neighbours (simplify.h: SIMPLIFY_HUB_FACES), so the cone
    # keeps no level; the collapses next to it cost about n squared before (this cone took 23 s, one of
    # 100,000 faces more than 7 minutes). The grid gets its chain.
    pos, nor, uv, idx = grid()
    g.add_mesh('grid', [g.primitive(pos, idx, nor, uv)])
    sectors, apex = 20000, 0
    pos, nor, uv, idx = [2.5, 0.5, 0.5], [0.0, 0.0, 1.0], [0.5, 0.5], []
    for t in range(sectors):
        a = 2 * math.pi * t / sectors
        pos += [2.5 + 0.5 * math.cos(a), 0.5 + 0.5 * math.sin(a), 0.0]
        nor += [0.0, 0.0, 1.0]
        uv += [0.5 + 0.5 * math.cos(a), 0.5 + 0.5 * math.sin(a)]
    for t in range(sectors):
        idx += [apex, apex + 1 + t, apex + 1 + (t + 1) % sectors]
    g.add_mesh('cone', [g.primitive(pos, idx, nor, uv)])


CASES = [
    ('zero_area_triangles', case_zero_area, 'zero-area triangles: one on a grid edge (non-manifold), one degenerate by index, one of three collinear points', 'have no area'),
    ('duplicate_triangles', case_duplicate_triangles, 'triangles repeated, some with the opposite winding', 'repeat the vertices'),
    ('unreferenced_vertices', case_unreferenced_vertices, '40 vertices far away that no triangle uses', 'used by no triangle'),
    ('nonfinite_attributes', case_nonfinite_attributes, 'NaN normals and +-Inf texture coordinates (positions finite)', 'NaN or infinite'),
    ('one_triangle', case_one_triangle, 'a mesh of one triangle', None),
    ('empty_primitives', case_empty_primitives, 'primitives with no triangle next to a real one; a mesh with only such', 'has no triangle'),
    ('zero_diagonal', case_zero_diagonal, 'a mesh whose vertices are all one point (bbox diagonal 0), next to a grid', 'span no space'),
    ('collinear_mesh', case_collinear_mesh, 'every triangle on one line: zero area, non-zero diagonal', 'have no area'),
    ('tiny_scale', case_tiny_scale, 'the grid scaled by 1e-30', None),
    ('huge_scale', case_huge_scale, 'the grid scaled by 1e30', None),
    ('degenerate_strip', case_degenerate_strip, 'a triangle strip with repeated indices between its rows', 'off its surface'),
    ('hub', case_hub, 'a cone of 20,000 faces around one vertex: kept whole; a grid beside it simplified',
     '20001 vertices are kept at every level'),
]


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    cases = {}
    for name, build, what, warning in CASES:
        g = Glb()
        build(g)
        g.write(os.path.join(out, name + '.glb'))
        cases[name + '.glb'] = {'what': what, 'expect': 'handle', 'warning': warning}
    # The main job passes a TRIANGLES primitive without a triangle through into every level as it is
    # (like points and lines) and leaves a mesh without triangles out of its --json summary;
    # tests/lib/lodcheck.mjs expects new index data for every TRIANGLES primitive and every mesh listed.
    cases['empty_primitives.glb']['tolerate'] = (
        r'primitive [12]: (index accessor|no index accessor|level \d+ uses vertex)|mesh 1 \(used by nodes')
    cases['empty_primitives.glb']['tolerate_why'] = 'TRIANGLES primitives without a triangle pass through as they are'
    with open(os.path.join(out, 'cases.json'), 'w') as f:
        json.dump(cases, f, indent=1, sort_keys=True)
    print('%d files in %s' % (len(cases), out))


if __name__ == '__main__':
    main()
