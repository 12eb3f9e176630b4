#!/usr/bin/env python3
"""Exact proof that two planar meshes cover the same points (two-sided Hausdorff distance 0),
for the levels the CGAL tool cannot settle: a sheet exactly flat in float32 (every z equal,
1e5 from the origin), or a few such sheets, certified exact, where its branch and bound
refines without end.

Coordinates are read as float32 (as exact_vertex_distance.py does) and used as exact
rationals. The proof, for each plane that triangles of either mesh lie in (when each
plane's part of A covers what its part of B covers, so do the unions): every triangle
of both meshes in it faces the same way, none has zero area, so at a point p the
number of triangles covering p is the winding number of the mesh's border around p; the two
borders, as directed edges split at every border vertex of either mesh lying on them, are the
same multiset of segments, so the winding numbers, hence the covering counts, are equal
everywhere: each mesh covers exactly the points the other covers.

usage: exact_planar_cover.py A.obj B.obj
prints one JSON line: {"proven": true|false, "why": ...}; exit 0 when proven, 1 when not
(which proves nothing either way), 2 on bad input."""
import json
import sys
from collections import Counter
from fractions import Fraction

from exact_vertex_distance import cross, load, sub


def load_exact(path):
    """The OBJ as exact_vertex_distance.py reads it (float32 values), coordinates as rationals."""
    vertices, faces = load(path)
    return [tuple(Fraction(x) for x in v) for v in vertices], faces


def orient(a, b, c):
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


def border(triangles):
    """Directed border edges of triangles given as point triples: those whose reverse no triangle has."""
    directed = Counter()
    for t in triangles:
        for i in range(3):
            directed[(t[i], t[(i + 1) % 3])] += 1
    edges = []
    for (a, b), n in directed.items():
        edges += [(a, b)] * (n - min(n, directed.get((b, a), 0)))
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


def plane_of(a, b, c):
    """The triangle's plane as an exact key (normal scaled so its first nonzero component is 1, and
    the offset): triangles of either facing share it. None for a zero-area triangle."""
    n = cross(sub(b, a), sub(c, a))
    lead = next((x for x in n if x != 0), None)
    if lead is None:
        return None
    n = tuple(x / lead for x in n)
    return n, sum(n[i] * a[i] for i in range(3))


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    try:
        meshes = [load_exact(p) for p in sys.argv[1:]]
    except (OSError, ValueError, IndexError) as e:
        print(f'exact_planar_cover.py: {e}', file=sys.stderr)
        return 2
    # the triangles, as point triples, grouped by their plane; each group compared alone
    planes = {}
    for m, (v, faces) in enumerate(meshes):
        for f in faces:
            t = (v[f[0]], v[f[1]], v[f[2]])
            key = plane_of(*t)
            if key is None:
                return report(False, f'a triangle of mesh {m + 1} has zero area')
            planes.setdefault(key, ([], []))[m].append(t)
    segments = triangles = 0
    for (normal, _), groups in planes.items():
        drop = max(range(3), key=lambda i: abs(normal[i]))  # the projection along it is one to one
        keep = [i for i in range(3) if i != drop]
        flat = [[tuple((p[keep[0]], p[keep[1]]) for p in t) for t in ts] for ts in groups]
        signs = {(o > 0) - (o < 0) for ts in flat for o in (orient(*t) for t in ts)}
        if len(signs) != 1:
            return report(False, 'a plane with triangles of both facings')
        borders = [border(ts) for ts in flat]
        points = {p for b in borders for e in b for p in e}
        cut = [split(b, points) for b in borders]
        if cut[0] != cut[1]:
            return report(False, f'in a plane, the borders differ ({sum(cut[0].values())} and '
                                 f'{sum(cut[1].values())} segments)')
        segments += sum(cut[0].values())
        triangles += sum(len(ts) for ts in groups)
    return report(True, f'{len(planes)} plane(s), {triangles} triangles, each plane\'s of one facing, '
                        f'equal borders of {segments} segments')


def report(proven, why):
    print(json.dumps({'proven': proven, 'why': why}))
    return 0 if proven else 1


if __name__ == '__main__':
    sys.exit(main())
