// KHR_meshopt_compression input (the ratified EXT_meshopt_compression): decoded on load like EXT,
// dropped from the output like EXT (extension objects, extensionsUsed/Required, fallback buffers).
// A KHR stream libmeshoptimizer 0.18 cannot decode (a version-1 attribute stream, the COLOR filter)
// takes the file's uncompressed fallback when the extension is optional, and is refused (exit 2, one
// line naming the bufferView and the reason, no output) when it is required or the fallback has no data.
// Before this, KHR was refused when required and, when optional, its object was passed through on a
// bufferView whose bytes lodpipe had repacked: it pointed at compressed bytes the output no longer had.
// Inputs are built here from compressed/BoxMeshopt.glb (gltfpack, EXT, version-0 streams) with the
// meshoptimizer npm package (decoder for the fallback data, encoder for version-1 and COLOR streams).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { MeshoptEncoder } from 'meshoptimizer';
import {
  corpusPath, describeRun, getMeshoptDecoder, listFilesRecursive, oneLineErrorProblems, parseGlb, readRaw,
  runHealthProblems, runLodpipe, skipWithoutBinary, successStderrProblems, tempDir, validateFile,
} from './lib/gltf.mjs';
import { writeGlb } from './lib/lodfixture.mjs';

const skip = skipWithoutBinary();
const BOX = corpusPath('compressed/BoxMeshopt.glb');
const EXT = 'EXT_meshopt_compression';
const KHR = 'KHR_meshopt_compression';

const pad4 = (b) => (b.length % 4 ? Buffer.concat([b, Buffer.alloc(4 - (b.length % 4))]) : b);

/** BoxMeshopt.glb with every EXT_meshopt_compression name (view objects, fallback mark, lists) renamed to KHR. */
function renamedBox() {
  const { json, bin } = parseGlb(fs.readFileSync(BOX));
  return { json: JSON.parse(JSON.stringify(json).replaceAll(EXT, KHR)), bin: Buffer.from(bin) };
}

/**
 * A KHR box: BoxMeshopt's streams re-packed, the uncompressed fallback (the npm decoder's output) in
 * buffers[1], which is marked as fallback. v1: the positions (bufferViews[1]) re-encoded as a version-1
 * stream. color: a COLOR_0 attribute (bufferViews[3], 8-bit RGBA) with the COLOR filter.
 * fallback: 'file' (buffers[1] is box.fallback.bin beside the glb), 'bin' (no buffers[1]: the views read
 * the fallback from the BIN chunk, after the streams) or 'none' (buffers[1] has no uri: no data).
 * Writes dir/box.glb (and the fallback file); returns { file, fallbackFile, json, plain } where plain is
 * the same box uncompressed (dir/plain.glb: the fallback as its only buffer), the data the output must hold.
 */
async function writeKhrBox(dir, { v1 = false, color = false, required = true, fallback = 'file' } = {}) {
  const dec = await getMeshoptDecoder();
  await MeshoptEncoder.ready;
  const { json, bin } = renamedBox();
  const views = json.bufferViews;
  const decoded = views.map((v) => {
    const m = v.extensions[KHR];
    const out = new Uint8Array(m.count * m.byteStride);
    dec.decodeGltfBuffer(out, m.count, m.byteStride, bin.subarray(m.byteOffset || 0, (m.byteOffset || 0) + m.byteLength), m.mode, m.filter || 'NONE');
    return Buffer.from(out);
  });
  const streams = views.map((v) => {
    const m = v.extensions[KHR];
    return Buffer.from(bin.subarray(m.byteOffset || 0, (m.byteOffset || 0) + m.byteLength));
  });
  if (v1) {
    const m = views[1].extensions[KHR];
    streams[1] = Buffer.from(MeshoptEncoder.encodeVertexBufferLevel(decoded[1], m.count, m.byteStride, 2, 1));
    assert.equal(streams[1][0], 0xa1, 'test premise: a version-1 attribute stream');
  }
  if (color) {
    const n = json.accessors[0].count;
    const rgba = new Float32Array(n * 4);
    for (let i = 0; i < n; i++) rgba.set([(i % 5) / 4, (i % 3) / 2, i / (n - 1), 1], i * 4);
    const filtered = MeshoptEncoder.encodeFilterColor(rgba, n, 4, 8);
    const stream = Buffer.from(MeshoptEncoder.encodeGltfBuffer(filtered, n, 4, 'ATTRIBUTES'));
    const out = new Uint8Array(n * 4);
    dec.decodeGltfBuffer(out, n, 4, stream, 'ATTRIBUTES', 'COLOR');
    decoded.push(Buffer.from(out));
    streams.push(stream);
    views.push({ buffer: 1, byteLength: n * 4, byteStride: 4, target: 34962,
      extensions: { [KHR]: { buffer: 0, byteLength: stream.length, byteStride: 4, mode: 'ATTRIBUTES', filter: 'COLOR', count: n } } });
    json.accessors.push({ bufferView: 3, componentType: 5121, normalized: true, count: n, type: 'VEC4' });
    json.meshes[0].primitives[0].attributes.COLOR_0 = json.accessors.length - 1;
  }
  // compressed streams in the BIN chunk (buffers[0]), the fallback's views packed in buffers[1]
  let binOut = Buffer.alloc(0);
  let fb = Buffer.alloc(0);
  views.forEach((v, i) => {
    const m = v.extensions[KHR];
    m.byteOffset = binOut.length;
    m.byteLength = streams[i].length;
    binOut = pad4(Buffer.concat([binOut, streams[i]]));
    v.byteOffset = fb.length;
    fb = pad4(Buffer.concat([fb, decoded[i]]));
  });
  json.buffers = [{ byteLength: binOut.length }, { byteLength: fb.length, extensions: { [KHR]: { fallback: true } } }];
  if (!required) json.extensionsRequired = json.extensionsRequired.filter((e) => e !== KHR);
  // the same box uncompressed: what a client without the extension reads
  const plain = JSON.parse(JSON.stringify(json));
  for (const v of plain.bufferViews) { delete v.extensions; v.buffer = 0; }
  plain.buffers = [{ byteLength: fb.length }];
  plain.extensionsUsed = plain.extensionsUsed.filter((e) => e !== KHR);
  plain.extensionsRequired = plain.extensionsRequired.filter((e) => e !== KHR);
  const plainFile = path.join(dir, 'plain.glb');
  writeGlb(plainFile, plain, fb);

  const fallbackFile = path.join(dir, 'box.fallback.bin');
  if (fallback === 'bin') {
    for (const v of views) { v.buffer = 0; v.byteOffset += binOut.length; }
    binOut = Buffer.concat([binOut, fb]);
    json.buffers = [{ byteLength: binOut.length }];
  } else if (fallback === 'file') {
    json.buffers[1].uri = 'box.fallback.bin';
    fs.writeFileSync(fallbackFile, fb);
  }
  const file = path.join(dir, 'box.glb');
  writeGlb(file, json, binOut);

  return { file, fallbackFile, json, plainFile };
}

/** Problems of a converted output: meshopt left anywhere in its JSON, validator errors. */
async function outputProblems(out) {
  const p = [];
  const { json } = parseGlb(fs.readFileSync(out));
  const text = JSON.stringify(json);
  if (/meshopt/i.test(text)) p.push(`meshopt is still named in the output: ${text.match(/.{0,80}meshopt.{0,80}/i)[0]}`);
  if (json.buffers.length !== 1) p.push(`${json.buffers.length} buffers (expected the BIN chunk alone)`);
  const v = await validateFile(out);
  if (v.errors) p.push(`validator errors: ${JSON.stringify(v.errorCodes)} ${v.exception || ''}`);
  return p;
}

/** Every accessor of `out` holds the bytes of the same accessor of `expected` (both plain files). */
function sameAccessorData(out, expected) {
  const a = readRaw(out);
  const b = readRaw(expected);
  assert.equal(a.json.accessors.length, b.json.accessors.length, 'accessor count');
  for (let i = 0; i < b.json.accessors.length; i++)
    assert.ok(Buffer.from(a.accessorBytes(i)).equals(Buffer.from(b.accessorBytes(i))), `accessor ${i} differs from the expected data`);
}

function convert(input, out) {
  const r = runLodpipe(['convert', input, out]);
  const p = [...runHealthProblems(r), ...successStderrProblems(r.stderr)];
  if (r.status !== 0) p.push(`exit ${r.status}`);
  assert.deepEqual(p, [], describeRun(r));
  return r;
}

/** The KHR box written with `options` and converted: no output problem, every accessor equal to the
 * uncompressed box's (the fallback data, or what the stream decodes to). Returns { dir, box }. */
async function convertsToPlainData(st, options) {
  const dir = tempDir(st);
  const box = await writeKhrBox(dir, options);
  const out = path.join(dir, 'out.glb');
  convert(box.file, out);
  assert.deepEqual(await outputProblems(out), []);
  sameAccessorData(out, box.plainFile);
  return { dir, box };
}

/** A refusal: exit 2, one line matching `needle`, no output file left in dir beyond `keep`. */
function assertRefused(input, dir, needle, keep) {
  const out = path.join(dir, 'out.glb');
  const r = runLodpipe(['convert', input, out]);
  const p = [...runHealthProblems(r), ...oneLineErrorProblems(r.stderr)];
  if (r.status !== 2) p.push(`exit ${r.status} (expected 2)`);
  if (!needle.test(r.stderr)) p.push(`stderr does not match ${needle}`);
  const left = listFilesRecursive(dir).filter((f) => !keep.includes(path.basename(f)));
  if (left.length) p.push(`files left: ${JSON.stringify(left)}`);
  assert.deepEqual(p, [], describeRun(r));
}

test('KHR_meshopt_compression input', { skip }, async (t) => {
  await t.test('required, version 0: decoded; the output is byte-identical to the EXT original\'s', async (st) => {
    const dir = tempDir(st);
    const { json, bin } = renamedBox();
    assert.ok(json.extensionsRequired.includes(KHR), 'test premise');
    const khr = path.join(dir, 'khr.glb');
    writeGlb(khr, json, bin);
    convert(BOX, path.join(dir, 'ext_out.glb'));
    convert(khr, path.join(dir, 'khr_out.glb'));
    assert.deepEqual(await outputProblems(path.join(dir, 'khr_out.glb')), []);
    assert.ok(fs.readFileSync(path.join(dir, 'khr_out.glb')).equals(fs.readFileSync(path.join(dir, 'ext_out.glb'))),
      'the KHR file converts to the same bytes as the EXT file');
    const r = runLodpipe([khr, '-o', path.join(dir, 'main.glb')]);
    assert.equal(r.status, 0, describeRun(r));
    assert.deepEqual(await outputProblems(path.join(dir, 'main.glb')), []);
  });

  await t.test('optional with a fallback file, version 0: decoded, no KHR object left, data = fallback', async (st) => {
    await convertsToPlainData(st, { required: false });
  });

  await t.test('optional, version-1 positions: the fallback data is used, read and listed as an input', async (st) => {
    const { dir, box } = await convertsToPlainData(st, { v1: true, required: false });
    const r = runLodpipe([box.file, '-o', path.join(dir, 'main.glb'), '--json']);
    assert.equal(r.status, 0, describeRun(r));
    assert.ok(JSON.parse(r.stdout).inputs.includes(box.fallbackFile), `the fallback file is an input: ${r.stdout}`);
    assert.deepEqual(await outputProblems(path.join(dir, 'main.glb')), []);
  });

  await t.test('optional, version-1 positions, fallback in the BIN chunk beside the streams: the fallback is used', async (st) => {
    await convertsToPlainData(st, { v1: true, required: false, fallback: 'bin' });
  });

  await t.test('optional, COLOR filter: the fallback data is used', async (st) => {
    await convertsToPlainData(st, { color: true, required: false });
  });

  await t.test('required, version-1 stream -> exit 2 naming the bufferView and the reason', async (st) => {
    const dir = tempDir(st);
    const box = await writeKhrBox(dir, { v1: true, required: true, fallback: 'none' });
    assertRefused(box.file, dir, /bufferViews\[1\]: cannot decode its KHR_meshopt_compression data: a version-1 attribute stream .*required/,
      ['box.glb', 'plain.glb']);
  });

  await t.test('required, COLOR filter -> exit 2 naming the bufferView and the filter', async (st) => {
    const dir = tempDir(st);
    const box = await writeKhrBox(dir, { color: true, required: true, fallback: 'none' });
    assertRefused(box.file, dir, /bufferViews\[3\]: cannot decode its KHR_meshopt_compression data: the COLOR filter .*required/,
      ['box.glb', 'plain.glb']);
  });

  await t.test('a bufferView with both EXT and KHR objects -> exit 2 (the specification forbids it)', async (st) => {
    const dir = tempDir(st);
    const { json, bin } = renamedBox();
    json.bufferViews[0].extensions[EXT] = json.bufferViews[0].extensions[KHR];
    json.extensionsUsed.push(EXT);
    const f = path.join(dir, 'both.glb');
    writeGlb(f, json, bin);
    assertRefused(f, dir, /bufferViews\[0\] has both EXT_meshopt_compression and KHR_meshopt_compression/, ['both.glb']);
  });

  // A stream this build cannot decode is held to the specification's mode, filter and stride all the
  // same: its fallback stands in for a codec, not for a check (before, neither was looked at).
  await t.test('optional, version-1 stream with an unknown filter -> exit 2 naming it; the fallback is not used', async (st) => {
    const dir = tempDir(st);
    const box = await writeKhrBox(dir, { v1: true, required: false });
    const { json, bin } = parseGlb(fs.readFileSync(box.file));
    json.bufferViews[1].extensions[KHR].filter = 'WAVELET';
    writeGlb(box.file, json, bin);
    assertRefused(box.file, dir, /bufferViews\[1\]: unknown meshopt filter "WAVELET"/, ['box.glb', 'plain.glb', 'box.fallback.bin']);
  });

  await t.test('optional, COLOR filter with byteStride 12 -> exit 2 naming the stride; the fallback is not used', async (st) => {
    const dir = tempDir(st);
    const box = await writeKhrBox(dir, { color: true, required: false });
    const { json, bin } = parseGlb(fs.readFileSync(box.file));
    const m = json.bufferViews[3].extensions[KHR];
    assert.equal((m.count * 4) % 12, 0, 'test premise: the same bytes as 12-byte elements');
    m.count = (m.count * 4) / 12;
    m.byteStride = 12;
    json.bufferViews[3].byteStride = 12; // (the view's stride must be the stream's)
    writeGlb(box.file, json, bin);
    assertRefused(box.file, dir, /bufferViews\[3\]: COLOR filter needs byteStride 4 or 8/, ['box.glb', 'plain.glb', 'box.fallback.bin']);
  });

  await t.test('optional, version-1 stream, fallback buffer without data -> exit 2', async (st) => {
    const dir = tempDir(st);
    const box = await writeKhrBox(dir, { v1: true, required: false, fallback: 'none' });
    assertRefused(box.file, dir, /bufferViews\[1\]: cannot decode .*version-1.*fallback buffers\[1\] has no uri/, ['box.glb', 'plain.glb']);
  });
});
