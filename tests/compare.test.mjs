// Self-tests of the comparison logic in lib/gltf.mjs (runs without the lodpipe binary).
//
// 1. No false alarms: a small reference implementation of the `convert` contract, written here in JS
//    (repack everything into one buffer with renumbered bufferViews, decode Draco/meshopt, keep all
//    other JSON), must pass every check for every valid corpus asset and both output kinds.
// 2. A second, independent writer (glTF-Transform's io.write) must pass the data checks (geometry,
//    animation/skin data, image bytes); its JSON normalisation (generator etc.) must be reported.
// 3. Planted differences (one flipped float, NaN, -0, a renamed material, a changed image byte, a stray
//    file, swapped indices, a leftover compression extension, an out-of-range index) must be caught.
// 4. The validator helper reproduces the validator counts recorded in the corpus manifest.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import {
  ASPECTS, COMPRESSION_EXTENSIONS, analyzeConversion, compareGeometry, corpusPath, diffTypedArrays, formatDiffs,
  MESHOPT_FILTER_ULP, getIO, getMeshoptDecoder, isDataUri, meshoptFilterOf, loadInput, manifestInputs, outputNameFor, readDocument, readRaw, tempDir, validateFile,
} from './lib/gltf.mjs';

// ---------------------------------------------------------------------------------------------
// Reference converter (JS) implementing the convert contract, used only to test the comparator.

const COMPONENT_SIZE = { 5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4 };
const TYPE_COMPONENTS = { SCALAR: 1, VEC2: 2, VEC3: 3, VEC4: 4, MAT2: 4, MAT3: 9, MAT4: 16 };

function writeGlb(file, json, bin) {
  const jsonBytes = Buffer.from(JSON.stringify(json), 'utf8');
  const jsonPad = (4 - (jsonBytes.length % 4)) % 4;
  const jsonChunk = Buffer.concat([jsonBytes, Buffer.alloc(jsonPad, 0x20)]);
  const parts = [null, Buffer.alloc(8), jsonChunk];
  parts[1].writeUInt32LE(jsonChunk.length, 0);
  parts[1].writeUInt32LE(0x4e4f534a, 4);
  if (bin && bin.length) {
    const binPad = (4 - (bin.length % 4)) % 4;
    const binChunk = Buffer.concat([Buffer.from(bin), Buffer.alloc(binPad, 0)]);
    const h = Buffer.alloc(8);
    h.writeUInt32LE(binChunk.length, 0);
    h.writeUInt32LE(0x004e4942, 4);
    parts.push(h, binChunk);
  }
  const header = Buffer.alloc(12);
  header.writeUInt32LE(0x46546c67, 0);
  header.writeUInt32LE(2, 4);
  parts[0] = header;
  const total = parts.reduce((n, p) => n + p.length, 0);
  header.writeUInt32LE(total, 8);
  fs.writeFileSync(file, Buffer.concat(parts));
}

/** convert IN OUT as the contract describes it (reference implementation for the comparator self-test). */
async function referenceConvert(inFile, outFile) {
  const raw = readRaw(inFile);
  const { doc } = await loadInput(inFile);
  const json = structuredClone(raw.json);
  const kind = path.extname(outFile).toLowerCase();
  const outDir = path.dirname(outFile);
  const chunks = []; // { bytes, byteStride?, target? }
  const addView = (bytes, extra = {}) => {
    chunks.push({ bytes, ...extra });
    return chunks.length - 1;
  };

  // Old bufferViews, emitted in REVERSE order so every index changes (renumbering must be tolerated).
  const oldViews = json.bufferViews || [];
  const remap = new Map();
  for (let i = oldViews.length - 1; i >= 0; i--) {
    const bv = oldViews[i];
    const mo = bv.extensions?.EXT_meshopt_compression || bv.extensions?.KHR_meshopt_compression;
    let bytes;
    if (mo) {
      const dec = await getMeshoptDecoder();
      const src = raw.buffers[mo.buffer].subarray(mo.byteOffset || 0, (mo.byteOffset || 0) + mo.byteLength);
      bytes = new Uint8Array(mo.count * mo.byteStride);
      dec.decodeGltfBuffer(bytes, mo.count, mo.byteStride, src, mo.mode, mo.filter);
    } else {
      const buf = raw.buffers[bv.buffer];
      if (!buf) continue; // e.g. an unused meshopt fallback buffer without data
      bytes = raw.viewBytes(i);
    }
    const extra = {};
    if (bv.byteStride !== undefined) extra.byteStride = bv.byteStride;
    if (bv.target !== undefined) extra.target = bv.target;
    if (bv.name !== undefined) extra.name = bv.name;
    remap.set(i, addView(bytes, extra));
  }
  for (const a of json.accessors || []) {
    if (a.bufferView !== undefined) a.bufferView = remap.get(a.bufferView);
    if (a.sparse) {
      a.sparse.indices.bufferView = remap.get(a.sparse.indices.bufferView);
      a.sparse.values.bufferView = remap.get(a.sparse.values.bufferView);
    }
  }
  for (const im of json.images || []) if (im.bufferView !== undefined) im.bufferView = remap.get(im.bufferView);

  // Draco: decoded data from glTF-Transform, one new bufferView per accessor.
  const meshes = doc.getRoot().listMeshes();
  const done = new Set();
  (json.meshes || []).forEach((m, mi) => m.primitives.forEach((prim, pi) => {
    const dr = prim.extensions?.KHR_draco_mesh_compression;
    if (!dr) return;
    const dprim = meshes[mi].listPrimitives()[pi];
    const put = (accIndex, array, vertex) => {
      if (done.has(accIndex)) return;
      done.add(accIndex);
      const a = json.accessors[accIndex];
      const elem = COMPONENT_SIZE[a.componentType] * TYPE_COMPONENTS[a.type];
      const src = new Uint8Array(array.buffer, array.byteOffset, array.byteLength);
      assert.equal(src.byteLength, elem * a.count, `draco accessor ${accIndex} decoded size`);
      const stride = vertex ? Math.ceil(elem / 4) * 4 : elem;
      const bytes = new Uint8Array(stride * a.count);
      for (let e = 0; e < a.count; e++) bytes.set(src.subarray(e * elem, (e + 1) * elem), e * stride);
      a.bufferView = addView(bytes, vertex ? { byteStride: stride, target: 34962 } : { target: 34963 });
      delete a.byteOffset;
    };
    for (const [sem, acc] of Object.entries(prim.attributes)) put(acc, dprim.getAttribute(sem).getArray(), true);
    if (prim.indices !== undefined) put(prim.indices, dprim.getIndices().getArray(), false);
    delete prim.extensions.KHR_draco_mesh_compression;
    if (Object.keys(prim.extensions).length === 0) delete prim.extensions;
  }));

  // Images keep their storage form: external files are copied under their relative uri.
  (json.images || []).forEach((im, i) => {
    if (im.uri === undefined || isDataUri(im.uri)) return;
    const dst = path.resolve(outDir, decodeURIComponent(im.uri));
    fs.mkdirSync(path.dirname(dst), { recursive: true });
    fs.writeFileSync(dst, raw.imageBytes(i).bytes);
  });

  // One buffer.
  let size = 0;
  const views = chunks.map((c) => {
    size = Math.ceil(size / 4) * 4;
    const v = { buffer: 0, byteOffset: size, byteLength: c.bytes.byteLength };
    if (c.byteStride !== undefined) v.byteStride = c.byteStride;
    if (c.target !== undefined) v.target = c.target;
    if (c.name !== undefined) v.name = c.name;
    c.offset = size;
    size += c.bytes.byteLength;
    return v;
  });
  const bin = new Uint8Array(Math.ceil(size / 4) * 4);
  for (const c of chunks) bin.set(c.bytes, c.offset);
  if (views.length) {
    json.bufferViews = views;
    json.buffers = [{ byteLength: bin.byteLength }];
  } else {
    delete json.bufferViews;
    delete json.buffers;
  }
  for (const key of ['extensionsUsed', 'extensionsRequired']) {
    if (!json[key]) continue;
    json[key] = json[key].filter((e) => !COMPRESSION_EXTENSIONS.includes(e));
    if (json[key].length === 0) delete json[key];
  }
  if (kind === '.glb') writeGlb(outFile, json, views.length ? bin : null);
  else {
    if (views.length) {
      const binName = path.basename(outFile, path.extname(outFile)) + '.bin';
      json.buffers[0].uri = binName;
      fs.writeFileSync(path.join(outDir, binName), bin);
    }
    fs.writeFileSync(outFile, JSON.stringify(json, null, 1));
  }
}

// ---------------------------------------------------------------------------------------------

const handled = (f) => f.category !== 'invalid' || String(f.expect || '').startsWith('handle');
const convertible = manifestInputs(handled);
const KINDS = ['.glb', '.gltf'];

function assertNoDiffs(res, label) {
  const bad = ASPECTS.filter(([k]) => res[k].length).map(([k, title]) => formatDiffs(`${label}: ${title}`, res[k]));
  assert.equal(bad.length, 0, bad.join('\n'));
}

test('validator helper reproduces the counts recorded in manifest.json', async () => {
  const wrong = [];
  for (const f of manifestInputs()) {
    const v = await validateFile(corpusPath(f.path));
    if (v.errors !== f.validator.errors || v.warnings !== f.validator.warnings) {
      wrong.push(`${f.path}: errors ${v.errors} warnings ${v.warnings}, manifest ${f.validator.errors}/${f.validator.warnings}`);
    }
    for (const [code, n] of Object.entries(f.validator.error_codes || {})) {
      if ((v.errorCodes[code] || 0) !== n) wrong.push(`${f.path}: ${code} ${v.errorCodes[code] || 0}, manifest ${n}`);
    }
  }
  assert.deepEqual(wrong, []);
});

test('no false alarms: a reference JS implementation of convert passes every check', async (t) => {
  for (const f of convertible) {
    for (const kind of KINDS) {
      await t.test(`${f.path} -> ${kind}`, async (st) => {
        const dir = tempDir(st);
        const out = path.join(dir, outputNameFor(f.path, kind));
        await referenceConvert(corpusPath(f.path), out);
        assertNoDiffs(await analyzeConversion(corpusPath(f.path), out, dir), `${f.path} -> ${kind}`);
      });
    }
  }
});

test('glTF-Transform round trip (independent writer): data checks pass, JSON changes are reported', async (t) => {
  const io = await getIO();
  for (const f of convertible) {
    await t.test(f.path, async (st) => {
      const dir = tempDir(st);
      const out = path.join(dir, outputNameFor(f.path, '.glb'));
      const doc = await readDocument(corpusPath(f.path)); // own copy: it is modified below
      for (const e of doc.getRoot().listExtensionsUsed()) if (COMPRESSION_EXTENSIONS.includes(e.extensionName)) e.dispose();
      const [first, ...rest] = doc.getRoot().listBuffers(); // GLB: one buffer
      for (const a of doc.getRoot().listAccessors()) a.setBuffer(first || null);
      rest.forEach((b) => b.dispose());
      await io.write(out, doc);
      const res = await analyzeConversion(corpusPath(f.path), out, dir);
      for (const k of ['geometry', 'animSkin', 'images', 'leftovers']) {
        assert.deepEqual(res[k], [], formatDiffs(`${f.path}: ${k}`, res[k]));
      }
      // glTF-Transform always rewrites asset.generator: the JSON comparator must notice.
      const inGen = readRaw(corpusPath(f.path)).json.asset.generator;
      if (inGen !== readRaw(out).json.asset.generator) {
        assert.ok(res.json.some((d) => d.startsWith('/asset/generator')), `generator change not reported: ${res.json}`);
      }
    });
  }
});

test('typed-array comparison: NaN equals NaN, -0 differs from 0, array type matters', () => {
  assert.equal(diffTypedArrays(new Float32Array([1, NaN]), new Float32Array([1, NaN]), 'x'), null);
  assert.match(diffTypedArrays(new Float32Array([1, 2]), new Float32Array([1, NaN]), 'x'), /element \[1\] input 2, output NaN/);
  assert.match(diffTypedArrays(new Float32Array([0]), new Float32Array([-0]), 'x'), /input 0, output -0/);
  assert.match(diffTypedArrays(new Uint16Array([1]), new Uint32Array([1]), 'x'), /array type input Uint16Array, output Uint32Array/);
  assert.equal(diffTypedArrays([1, 2], [1, 2], 'idx', { allowTypeChange: true }), null);
});

/** Reference .gltf conversion of an asset into a fresh folder; returns paths and the parsed output. */
async function plantBase(t, rel) {
  const dir = tempDir(t);
  const out = path.join(dir, outputNameFor(rel, '.gltf'));
  await referenceConvert(corpusPath(rel), out);
  const raw = readRaw(out);
  const binPath = path.join(dir, raw.json.buffers[0].uri);
  return { dir, out, raw, json: raw.json, binPath, bin: fs.readFileSync(binPath) };
}

/** Byte offset of component `comp` of element `elem` of accessor `ai` in the output .bin. */
function componentOffset(json, ai, elem, comp) {
  const a = json.accessors[ai];
  const bv = json.bufferViews[a.bufferView];
  const cs = COMPONENT_SIZE[a.componentType];
  const stride = bv.byteStride || cs * TYPE_COMPONENTS[a.type];
  return (bv.byteOffset || 0) + (a.byteOffset || 0) + elem * stride + comp * cs;
}

test('planted differences are caught', async (t) => {
  const rel = 'scenes/Duck.glb';
  const input = corpusPath(rel);

  await t.test('baseline: unmodified reference output passes', async (st) => {
    const b = await plantBase(st, rel);
    assertNoDiffs(await analyzeConversion(input, b.out, b.dir), 'baseline');
  });

  await t.test('one flipped float in POSITION', async (st) => {
    const b = await plantBase(st, rel);
    const pos = b.json.meshes[0].primitives[0].attributes.POSITION;
    const off = componentOffset(b.json, pos, 7, 1);
    b.bin.writeFloatLE(-b.bin.readFloatLE(off) || 1, off);
    fs.writeFileSync(b.binPath, b.bin);
    const res = await analyzeConversion(input, b.out, b.dir);
    assert.ok(res.geometry.some((d) => /POSITION: element \[22\]/.test(d)), `geometry: ${res.geometry}`);
    assert.ok(res.accessors.some((d) => d.startsWith(`/accessors/${pos}`) && /element 7/.test(d)), `accessors: ${res.accessors}`);
  });

  await t.test('lowest mantissa bit of one NORMAL component', async (st) => {
    const b = await plantBase(st, rel);
    const nrm = b.json.meshes[0].primitives[0].attributes.NORMAL;
    const off = componentOffset(b.json, nrm, 100, 2);
    b.bin[off] ^= 1;
    fs.writeFileSync(b.binPath, b.bin);
    const res = await analyzeConversion(input, b.out, b.dir);
    assert.ok(res.geometry.some((d) => /NORMAL: element \[302\]/.test(d)), `geometry: ${res.geometry}`);
  });

  await t.test('NaN where the input had none, and -0 where the input had 0', async (st) => {
    const b = await plantBase(st, rel);
    const uv = b.json.meshes[0].primitives[0].attributes.TEXCOORD_0;
    b.bin.writeFloatLE(NaN, componentOffset(b.json, uv, 3, 0));
    fs.writeFileSync(b.binPath, b.bin);
    const res = await analyzeConversion(input, b.out, b.dir);
    assert.ok(res.geometry.some((d) => /TEXCOORD_0: element \[6\] input .*, output NaN/.test(d)), `geometry: ${res.geometry}`);
    // -0: find a +0 component in the input positions
    const b2 = await plantBase(st, 'scans/cow.glb');
    const docIn = (await loadInput(corpusPath('scans/cow.glb'))).doc;
    const arr = docIn.getRoot().listMeshes()[0].listPrimitives()[0].getAttribute('POSITION').getArray();
    const k = arr.findIndex((x) => Object.is(x, 0));
    if (k >= 0) {
      const p2 = b2.json.meshes[0].primitives[0].attributes.POSITION;
      b2.bin.writeFloatLE(-0, componentOffset(b2.json, p2, Math.floor(k / 3), k % 3));
      fs.writeFileSync(b2.binPath, b2.bin);
      const r2 = await analyzeConversion(corpusPath('scans/cow.glb'), b2.out, b2.dir);
      assert.ok(r2.geometry.some((d) => /output -0/.test(d)), `geometry: ${r2.geometry}`);
    }
  });

  await t.test('two indices swapped', async (st) => {
    const b = await plantBase(st, rel);
    const ia = b.json.meshes[0].primitives[0].indices;
    const o0 = componentOffset(b.json, ia, 0, 0);
    const o1 = componentOffset(b.json, ia, 1, 0);
    const v0 = b.bin.readUInt16LE(o0);
    b.bin.writeUInt16LE(b.bin.readUInt16LE(o1), o0);
    b.bin.writeUInt16LE(v0, o1);
    fs.writeFileSync(b.binPath, b.bin);
    const res = await analyzeConversion(input, b.out, b.dir);
    assert.ok(res.geometry.some((d) => /indices: element \[0\]/.test(d)), `geometry: ${res.geometry}`);
  });

  await t.test('renamed material, changed node matrix, default mode made explicit, lost extras', async (st) => {
    const relT = 'scenes/CesiumMilkTruck/CesiumMilkTruck.gltf';
    const b = await plantBase(st, relT);
    b.json.materials[0].name += 'x';
    b.json.nodes[1].matrix[12] += 1e-6;
    fs.writeFileSync(b.out, JSON.stringify(b.json));
    const res = await analyzeConversion(corpusPath(relT), b.out, b.dir);
    assert.ok(res.json.some((d) => d.startsWith('/materials/0/name')), `json: ${res.json}`);
    assert.ok(res.json.some((d) => d.startsWith('/nodes/1/matrix/12')), `json: ${res.json}`);
    // the spec default made explicit is still a difference (an input whose primitive has no mode)
    const relM = 'animated/simple_skin.gltf';
    assert.equal(readRaw(corpusPath(relM)).json.meshes[0].primitives[0].mode, undefined, `test premise: ${relM} primitive 0 has no mode`);
    const m = await plantBase(st, relM);
    m.json.meshes[0].primitives[0].mode = 4;
    fs.writeFileSync(m.out, JSON.stringify(m.json));
    const rm = await analyzeConversion(corpusPath(relM), m.out, m.dir);
    assert.ok(rm.json.some((d) => d.startsWith('/meshes/0/primitives/0/mode') && /spec default/.test(d)), `json: ${rm.json}`);
    // extras dropped from the output
    const relE = 'scans/cow.glb';
    const e = await plantBase(st, relE);
    assert.ok(e.json.asset.extras !== undefined, 'test premise: cow.glb has asset.extras');
    delete e.json.asset.extras;
    fs.writeFileSync(e.out, JSON.stringify(e.json));
    const r2 = await analyzeConversion(corpusPath(relE), e.out, e.dir);
    assert.ok(r2.json.some((d) => d.startsWith('/asset/extras: input') && /output \(absent\)/.test(d)), `json: ${r2.json}`);
  });

  await t.test('accessor min/max and texture transform changes', async (st) => {
    const relK = 'scenes/kenney/pavement.glb';
    const b = await plantBase(st, relK);
    const a = b.json.accessors.find((x) => x.min);
    a.min[0] = Math.fround(a.min[0] - 1);
    const mat = b.json.materials.find((m) => JSON.stringify(m).includes('KHR_texture_transform'));
    const tex = mat.pbrMetallicRoughness.baseColorTexture;
    tex.extensions.KHR_texture_transform.scale = [2, 2];
    fs.writeFileSync(b.out, JSON.stringify(b.json));
    const res = await analyzeConversion(corpusPath(relK), b.out, b.dir);
    assert.ok(res.json.some((d) => /^\/accessors\/\d+\/min\/0/.test(d)), `json: ${res.json}`);
    assert.ok(res.json.some((d) => /KHR_texture_transform\/scale/.test(d)), `json: ${res.json}`);
  });

  await t.test('one changed image byte', async (st) => {
    const b = await plantBase(st, 'scenes/CesiumMilkTruck/CesiumMilkTruck.gltf');
    const imgPath = path.join(b.dir, b.json.images[0].uri);
    const img = fs.readFileSync(imgPath);
    img[img.length - 20] ^= 0xff;
    fs.writeFileSync(imgPath, img);
    const res = await analyzeConversion(corpusPath('scenes/CesiumMilkTruck/CesiumMilkTruck.gltf'), b.out, b.dir);
    assert.ok(res.images.some((d) => /image bytes differ/.test(d)), `images: ${res.images}`);
  });

  await t.test('stray temp file and a second buffer', async (st) => {
    const b = await plantBase(st, rel);
    fs.writeFileSync(path.join(b.dir, '.Duck.gltf.tmp123'), 'x');
    b.json.buffers.push({ byteLength: 4, uri: 'data:application/octet-stream;base64,AAAAAA==' });
    fs.writeFileSync(b.out, JSON.stringify(b.json));
    const res = await analyzeConversion(input, b.out, b.dir);
    assert.ok(res.leftovers.some((d) => /\.Duck\.gltf\.tmp123/.test(d)), `leftovers: ${res.leftovers}`);
    assert.ok(res.form.some((d) => /2 buffers/.test(d)), `form: ${res.form}`);
  });

  await t.test('Draco input: decoded output with one changed normal; compression extension left over', async (st) => {
    const relD = 'compressed/BoxDraco/BoxDraco.gltf';
    const b = await plantBase(st, relD);
    assertNoDiffs(await analyzeConversion(corpusPath(relD), b.out, b.dir), 'draco baseline');
    const nrm = b.json.meshes[0].primitives[0].attributes.NORMAL;
    const off = componentOffset(b.json, nrm, 5, 0);
    b.bin.writeFloatLE(b.bin.readFloatLE(off) + 0.5, off);
    fs.writeFileSync(b.binPath, b.bin);
    b.json.extensionsUsed = [...(b.json.extensionsUsed || []), 'KHR_draco_mesh_compression'];
    fs.writeFileSync(b.out, JSON.stringify(b.json));
    const res = await analyzeConversion(corpusPath(relD), b.out, b.dir);
    assert.ok(res.geometry.some((d) => /NORMAL: element \[15\]/.test(d)), `geometry: ${res.geometry}`);
    assert.ok(res.form.some((d) => /KHR_draco_mesh_compression/.test(d)), `form: ${res.form}`);
  });

  await t.test('meshopt input: one changed quantized position', async (st) => {
    const relM = 'compressed/BoxMeshopt.glb';
    const b = await plantBase(st, relM);
    assertNoDiffs(await analyzeConversion(corpusPath(relM), b.out, b.dir), 'meshopt baseline');
    const pos = b.json.meshes[0].primitives[0].attributes.POSITION;
    const off = componentOffset(b.json, pos, 2, 0);
    b.bin[off] ^= 1;
    fs.writeFileSync(b.binPath, b.bin);
    const res = await analyzeConversion(corpusPath(relM), b.out, b.dir);
    assert.ok(res.geometry.some((d) => /POSITION: element \[6\]/.test(d)), `geometry: ${res.geometry}`);
    assert.ok(res.accessors.some((d) => d.startsWith(`/accessors/${pos}`)), `accessors: ${res.accessors}`);
  });

  await t.test('meshopt OCTAHEDRAL-filtered normal: 1 ULP tolerated (spec), 2 ULP caught', async (st) => {
    const relP = 'compressed/pirate.glb';
    const b = await plantBase(st, relP);
    const prim = b.json.meshes[0].primitives[0];
    const nrm = prim.attributes.NORMAL;
    assert.equal(meshoptFilterOf(readRaw(corpusPath(relP)).json, nrm), 'OCTAHEDRAL', 'test premise');
    const off = componentOffset(b.json, nrm, 10, 0);
    const orig = b.bin.readInt8(off);
    b.bin.writeInt8(orig > 0 ? orig - 1 : orig + 1, off);
    fs.writeFileSync(b.binPath, b.bin);
    const res = await analyzeConversion(corpusPath(relP), b.out, b.dir);
    if (MESHOPT_FILTER_ULP === 1) {
      assert.deepEqual(res.geometry, []);
      assert.deepEqual(res.accessors, []);
      assert.ok(res.notes.some((n) => /NORMAL: 1 of \d+ components differ by 1 ULP/.test(n)), `notes: ${res.notes}`);
    } else {
      assert.ok(res.geometry.length > 0);
    }
    b.bin.writeInt8(orig > 0 ? orig - 2 : orig + 2, off);
    fs.writeFileSync(b.binPath, b.bin);
    const res2 = await analyzeConversion(corpusPath(relP), b.out, b.dir);
    assert.ok(res2.geometry.some((d) => /NORMAL: element \[30\]/.test(d)), `geometry: ${res2.geometry}`);
    assert.ok(res2.accessors.some((d) => d.startsWith(`/accessors/${nrm}`)), `accessors: ${res2.accessors}`);
    // unfiltered meshopt data (positions) gets no tolerance
    const pos = prim.attributes.POSITION;
    assert.equal(meshoptFilterOf(readRaw(corpusPath(relP)).json, pos), null, 'test premise');
    const b3 = await plantBase(st, relP);
    const o3 = componentOffset(b3.json, pos, 4, 1);
    b3.bin.writeInt16LE(b3.bin.readInt16LE(o3) + 1, o3);
    fs.writeFileSync(b3.binPath, b3.bin);
    const res3 = await analyzeConversion(corpusPath(relP), b3.out, b3.dir);
    assert.ok(res3.geometry.some((d) => /POSITION: element \[13\]/.test(d)), `geometry: ${res3.geometry}`);
  });

  await t.test('out-of-range index is a new validator error', async (st) => {
    const b = await plantBase(st, rel);
    const ia = b.json.meshes[0].primitives[0].indices;
    b.bin.writeUInt16LE(60000, componentOffset(b.json, ia, 4, 0));
    fs.writeFileSync(b.binPath, b.bin);
    const res = await analyzeConversion(input, b.out, b.dir);
    assert.ok(res.validator.some((d) => /ACCESSOR_INDEX_OOB/.test(d)), `validator: ${res.validator}`);
  });

  await t.test('animation keyframe and inverse bind matrix changes', async (st) => {
    const relA = 'animated/CesiumMan.glb';
    const b = await plantBase(st, relA);
    const s = b.json.animations[0].samplers[0];
    const o1 = componentOffset(b.json, s.output, 1, 0);
    b.bin.writeFloatLE(b.bin.readFloatLE(o1) + 1, o1);
    const ibm = b.json.skins[0].inverseBindMatrices;
    const o2 = componentOffset(b.json, ibm, 0, 12);
    b.bin.writeFloatLE(b.bin.readFloatLE(o2) + 1, o2);
    fs.writeFileSync(b.binPath, b.bin);
    const res = await analyzeConversion(corpusPath(relA), b.out, b.dir);
    assert.ok(res.animSkin.some((d) => /animation 0 sampler 0 output/.test(d)), `animSkin: ${res.animSkin}`);
    assert.ok(res.animSkin.some((d) => /skin 0 inverseBindMatrices: element \[12\]/.test(d)), `animSkin: ${res.animSkin}`);
  });
});

test('geometry comparator reports a missing primitive and a changed material index', async () => {
  const a = await readDocument(corpusPath('scenes/2CylinderEngine.glb'));
  const b = await readDocument(corpusPath('scenes/2CylinderEngine.glb'));
  const mesh = b.getRoot().listMeshes()[0];
  const mats = b.getRoot().listMaterials();
  const prim = mesh.listPrimitives()[0];
  prim.setMaterial(mats.find((m) => m !== prim.getMaterial()) || null);
  const d1 = compareGeometry(a, b);
  assert.ok(d1.some((d) => /mesh 0.* primitive 0: material/.test(d)), d1.join('\n'));
  mesh.removePrimitive(prim);
  const d2 = compareGeometry(a, b);
  assert.ok(d2.some((d) => /mesh 0.*: primitives input \d+, output \d+/.test(d)), d2.join('\n'));
});
