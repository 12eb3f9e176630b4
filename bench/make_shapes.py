#!/usr/bin/env python3
"""Meshes that cost lodpipe far more than their size suggests, for the benchmark's part 3
(bench/run.py) and tests/simplify.test.mjs.

usage: make_shapes.py KIND SEGMENTS OUT.glb      KIND: disc | cone | cylinder | grid

  disc      a flat disc of radius 1 triangulated from its centre (SEGMENTS triangles, an open
            border);
  cone      a closed cone: its side fanned from the apex (height 1, radius 0.5), its base
            fanned from the base's centre;
  cylinder  a closed cylinder (radius 0.5, height 1, 4 rows of quads on its side), each cap
            fanned from its centre: the way CAD exporters triangulate a round part;
  grid      a flat unit square at z = 0 of SEGMENTS x SEGMENTS cells, each cut in two along
            the same diagonal, vertices numbered row by row: a subdivided plane as modelling
            tools make it. Every collapse's quadric cost is exactly 0.

In the first three, every centre has SEGMENTS triangles around it, below lodpipe's hub limit
(4,096) when SEGMENTS is, so the simplifier may move it. Prints one JSON line {kind, segments,
vertices, triangles}. Deterministic; POSITION only, one primitive."""
import json
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tests", "tools"))
from adversarial_mesh import write_glb  # noqa: E402  (the project's own minimal GLB writer)


def ring(n, radius, z):
    return [(radius * math.cos(2 * math.pi * i / n), radius * math.sin(2 * math.pi * i / n), z) for i in range(n)]


def make(kind, n):
    if kind == "disc":
        v = ring(n, 1.0, 0.0) + [(0.0, 0.0, 0.0)]
        return v, [(n, i, (i + 1) % n) for i in range(n)]
    if kind == "cone":
        v = ring(n, 0.5, 0.0) + [(0.0, 0.0, 1.0), (0.0, 0.0, 0.0)]
        apex, centre = n, n + 1
        f = [(i, (i + 1) % n, apex) for i in range(n)] + [(centre, (i + 1) % n, i) for i in range(n)]
        return v, f
    if kind == "cylinder":
        rows = 4
        v = [p for r in range(rows + 1) for p in ring(n, 0.5, r / rows)]
        f = []
        for r in range(rows):
            for i in range(n):
                a, b = r * n + i, r * n + (i + 1) % n
                f += [(a, b, b + n), (a, b + n, a + n)]
        bottom, top = len(v), len(v) + 1
        v += [(0.0, 0.0, 0.0), (0.0, 0.0, 1.0)]
        f += [(bottom, (i + 1) % n, i) for i in range(n)]
        f += [(top, rows * n + i, rows * n + (i + 1) % n) for i in range(n)]
        return v, f
    if kind == "grid":
        v = [(i / n, j / n, 0.0) for j in range(n + 1) for i in range(n + 1)]
        f = []
        for j in range(n):
            for i in range(n):
                a = j * (n + 1) + i
                f += [(a, a + 1, a + n + 2), (a, a + n + 2, a + n + 1)]
        return v, f
    raise SystemExit("make_shapes.py: unknown kind %r (disc, cone, cylinder or grid)" % kind)


def main():
    if len(sys.argv) != 4:
        raise SystemExit(__doc__)
    kind, n, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    if n < 3:
        raise SystemExit("make_shapes.py: SEGMENTS must be at least 3")
    v, f = make(kind, n)
    write_glb(out, v, [f])
    print(json.dumps({"kind": kind, "segments": n, "vertices": len(v), "triangles": len(f)}))


if __name__ == "__main__":
    main()
