// Checkers for the main job's output (`lodpipe IN -o OUT`, issue 4): an MSFT_lod chain per mesh of the
// default scene, written into a copy of the input. Used by tests/lodchain.test.mjs (must show 1-3) and
// tests/clients.test.mjs (must show 4).
//
// Everything here reads the files with instruments that are not lodpipe's code: our own raw glTF reader
// (tests/lib/gltf.mjs, for the output's JSON and accessor bytes), glTF-Transform (the input's decoded
// geometry, Draco and meshopt included), the Khronos validator, and the CGAL Hausdorff tool
// (build/hausdorff/hausdorff, `file.glb#node=N` = node N's mesh in mesh space).
//
// analyzeChain() returns { problems: {aspect: [...]}, notes: [...], stats } for one (input, output, --json
// summary) triple; the aspects are listed in CHAIN_ASPECTS. Each aspect is a list of human-readable
// problems (empty = the promise holds), so a test can assert aspect by aspect and a self-test can check
// that a planted defect lands in the aspect it belongs to.
import fs from 'node:fs';
import path from 'node:path';
import { spawnSync } from 'node:child_process';
import {
  COMPRESSION_EXTENSIONS, MESHOPT_FILTER_ULP, compareAnimationSkinData, compareImages, compressedAccessorIndices,
  contractView, diffJson, getIO, isDataUri, loadInput, meshoptFilterOf, newValidatorErrors, readDocument, readRaw, repoRoot,
  validateFile,
} from './gltf.mjs';

// ---------------------------------------------------------------------------------------------
// Constants of the contract

export const DEFAULT_LADDER = [1, 3, 7, 15]; // percent of the mesh's bbox diagonal
export const DEFAULT_CAMERA = { pixel_error: 1, viewport_height: 1080, fov_y: 0.7853981633974483 };
export const MIN_REDUCTION = 0.1; // a kept level removes at least 10 % of the previous kept level's triangles
export const SLACK_REL = 1e-7; // hausdorff_upper <= error + SLACK_REL * diagonal (float printing / float32 positions)
export const SWITCH_REL = 1e-9; // recorded distance / coverage vs recomputed, relative
const EPS_REL_TOL = 1e-12; // error <= eps * (1 + this)
const FRACTION_REL_TOL = 1e-9; // error_fraction vs error / diagonal; eps vs ladder x diagonal
const DIAG_REL_TOL = 1e-9; // recorded diagonal vs ours (both from the same float32 positions)

export const BUILD = process.env.LODPIPE_BUILD || path.join(repoRoot, 'build');
export const HAUSDORFF = path.join(BUILD, 'hausdorff', 'hausdorff');
const HAUSDORFF_TIMEOUT_MS = Number(process.env.LODPIPE_HAUSDORFF_TIMEOUT_MS || 600000);

// Every valid corpus asset of this many triangles gets a level (2026-12-03: the smallest that does is
// CesiumMilkTruck, 2,856; ShapeCollection's 2,390 in simple shapes get none).
export const CHAIN_EXPECTED_MIN_TRIANGLES = 2500;

export const CHAIN_ASPECTS = [
  ['validator', 'no Khronos validator error the input did not have'],
  ['summary', '--json summary: every mesh of the default scene once, levels consistent with the file'],
  ['eps', 'recorded error <= eps of the ladder level it came from'],
  ['chain', 'MSFT_lod structure: one LOD node per kept level on every instance, same transform/skin/weights, LOD meshes shared by instances, nothing else added'],
  ['hierarchy', 'a node carrying MSFT_lod has no children, camera, extras or extension its LOD nodes lack (a client that swaps the node would lose them)'],
  ['soundness', 'Hausdorff(LOD node mesh, LOD0 mesh) by the CGAL tool <= recorded error, proven'],
  ['unchanged', 'animations, skins, materials, textures, images, samplers, cameras, scenes, other nodes/meshes/accessors unchanged'],
  ['geometry', 'original meshes: same vertices and triangles (as sets of attribute tuples) after the reorder'],
  ['lodprims', 'LOD primitives: the original attribute/target accessors, material and mode; points/lines copied'],
  ['indextype', 'LOD index accessors are UNSIGNED_SHORT where the level\'s vertex prefix fits'],
  ['prefix', 'level k+1 uses a prefix of the vertices level k uses (max index nested)'],
  ['watertight', 'a mesh closed at level 0 (welded by exact position, all primitives) is closed at every level'],
  ['switching', 'distances, screen coverages and MSFT_screencoverage recomputed from error, world scale and camera'],
  ['buffers', 'no dead data: every bufferView the output has is used (unless the input had it unused too)'],
];

// ---------------------------------------------------------------------------------------------
// Small numeric helpers

export const relClose = (a, b, rel) => a === b || (Number.isFinite(a) && Number.isFinite(b) && Math.abs(a - b) <= rel * Math.max(Math.abs(a), Math.abs(b)));
export const fmt = (x, d = 6) => (typeof x === 'number' && Number.isFinite(x) ? Number(x.toPrecision(d)).toString() : String(x));
const isInt = (x) => Number.isInteger(x);
const deepEqual = (a, b) => JSON.stringify(canon(a)) === JSON.stringify(canon(b));
function canon(v) {
  if (Array.isArray(v)) return v.map(canon);
  if (v && typeof v === 'object') return Object.fromEntries(Object.keys(v).sort().map((k) => [k, canon(v[k])]));
  return v;
}
const clone = (v) => (v === undefined ? undefined : JSON.parse(JSON.stringify(v)));

// ---------------------------------------------------------------------------------------------
// Node transforms (column-major 4x4, glTF convention)

const IDENTITY = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];

export function mat4Mul(a, b) {
  const o = new Array(16).fill(0);
  for (let c = 0; c < 4; c++) for (let r = 0; r < 4; r++) {
    let s = 0;
    for (let k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k];
    o[c * 4 + r] = s;
  }
  return o;
}

/** The node's local matrix: `matrix`, or T * R * S. */
export function localMatrix(node) {
  if (Array.isArray(node.matrix) && node.matrix.length === 16) return node.matrix.slice();
  const [tx, ty, tz] = node.translation || [0, 0, 0];
  const [x, y, z, w] = node.rotation || [0, 0, 0, 1];
  const [sx, sy, sz] = node.scale || [1, 1, 1];
  const r = [
    1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w),
    2 * (x * y - z * w), 1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
    2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y),
  ];
  return [r[0] * sx, r[1] * sx, r[2] * sx, 0, r[3] * sy, r[4] * sy, r[5] * sy, 0, r[6] * sz, r[7] * sz, r[8] * sz, 0, tx, ty, tz, 1];
}

/** World matrix of every node from the hierarchy (children arrays). A node without parent is its own root. */
export function worldMatrices(json) {
  const nodes = json.nodes || [];
  const parent = new Array(nodes.length).fill(-1);
  nodes.forEach((n, i) => (n.children || []).forEach((c) => {
    if (isInt(c) && c >= 0 && c < nodes.length) parent[c] = i;
  }));
  const world = new Array(nodes.length).fill(null);
  const get = (i, depth = 0) => {
    if (world[i]) return world[i];
    if (depth > 10000) throw new Error('node hierarchy has a cycle');
    const local = localMatrix(nodes[i]);
    world[i] = parent[i] < 0 ? local : mat4Mul(get(parent[i], depth + 1), local);
    return world[i];
  };
  nodes.forEach((_, i) => get(i));
  return { world, parent };
}

/** Largest column length of the 3x3 part (the world scale s of DESIGN.md §8). */
export function maxColumnScale(m) {
  let s = 0;
  for (let c = 0; c < 3; c++) s = Math.max(s, Math.hypot(m[c * 4], m[c * 4 + 1], m[c * 4 + 2]));
  return s;
}

/**
 * How much a 4x4 (column-major) stretches lengths: the largest singular value of its 3x3 part, by Jacobi
 * rotations on M^T M (independently of lodpipe's C); the longest column when there is no shear.
 */
export function maxStretch(m) {
  const a = [0, 1, 2].map((i) => [0, 1, 2].map((k) => m[i * 4] * m[k * 4] + m[i * 4 + 1] * m[k * 4 + 1] + m[i * 4 + 2] * m[k * 4 + 2]));
  for (let sweep = 0; sweep < 50; sweep++) {
    let off = 0;
    for (const [p, q] of [[0, 1], [0, 2], [1, 2]]) off += a[p][q] * a[p][q];
    if (!(off > 1e-34 * (a[0][0] + a[1][1] + a[2][2]) ** 2)) break;
    for (const [p, q] of [[0, 1], [0, 2], [1, 2]]) {
      if (a[p][q] === 0) continue;
      // the rotation in the (p, q) plane that zeroes a[p][q], applied as J^T A J
      const phi = 0.5 * Math.atan2(2 * a[p][q], a[q][q] - a[p][p]);
      const c = Math.cos(phi);
      const sn = Math.sin(phi);
      const next = a.map((row) => row.slice());
      for (let k = 0; k < 3; k++) {
        next[k][p] = c * a[k][p] - sn * a[k][q];
        next[k][q] = sn * a[k][p] + c * a[k][q];
      }
      const rows = next.map((row) => row.slice());
      for (let k = 0; k < 3; k++) {
        rows[p][k] = c * next[p][k] - sn * next[q][k];
        rows[q][k] = sn * next[p][k] + c * next[q][k];
      }
      for (let i = 0; i < 3; i++) for (let k = 0; k < 3; k++) a[i][k] = rows[i][k];
    }
  }
  return Math.max(maxColumnScale(m), Math.sqrt(Math.max(0, a[0][0], a[1][1], a[2][2])));
}

/**
 * How much node n stretches its mesh into the world (README "Output format"): its world matrix's maxStretch, or
 * for a skinned node (glTF ignores its own transform: the joints place the mesh) the largest over the skin's
 * joints of maxStretch(joint world * inverse bind matrix).
 */
export function meshStretch(raw, world, n) {
  const skin = raw.json.skins?.[raw.json.nodes[n].skin];
  if (!skin || !(skin.joints || []).length) return maxStretch(world[n]);
  const ibm = skin.inverseBindMatrices !== undefined ? rawAccessor(raw, skin.inverseBindMatrices) : null;
  const identity = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];
  return Math.max(...skin.joints.map((jn, k) => {
    const bind = ibm && k < ibm.count ? [...Array(16)].map((_, i) => ibm.array[16 * k + i]) : identity;
    return maxStretch(mat4Mul(world[jn], bind));
  }));
}

/** d, R, c of DESIGN.md §8 / the README's output format, recomputed. */
export function expectedSwitching(error, scale, diagonal, camera) {
  const t = Math.tan(camera.fov_y / 2);
  const d = (error * scale * camera.viewport_height) / (2 * t * camera.pixel_error);
  const R = 0.5 * diagonal * scale;
  const c = d === 0 ? 1 : Math.min(1, R / (d * t));
  return { distance: d, coverage: c, radius: R };
}

// ---------------------------------------------------------------------------------------------
// Scene traversal

/** Nodes reachable from the default scene (scene, else scene 0), in traversal order. */
export function sceneNodes(json) {
  const scene = json.scenes?.[json.scene ?? 0];
  const out = [];
  const seen = new Set();
  const visit = (n) => {
    if (!isInt(n) || seen.has(n) || !json.nodes?.[n]) return;
    seen.add(n);
    out.push(n);
    for (const c of json.nodes[n].children || []) visit(c);
  };
  for (const n of scene?.nodes || []) visit(n);
  return out;
}

const TRIANGLE_MODES = [4, 5, 6];
export const modeOf = (prim) => (prim.mode === undefined ? 4 : prim.mode);
export const isTrianglePrim = (prim) => TRIANGLE_MODES.includes(modeOf(prim)) && prim.attributes?.POSITION !== undefined;

/** Meshes used by the default scene with at least one triangle primitive; { mesh: [instance nodes] }. */
export function sceneTriangleMeshes(json) {
  const inst = new Map();
  for (const n of sceneNodes(json)) {
    const m = json.nodes[n].mesh;
    if (m === undefined || !json.meshes?.[m]) continue;
    if (!(json.meshes[m].primitives || []).some(isTrianglePrim)) continue;
    if (!inst.has(m)) inst.set(m, []);
    inst.get(m).push(n);
  }
  return inst;
}

/**
 * The nodes that get a mesh's chain: for every mesh of sceneTriangleMeshes, every node that uses it,
 * in node order, whichever scene it is in (README "Output format": the chain goes on every node that
 * uses the mesh, so a scene the client switches to shows it too), except a node that already has
 * MSFT_lod (left as it is); a mesh left with no such node is not processed at all; { mesh: [nodes] }.
 */
export function chainedNodes(json) {
  const out = new Map();
  for (const m of sceneTriangleMeshes(json).keys()) out.set(m, []);
  (json.nodes || []).forEach((n, i) => {
    if (out.has(n.mesh) && !n.extensions?.MSFT_lod) out.get(n.mesh).push(i);
  });
  for (const [m, list] of out) if (!list.length) out.delete(m);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Geometry access (component values, no normalization applied) and triangles

const TYPE_SIZE = { SCALAR: 1, VEC2: 2, VEC3: 3, VEC4: 4, MAT2: 4, MAT3: 9, MAT4: 16 };

/** Dequantized float value of a component (glTF 2.0 §3.11 normalized integers). */
export function dequant(v, componentType, normalized) {
  if (!normalized) return v;
  switch (componentType) {
    case 5120: return Math.max(v / 127, -1);
    case 5121: return v / 255;
    case 5122: return Math.max(v / 32767, -1);
    case 5123: return v / 65535;
    default: return v;
  }
}

/** { array, size, count, componentType, normalized } of output accessor i (raw reader). */
/** EXT_mesh_gpu_instancing: the largest absolute instance SCALE component of a node (1 without). */
function instanceScale(raw, node) {
  const a = node.extensions?.EXT_mesh_gpu_instancing?.attributes?.SCALE;
  if (a === undefined) return 1;
  const acc = rawAccessor(raw, a);
  let best = 0;
  for (let i = 0; i < acc.count * acc.size; i++) best = Math.max(best, Math.abs(dequant(acc.array[i], acc.componentType, acc.normalized)));
  return acc.count ? best : 1;
}

function rawAccessor(raw, i) {
  const a = raw.json.accessors[i];
  return { array: raw.accessorArray(i), size: TYPE_SIZE[a.type], count: a.count, componentType: a.componentType, normalized: !!a.normalized, index: i };
}

function docAccessor(acc, index) {
  return { array: acc.getArray(), size: acc.getElementSize(), count: acc.getCount(), componentType: acc.getComponentType(), normalized: acc.getNormalized(), index };
}

/** Geometry of output primitive (m, p): { mode, indices, attrs: {SEM: acc}, targets: [{SEM: acc}] }. */
export function rawPrimGeometry(raw, m, p) {
  const jp = raw.json.meshes[m].primitives[p];
  const attrs = {};
  for (const [s, i] of Object.entries(jp.attributes || {})) attrs[s] = rawAccessor(raw, i);
  const targets = (jp.targets || []).map((t) => Object.fromEntries(Object.entries(t).map(([s, i]) => [s, rawAccessor(raw, i)])));
  return { mode: modeOf(jp), indices: jp.indices !== undefined ? raw.accessorArray(jp.indices) : null, attrs, targets };
}

/** Geometry of input primitive (m, p) decoded by glTF-Transform (Draco / meshopt included). */
export function docPrimGeometry(doc, jsonIn, m, p) {
  const prim = doc.getRoot().listMeshes()[m].listPrimitives()[p];
  const jp = jsonIn.meshes[m].primitives[p];
  const attrs = {};
  for (const s of prim.listSemantics()) attrs[s] = docAccessor(prim.getAttribute(s), jp.attributes?.[s]);
  const targets = prim.listTargets().map((t, ti) => Object.fromEntries(t.listSemantics().map((s) => [s, docAccessor(t.getAttribute(s), jp.targets?.[ti]?.[s])])));
  const ind = prim.getIndices();
  return { mode: prim.getMode(), indices: ind ? ind.getArray() : null, attrs, targets };
}

/** Oriented triangles (vertex indices) of a primitive: lists, strips and fans expanded. */
export function primTriangles(g) {
  const n = g.indices ? g.indices.length : g.attrs.POSITION ? g.attrs.POSITION.count : 0;
  const at = g.indices ? (i) => g.indices[i] : (i) => i;
  const tris = [];
  if (g.mode === 4) for (let i = 0; i + 2 < n; i += 3) tris.push(at(i), at(i + 1), at(i + 2));
  else if (g.mode === 5) for (let i = 0; i + 2 < n; i++) i % 2 ? tris.push(at(i + 1), at(i), at(i + 2)) : tris.push(at(i), at(i + 1), at(i + 2));
  else if (g.mode === 6) for (let i = 1; i + 1 < n; i++) tris.push(at(0), at(i), at(i + 1));
  return Uint32Array.from(tris);
}

/** Dequantized position of vertex v as [x, y, z]. */
function position(acc, v) {
  const a = acc.array;
  const o = v * acc.size;
  return [dequant(a[o], acc.componentType, acc.normalized), dequant(a[o + 1], acc.componentType, acc.normalized), dequant(a[o + 2], acc.componentType, acc.normalized)];
}

/**
 * Triangle count and bbox diagonal (over vertices triangles use) of output mesh m. For normalized-integer
 * positions (KHR_mesh_quantization) diagonalF32 is the diagonal of the positions dequantized in float32 (as a
 * GPU and lodpipe's float pipeline see them); `diagonal` dequantizes exactly in double (as the CGAL tool does).
 */
export function meshTrianglesAndDiagonal(raw, m) {
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  const lo32 = [Infinity, Infinity, Infinity];
  const hi32 = [-Infinity, -Infinity, -Infinity];
  let triangles = 0;
  (raw.json.meshes[m].primitives || []).forEach((jp, p) => {
    if (!isTrianglePrim(jp)) return;
    const g = rawPrimGeometry(raw, m, p);
    const tris = primTriangles(g);
    triangles += tris.length / 3;
    const pos = g.attrs.POSITION;
    for (const v of tris) {
      const q = position(pos, v);
      for (let c = 0; c < 3; c++) {
        if (q[c] < lo[c]) lo[c] = q[c];
        if (q[c] > hi[c]) hi[c] = q[c];
        const q32 = Math.fround(q[c]);
        if (q32 < lo32[c]) lo32[c] = q32;
        if (q32 > hi32[c]) hi32[c] = q32;
      }
    }
  });
  const diag = (a, b) => (b[0] >= a[0] ? Math.hypot(b[0] - a[0], b[1] - a[1], b[2] - a[2]) : 0);
  return { triangles, diagonal: diag(lo, hi), diagonalF32: diag(lo32, hi32) };
}

/** The diagonal variant (exact / float32-dequantized) that matches `recorded`, else the exact one. */
export function pickDiagonal(inf, recorded) {
  if (relClose(Number(recorded), inf.diagonal, DIAG_REL_TOL)) return inf.diagonal;
  if (relClose(Number(recorded), inf.diagonalF32, DIAG_REL_TOL)) return inf.diagonalF32;
  return inf.diagonal;
}

/**
 * Border and non-manifold edges of a set of primitives (output mesh m, or explicit geometries), the
 * vertices welded by exact (dequantized) position across all primitives. Degenerate triangles (two
 * welded corners equal) are left out and counted.
 */
export function edgeCensus(geoms) {
  const ids = new Map();
  const edges = new Map();
  let degenerate = 0;
  let triangles = 0;
  const weld = (pos, v) => {
    const k = position(pos, v).join(',');
    let id = ids.get(k);
    if (id === undefined) ids.set(k, (id = ids.size));
    return id;
  };
  for (const g of geoms) {
    const tris = primTriangles(g);
    const pos = g.attrs.POSITION;
    for (let t = 0; t < tris.length; t += 3) {
      const a = weld(pos, tris[t]), b = weld(pos, tris[t + 1]), c = weld(pos, tris[t + 2]);
      triangles++;
      if (a === b || b === c || c === a) {
        degenerate++;
        continue;
      }
      for (const [u, v] of [[a, b], [b, c], [c, a]]) {
        const k = u < v ? `${u},${v}` : `${v},${u}`;
        edges.set(k, (edges.get(k) || 0) + 1);
      }
    }
  }
  let border = 0;
  let nonmanifold = 0;
  const examples = [];
  const keyToPos = [...ids.keys()];
  for (const [k, n] of edges) {
    if (n === 1) {
      border++;
      if (examples.length < 3) examples.push(k.split(',').map((i) => `(${keyToPos[Number(i)]})`).join('-'));
    } else if (n > 2) nonmanifold++;
  }
  return { triangles, degenerate, edges: edges.size, border, nonmanifold, examples };
}

// ---------------------------------------------------------------------------------------------
// Vertex correspondence (input primitive vs reordered output primitive)

const f32 = new Float32Array(2);
const f32bits = new Int32Array(f32.buffer);
function withinUlp(x, y, isFloat, ulp) {
  if (Object.is(x, y)) return true;
  if (!(ulp > 0)) return false;
  if (isFloat) {
    if (Number.isNaN(x) || Number.isNaN(y)) return false;
    f32[0] = x;
    f32[1] = y;
    if ((f32bits[0] < 0) !== (f32bits[1] < 0)) return x === y;
    return Math.abs(f32bits[0] - f32bits[1]) <= ulp;
  }
  return Math.abs(x - y) <= ulp;
}
const numKey = (x) => (Object.is(x, -0) ? '-0' : String(x));

/** The primitive's vertex streams in a fixed order: attributes by semantic, then targets. */
function streams(g) {
  const list = [];
  for (const s of Object.keys(g.attrs).sort()) list.push({ name: s, acc: g.attrs[s] });
  g.targets.forEach((t, ti) => Object.keys(t).sort().forEach((s) => list.push({ name: `target${ti}.${s}`, acc: t[s] })));
  return list;
}

/**
 * Match the output primitive's vertices to the input's: every output vertex must equal a distinct input
 * vertex on every attribute and morph target (exactly; within MESHOPT_FILTER_ULP for streams whose input
 * went through a meshopt filter). Then the triangles must be the same multiset of oriented triangles once
 * mapped through that correspondence (input vertices equal on every stream count as one). Returns { problems, perm (out -> in), notes }.
 */
export function compareReorderedPrimitive(gin, gout, label, { tolerant = new Set(), notes = [] } = {}) {
  const problems = [];
  const sin = streams(gin);
  const sout = streams(gout);
  const names = sin.map((s) => s.name).join();
  if (names !== sout.map((s) => s.name).join()) return { problems: [`${label}: vertex streams input [${names}], output [${sout.map((s) => s.name)}]`] };
  const nin = gin.attrs.POSITION.count;
  const nout = gout.attrs.POSITION.count;
  if (nin !== nout) return { problems: [`${label}: ${nin} vertices in the input, ${nout} in the output`] };
  for (let k = 0; k < sin.length; k++) {
    if (sin[k].acc.size !== sout[k].acc.size) return { problems: [`${label} ${sin[k].name}: ${sin[k].acc.size} components in the input, ${sout[k].acc.size} in the output`] };
  }
  const exact = sin.map((s) => !tolerant.has(s.name));
  const key = (ss, v, everyStream = false) => {
    const parts = [];
    ss.forEach((s, k) => {
      if (!exact[k] && !everyStream) return;
      const { array, size } = s.acc;
      for (let c = 0; c < size; c++) parts.push(numKey(array[v * size + c]));
    });
    return parts.join(',');
  };
  const buckets = new Map();
  for (let v = 0; v < nin; v++) {
    const k = key(sin, v);
    if (!buckets.has(k)) buckets.set(k, []);
    buckets.get(k).push(v);
  }
  const perm = new Int32Array(nout).fill(-1);
  let unmatched = 0;
  let firstUnmatched = -1;
  let tolerated = 0;
  for (let v = 0; v < nout; v++) {
    const list = buckets.get(key(sout, v));
    if (!list || list.length === 0) {
      if (unmatched++ === 0) firstUnmatched = v;
      continue;
    }
    let pick = -1;
    for (let i = 0; i < list.length && pick < 0; i++) {
      const u = list[i];
      let ok = true;
      for (let k = 0; k < sin.length && ok; k++) {
        if (exact[k]) continue;
        const a = sin[k].acc;
        const b = sout[k].acc;
        const isFloat = a.array instanceof Float32Array;
        for (let c = 0; c < a.size && ok; c++) {
          const x = a.array[u * a.size + c];
          const y = b.array[v * b.size + c];
          if (!Object.is(x, y)) {
            if (withinUlp(x, y, isFloat, MESHOPT_FILTER_ULP)) tolerated++;
            else ok = false;
          }
        }
      }
      if (ok) pick = i;
    }
    if (pick < 0) {
      if (unmatched++ === 0) firstUnmatched = v;
      continue;
    }
    perm[v] = list[pick];
    list.splice(pick, 1);
  }
  if (unmatched) {
    const vals = sout.map((s) => `${s.name}=[${Array.from(s.acc.array.subarray(firstUnmatched * s.acc.size, (firstUnmatched + 1) * s.acc.size)).map(numKey)}]`);
    problems.push(`${label}: ${unmatched} of ${nout} output vertices equal no (remaining) input vertex; first: output vertex ${firstUnmatched} ${vals.join(' ')}`);
    return { problems, perm };
  }
  if (tolerated) notes.push(`${label}: ${tolerated} meshopt-filtered components matched within ${MESHOPT_FILTER_ULP} ULP`);
  // input vertices equal on every stream cannot be told apart, and the reorder may swap them (one copy used by a
  // level, the other not): a triangle corner counts as the first input vertex equal to it
  const same = new Int32Array(nin);
  const firstEqual = new Map();
  for (let v = 0; v < nin; v++) {
    const k = key(sin, v, true);
    if (!firstEqual.has(k)) firstEqual.set(k, v);
    same[v] = firstEqual.get(k);
  }
  // triangles as oriented index triples of the INPUT numbering
  const canonKey = (a, b, c) => {
    if (a <= b && a <= c) return `${a},${b},${c}`;
    if (b <= a && b <= c) return `${b},${c},${a}`;
    return `${c},${a},${b}`;
  };
  const tin = primTriangles(gin);
  const tout = primTriangles(gout);
  const count = new Map();
  for (let t = 0; t < tin.length; t += 3) {
    const k = canonKey(same[tin[t]], same[tin[t + 1]], same[tin[t + 2]]);
    count.set(k, (count.get(k) || 0) + 1);
  }
  let extra = 0;
  let firstExtra = null;
  for (let t = 0; t < tout.length; t += 3) {
    const k = canonKey(same[perm[tout[t]]], same[perm[tout[t + 1]]], same[perm[tout[t + 2]]]);
    const n = count.get(k) || 0;
    if (n === 0) {
      if (extra++ === 0) firstExtra = `output [${tout[t]},${tout[t + 1]},${tout[t + 2]}] = input vertices [${k}] (orientation kept)`;
    } else count.set(k, n - 1);
  }
  let missing = 0;
  for (const n of count.values()) missing += n;
  if (extra || missing) {
    problems.push(`${label}: triangles differ after mapping the reordered vertices: ${missing} input triangles missing, ${extra} output triangles not in the input ` +
      `(input ${tin.length / 3}, output ${tout.length / 3} triangles)${firstExtra ? `; first extra: ${firstExtra}` : ''}`);
  }
  return { problems, perm };
}

// ---------------------------------------------------------------------------------------------
// The CGAL Hausdorff tool (copied logic of tests/simplify.test.mjs: --within, proven verdicts)

export function hausdorffAvailable() {
  try {
    fs.accessSync(HAUSDORFF, fs.constants.X_OK);
    return true;
  } catch {
    return false;
  }
}

export function runHausdorff(args) {
  const t0 = Date.now();
  const r = spawnSync(HAUSDORFF, args, { encoding: 'utf8', timeout: HAUSDORFF_TIMEOUT_MS, maxBuffer: 64 << 20 });
  let j = null;
  try {
    j = JSON.parse(r.stdout);
  } catch {
    /* reported below */
  }
  if (r.status !== 0 || !j || j.error) {
    throw new Error(`hausdorff ${args.join(' ')}: ${j?.error || r.error || r.stderr || `status ${r.status}`} (signal ${r.signal})`);
  }
  j.wall = (Date.now() - t0) / 1000;
  return j;
}

/**
 * Decide "two-sided H(A, B) <= limit" with the tool's branch and bound (`--within`). 'pass' is proven
 * (hausdorff_upper <= limit, no work cap); 'fail' is proven (a distance > limit found); else 'open'.
 */
export function hausdorffWithin(a, b, limit, diagA, slackAbs) {
  const rel = (limit / diagA) * (1 - 1e-9);
  const attempts = [
    ['--within', String(rel)],
    ['--within', String(rel), '--err-abs', String(Math.max(slackAbs / 4, limit * 1e-9)), '--max-work', '2e9'],
  ];
  const runs = [];
  let seconds = 0;
  for (const extra of attempts) {
    const j = runHausdorff([...extra, a, b]);
    runs.push(j);
    seconds += j.wall;
    const upper = j.hausdorff_upper === null || j.hausdorff_upper === undefined ? Infinity : Number(j.hausdorff_upper);
    const lower = Number(j.hausdorff);
    if (lower > limit) return { verdict: 'fail', lower, upper, seconds, runs };
    if (!j.capped && upper <= limit) return { verdict: 'pass', lower, upper, seconds, runs };
  }
  const last = runs[runs.length - 1];
  return { verdict: 'open', lower: Number(last.hausdorff), upper: last.hausdorff_upper === null ? Infinity : Number(last.hausdorff_upper), seconds, runs };
}

// ---------------------------------------------------------------------------------------------
// Validator: new errors

/**
 * Output validator errors the input did not have. An error counts as old when the input had an error with
 * the same code and the same message text up to element positions ("at indices 340..343" - the vertices
 * were reordered) and JSON pointer (a LOD primitive that references an input accessor repeats that
 * accessor's error under a new pointer): e.g. CesiumMan's non-normalized WEIGHTS, each reported with its
 * sum, once per primitive that uses the accessor. Returns { problems, notes }.
 */
export function newValidatorErrorMessages(inp, out) {
  const problems = [];
  const notes = [];
  if (out.exception) problems.push(`validator exception on the output: ${out.exception}`);
  const norm = (x) => `${x.code}|${String(x.message).replace(/\b(indices|index)\s+\d+(\.\.\d+)?/g, '$1 #')}`;
  const old = new Set(inp.messages.filter((x) => x.severity === 0).map(norm));
  const fresh = new Map();
  let repeated = 0;
  for (const x of out.messages.filter((y) => y.severity === 0)) {
    if (old.has(norm(x))) {
      repeated++;
      continue;
    }
    if (!fresh.has(x.code)) fresh.set(x.code, []);
    fresh.get(x.code).push(`${x.message} ${x.pointer || ''}`.trim());
  }
  for (const [code, list] of fresh) problems.push(`validator error ${code} (${list.length} new): e.g. ${JSON.stringify(list.slice(0, 2))}`);
  const legacy = newValidatorErrors(inp, out);
  if (repeated && legacy.length) notes.push(`validator: ${repeated} output error(s) repeat an input error under another pointer (same code and message), e.g. ${legacy[0]}`);
  return { problems, notes };
}

// ---------------------------------------------------------------------------------------------
// Sizes

/** Bytes of a glTF file plus the external files it references (buffers, images), each counted once. */
export function fileSetBytes(file, json) {
  const dir = path.dirname(file);
  const seen = new Set([path.resolve(file)]);
  let bytes = fs.statSync(file).size;
  for (const x of [...(json.buffers || []), ...(json.images || [])]) {
    if (x.uri === undefined || isDataUri(x.uri)) continue;
    try {
      const p = path.resolve(dir, decodeURIComponent(x.uri));
      if (seen.has(p)) continue;
      seen.add(p);
      bytes += fs.statSync(p).size;
    } catch {
      /* missing external file: the validator reports it */
    }
  }
  return bytes;
}

const COMPONENT_BYTES = { 5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4 };

// ---------------------------------------------------------------------------------------------
// Ladder matching (independent of the --json "level" field)

/**
 * Kept levels are a subsequence of the ladder, each within its eps: is there a strictly increasing
 * assignment of ladder positions with error_fraction_k <= ladder_k / 100? Greedy (smallest position that
 * fits) is optimal. Returns the positions (1-based) or null.
 */
export function matchLadder(fractions, ladder) {
  const pos = [];
  let next = 0;
  for (const f of fractions) {
    while (next < ladder.length && !(f <= (ladder[next] / 100) * (1 + EPS_REL_TOL))) next++;
    if (next >= ladder.length) return null;
    pos.push(next + 1);
    next++;
  }
  return pos;
}

/** Prefix nesting of one primitive's levels: max index of level k+1 <= max index of level k. */
export function prefixProblems(indexArrays, label) {
  const p = [];
  let prevMax = Infinity;
  indexArrays.forEach((arr, k) => {
    let mx = -1;
    for (const x of arr) if (x > mx) mx = x;
    if (mx > prevMax) p.push(`${label}: level ${k} uses vertex ${mx}, beyond the prefix [0, ${prevMax}] that level ${k - 1} uses`);
    prevMax = Math.min(prevMax, mx);
  });
  return p;
}

/**
 * Death order of one primitive: lodpipe sorts a primitive's vertices by the level at which they die, last
 * to die first. d(v) = the last level (0 = the original) whose index array uses vertex v (-1: never). The
 * order is right when d never increases along the vertex buffer: then every level uses a prefix of it, and
 * no vertex a level does not use sits inside that prefix. `indexArrays[k]` is the primitive's index array
 * at level k (levels share its vertex buffer, so index v is the same vertex at every level, wherever a
 * placed level moved its position). Keyed by index, not by position: two vertices at one position (a UV
 * seam, a copy only a degenerate triangle used) can die at different levels.
 */
export function deathOrderProblems(indexArrays, vertexCount, label) {
  const death = new Int32Array(vertexCount).fill(-1);
  indexArrays.forEach((arr, k) => {
    for (const v of arr) if (v < vertexCount) death[v] = k;
  });
  let inversions = 0;
  let first = '';
  for (let v = 1; v < vertexCount; v++) {
    if (death[v] > death[v - 1] && inversions++ === 0) {
      first = `vertex ${v} (used up to level ${death[v]}) comes after vertex ${v - 1} (used up to level ${death[v - 1]}), so level ${death[v]} needs vertex ${v} beyond a vertex it does not use`;
    }
  }
  return inversions ? [`${label}: vertices not sorted by the level at which they die (${inversions} inversion(s)); first: ${first}`] : [];
}

/** Drop rule: every kept level non-empty and <= (1 - MIN_REDUCTION) x the previous kept level's triangles. */
export function dropRuleProblems(baseTriangles, levelTriangles, label, minReduction = MIN_REDUCTION) {
  const p = [];
  let prev = baseTriangles;
  levelTriangles.forEach((t, k) => {
    if (!(t > 0)) p.push(`${label}: kept level ${k + 1} has ${t} triangles (an empty level must be dropped)`);
    else if (!(prev - t >= minReduction * prev - 1e-9)) {
      p.push(`${label}: kept level ${k + 1} has ${t} triangles, removing only ${fmt((100 * (prev - t)) / prev, 4)} % of the previous kept level's ${prev} (< ${100 * minReduction} %: should have been dropped)`);
    }
    prev = t;
  });
  return p;
}

// ---------------------------------------------------------------------------------------------
// The whole analysis

/** Accessors referenced by primitives / skins / animations of a glTF JSON: accessor -> [who]. */
function accessorUsers(json) {
  const users = new Map();
  const add = (a, who) => {
    if (a === undefined) return;
    if (!users.has(a)) users.set(a, []);
    users.get(a).push(who);
  };
  (json.meshes || []).forEach((m, mi) => (m.primitives || []).forEach((p, pi) => {
    const who = `mesh ${mi} primitive ${pi}`;
    for (const a of Object.values(p.attributes || {})) add(a, who);
    for (const t of p.targets || []) for (const a of Object.values(t)) add(a, who);
    add(p.indices, `${who} indices`);
  }));
  (json.skins || []).forEach((s, i) => add(s.inverseBindMatrices, `skin ${i}`));
  (json.animations || []).forEach((an, i) => (an.samplers || []).forEach((s, si) => {
    add(s.input, `animation ${i} sampler ${si}`);
    add(s.output, `animation ${i} sampler ${si}`);
  }));
  return users;
}

/** Does lodpipe have to keep primitive (m, p)'s vertex order (an accessor of it shared with another object)? */
function reorderBlocked(json, users, m, p) {
  const jp = json.meshes[m].primitives[p];
  const me = `mesh ${m} primitive ${p}`;
  const accs = [...Object.values(jp.attributes || {}), ...(jp.targets || []).flatMap((t) => Object.values(t))];
  if (jp.indices !== undefined) accs.push(jp.indices);
  for (const a of accs) {
    const others = (users.get(a) || []).filter((w) => w !== me && w !== `${me} indices`);
    if (others.length) return `accessor ${a} is shared with ${others[0]}`;
  }
  return null;
}

/** Output node `node` without what the chain adds; `inNode`, the input's, tells an input {} from no extras. */
function stripChainProps(node, inNode) {
  const n = clone(node);
  if (n.extensions) {
    delete n.extensions.MSFT_lod;
    if (Object.keys(n.extensions).length === 0) delete n.extensions;
  }
  if (n.extras && typeof n.extras === 'object') {
    delete n.extras.MSFT_screencoverage;
    delete n.extras.lodpipe;
    if (FOLDED_OWN_EXTRAS in n.extras) n.extras = n.extras[FOLDED_OWN_EXTRAS];
    else if (Object.keys(n.extras).length === 0 && inNode?.extras === undefined) delete n.extras;
  }
  return n;
}

let quiet = false;
/** glTF-Transform logs "Missing optional extension MSFT_lod" for every output: keep its errors only. */
async function quietIO() {
  if (quiet) return;
  quiet = true;
  const { Logger } = await import('@gltf-transform/core');
  (await getIO()).setLogger(new Logger(Logger.Verbosity.ERROR));
}

const TRANSFORM_KEYS = ['matrix', 'translation', 'rotation', 'scale', 'skin', 'weights'];

/**
 * Analyze one output of the main job.
 *   inFile, outFile: the input and the output (.glb / .gltf)
 *   summary: the parsed --json stdout (null if not available)
 *   ladder: percent values given with --levels (default 1,3,7,15); camera: the camera given on the CLI
 *   hausdorff: run the CGAL soundness checks (default true)
 * Returns { problems, notes, stats }.
 */
/** The node extensions a LOD node copies (README: Output format), and MSFT_lod, which the chain writes. */
const LOD_NODE_EXTENSIONS = ['EXT_mesh_gpu_instancing', 'KHR_node_visibility', 'MSFT_lod'];

/**
 * What a client that shows a LOD node in node n's place would lose of n: its children, its camera, its
 * extras (any but {} and the switching metadata the chain writes there) and every extension a LOD node
 * does not copy, as strings ([] when nothing).
 */
export function lostInSwap(n) {
  const lost = [];
  if ((n?.children || []).length) lost.push(`children [${n.children}]`);
  if (n?.extras !== undefined) {
    const own = n.extras !== null && typeof n.extras === 'object' && !Array.isArray(n.extras)
      ? Object.keys(n.extras).filter((k) => k !== 'MSFT_screencoverage' && k !== 'lodpipe') : ['(not an object)'];
    if (own.length) lost.push(`extras ${JSON.stringify(n.extras)}`);
  }
  if (n?.camera !== undefined) lost.push(`camera ${n.camera}`);
  for (const e of Object.keys(n?.extensions || {})) if (!LOD_NODE_EXTENSIONS.includes(e)) lost.push(`extension ${e}`);
  return lost;
}

/**
 * A node with a mesh AND anything a LOD node would lose in its place (children, a camera, a
 * light: lostInSwap) hands its mesh to a new child (the "carrier", README: Output format)
 * that carries the chain. To check the chain with the same rules as
 * everywhere else, fold each carrier back into its node in the parsed output: the node
 * gets the carrier's mesh/skin/weights, MSFT_lod and extras (beside its own) again, animation channels
 * retargeted to the carrier point back at it, and the carrier's slot is left empty. A
 * carrier must have been added as the node's last child, with no transform, the input
 * node's mesh (and skin/weights), and the node must have lost exactly those. Returns
 * Map(carrier -> node) (the carrier's transform, none, is what its LOD nodes copy).
 */
/**
 * What an animation channel animates: { node, prop } with prop the node's JSON pointer suffix, from
 * target.node and target.path, or for a KHR_animation_pointer channel (path "pointer") from its
 * "/nodes/N/prop" pointer; node undefined when it animates no node.
 */
export function channelTarget(ch) {
  if (ch?.target?.path !== 'pointer') return { node: ch?.target?.node, prop: ch?.target?.path };
  const m = /^\/nodes\/(\d+)\/(.+)$/.exec(ch.target.extensions?.KHR_animation_pointer?.pointer ?? '');
  return m ? { node: Number(m[1]), prop: m[2] } : { node: undefined, prop: undefined };
}

/** Points a channel at node n for the same property (its target node, or its pointer). */
function retargetChannel(ch, n) {
  if (ch.target.path === 'pointer') ch.target.extensions.KHR_animation_pointer.pointer = `/nodes/${n}/${channelTarget(ch).prop}`;
  else ch.target.node = n;
}

/** Where foldCarriers keeps a node's own extras that are not an object (stripChainProps puts them back). */
const FOLDED_OWN_EXTRAS = 'lodcheck: the node\'s own extras';

export function foldCarriers(j, jin, nInNodes, notes) {
  const carriers = new Map();
  (j.nodes || []).forEach((n, i) => {
    if (i >= nInNodes || !lostInSwap(jin.nodes[i]).length || jin.nodes[i].mesh === undefined) return;
    const kids = n.children || [];
    const c = kids[kids.length - 1];
    const cn = j.nodes[c];
    if (!(c >= nInNodes) || !cn?.extensions?.MSFT_lod || n.mesh !== undefined) return;
    if (cn.mesh !== jin.nodes[i].mesh) return;
    if (['matrix', 'translation', 'rotation', 'scale', 'children', 'camera'].some((k) => cn[k] !== undefined)) return;
    carriers.set(c, i);
  });
  for (const [c, i] of carriers) {
    const n = j.nodes[i];
    const cn = j.nodes[c];
    n.children = n.children.slice(0, -1);
    if (!n.children.length && !jin.nodes[i].children) delete n.children; // the carrier made the array
    for (const k of ['mesh', 'skin', 'weights']) if (cn[k] !== undefined) n[k] = cn[k];
    n.extensions = { ...(n.extensions || {}), MSFT_lod: cn.extensions.MSFT_lod };
    if (cn.extensions.EXT_mesh_gpu_instancing) n.extensions.EXT_mesh_gpu_instancing = cn.extensions.EXT_mesh_gpu_instancing;
    if (cn.extras) {
      // the node's own extras stay on it (any JSON value); the chain's metadata came on the carrier
      const own = n.extras;
      const isObject = own !== null && typeof own === 'object' && !Array.isArray(own);
      n.extras = { ...(isObject ? own : {}), ...cn.extras };
      if (own !== undefined && !isObject) n.extras[FOLDED_OWN_EXTRAS] = own;
    }
    if (n.extras?.lodpipe?.levels?.[0]?.node === c) n.extras.lodpipe.levels[0].node = i;
    for (const a of j.animations || []) for (const ch of a.channels || []) if (channelTarget(ch).node === c) retargetChannel(ch, i);
    j.nodes[c] = { name: cn.name };
    notes.push(`node ${i} hands its mesh to carrier node ${c}; checked as if the chain were on node ${i}`);
  }
  return carriers;
}

export async function analyzeChain({ inFile, outFile, summary, ladder = DEFAULT_LADDER, camera = DEFAULT_CAMERA, hausdorff = true, minReduction = MIN_REDUCTION, placement = 'half-edge' }) {
  const problems = Object.fromEntries(CHAIN_ASPECTS.map(([k]) => [k, []]));
  const notes = [];
  const stats = { levels: [], hausdorffSeconds: 0 };
  const P = (k, msg) => problems[k].push(msg);

  await quietIO();
  const inp = await loadInput(inFile);
  const jin = inp.raw.json;
  const raw = readRaw(outFile);
  const j = raw.json;
  const nInNodes = (jin.nodes || []).length;
  const nInMeshes = (jin.meshes || []).length;
  const nInAcc = (jin.accessors || []).length;
  const carriers = foldCarriers(j, jin, nInNodes, notes);
  const nodes = j.nodes || [];

  // ---- validator
  try {
    const vout = await validateFile(outFile);
    const r = newValidatorErrorMessages(inp.validation, vout);
    problems.validator.push(...r.problems);
    notes.push(...r.notes);
  } catch (e) {
    P('validator', `validator: ${e.message}`);
  }

  // ---- what the input asks for
  const instances = chainedNodes(jin); // mesh -> the nodes that get its chain (input numbering = output numbering)
  const meshInfo = new Map(); // mesh -> { triangles, diagonal } from the OUTPUT's original mesh
  const info = (m) => {
    if (!meshInfo.has(m)) meshInfo.set(m, meshTrianglesAndDiagonal(raw, m));
    return meshInfo.get(m);
  };

  const diagNoted = new Set();
  /** The mesh's diagonal in the variant lodpipe used (exact or float32-dequantized positions). */
  const diagOf = (m) => {
    const inf = info(m);
    let rec = sumMeshes.get(m)?.diagonal;
    if (rec === undefined) {
      const n = chains.get(m)?.nodes[0];
      const lv = (nodes[n]?.extras?.lodpipe?.levels || []).find((l) => Number(l.error_fraction) > 0);
      if (lv) rec = Number(lv.error) / Number(lv.error_fraction);
    }
    const d = pickDiagonal(inf, rec);
    if (d !== inf.diagonal && !diagNoted.has(m)) {
      diagNoted.add(m);
      notes.push(`mesh ${m}: the recorded diagonal ${rec} is that of the positions dequantized in float32 (${inf.diagonalF32}); exact dequantization gives ${inf.diagonal}`);
    }
    return d;
  };

  // ---- the chains as written in the file
  const chains = new Map(); // mesh -> { nodes: [n], ids: {n: [...]}, lodMeshes: [...] }
  nodes.forEach((n, i) => {
    const ext = n.extensions?.MSFT_lod;
    if (!ext || jin.nodes?.[i]?.extensions?.MSFT_lod) return; // one the input had: 'unchanged' compares it
    if (i >= nInNodes) {
      P('chain', `node ${i} is a new node and carries MSFT_lod itself`);
      return;
    }
    if (!Array.isArray(ext.ids) || !ext.ids.every((x) => isInt(x) && x >= 0 && x < nodes.length)) {
      P('chain', `node ${i}: MSFT_lod.ids ${JSON.stringify(ext.ids)} is not an array of node indices`);
      return;
    }
    if (!chains.has(n.mesh)) chains.set(n.mesh, { nodes: [], ids: new Map() });
    chains.get(n.mesh).nodes.push(i);
    chains.get(n.mesh).ids.set(i, ext.ids);
  });

  // ---- summary (--json)
  const sumMeshes = new Map();
  if (!summary || !Array.isArray(summary.meshes)) P('summary', '--json printed no "meshes" array');
  else {
    for (const e of summary.meshes) {
      if (sumMeshes.has(e.mesh)) P('summary', `mesh ${e.mesh} is listed ${1 + [...summary.meshes].filter((x) => x.mesh === e.mesh).length - 1} times in the --json summary (each distinct mesh once)`);
      else sumMeshes.set(e.mesh, e);
    }
    for (const m of instances.keys()) if (!sumMeshes.has(m)) P('summary', `mesh ${m} (used by nodes ${instances.get(m)}) is missing from the --json summary`);
    for (const m of sumMeshes.keys()) if (!instances.has(m)) P('summary', `the --json summary lists mesh ${m}, which no default-scene node uses with triangles`);
  }
  const ladderFr = ladder.map((x) => x / 100);
  const ladderPositions = new Map(); // mesh -> ladder position (1-based) of each kept level, from its eps
  for (const [m, e] of sumMeshes) {
    if (!instances.has(m) || !j.meshes?.[m]) continue;
    const tag = `mesh ${m}${e.name ? ` "${e.name}"` : ''}`;
    const { triangles } = info(m);
    const diagonal = diagOf(m);
    if (e.triangles !== triangles) P('summary', `${tag}: --json says ${e.triangles} triangles, the mesh has ${triangles}`);
    if (!relClose(Number(e.diagonal), diagonal, DIAG_REL_TOL)) P('summary', `${tag}: --json diagonal ${e.diagonal}, the bbox diagonal of the vertices triangles use is ${diagonal}${info(m).diagonalF32 !== diagonal ? ` (${info(m).diagonalF32} with float32 dequantization)` : ''}`);
    const levels = Array.isArray(e.levels) ? e.levels : [];
    const chain = chains.get(m);
    const expectNodes = levels.length ? instances.get(m).length : 0;
    if (e.nodes !== expectNodes) P('summary', `${tag}: --json "nodes" is ${e.nodes}, expected ${expectNodes} (the nodes that use the mesh, in any scene)`);
    // The ladder level each kept level came from, identified by its eps (the "level" field is the kept
    // level's number 1, 2, ... or its ladder position; both are accepted).
    let prevPos = 0;
    const positions = [];
    levels.forEach((lv, k) => {
      const lt = `${tag} kept level ${k + 1}`;
      const pos = ladderFr.findIndex((f) => relClose(Number(lv.eps), f * diagonal, FRACTION_REL_TOL)) + 1;
      positions.push(pos);
      if (pos === 0) P('eps', `${lt}: eps ${lv.eps} is none of the ladder's [${ladder.map((x) => `${x} %`)}] x diagonal ${diagonal} (= ${ladderFr.map((f) => f * diagonal)})`);
      else if (pos <= prevPos) P('eps', `${lt}: eps ${lv.eps} is ladder level ${pos}, not after the previous kept level's ${prevPos}`);
      if (pos) prevPos = pos;
      if (lv.level !== k + 1 && lv.level !== pos) P('summary', `${lt}: "level" is ${lv.level}, neither the kept level's number ${k + 1} nor its ladder position ${pos}`);
      const frac = pos ? ladderFr[pos - 1] : undefined;
      if (!(Number(lv.error) >= 0 && Number(lv.error) <= Number(lv.eps) * (1 + EPS_REL_TOL))) P('eps', `${lt}: error ${lv.error} > eps ${lv.eps}`);
      if (frac !== undefined && !(Number(lv.error) <= frac * diagonal * (1 + EPS_REL_TOL))) P('eps', `${lt}: error ${lv.error} > ${ladder[pos - 1]} % of the diagonal ${diagonal} (${frac * diagonal})`);
      if (!relClose(Number(lv.error_fraction), Number(lv.error) / diagonal, FRACTION_REL_TOL)) P('summary', `${lt}: error_fraction ${lv.error_fraction} != error / diagonal = ${Number(lv.error) / diagonal}`);
      if (!isInt(lv.mesh) || !j.meshes?.[lv.mesh]) P('summary', `${lt}: mesh ${lv.mesh} does not exist in the output`);
      else {
        const t = info(lv.mesh).triangles;
        if (lv.triangles !== t) P('summary', `${lt}: --json says ${lv.triangles} triangles, mesh ${lv.mesh} has ${t}`);
      }
    });
    ladderPositions.set(m, positions);
    problems.summary.push(...dropRuleProblems(triangles, levels.map((l) => l.triangles), tag, minReduction));
    if (levels.length && !chain) P('chain', `${tag}: ${levels.length} kept level(s) in --json but no node carries MSFT_lod for it`);
    if (!levels.length && chain) P('chain', `${tag}: no kept level in --json but nodes ${chain.nodes} carry MSFT_lod`);
  }

  // ---- chain structure
  const lodNodeUse = new Map();
  const lodMeshOf = new Map(); // `${m},${k}` -> LOD mesh
  const inScene = new Set(sceneNodes(j));
  const isChild = new Set();
  nodes.forEach((n) => (n.children || []).forEach((c) => isChild.add(c)));
  const sceneRoots = new Set((j.scenes || []).flatMap((s) => s.nodes || []));
  let expectedNewNodes = 0;
  let expectedNewMeshes = 0;
  for (const [m, inst] of instances) {
    const e = sumMeshes.get(m);
    const L = e && Array.isArray(e.levels) ? e.levels.length : null;
    const chain = chains.get(m);
    const tag = `mesh ${m}${j.meshes[m]?.name ? ` "${j.meshes[m].name}"` : ''}`;
    if (L === null) continue;
    expectedNewNodes += L * inst.length + (L ? inst.filter((n) => [...carriers.values()].includes(n)).length : 0);
    expectedNewMeshes += L;
    if (L === 0) continue;
    for (const n of inst) {
      const ids = chain?.ids.get(n);
      if (!ids) {
        P('chain', `${tag}: node ${n} uses it but has no MSFT_lod`);
        continue;
      }
      if (ids.length !== L) P('chain', `${tag}: node ${n} MSFT_lod.ids has ${ids.length} entries, ${L} levels were kept`);
      ids.forEach((id, k) => {
        const lod = nodes[id];
        const lt = `${tag} node ${n} LOD ${k + 1} (node ${id})`;
        lodNodeUse.set(id, (lodNodeUse.get(id) || 0) + 1);
        if (id < nInNodes) P('chain', `${lt}: is an input node, not a new one`);
        if (inScene.has(id) || sceneRoots.has(id)) P('chain', `${lt}: is part of a scene`);
        if (isChild.has(id)) P('chain', `${lt}: is some node's child`);
        if (lod.children?.length) P('chain', `${lt}: has children ${lod.children}`);
        if (lod.extensions?.MSFT_lod) P('chain', `${lt}: carries MSFT_lod itself`);
        const carried = [...carriers.values()].includes(n);
        for (const key of TRANSFORM_KEYS) {
          const want = carried && ['matrix', 'translation', 'rotation', 'scale'].includes(key) ? undefined : nodes[n][key];
          if (!deepEqual(lod[key], want)) P('chain', `${lt}: ${key} ${JSON.stringify(lod[key])} differs from ${carried ? 'the carrier' : 'the node'}'s ${JSON.stringify(want)}`);
        }
        if (lod.camera !== undefined) P('chain', `${lt}: has a camera`);
        // an instanced node's LOD nodes are instanced the same way (a client shows every instance at every level)
        const inst = nodes[n].extensions?.EXT_mesh_gpu_instancing;
        if (!deepEqual(lod.extensions?.EXT_mesh_gpu_instancing, inst)) P('chain', `${lt}: EXT_mesh_gpu_instancing ${JSON.stringify(lod.extensions?.EXT_mesh_gpu_instancing)} differs from the node's ${JSON.stringify(inst)}`);
        // a hidden node's LOD nodes are hidden alike (a carrier's sit under the node, which hides them)
        const vis = carried ? undefined : nodes[n].extensions?.KHR_node_visibility;
        if (!deepEqual(lod.extensions?.KHR_node_visibility, vis)) P('chain', `${lt}: KHR_node_visibility ${JSON.stringify(lod.extensions?.KHR_node_visibility)}, the node's ${JSON.stringify(vis)}`);
        const want = e.levels[k]?.mesh;
        if (lod.mesh !== want) P('chain', `${lt}: mesh ${lod.mesh}, the --json summary says level ${e.levels[k]?.level} is mesh ${want}`);
        const key = `${m},${k}`;
        if (!lodMeshOf.has(key)) lodMeshOf.set(key, lod.mesh);
        else if (lodMeshOf.get(key) !== lod.mesh) P('chain', `${tag} LOD ${k + 1}: instances use different meshes (${lodMeshOf.get(key)} and ${lod.mesh}): an instanced mesh must be simplified once`);
        if (isInt(lod.mesh) && lod.mesh < nInMeshes) P('chain', `${lt}: mesh ${lod.mesh} is an input mesh, not a new one`);
      });
    }
  }
  for (const [id, n] of lodNodeUse) if (n > 1) P('chain', `LOD node ${id} is listed by ${n} MSFT_lod chains (one LOD node per instance expected)`);
  const allLodMeshes = [...lodMeshOf.values()];
  if (new Set(allLodMeshes).size !== allLodMeshes.length) P('chain', `a LOD mesh serves two levels or two meshes: ${allLodMeshes}`);
  if (summary && Array.isArray(summary.meshes)) {
    if (nodes.length !== nInNodes + expectedNewNodes) P('chain', `output has ${nodes.length} nodes, expected ${nInNodes} + ${expectedNewNodes} LOD nodes`);
    if ((j.meshes || []).length !== nInMeshes + expectedNewMeshes) P('chain', `output has ${(j.meshes || []).length} meshes, expected ${nInMeshes} + ${expectedNewMeshes} LOD meshes (one per kept level of each distinct mesh)`);
  }
  for (const [m, chain] of chains) {
    for (const n of chain.nodes) if (!instances.get(m)?.includes(n)) notes.push(`node ${n} (mesh ${m}) carries MSFT_lod but is not a node of a default-scene mesh`);
  }
  const anyChain = chains.size > 0;
  const used = j.extensionsUsed || [];
  if (anyChain && !used.includes('MSFT_lod')) P('chain', 'extensionsUsed does not list MSFT_lod');
  if (!anyChain && used.includes('MSFT_lod') && !(jin.extensionsUsed || []).includes('MSFT_lod')) P('chain', 'extensionsUsed lists MSFT_lod but no node carries it');
  if ((j.extensionsRequired || []).includes('MSFT_lod') && !(jin.extensionsRequired || []).includes('MSFT_lod')) P('chain', 'extensionsRequired lists MSFT_lod (clients without it could not load the file)');

  // ---- hierarchy
  for (const [, chain] of chains) {
    for (const n of chain.nodes) {
      if ([...carriers.values()].includes(n)) continue;
      if (nodes[n].children?.length) {
        const kids = nodes[n].children.map((c) => `${c}${nodes[c]?.name ? ` "${nodes[c].name}"` : ''}`);
        P('hierarchy', `node ${n}${nodes[n].name ? ` "${nodes[n].name}"` : ''} carries MSFT_lod and has children [${kids.join(', ')}]: a client that replaces the node by a LOD node drops them`);
      }
      const lost = lostInSwap({ ...nodes[n], children: undefined });
      if (lost.length) P('hierarchy', `node ${n}${nodes[n].name ? ` "${nodes[n].name}"` : ''} carries MSFT_lod and has ${lost.join(', ')}, which its LOD nodes lack: a client that shows a LOD node in its place loses them`);
    }
  }

  // ---- metadata (switching) and eps from the extras
  const { world } = worldMatrices(j);
  for (const [m, chain] of chains) {
    const e = sumMeshes.get(m);
    if (!j.meshes?.[m]) continue;
    const { triangles } = info(m);
    const diagonal = diagOf(m);
    for (const n of chain.nodes) {
      const tag = `node ${n} (mesh ${m})`;
      const ids = chain.ids.get(n);
      const meta = nodes[n].extras?.lodpipe;
      const cov = nodes[n].extras?.MSFT_screencoverage;
      if (!meta || !Array.isArray(meta.levels)) {
        P('switching', `${tag}: no extras.lodpipe.levels`);
        continue;
      }
      const cam = meta.camera || {};
      for (const k of ['pixel_error', 'viewport_height', 'fov_y']) {
        if (cam[k] !== camera[k]) P('switching', `${tag}: extras.lodpipe.camera.${k} = ${cam[k]}, the run used ${camera[k]}`);
      }
      if (meta.levels.length !== ids.length + 1) P('switching', `${tag}: extras.lodpipe.levels has ${meta.levels.length} entries, expected ${ids.length + 1} (the node + one per LOD)`);
      const s = meshStretch(raw, world, n) * instanceScale(raw, nodes[n]);
      const l0 = meta.levels[0] || {};
      const want0 = { node: n, mesh: m, error: 0, error_fraction: 0, triangles, distance: 0, screen_coverage: 1 };
      for (const [k, v] of Object.entries(want0)) if (l0[k] !== v) P(k === 'triangles' || k === 'node' || k === 'mesh' ? 'chain' : 'switching', `${tag}: extras.lodpipe.levels[0].${k} = ${l0[k]}, expected ${v}`);
      const fr = [];
      const expCov = [];
      meta.levels.slice(1).forEach((lv, i) => {
        const k = i + 1;
        const lt = `${tag} level ${k}`;
        if (lv.node !== ids[i]) P('chain', `${lt}: extras.lodpipe.levels[${k}].node = ${lv.node}, MSFT_lod.ids[${i}] = ${ids[i]}`);
        if (lv.mesh !== nodes[ids[i]]?.mesh) P('chain', `${lt}: extras.lodpipe.levels[${k}].mesh = ${lv.mesh}, node ${ids[i]} has mesh ${nodes[ids[i]]?.mesh}`);
        if (isInt(lv.mesh) && j.meshes?.[lv.mesh] && lv.triangles !== info(lv.mesh).triangles) P('chain', `${lt}: extras triangles ${lv.triangles}, mesh ${lv.mesh} has ${info(lv.mesh).triangles}`);
        const err = Number(lv.error);
        if (!(Number.isFinite(err) && err >= 0)) {
          P('switching', `${lt}: error ${lv.error} is not a number >= 0`);
          return;
        }
        const sl = e?.levels?.[i];
        if (sl && Number(sl.error) !== err) P('summary', `${lt}: extras error ${err}, --json error ${sl.error}`);
        if (!relClose(Number(lv.error_fraction), err / diagonal, FRACTION_REL_TOL)) P('switching', `${lt}: error_fraction ${lv.error_fraction} != error / diagonal = ${err / diagonal} (diagonal ${diagonal})`);
        fr.push(err / diagonal);
        const x = expectedSwitching(err, s, diagonal, camera);
        expCov.push(x.coverage);
        if (!relClose(Number(lv.distance), x.distance, SWITCH_REL)) {
          P('switching', `${lt}: distance ${lv.distance}, recomputed ${x.distance} (error ${err}, world scale ${s}, camera ${JSON.stringify(camera)}; ratio ${fmt(Number(lv.distance) / x.distance, 10)})`);
        }
        if (!relClose(Number(lv.screen_coverage), x.coverage, SWITCH_REL)) {
          P('switching', `${lt}: screen_coverage ${lv.screen_coverage}, recomputed ${x.coverage} (R = ${x.radius}, d = ${x.distance}; ratio ${fmt(Number(lv.screen_coverage) / x.coverage, 10)})`);
        }
        if (m === [...chains.keys()][0] && n === chain.nodes[0]) stats.example = { node: n, level: k, error: err, scale: s, diagonal, distance: lv.distance, coverage: lv.screen_coverage };
      });
      // MSFT_screencoverage: entry i = the coverage below which LOD i gives way to LOD i+1, last = cull p / H
      const want = [...expCov, camera.pixel_error / camera.viewport_height];
      if (!Array.isArray(cov) || cov.length !== want.length) P('switching', `${tag}: extras.MSFT_screencoverage ${JSON.stringify(cov)} should have ${want.length} entries`);
      else {
        want.forEach((w, i) => {
          if (!relClose(Number(cov[i]), w, SWITCH_REL)) P('switching', `${tag}: MSFT_screencoverage[${i}] = ${cov[i]}, recomputed ${w}${i === want.length - 1 ? ' (cull = pixel_error / viewport_height)' : ` (coverage at LOD ${i + 1}'s distance)`}`);
        });
        for (let i = 1; i < cov.length; i++) if (!(cov[i] < cov[i - 1])) P('switching', `${tag}: MSFT_screencoverage not decreasing at ${i}: ${cov[i - 1]} then ${cov[i]} (a client could not pick one LOD per coverage)`);
      }
      // eps, independent of --json's "level": the kept levels are a subsequence of the ladder
      if (fr.length && !matchLadder(fr, ladder)) P('eps', `${tag}: error fractions [${fr.map((x) => fmt(x, 8))}] cannot be matched to increasing ladder levels [${ladder.map((x) => `${x} %`)}] with error <= eps`);
      const pos = ladderPositions.get(m);
      if (pos && fr.length === pos.length) {
        pos.forEach((q, i) => {
          const f = ladderFr[q - 1];
          if (f !== undefined && !(fr[i] <= f * (1 + EPS_REL_TOL))) P('eps', `${tag} level ${i + 1}: error fraction ${fr[i]} > ${ladder[q - 1]} %, the ladder level its eps names`);
        });
      }
    }
  }

  // ---- LOD primitives, index types, prefix, geometry, watertight, soundness: per mesh with a chain
  const users = accessorUsers(jin);
  const reorderable = new Map(); // `${m},${p}` -> null | reason
  const geomAccessors = new Set(); // input accessors whose data may legitimately change (reordered geometry)
  for (const [m, e] of sumMeshes) {
    if (!instances.has(m) || !Array.isArray(e.levels) || !e.levels.length || !jin.meshes?.[m]) continue;
    (jin.meshes[m].primitives || []).forEach((jp, p) => {
      if (!isTrianglePrim(jp)) return;
      const why = reorderBlocked(jin, users, m, p);
      reorderable.set(`${m},${p}`, why);
      if (!why) {
        for (const a of Object.values(jp.attributes || {})) geomAccessors.add(a);
        for (const t of jp.targets || []) for (const a of Object.values(t)) geomAccessors.add(a);
        if (jp.indices !== undefined) geomAccessors.add(jp.indices);
      }
    });
  }
  const perLevelIndexBytes = [];
  const lodIndexAccessors = new Map();
  for (const [m, chain] of chains) {
    const e = sumMeshes.get(m);
    const firstNode = chain.nodes[0];
    const ids = chain.ids.get(firstNode);
    const prims = j.meshes?.[m]?.primitives || [];
    const tag = `mesh ${m}${j.meshes?.[m]?.name ? ` "${j.meshes[m].name}"` : ''}`;
    const lodMeshes = ids.map((id) => nodes[id]?.mesh);
    const diagonal = diagOf(m);
    // LOD primitives and index accessors
    lodMeshes.forEach((M, k) => {
      const lm = j.meshes?.[M];
      const lt = `${tag} LOD ${k + 1} (mesh ${M})`;
      if (!lm) {
        P('lodprims', `${lt}: mesh does not exist`);
        return;
      }
      if ((lm.primitives || []).length !== prims.length) P('lodprims', `${lt}: ${(lm.primitives || []).length} primitives, the original has ${prims.length}`);
      // the mesh's own default weights, extras (targetNames) and extensions come along
      for (const key of ['weights', 'extras', 'extensions']) if (!deepEqual(lm[key], j.meshes[m][key])) P('lodprims', `${lt}: ${key} ${JSON.stringify(lm[key])}, the original's is ${JSON.stringify(j.meshes[m][key])}`);
      lm.primitives.slice(0, prims.length).forEach((lp, p) => {
        const op = prims[p];
        const pt = `${lt} primitive ${p}`;
        if (!isTrianglePrim(op)) {
          if (!deepEqual(lp, op)) P('lodprims', `${pt}: the original's ${modeOf(op) < 4 ? 'points/lines' : 'non-geometry'} primitive must be copied as it is: ${JSON.stringify(lp)} vs ${JSON.stringify(op)}`);
          return;
        }
        if (!deepEqual(lp.attributes, op.attributes)) {
          // lod.placement = "optimal": a level that placed vertices has its own POSITION accessor, a new float
          // VEC3 one of the same count, sparse over the original's data (or, for non-float originals, whole);
          // every other attribute is the original's
          const others = (a) => Object.fromEntries(Object.entries(a || {}).filter(([name]) => name !== 'POSITION'));
          const pa = j.accessors?.[lp.attributes?.POSITION];
          const oa = j.accessors?.[op.attributes?.POSITION];
          const placed = placement === 'optimal' && deepEqual(others(lp.attributes), others(op.attributes)) && pa && oa &&
            lp.attributes.POSITION >= nInAcc && pa.componentType === 5126 && pa.type === 'VEC3' && pa.count === oa.count &&
            (!pa.sparse || (pa.bufferView === oa.bufferView && (pa.byteOffset || 0) === (oa.byteOffset || 0) && !oa.sparse));
          if (placed) stats.placedPrimitives = (stats.placedPrimitives || 0) + 1;
          else P('lodprims', `${pt}: attributes ${JSON.stringify(lp.attributes)}, the original's are ${JSON.stringify(op.attributes)}`);
        }
        if (!deepEqual(lp.targets, op.targets)) P('lodprims', `${pt}: targets ${JSON.stringify(lp.targets)}, the original's are ${JSON.stringify(op.targets)}`);
        if (lp.material !== op.material) P('lodprims', `${pt}: material ${lp.material}, the original's is ${op.material}`);
        const strip = (x) => {
          const c = clone(x) || {};
          for (const ce of COMPRESSION_EXTENSIONS) delete c[ce];
          return Object.keys(c).length ? c : undefined;
        };
        if (!deepEqual(strip(lp.extensions), strip(op.extensions))) P('lodprims', `${pt}: extensions ${JSON.stringify(lp.extensions)}, the original's are ${JSON.stringify(op.extensions)}`);
        if (modeOf(lp) !== 4) P('lodprims', `${pt}: mode ${lp.mode} (a level is a triangle list)`);
        const ia = lp.indices;
        const acc = j.accessors?.[ia];
        if (!acc) {
          P('lodprims', `${pt}: no index accessor`);
          return;
        }
        if (ia < nInAcc) P('lodprims', `${pt}: index accessor ${ia} is an input accessor, not a new one`);
        if (lodIndexAccessors.has(ia)) P('lodprims', `${pt}: index accessor ${ia} is also used by ${lodIndexAccessors.get(ia)}`);
        lodIndexAccessors.set(ia, pt);
        if (acc.type !== 'SCALAR' || acc.count % 3 !== 0 || acc.sparse) P('lodprims', `${pt}: index accessor ${ia} type ${acc.type} count ${acc.count}${acc.sparse ? ' sparse' : ''}`);
        const arr = raw.accessorArray(ia);
        let mx = -1;
        for (const x of arr) if (x > mx) mx = x;
        const nv = j.accessors[op.attributes.POSITION].count;
        if (mx >= nv) P('lodprims', `${pt}: index ${mx} >= ${nv} vertices`);
        const want = mx <= 65534 ? 5123 : 5125;
        if (acc.componentType !== want) {
          P('indextype', `${pt}: index accessor ${ia} is ${acc.componentType === 5125 ? 'UNSIGNED_INT' : acc.componentType === 5121 ? 'UNSIGNED_BYTE' : acc.componentType} ` +
            `but the level's largest index is ${mx} (its vertices are a prefix of ${mx + 1} of the accessor's ${nv}): ${want === 5123 ? 'UNSIGNED_SHORT fits' : 'UNSIGNED_INT needed'}`);
        }
        perLevelIndexBytes[k] = (perLevelIndexBytes[k] || 0) + acc.count * (COMPONENT_BYTES[acc.componentType] || 0);
      });
    });
    // prefix nesting and death order, per reorderable primitive
    const levelGeoms = [m, ...lodMeshes].map((M) => (j.meshes?.[M]?.primitives || []).map((lp, p) => (isTrianglePrim(lp) ? rawPrimGeometry(raw, M, p) : null)).filter(Boolean));
    const density = [];
    prims.forEach((op, p) => {
      if (!isTrianglePrim(op)) return;
      const why = reorderable.get(`${m},${p}`);
      const g0 = rawPrimGeometry(raw, m, p);
      const arrays = [primTriangles(g0)];
      for (const M of lodMeshes) {
        const lp = j.meshes?.[M]?.primitives?.[p];
        if (lp?.indices === undefined || !j.accessors?.[lp.indices]) return;
        arrays.push(raw.accessorArray(lp.indices));
      }
      const d = arrays.map((a) => {
        let mx = -1;
        for (const x of a) if (x > mx) mx = x;
        return `${new Set(a).size}/${mx + 1}`;
      });
      density.push(`primitive ${p}: ${d.join(' ')}${why ? ` (not reordered: ${why})` : ''}`);
      if (why) return;
      problems.prefix.push(...prefixProblems(arrays, `${tag} primitive ${p}`));
      problems.prefix.push(...deathOrderProblems(arrays, g0.attrs.POSITION.count, `${tag} primitive ${p}`));
    });
    notes.push(`${tag}: vertices used / prefix length per level: ${density.join('; ')}`);

    // watertight
    const c0 = edgeCensus(levelGeoms[0]);
    const closed0 = c0.border === 0 && c0.nonmanifold === 0 && c0.triangles > c0.degenerate;
    const wt = [`level 0: ${c0.border} border / ${c0.nonmanifold} non-manifold edges`];
    lodMeshes.forEach((M, k) => {
      if (!j.meshes?.[M]) return;
      const ck = edgeCensus(levelGeoms[k + 1]);
      wt.push(`level ${k + 1}: ${ck.border} / ${ck.nonmanifold}`);
      if (closed0 && ck.border > 0) {
        P('watertight', `${tag} LOD ${k + 1} (mesh ${M}): ${ck.border} border edges (edges used by one triangle) after welding all primitives by exact position; level 0 is closed. e.g. ${ck.examples.join('; ')}`);
      }
    });
    notes.push(`${tag}: ${closed0 ? 'closed' : 'open'} at level 0; edges ${wt.join(', ')}`);

    // soundness: each distinct LOD mesh once, measured between node firstNode and its LOD node
    if (hausdorff) {
      ids.forEach((id, k) => {
        const lv = nodes[firstNode].extras?.lodpipe?.levels?.[k + 1];
        const err = Number(lv?.error);
        const lt = `${tag} LOD ${k + 1} (node ${id}, mesh ${nodes[id]?.mesh})`;
        if (!(Number.isFinite(err) && err >= 0 && diagonal > 0)) {
          P('soundness', `${lt}: not measured (recorded error ${lv?.error}, diagonal ${diagonal})`);
          return;
        }
        const slackAbs = SLACK_REL * diagonal;
        const limit = err + slackAbs;
        try {
          /* in the file itself, a folded node's mesh sits on its carrier */
          const carrier = [...carriers].find(([, n]) => n === firstNode)?.[0];
          const lod0 = carrier === undefined ? firstNode : carrier;
          const hd = hausdorffWithin(`${outFile}#node=${lod0}`, `${outFile}#node=${id}`, limit, diagonal, slackAbs);
          stats.hausdorffSeconds += hd.seconds;
          const last = hd.runs[hd.runs.length - 1];
          const detail = `hausdorff in [${hd.lower}, ${hd.upper}], recorded error ${err}, error + slack ${limit}, diagonal ${diagonal}; ` +
            `LOD0 -> LOD <= ${last.a_to_b_upper}, LOD -> LOD0 <= ${last.b_to_a_upper}, capped ${last.capped}, ${hd.runs.length} run(s)`;
          if (hd.verdict === 'fail') {
            P('soundness', `${lt}: PROVEN UNSOUND: two-sided Hausdorff >= ${hd.lower} > recorded error ${err} (${fmt(hd.lower / err, 8)} x error, ${fmt(hd.lower / diagonal, 8)} of the diagonal); ${detail}`);
          } else if (hd.verdict === 'open') P('soundness', `${lt}: NOT PROVEN within the recorded error: ${detail}`);
          stats.levels.push({ mesh: m, level: k + 1, error: err, eps: e?.levels?.[k]?.eps, lower: hd.lower, upper: hd.upper, verdict: hd.verdict, seconds: hd.seconds, diagonal });
        } catch (ex) {
          P('soundness', `${lt}: ${ex.message}`);
        }
      });
    }
  }
  stats.perLevelIndexBytes = perLevelIndexBytes;

  // ---- original geometry: every triangle primitive of every input mesh, as sets
  let docIn = inp.doc;
  for (let m = 0; m < nInMeshes && m < (j.meshes || []).length; m++) {
    (jin.meshes[m].primitives || []).forEach((jp, p) => {
      if (!isTrianglePrim(jp)) return;
      const label = `mesh ${m} primitive ${p}`;
      try {
        const gin = docPrimGeometry(docIn, jin, m, p);
        const gout = rawPrimGeometry(raw, m, p);
        if (gin.mode !== gout.mode) problems.geometry.push(`${label}: mode input ${gin.mode}, output ${gout.mode}`);
        const tolerant = new Set();
        for (const s of streams(gin)) if (meshoptFilterOf(jin, s.acc.index) && MESHOPT_FILTER_ULP > 0) tolerant.add(s.name);
        const r = compareReorderedPrimitive(gin, gout, label, { tolerant, notes });
        problems.geometry.push(...r.problems);
        const why = reorderable.get(`${m},${p}`);
        if (why && r.perm && r.perm.some((u, v) => u !== v)) problems.geometry.push(`${label}: its vertices were reordered although ${why}`);
      } catch (ex) {
        problems.geometry.push(`${label}: ${ex.message}`);
      }
    });
  }

  // ---- LOD nodes follow their node's animations (README): each channel that moves a chain node (TRS) or
  // drives its weights is copied once per LOD node (same sampler and path, appended); checked here, then
  // the copies are set aside so that the animations compare unchanged
  const lodOwner = new Map();
  nodes.forEach((n, i) => (n.extensions?.MSFT_lod?.ids || []).forEach((id) => { if (id >= nInNodes) lodOwner.set(id, i); }));
  // (by target node and path, or by a KHR_animation_pointer "/nodes/N/..." pointer; KHR_node_visibility too)
  // ("weights", or one weight "weights/K" by pointer: the glTF object model's /nodes/{}/weights/{})
  const isWeights = (prop) => /^weights(\/(0|[1-9]\d*))?$/.test(prop ?? '');
  const followed = (prop) => ['translation', 'rotation', 'scale', 'extensions/KHR_node_visibility/visible'].includes(prop) || isWeights(prop);
  // a pointer "/meshes/M/weights" or "/meshes/M/weights/K" (a mesh's default morph weights) is copied once
  // per LOD mesh of M, for the same weights
  const lodMeshOwner = new Map();
  nodes.forEach((n) => (n.extensions?.MSFT_lod?.ids || []).forEach((id) => {
    if (n.mesh !== undefined && nodes[id]?.mesh >= nInMeshes) lodMeshOwner.set(nodes[id].mesh, n.mesh);
  }));
  const meshPointer = (ch) => ch?.target?.path === 'pointer' && /^\/meshes\/(\d+)\/(weights(?:\/(?:0|[1-9]\d*))?)$/.exec(ch.target.extensions?.KHR_animation_pointer?.pointer ?? '');
  const meshWeights = (ch) => (meshPointer(ch) ? Number(meshPointer(ch)[1]) : undefined);
  const meshProp = (ch) => (meshPointer(ch) ? meshPointer(ch)[2] : undefined);
  (j.animations || []).forEach((an, ai) => {
    const channels = an.channels || [];
    const isCopy = (ch) => lodOwner.has(channelTarget(ch).node) || lodMeshOwner.has(meshWeights(ch));
    const own = channels.filter((ch) => !isCopy(ch));
    const copies = channels.filter(isCopy);
    if (channels.slice(own.length).some((ch) => !isCopy(ch))) {
      P('unchanged', `/animations/${ai}: the channels for LOD nodes are not all after the input's channels`);
    }
    const same = (x, y) => x.sampler === y.sampler && x.target?.path === y.target?.path && channelTarget(x).prop === channelTarget(y).prop;
    for (const ch of copies.filter((c) => meshWeights(c) !== undefined)) {
      const owner = lodMeshOwner.get(meshWeights(ch));
      if (!own.some((o) => meshWeights(o) === owner && o.sampler === ch.sampler && meshProp(o) === meshProp(ch))) P('unchanged', `/animations/${ai}: a channel for LOD mesh ${meshWeights(ch)} (sampler ${ch.sampler}) copies no channel of its mesh ${owner}`);
    }
    for (const o of own.filter((c) => meshWeights(c) !== undefined)) {
      for (const [M, owner] of lodMeshOwner) {
        if (owner === meshWeights(o) && !copies.some((ch) => meshWeights(ch) === M && ch.sampler === o.sampler && meshProp(ch) === meshProp(o))) P('chain', `/animations/${ai}: LOD mesh ${M} does not follow mesh ${owner}'s ${meshProp(o)} channel (sampler ${o.sampler})`);
      }
    }
    for (const ch of copies.filter((c) => meshWeights(c) === undefined)) {
      const { node: id, prop } = channelTarget(ch);
      const owner = lodOwner.get(id);
      if (!own.some((o) => channelTarget(o).node === owner && same(o, ch))) P('unchanged', `/animations/${ai}: a channel for LOD node ${id} (sampler ${ch.sampler}, ${prop}) copies no channel of its node ${owner}`);
    }
    const carried = new Set(carriers.values());
    for (const o of own) {
      const { node, prop } = channelTarget(o);
      if (!followed(prop)) continue;
      // a carrier's LOD nodes take the carrier's place under the node: the node's own TRS moves them already
      if (carried.has(node) && !isWeights(prop)) continue;
      for (const id of nodes[node]?.extensions?.MSFT_lod?.ids || []) {
        if (id >= nInNodes && !copies.some((ch) => channelTarget(ch).node === id && same(o, ch))) P('chain', `/animations/${ai}: LOD node ${id} does not follow node ${node}'s ${prop} channel (sampler ${o.sampler})`);
      }
    }
    an.channels = own;
  });

  // ---- unchanged parts
  const a = contractView(jin);
  const b = contractView(j);
  for (const key of ['asset', 'scene', 'scenes', 'materials', 'textures', 'samplers', 'images', 'animations', 'skins', 'cameras', 'extensions', 'extras', 'extensionsRequired']) {
    const av = a[key];
    const bv = b[key];
    if (Array.isArray(av) && av.length === 0 && bv === undefined) continue;
    if (Array.isArray(bv) && bv.length === 0 && av === undefined) continue;
    const d = diffJson(av, bv, `/${key}`, []);
    problems.unchanged.push(...d);
  }
  const usedOut = (b.extensionsUsed || []).filter((x) => x !== 'MSFT_lod' || (a.extensionsUsed || []).includes('MSFT_lod'));
  if (!deepEqual([...usedOut].sort(), [...(a.extensionsUsed || [])].sort())) P('unchanged', `extensionsUsed input ${JSON.stringify(a.extensionsUsed)}, output ${JSON.stringify(b.extensionsUsed)} (only MSFT_lod may be added)`);
  for (let i = 0; i < nInNodes; i++) {
    const had = jin.nodes[i]?.extensions?.MSFT_lod; // a chain the input had is left as it is
    const d = diffJson(a.nodes[i], had ? b.nodes?.[i] : stripChainProps(b.nodes?.[i], a.nodes[i]), `/nodes/${i}`, []);
    problems.unchanged.push(...d.map((x) => `${x} (besides MSFT_lod and extras.MSFT_screencoverage/lodpipe)`));
  }
  for (let i = 0; i < nInMeshes; i++) problems.unchanged.push(...diffJson(a.meshes[i], b.meshes?.[i], `/meshes/${i}`, []));
  for (let i = 0; i < nInAcc; i++) problems.unchanged.push(...diffJson(a.accessors[i], b.accessors?.[i], `/accessors/${i}`, []));
  problems.unchanged.push(...compareImages(inp.raw, raw));
  // accessor data other than the reordered geometry: byte-identical (meshopt-filtered: within the ULP rule)
  const compressed = compressedAccessorIndices(jin, inp.raw.meshoptDecoded);
  for (let i = 0; i < nInAcc && problems.unchanged.length < 40; i++) {
    if (geomAccessors.has(i) || compressed.has(i)) continue;
    try {
      const x = inp.raw.accessorBytes(i);
      const y = raw.accessorBytes(i);
      if (x.byteLength !== y.byteLength) {
        P('unchanged', `/accessors/${i}: data length input ${x.byteLength}, output ${y.byteLength}`);
        continue;
      }
      let at = -1;
      for (let q = 0; q < x.byteLength; q++) if (x[q] !== y[q]) {
        at = q;
        break;
      }
      if (at < 0) continue;
      if (meshoptFilterOf(jin, i) && MESHOPT_FILTER_ULP > 0) {
        const xa = inp.raw.accessorArray(i);
        const ya = raw.accessorArray(i);
        const isFloat = xa instanceof Float32Array;
        if (xa.every((v, q) => withinUlp(v, ya[q], isFloat, MESHOPT_FILTER_ULP))) continue;
      }
      const who = (users.get(i) || ['(unreferenced)'])[0];
      P('unchanged', `/accessors/${i} (${who}): data differs from the input from byte ${at} on`);
    } catch (ex) {
      P('unchanged', `/accessors/${i}: ${ex.message}`);
    }
  }
  try {
    const docOut = await readDocument(outFile);
    problems.unchanged.push(...compareAnimationSkinData(docIn, docOut, { jsonIn: jin, notes }));
  } catch (ex) {
    P('unchanged', `glTF-Transform cannot read the output: ${ex.message}`);
  }

  // ---- dead data: bufferViews nothing references
  const unusedViews = (json, withCompression) => {
    const used = new Set();
    for (const a of json.accessors || []) {
      if (a.bufferView !== undefined) used.add(a.bufferView);
      if (a.sparse) {
        used.add(a.sparse.indices?.bufferView);
        used.add(a.sparse.values?.bufferView);
      }
    }
    for (const im of json.images || []) if (im.bufferView !== undefined) used.add(im.bufferView);
    if (withCompression) {
      for (const m of json.meshes || []) for (const p of m.primitives || []) {
        const d = p.extensions?.KHR_draco_mesh_compression;
        if (d?.bufferView !== undefined) used.add(d.bufferView);
      }
    }
    return (json.bufferViews || []).map((bv, i) => [i, bv]).filter(([i]) => !used.has(i));
  };
  const deadIn = unusedViews(jin, true);
  const deadOut = unusedViews(j, false);
  if (deadOut.length > deadIn.length) {
    const bytes = deadOut.reduce((x, [, bv]) => x + (bv.byteLength || 0), 0);
    P('buffers', `${deadOut.length} bufferView(s) of the output are referenced by nothing (${bytes} bytes of dead data; the input had ${deadIn.length}): ` +
      deadOut.slice(0, 4).map(([i, bv]) => `view ${i} (${bv.byteLength} B at ${bv.byteOffset || 0})`).join(', '));
  }
  stats.newIndexBytes = perLevelIndexBytes.reduce((x, y) => x + (y || 0), 0);
  stats.newAccessors = Math.max(0, (j.accessors || []).length - nInAcc);

  // ---- sizes
  const inBytes = fileSetBytes(inFile, jin);
  const outBytes = fileSetBytes(outFile, j);
  stats.inBytes = inBytes;
  stats.outBytes = outBytes;
  return { problems, notes, stats };
}

/** Assertion message for a list of problems. */
export function formatProblems(title, list) {
  return `${title}: ${list.length} problem(s)\n${list.slice(0, 12).map((p) => '  - ' + p).join('\n')}${list.length > 12 ? `\n  ... ${list.length - 12} more` : ''}`;
}
