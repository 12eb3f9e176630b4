#!/usr/bin/env python3
"""Exact proof that two planar meshes cover the same points (two-sided Hausdorff distance 0),
for the levels the CGAL tool cannot settle: a sheet exactly flat in float32 (every z equal,
1e5 from the origin), certified exact, where its branch and bound refines without end.

Coordinates are read as float32 (as exact_vertex_distance.py does) and used as exact
rationals. The proof: every vertex has the same z; every used triangle of both meshes has
positive (or every one negative) orientation in the xy plane, none zero, so at a point p the
number of triangles covering p is the winding number of the mesh's border around p; the two
borders, as directed edges split at every border vertex of either mesh lying on them, are the
same multiset of segments, so the winding numbers, hence the covering counts, are equal
everywhere: each mesh covers exactly the points the other covers.

usage: exact_planar_cover.py A.obj B.obj
prints one JSON line: {"proven": true|false, "why": ...}; exit 0 when proven, 1 when not
(which proves nothing either way), 2 on bad input."""
import json
import struct
import sys
from collections import Counter
from fractions import Fraction


def f32(text):
    return Fraction(struct.unpack('f', struct.pack('f', float(text)))[0])


def load(path):
    vertices, faces = [], []
    with open(path) as f:
        for line in f:
            p = line.split()
            if p and p[0] == 'v':
                vertices.append(tuple(f32(x) for x in p[1:4]))
            elif p and p[0] == 'f':
                faces.append(tuple(int(x.split('/')[0]) - 1 for x in p[1:4]))
    return vertices, faces


def orient(a, b, c):
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


def border(vertices, faces):
    """Directed border edges (as point pairs): those whose reverse no triangle has."""
    directed = Counter()
    for f in faces:
        for i in range(3):
            directed[(f[i], f[(i + 1) % 3])] += 1
    edges = []
    for (u, v), n in directed.items():
        inner = min(n, directed.get((v, u), 0))
        edges += [(vertices[u][:2], vertices[v][:2])] * (n - inner)
    return edges


def split(edges, points):
    """Each edge cut at every point strictly inside it, as unit segments."""
    out = Counter()
    for a, b in edges:
        inside = [p for p in points if p != a and p != b and orient(a, b, p) == 0 and
                  min(a[0], b[0]) <= p[0] <= max(a[0], b[0]) and min(a[1], b[1]) <= p[1] <= max(a[1], b[1])]
        key = (lambda p: p[0]) if a[0] != b[0] else (lambda p: p[1])
        chain = [a] + sorted(set(inside), key=key, reverse=key(a) > key(b)) + [b]
        for p, q in zip(chain, chain[1:]):
            out[(p, q)] += 1
    # a segment and its reverse cancel (a seam the border runs both ways)
    for (p, q) in list(out):
        both = min(out[(p, q)], out.get((q, p), 0))
        if both:
            out[(p, q)] -= both
            out[(q, p)] -= both
    return +out


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    meshes = [load(p) for p in sys.argv[1:]]
    used = [[v[i] for f in faces for i in f] for v, faces in meshes]
    zs = {p[2] for u in used for p in u}
    if len(zs) != 1:
        return report(False, f'{len(zs)} different z values among the used vertices')
    signs = set()
    for v, faces in meshes:
        for f in faces:
            signs.add((orient(v[f[0]], v[f[1]], v[f[2]]) > 0) - (orient(v[f[0]], v[f[1]], v[f[2]]) < 0))
    if 0 in signs or len(signs) != 1:
        return report(False, f'triangle orientations {sorted(signs)} (need one sign, none zero)')
    borders = [border(v, faces) for v, faces in meshes]
    points = {p for b in borders for e in b for p in e}
    cut = [split(b, points) for b in borders]
    if cut[0] != cut[1]:
        return report(False, f'the borders differ ({sum(cut[0].values())} and {sum(cut[1].values())} segments)')
    return report(True, f'one plane z = {float(zs.pop())}, {sum(len(f) for _, f in meshes)} triangles of one '
                        f'orientation, equal borders of {sum(cut[0].values())} segments')


def report(proven, why):
    print(json.dumps({'proven': proven, 'why': why}))
    return 0 if proven else 1


if __name__ == '__main__':
    sys.exit(main())
