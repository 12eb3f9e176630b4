#!/usr/bin/env python3
"""Seeded adversarial meshes for soundness runs of the certified simplifier.

usage: adversarial_mesh.py SEED OUT.glb
writes one mesh (one or two triangle primitives, POSITION only) and prints one JSON line
{"seed", "kind", "vertices", "triangles", "primitives", "scale", "shift"}.

The seed picks a kind, each a case the certificate must not be fooled by (DESIGN.md §4, §5):
  sphere   an icosphere with multi-scale bumps and spikes/pits, some narrower than eps
  terrain  an open height field, a cliff on some seeds, a jagged (sawtooth) border on others
  plate    a closed box about as thin as eps or thinner (both sides must stay covered), bent
           on some seeds
  shells   two separate nested spheres a gap apart, the outer one facing inwards (a thin shell)
  grooves  V-grooves and steps across an open strip
  crumple  a folded sheet that intersects itself
  tube     a long open cylinder whose radius is near eps
  fins     three sheets on one edge (non-manifold) plus duplicated faces
  slits    an open sheet cut by slits about as wide as eps and perforated by holes of one
           cell (border loops close together, and vertices where two holes touch)
  slivers  needle and very obtuse triangles: a fan or a polar grid of many thin sectors, or
           a strip between a finely and a coarsely divided edge, over a height field
  book     one sheet folded back over itself, its two pages a gap about as wide as eps apart
           (an open thin part: each page must stay covered by itself)
then, on some seeds, a material split into two primitives (seams), a scale of 1e-3 or 1e3
and a move 1e5 units from the origin (where float32 has few digits left; with the scale
1e-3 as well, the mesh collapses to a point in float32: a degenerate input that must get
no levels, and no crash).

Pure Python (no numpy), deterministic for a seed. Used by tests/simplify.test.mjs and for
longer runs by hand: tests/tools/soundness_run.py."""
import json, math, random, struct, sys


def icosphere(n):
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    v = [tuple(c / math.sqrt(sum(x * x for x in p)) for c in p) for p in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    for _ in range(n):
        mid = {}
        nf = []

        def m(a, b):
            k = (min(a, b), max(a, b))
            if k not in mid:
                p = [(v[a][i] + v[b][i]) / 2 for i in range(3)]
                l = math.sqrt(sum(x * x for x in p))
                v.append(tuple(x / l for x in p))
                mid[k] = len(v) - 1
            return mid[k]
        for a, b, c in f:
            ab, bc, ca = m(a, b), m(b, c), m(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = nf
    return [list(p) for p in v], f


def grid(nx, ny, jag=0.0, rnd=None):
    v, f = [], []
    for j in range(ny + 1):
        for i in range(nx + 1):
            x, y = i / nx, j / ny
            if jag and (i in (0, nx) or j in (0, ny)):
                x += jag * (rnd.random() - 0.5) / nx
                y += jag * (rnd.random() - 0.5) / ny
            v.append([x, y, 0.0])
    for j in range(ny):
        for i in range(nx):
            a = j * (nx + 1) + i
            b, c, d = a + 1, a + nx + 1, a + nx + 2
            if (i + j) % 2:
                f += [(a, b, d), (a, d, c)]
            else:
                f += [(a, b, c), (b, d, c)]
    return v, f


def noise_fn(rnd, octaves):
    waves = []
    for o in range(octaves):
        fr = 2 ** o * rnd.uniform(1, 3)
        waves.append(([rnd.gauss(0, 1) * fr for _ in range(3)], rnd.uniform(0, 6.3), rnd.uniform(0.3, 1) / 2 ** o))
    return lambda p: sum(a * math.sin(k[0] * p[0] + k[1] * p[1] + k[2] * p[2] + ph) for k, ph, a in waves)


def spikes(rnd, v, count, amp, normal_of):
    for _ in range(count):
        i = rnd.randrange(len(v))
        n = normal_of(i)
        s = amp * rnd.choice([-1, 1]) * rnd.uniform(0.3, 1)
        v[i] = [v[i][k] + s * n[k] for k in range(3)]


def make(seed):
    rnd = random.Random(seed)
    kind = rnd.choice(['sphere', 'terrain', 'plate', 'shells', 'grooves', 'crumple', 'tube', 'fins', 'slits', 'slivers',
                       'book'])
    prims = None
    if kind == 'sphere':
        v, f = icosphere(rnd.choice([4, 5]))
        nf = noise_fn(rnd, rnd.randint(1, 6))
        amp = rnd.choice([0.01, 0.05, 0.2])
        base = [list(p) for p in v]
        v = [[c * (1 + amp * nf(p)) for c in p] for p in v]
        spikes(rnd, v, rnd.randint(0, 30), rnd.choice([0.02, 0.1, 0.5]), lambda i: base[i])
    elif kind == 'terrain':
        n = rnd.choice([40, 70, 100])
        v, f = grid(n, n, jag=rnd.choice([0, 0.8]), rnd=rnd)
        nf = noise_fn(rnd, rnd.randint(1, 6))
        amp = rnd.choice([0.01, 0.05, 0.2])
        step = rnd.choice([0, 0, 0.05])
        for p in v:
            p[2] = amp * nf(p) + (step if p[0] > 0.5 else 0)
        spikes(rnd, v, rnd.randint(0, 30), rnd.choice([0.02, 0.1, 0.3]), lambda i: (0, 0, 1))
    elif kind == 'plate':  # a closed box thinner than eps
        n = rnd.choice([30, 60])
        t = rnd.choice([0.001, 0.005, 0.02])
        v1, f1 = grid(n, n)
        v = [[p[0], p[1], 0.0] for p in v1] + [[p[0], p[1], t] for p in v1]
        off = len(v1)
        f = [(a, c, b) for a, b, c in f1] + [(a + off, b + off, c + off) for a, b, c in f1]
        ring = [i for i in range(n + 1)] + [j * (n + 1) + n for j in range(1, n + 1)] + \
               [n * (n + 1) + i for i in range(n - 1, -1, -1)] + [j * (n + 1) for j in range(n - 1, 0, -1)]
        for k in range(len(ring)):
            a, b = ring[k], ring[(k + 1) % len(ring)]
            f += [(a, b, b + off), (a, b + off, a + off)]
        nf = noise_fn(rnd, 3)
        bend = rnd.choice([0, 0.3])
        for p in v:
            p[2] += bend * nf([p[0], p[1], 0])
    elif kind == 'shells':  # two separate nearly coincident spheres
        v1, f1 = icosphere(4)
        gap = rnd.choice([0.002, 0.01, 0.03])
        nf = noise_fn(rnd, 3)
        v = [[c * (1 + 0.05 * nf(p)) for c in p] for p in v1]
        v += [[c * (1 + 0.05 * nf(p) + gap) for c in p] for p in v1]
        off = len(v1)
        f = list(f1) + [(a + off, c + off, b + off) for a, b, c in f1]
    elif kind == 'grooves':
        n = rnd.choice([60, 90])
        v, f = grid(n, n // 3)
        per = rnd.choice([3, 5, 9])
        depth = rnd.choice([0.005, 0.02, 0.1])
        for p in v:
            i = round(p[0] * n)
            p[2] = depth * ((i // per) % 2) + depth * abs((i % per) - per / 2) / per
    elif kind == 'crumple':  # self-intersecting input
        n = rnd.choice([30, 50])
        v, f = grid(n, n)
        amp = rnd.choice([0.05, 0.3])
        nf = [noise_fn(rnd, 3) for _ in range(3)]
        v = [[p[k] + amp * nf[k]([4 * p[0], 4 * p[1], 0]) for k in range(3)] for p in v]
    elif kind == 'tube':  # long thin open cylinder, radius near eps
        n, m = rnd.choice([200, 400]), rnd.choice([6, 12])
        r = rnd.choice([0.002, 0.01, 0.05])
        v, f = [], []
        for i in range(n + 1):
            for j in range(m):
                a = 2 * math.pi * j / m
                z = i / n
                v.append([r * math.cos(a) + 0.1 * math.sin(3 * z), r * math.sin(a), z])
        for i in range(n):
            for j in range(m):
                a, b = i * m + j, i * m + (j + 1) % m
                f += [(a, b, b + m), (a, b + m, a + m)]
    elif kind == 'slits':
        n = rnd.choice([40, 60, 80])
        v, f = grid(n, n)
        gone = set()  # cells (i, j) cut out
        for _ in range(rnd.randint(2, 6)):  # a slit one cell wide along x or y
            j, i0 = rnd.randrange(1, n - 1), rnd.randrange(0, n // 2)
            along_x = rnd.random() < 0.5
            for i in range(i0, min(n, i0 + rnd.randint(n // 4, n - 1))):
                gone.add((i, j) if along_x else (j, i))
        for _ in range(rnd.randint(0, 40)):  # holes of one cell, some touching at a corner
            gone.add((rnd.randrange(n), rnd.randrange(n)))
        f = [t for k, t in enumerate(f) if ((k // 2) % n, (k // 2) // n) not in gone]
        nf = noise_fn(rnd, rnd.randint(1, 4))
        amp = rnd.choice([0.01, 0.05, 0.2])
        for p in v:
            p[2] = amp * nf(p)
    elif kind == 'slivers':
        shape = rnd.choice(['fan', 'polar', 'strip'])
        if shape == 'strip':  # a fine edge of m points against a coarse one of k
            m, k = rnd.choice([300, 800]), rnd.choice([2, 5, 20])
            v = [[i / m, 0.0, 0.0] for i in range(m + 1)] + [[i / k, 0.2, 0.0] for i in range(k + 1)]
            f, i, j = [], 0, 0
            while i < m or j < k:  # advance the side that lags behind
                if j == k or (i < m and (i + 1) / m <= (j + 1) / k):
                    f.append((i, i + 1, m + 1 + j))
                    i += 1
                else:
                    f.append((i, m + 2 + j, m + 1 + j))
                    j += 1
        else:  # sectors around the centre: a fan (one ring) or a polar grid of a few rings
            sectors, rings = rnd.choice([200, 600, 1500]), (1 if shape == 'fan' else rnd.choice([2, 4]))
            v = [[0.0, 0.0, 0.0]] + [[r / rings * math.cos(2 * math.pi * t / sectors),
                                      r / rings * math.sin(2 * math.pi * t / sectors), 0.0]
                                     for r in range(1, rings + 1) for t in range(sectors)]
            f = [(0, 1 + t, 1 + (t + 1) % sectors) for t in range(sectors)]
            for r in range(1, rings):
                a0, b0 = 1 + (r - 1) * sectors, 1 + r * sectors
                for t in range(sectors):
                    t1 = (t + 1) % sectors
                    f += [(a0 + t, b0 + t, b0 + t1), (a0 + t, b0 + t1, a0 + t1)]
        nf = noise_fn(rnd, rnd.randint(1, 4))
        amp = rnd.choice([0.005, 0.03, 0.1])
        for p in v:
            p[2] = amp * nf(p)
    elif kind == 'book':  # u runs along the sheet: the lower page, a half circle of radius r, the upper page back
        n = rnd.choice([40, 70])
        v, f = grid(n, n // 2)
        gap = rnd.choice([0.002, 0.01, 0.03])
        r, page = gap / 2, 0.5
        length = 2 * page + math.pi * r
        nf = noise_fn(rnd, 2)
        bend = rnd.choice([0, 0.05])
        for p in v:
            u, y = p[0] * length, p[1]
            if u < page:
                x, z = u, 0.0
            elif u < page + math.pi * r:
                th = (u - page) / r
                x, z = page + r * math.sin(th), r - r * math.cos(th)
            else:
                x, z = page - (u - page - math.pi * r), 2 * r
            p[0], p[2] = x, z + bend * nf([x, y, 0])
    else:  # fins: non-manifold edges (three sheets on one edge) and duplicate faces
        n = rnd.choice([30, 50])
        v1, f1 = grid(n, n)
        v = [list(p) for p in v1]
        f = list(f1)
        for ang in (1.2, 2.3):
            off = len(v)
            for p in v1:
                v.append([p[0], p[1] * math.cos(ang), p[1] * math.sin(ang)])
            f += [(a + off, b + off, c + off) for a, b, c in f1]
        # the sheets share the row y = 0 by position (lodpipe welds it); the rest is bent
        nf = noise_fn(rnd, 3)
        for p in v:
            p[2] += 0.01 * nf(p) * (p[1] != 0)
        dup = rnd.sample(range(len(f)), 20)
        f += [f[i] for i in dup]
    # a material split on some seeds (two primitives): seams
    if rnd.random() < 0.4:
        axis = rnd.randrange(3)
        cut = sorted(p[axis] for p in v)[len(v) // 2]
        a = [t for t in f if v[t[0]][axis] <= cut]
        b = [t for t in f if v[t[0]][axis] > cut]
        prims = [x for x in (a, b) if x]
    else:
        prims = [f]
    scale = rnd.choice([1, 1, 0.001, 1000])
    shift = rnd.choice([0, 0, 1e5])
    v = [[c * scale + shift for c in p] for p in v]
    return kind, v, prims, scale, shift


def write_glb(path, v, prims):
    pos = b''.join(struct.pack('<3f', *p) for p in v)
    buf = bytearray(pos)
    views = [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos), "target": 34962}]
    lo = [min(struct.unpack('<3f', struct.pack('<3f', *p))[k] for p in v) for k in range(3)]
    hi = [max(struct.unpack('<3f', struct.pack('<3f', *p))[k] for p in v) for k in range(3)]
    acc = [{"bufferView": 0, "componentType": 5126, "count": len(v), "type": "VEC3", "min": lo, "max": hi}]
    gl_prims = []
    for k, f in enumerate(prims):
        off = len(buf)
        idx = b''.join(struct.pack('<3I', *t) for t in f)
        buf += idx
        views.append({"buffer": 0, "byteOffset": off, "byteLength": len(idx), "target": 34963})
        acc.append({"bufferView": len(views) - 1, "componentType": 5125, "count": 3 * len(f), "type": "SCALAR"})
        gl_prims.append({"attributes": {"POSITION": 0}, "indices": len(acc) - 1, "material": k})
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
           "meshes": [{"primitives": gl_prims}], "materials": [{"name": "m%d" % k} for k in range(len(prims))],
           "buffers": [{"byteLength": len(buf)}], "bufferViews": views, "accessors": acc}
    js = json.dumps(doc).encode()
    js += b' ' * (-len(js) % 4)
    buf += b'\0' * (-len(buf) % 4)
    out = struct.pack('<III', 0x46546C67, 2, 12 + 8 + len(js) + 8 + len(buf))
    out += struct.pack('<II', len(js), 0x4E4F534A) + js + struct.pack('<II', len(buf), 0x004E4942) + bytes(buf)
    open(path, 'wb').write(out)


if __name__ == '__main__':
    seed = int(sys.argv[1])
    kind, v, prims, scale, shift = make(seed)
    write_glb(sys.argv[2], v, prims)
    print(json.dumps({"seed": seed, "kind": kind, "vertices": len(v), "triangles": sum(map(len, prims)),
                      "primitives": len(prims), "scale": scale, "shift": shift}))
