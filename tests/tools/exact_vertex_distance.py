#!/usr/bin/env python3
"""Exact check of a recorded bound at the vertices: is every vertex of A.obj within
BOUND of B.obj's surface? Coordinates are read as float32 (lodpipe writes each float
with %.17g, its exact value; rounding to float32 keeps it so and also reads an OBJ
printed with fewer digits as the floats it came from), distances
are screened in double and every vertex whose double distance is within 1e-6 of BOUND
(relative) is settled in exact rational arithmetic against BOUND as a double.

usage: exact_vertex_distance.py A.obj B.obj BOUND
prints one JSON line: {"vertices": n, "settled_exactly": k, "worst": d, "violations": [[i, d], ...]}
(i 1-based, d the distance rounded to a double); exit 0 either way, 2 on bad input."""
import json
import struct
import sys
from fractions import Fraction


def f32(text):
    return struct.unpack('f', struct.pack('f', float(text)))[0]


def load(path):
    vertices, faces = [], []
    with open(path) as f:
        for line in f:
            p = line.split()
            if not p:
                continue
            if p[0] == 'v':
                vertices.append(tuple(f32(x) for x in p[1:4]))
            elif p[0] == 'f':
                faces.append(tuple(int(x.split('/')[0]) - 1 for x in p[1:4]))
    return vertices, faces


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def segment2(p, a, b, zero, one):
    ab = sub(b, a)
    length2 = dot(ab, ab)
    if length2 == 0:
        d = sub(p, a)
        return dot(d, d)
    t = min(max(dot(sub(p, a), ab) / length2, zero), one)
    d = sub(p, (a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2]))
    return dot(d, d)


def triangle2(p, a, b, c, zero, one):
    """Squared distance from p to triangle abc, in the arithmetic of the inputs."""
    best = min(segment2(p, a, b, zero, one), segment2(p, b, c, zero, one), segment2(p, c, a, zero, one))
    n = cross(sub(b, a), sub(c, a))
    nn = dot(n, n)
    if nn > 0:
        s = dot(sub(p, a), n) / nn
        q = (p[0] - s * n[0], p[1] - s * n[1], p[2] - s * n[2])
        if all(dot(cross(sub(y, x), sub(q, x)), n) >= 0 for x, y in ((a, b), (b, c), (c, a))):
            d = sub(p, q)
            best = min(best, dot(d, d))
    return best


def main():
    if len(sys.argv) != 4:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    av, _ = load(sys.argv[1])
    bv, bf = load(sys.argv[2])
    bound = float(sys.argv[3])
    if not bf:
        print(json.dumps({"vertices": len(av), "settled_exactly": 0, "worst": None, "violations": []}))
        return
    tris = [(bv[f[0]], bv[f[1]], bv[f[2]]) for f in bf]
    exact_tris = None
    worst, settled, violations = 0.0, 0, []
    bound2 = Fraction(bound) ** 2
    for i, p in enumerate(av):
        d2 = min(triangle2(p, a, b, c, 0.0, 1.0) for a, b, c in tris)
        d = d2 ** 0.5
        worst = max(worst, d)
        if d < bound * (1 - 1e-6):
            continue
        if exact_tris is None:
            exact_tris = [tuple(tuple(Fraction(x) for x in v) for v in t) for t in tris]
        q = tuple(Fraction(x) for x in p)
        e2 = min(triangle2(q, a, b, c, Fraction(0), Fraction(1)) for a, b, c in exact_tris)
        settled += 1
        if e2 > bound2:
            violations.append([i + 1, float(e2) ** 0.5])
    print(json.dumps({"vertices": len(av), "settled_exactly": settled, "worst": worst, "violations": violations}))


if __name__ == '__main__':
    main()
