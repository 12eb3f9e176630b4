// cow.glb with many morph targets, as a face rig has (ARKit's 52 blend shapes and more): each distinct
// target moves every vertex by a sum of three smooth bumps (Gaussian falloff, 2 % of the diagonal high)
// at seeded random places, so no two targets move LOD0 the same way. Written as one .glb without lodpipe.
import fs from 'node:fs';
import path from 'node:path';
import { corpusPath, readRaw } from './gltf.mjs';

/** Seeded LCG in [0, 1): the same targets on every run. */
function random(seed) {
  let s = seed >>> 0;
  return () => (s = (Math.imul(s, 1664525) + 1013904223) >>> 0) / 4294967296;
}

/** Float32 POSITION deltas of one smooth target over the vertices pos (xyz), diagonal diag. */
function smoothTarget(pos, diag, rnd) {
  const count = pos.length / 3;
  const d = new Float32Array(3 * count);
  for (let b = 0; b < 3; b++) {
    const c = Math.floor(rnd() * count);
    const r = diag * (0.05 + 0.15 * rnd());
    const dir = [rnd() - 0.5, rnd() - 0.5, rnd() - 0.5];
    const amp = (0.02 * diag) / Math.hypot(...dir);
    for (let i = 0; i < count; i++) {
      const q = ((pos[3 * i] - pos[3 * c]) ** 2 + (pos[3 * i + 1] - pos[3 * c + 1]) ** 2 + (pos[3 * i + 2] - pos[3 * c + 2]) ** 2) / (r * r);
      for (let k = 0; k < 3; k++) d[3 * i + k] += Math.exp(-q) * amp * dir[k];
    }
  }
  return d;
}

/**
 * dir/name (.glb): cow.glb whose primitive has `distinct` distinct smooth targets followed by `repeats`
 * targets that reuse the accessors of the first ones (measured once by lodpipe). Returns the path.
 */
export function writeMorphCow(dir, name, { distinct, repeats = 0, seed = 1 }) {
  const raw = readRaw(corpusPath('scans/cow.glb'));
  const j = structuredClone(raw.json);
  const prim = j.meshes[0].primitives[0];
  const acc = j.accessors[prim.attributes.POSITION];
  const pos = new Float32Array(raw.accessorBytes(prim.attributes.POSITION).buffer);
  const diag = Math.hypot(...[0, 1, 2].map((c) => acc.max[c] - acc.min[c]));
  const chunks = [Buffer.from(raw.buffers[0])];
  let offset = chunks[0].length;
  const align = () => {
    const pad = (4 - (offset % 4)) % 4;
    chunks.push(Buffer.alloc(pad));
    offset += pad;
  };
  const rnd = random(seed);
  const accessors = [];
  for (let t = 0; t < distinct; t++) {
    align();
    const d = smoothTarget(pos, diag, rnd);
    const min = [0, 1, 2].map((c) => d.filter((_, i) => i % 3 === c).reduce((a, b) => Math.min(a, b)));
    const max = [0, 1, 2].map((c) => d.filter((_, i) => i % 3 === c).reduce((a, b) => Math.max(a, b)));
    const view = j.bufferViews.push({ buffer: 0, byteOffset: offset, byteLength: d.byteLength }) - 1;
    chunks.push(Buffer.from(d.buffer));
    offset += d.byteLength;
    accessors.push(j.accessors.push({ bufferView: view, componentType: 5126, count: acc.count, type: 'VEC3', min, max }) - 1);
  }
  prim.targets = [...accessors, ...[...Array(repeats)].map((_, i) => accessors[i % distinct])].map((a) => ({ POSITION: a }));
  j.meshes[0].weights = prim.targets.map(() => 0);
  align();
  const bin = Buffer.concat(chunks);
  j.buffers = [{ byteLength: bin.length }];
  const text = Buffer.from(JSON.stringify(j));
  const json = Buffer.concat([text, Buffer.alloc((4 - (text.length % 4)) % 4, 0x20)]);
  const chunk = (type, data) => {
    const h = Buffer.alloc(8);
    h.writeUInt32LE(data.length, 0);
    h.writeUInt32LE(type, 4);
    return Buffer.concat([h, data]);
  };
  const header = Buffer.alloc(12);
  header.writeUInt32LE(0x46546c67, 0); // "glTF"
  header.writeUInt32LE(2, 4);
  header.writeUInt32LE(12 + 8 + json.length + 8 + bin.length, 8);
  const file = path.join(dir, name);
  fs.writeFileSync(file, Buffer.concat([header, chunk(0x4e4f534a, json), chunk(0x004e4942, bin)]));
  return file;
}
