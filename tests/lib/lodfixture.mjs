// A hand-made input and the output a correct `lodpipe IN -o OUT --levels 5,10` would write for it, built
// without lodpipe, so the checkers of tests/lib/lodcheck.mjs (and the clients test) can be shown to pass a
// correct chain and to catch planted defects.
//
// The mesh "tentbox": the cube [-1,1]^3, every face a 4 x 4 quad grid (25 vertices, 32 triangles), the
// centre of the top face (+y) raised by H = 0.25 (a tent); two materials: primitive 0 = faces +y and +x,
// primitive 1 = the other four (each primitive has its own vertices: the two meet along a shared boundary,
// welded by position the surface is closed); primitive 2 = two POINTS far away (they must not enter the
// diagonal). Levels, each sharing the primitives' vertex accessors:
//   LOD1: every face a 2 x 2 grid (the even grid vertices; the raised centre stays): 48 triangles,
//         Hausdorff to LOD0 <= H/2 (largest vertical gap between the two height fields), recorded H/2;
//   LOD2: the plain 12-triangle cube: Hausdorff exactly H (the apex), recorded H.
// Ladder 5 %, 10 % of the diagonal sqrt(2^2 + 2.25^2 + 2^2) = 3.614: eps 0.181 and 0.361.
// Vertices: the input lists them in a scrambled order; the output sorts them by the level at which they
// die (corners first, then the other even vertices, then the rest) and rewrites the original indices.
// Nodes: 0 "root" (scale 2, children 1 and 2), 1 "box_a" (mesh 0, translation; world scale 2),
// 2 "box_b" (mesh 0, rotation 90 deg about y, scale [0.5, 1.5, 0.5]; world scale 3), 3 "mover" (animated).
// One animation (node 3 translation). The output adds LOD nodes 4, 5 (box_a) and 6, 7 (box_b), meshes 1
// and 2, index accessors 11-14, MSFT_lod + extras on nodes 1 and 2, and MSFT_lod in extensionsUsed.
import fs from 'node:fs';
import path from 'node:path';

export const TENT_H = 0.25;
export const FIXTURE_LADDER = [5, 10];
export const FIXTURE_CAMERA = { pixel_error: 1, viewport_height: 1080, fov_y: 0.7853981633974483 };
export const FIXTURE_DIAGONAL = Math.sqrt(4 + 2.25 * 2.25 + 4);
export const FIXTURE_SCALES = { 1: 2, 2: 3 }; // world scale of the two instances, by hand

// face: centre c, axes u, v with u x v = outward normal n
const FACES = [
  { name: '+y', n: [0, 1, 0], u: [0, 0, 1], v: [1, 0, 0], prim: 0 },
  { name: '+x', n: [1, 0, 0], u: [0, 1, 0], v: [0, 0, 1], prim: 0 },
  { name: '-x', n: [-1, 0, 0], u: [0, 0, 1], v: [0, 1, 0], prim: 1 },
  { name: '-y', n: [0, -1, 0], u: [1, 0, 0], v: [0, 0, 1], prim: 1 },
  { name: '+z', n: [0, 0, 1], u: [1, 0, 0], v: [0, 1, 0], prim: 1 },
  { name: '-z', n: [0, 0, -1], u: [0, 1, 0], v: [1, 0, 0], prim: 1 },
];

function primitiveGeometry(prim) {
  const verts = []; // { pos, normal, uv, level }
  const tris = [[], [], []]; // per level, generation ids
  for (const f of FACES.filter((x) => x.prim === prim)) {
    const base = verts.length;
    const id = (i, j) => base + i + 5 * j;
    for (let j = 0; j <= 4; j++) {
      for (let i = 0; i <= 4; i++) {
        const a = (i - 2) / 2;
        const b = (j - 2) / 2;
        const lift = f.name === '+y' && i === 2 && j === 2 ? TENT_H : 0;
        const pos = [0, 1, 2].map((c) => f.n[c] * (1 + lift) + a * f.u[c] + b * f.v[c]);
        const corner = (i === 0 || i === 4) && (j === 0 || j === 4);
        const even = i % 2 === 0 && j % 2 === 0;
        verts.push({ pos, normal: f.n, uv: [i / 4, j / 4], level: corner ? 2 : even ? 1 : 0 });
      }
    }
    const quad = (list, i, j, s) => list.push(id(i, j), id(i + s, j), id(i + s, j + s), id(i, j), id(i + s, j + s), id(i, j + s));
    for (let j = 0; j < 4; j++) for (let i = 0; i < 4; i++) quad(tris[0], i, j, 1);
    for (let j = 0; j < 4; j += 2) for (let i = 0; i < 4; i += 2) quad(tris[1], i, j, 2);
    quad(tris[2], 0, 0, 4);
  }
  // input order: a fixed scramble; output order: by level, last to die first (stable)
  const n = verts.length;
  const inOrder = [...Array(n).keys()].sort((x, y) => ((x * 37) % n) - ((y * 37) % n) || x - y);
  const outOrder = [...Array(n).keys()].sort((x, y) => verts[y].level - verts[x].level || x - y);
  return { verts, tris, inOrder, outOrder };
}

function streamsOf(g, order) {
  const pos = new Float32Array(order.length * 3);
  const nor = new Float32Array(order.length * 3);
  const uv = new Float32Array(order.length * 2);
  order.forEach((gid, k) => {
    pos.set(g.verts[gid].pos, 3 * k);
    nor.set(g.verts[gid].normal, 3 * k);
    uv.set(g.verts[gid].uv, 2 * k);
  });
  return { pos, nor, uv };
}

function remap(tris, order) {
  const at = new Map(order.map((gid, k) => [gid, k]));
  return Uint16Array.from(tris.map((gid) => at.get(gid)));
}

function minMax(arr, size) {
  const min = new Array(size).fill(Infinity);
  const max = new Array(size).fill(-Infinity);
  for (let i = 0; i < arr.length; i++) {
    min[i % size] = Math.min(min[i % size], arr[i]);
    max[i % size] = Math.max(max[i % size], arr[i]);
  }
  return { min: min.map(Math.fround), max: max.map(Math.fround) };
}

/**
 * The fixture as data: { inp: {json, datas}, out: {json, datas}, summary, ladder, camera, geometry }.
 * datas[i] is accessor i's typed array; pack() adds bufferViews. opts.errors = recorded [LOD1, LOD2] errors.
 */
export function buildFixture({ errors = [TENT_H / 2, TENT_H], camera = FIXTURE_CAMERA } = {}) {
  const G = [primitiveGeometry(0), primitiveGeometry(1)];
  const acc = (type, componentType, extra = {}) => ({ componentType, type, ...extra });
  const json = (order, withLods) => {
    const j = {
      asset: { version: '2.0', generator: 'lodpipe test fixture' },
      scene: 0,
      scenes: [{ name: 'fixture', nodes: [0, 3] }],
      nodes: [
        { name: 'root', scale: [2, 2, 2], children: [1, 2] },
        { name: 'box_a', mesh: 0, translation: [1, 0, 0] },
        { name: 'box_b', mesh: 0, translation: [-3, 0, 0], rotation: [0, 0.7071067811865476, 0, 0.7071067811865476], scale: [0.5, 1.5, 0.5] },
        { name: 'mover' },
      ],
      meshes: [{
        name: 'tentbox',
        primitives: [
          { attributes: { POSITION: 0, NORMAL: 1, TEXCOORD_0: 2 }, indices: 3, material: 0 },
          { attributes: { POSITION: 4, NORMAL: 5, TEXCOORD_0: 6 }, indices: 7, material: 1 },
          { attributes: { POSITION: 8 }, mode: 0 },
        ],
      }],
      materials: [
        { name: 'red', pbrMetallicRoughness: { baseColorFactor: [1, 0, 0, 1], metallicFactor: 0 } },
        { name: 'blue', pbrMetallicRoughness: { baseColorFactor: [0, 0, 1, 1], metallicFactor: 0 } },
      ],
      animations: [{ name: 'move', channels: [{ sampler: 0, target: { node: 3, path: 'translation' } }], samplers: [{ input: 9, output: 10 }] }],
      accessors: [],
    };
    return j;
  };
  const side = (order) => {
    const j = json(order);
    const datas = [];
    for (const p of [0, 1]) {
      const s = streamsOf(G[p], order[p]);
      j.accessors.push(acc('VEC3', 5126, minMax(s.pos, 3)), acc('VEC3', 5126), acc('VEC2', 5126), acc('SCALAR', 5123));
      datas.push(s.pos, s.nor, s.uv, remap(G[p].tris[0], order[p]));
    }
    const pts = Float32Array.from([10, 10, 10, -10, -10, -10]);
    j.accessors.push(acc('VEC3', 5126, minMax(pts, 3)));
    datas.push(pts);
    const t = Float32Array.from([0, 1]);
    j.accessors.push(acc('SCALAR', 5126, { min: [0], max: [1] }), acc('VEC3', 5126));
    datas.push(t, Float32Array.from([0, 0, 0, 0, 1, 0]));
    return { json: j, datas };
  };
  const inp = side(G.map((g) => g.inOrder));
  const out = side(G.map((g) => g.outOrder));

  // the chain
  const j = out.json;
  const lodMesh = [];
  for (const k of [1, 2]) {
    const prims = [0, 1].map((p) => {
      out.datas.push(remap(G[p].tris[k], G[p].outOrder));
      j.accessors.push({ componentType: 5123, type: 'SCALAR' });
      return { attributes: { ...j.meshes[0].primitives[p].attributes }, indices: j.accessors.length - 1, material: p };
    });
    j.meshes.push({ name: `tentbox_LOD${k}`, primitives: [...prims, JSON.parse(JSON.stringify(j.meshes[0].primitives[2]))] });
    lodMesh[k] = j.meshes.length - 1;
  }
  const tri = [192, 48, 12];
  const D = FIXTURE_DIAGONAL;
  const t = Math.tan(camera.fov_y / 2);
  for (const n of [1, 2]) {
    const ids = [1, 2].map((k) => {
      const src = j.nodes[n];
      const lod = { name: `${src.name}_LOD${k}`, mesh: lodMesh[k] };
      for (const key of ['translation', 'rotation', 'scale']) if (src[key]) lod[key] = src[key].slice();
      j.nodes.push(lod);
      return j.nodes.length - 1;
    });
    const s = FIXTURE_SCALES[n];
    const levels = [{ node: n, mesh: 0, error: 0, error_fraction: 0, triangles: tri[0], distance: 0, screen_coverage: 1 }];
    [1, 2].forEach((k) => {
      const e = errors[k - 1];
      const d = (e * s * camera.viewport_height) / (2 * t * camera.pixel_error);
      const c = Math.min(1, (0.5 * D * s) / (d * t));
      levels.push({ node: ids[k - 1], mesh: lodMesh[k], error: e, error_fraction: e / D, triangles: tri[k], distance: d, screen_coverage: c });
    });
    j.nodes[n].extensions = { MSFT_lod: { ids } };
    j.nodes[n].extras = {
      MSFT_screencoverage: [levels[1].screen_coverage, levels[2].screen_coverage, camera.pixel_error / camera.viewport_height],
      lodpipe: { camera: { ...camera }, levels },
    };
  }
  j.extensionsUsed = ['MSFT_lod'];
  const summary = {
    input: 'in.glb', output: 'out.glb',
    meshes: [{
      mesh: 0, name: 'tentbox', triangles: tri[0], diagonal: D, nodes: 2,
      levels: [1, 2].map((k) => ({ level: k, mesh: lodMesh[k], triangles: tri[k], eps: (FIXTURE_LADDER[k - 1] / 100) * D, error: errors[k - 1], error_fraction: errors[k - 1] / D, seconds: 0 })),
    }],
  };
  return { inp, out, summary, ladder: FIXTURE_LADDER, camera, G };
}

/** Give accessors bufferViews and counts; returns { json, bin } (one buffer). */
export function pack(model) {
  const json = JSON.parse(JSON.stringify(model.json));
  const size = { SCALAR: 1, VEC2: 2, VEC3: 3, VEC4: 4 };
  const chunks = [];
  let off = 0;
  json.bufferViews = [];
  json.accessors.forEach((a, i) => {
    const d = model.datas[i];
    const bytes = new Uint8Array(d.buffer, d.byteOffset, d.byteLength);
    const pad = (4 - (off % 4)) % 4;
    if (pad) chunks.push(new Uint8Array(pad));
    off += pad;
    const bv = { buffer: 0, byteOffset: off, byteLength: bytes.byteLength };
    if (a.componentType === 5123 || a.componentType === 5125) bv.target = 34963;
    json.bufferViews.push(bv);
    chunks.push(bytes);
    off += bytes.byteLength;
    a.bufferView = i;
    a.count = d.length / size[a.type];
  });
  const pad = (4 - (off % 4)) % 4;
  if (pad) chunks.push(new Uint8Array(pad));
  const bin = Buffer.concat(chunks.map((c) => Buffer.from(c)));
  json.buffers = [{ byteLength: bin.byteLength }];
  return { json, bin };
}

/** Write a GLB (JSON chunk padded with spaces, BIN chunk with zeros). */
export function writeGlb(file, json, bin) {
  let text = Buffer.from(JSON.stringify(json), 'utf8');
  if (text.length % 4) text = Buffer.concat([text, Buffer.alloc(4 - (text.length % 4), 0x20)]);
  const parts = [text];
  const header = Buffer.alloc(12);
  const jh = Buffer.alloc(8);
  jh.writeUInt32LE(text.length, 0);
  jh.writeUInt32LE(0x4e4f534a, 4);
  let total = 12 + 8 + text.length;
  let bh = null;
  if (bin && bin.length) {
    bh = Buffer.alloc(8);
    bh.writeUInt32LE(bin.length, 0);
    bh.writeUInt32LE(0x004e4942, 4);
    total += 8 + bin.length;
  }
  header.writeUInt32LE(0x46546c67, 0);
  header.writeUInt32LE(2, 4);
  header.writeUInt32LE(total, 8);
  fs.writeFileSync(file, Buffer.concat([header, jh, ...parts, ...(bh ? [bh, bin] : [])]));
}

/** Write in.glb and out.glb of a (possibly mutated) fixture into dir; returns the file names and the run's parameters. */
export function writeFixture(dir, fx) {
  const inFile = path.join(dir, 'in.glb');
  const outFile = path.join(dir, 'out.glb');
  const a = pack(fx.inp);
  writeGlb(inFile, a.json, a.bin);
  const b = pack(fx.out);
  if (fx.extraUnreferenced) b.json.accessors.pop(); // keep its bufferView: dead data (a planted defect)
  writeGlb(outFile, b.json, b.bin);
  return { inFile, outFile, summary: fx.summary, ladder: fx.ladder, camera: fx.camera };
}

/** Set the triangle count of LOD k (1-based) everywhere it is recorded (summary, both nodes' extras). */
export function setRecordedTriangles(fx, k, n) {
  fx.summary.meshes[0].levels[k - 1].triangles = n;
  for (const i of [1, 2]) fx.out.json.nodes[i].extras.lodpipe.levels[k].triangles = n;
}
