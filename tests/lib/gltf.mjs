// Shared helpers for the lodpipe end-to-end tests (node:test, node >= 20).
//
//  - paths: repo root, corpus, binary under test
//  - runLodpipe(): run the CLI (spawnSync, timeout, captures status/signal/stdout/stderr)
//  - tempDir(t): a fresh temp folder per test, removed afterwards (kept when LODPIPE_KEEP_TMP=1)
//  - validateFile(): Khronos glTF-Validator, external resources resolved next to the file
//  - readRaw(): our own small glTF/GLB reader (JSON + resolved buffers, bufferView/image/accessor bytes)
//  - readDocument(): glTF-Transform NodeIO with ALL_EXTENSIONS + Draco and meshopt decoders
//  - compare*(): the comparators used by roundtrip.test.mjs (each returns a list of human-readable
//    differences; an empty list means "equal under the lodpipe convert contract")
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { spawnSync } from 'node:child_process';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';

const require = createRequire(import.meta.url);

// ---------------------------------------------------------------------------------------------
// Paths

export const repoRoot = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');
export const sharedRoot = process.env.LODPIPE_SHARED || path.resolve(repoRoot, '..', 'shared');
export const assetsDir = path.join(sharedRoot, 'assets');
export const lodpipeBin = process.env.LODPIPE_BIN || path.join(repoRoot, 'build', 'lodpipe');

export function corpusPath(rel) {
  return path.join(assetsDir, rel);
}

let manifestCache = null;
export function loadManifest() {
  if (!manifestCache) manifestCache = JSON.parse(fs.readFileSync(path.join(assetsDir, 'manifest.json'), 'utf8'));
  return manifestCache;
}

/** Main input files (.gltf/.glb) of the manifest; side files (.bin, images) are never listed as inputs. */
export function manifestInputs(filter = () => true) {
  return loadManifest().files.filter((f) => /\.(gltf|glb)$/i.test(f.path)).filter(filter);
}

/** True when f is an executable regular file. */
export function isExecutable(f) {
  try {
    fs.accessSync(f, fs.constants.X_OK);
    return fs.statSync(f).isFile();
  } catch {
    return false;
  }
}

export function binaryExists() {
  return isExecutable(lodpipeBin);
}

/** Reason string for { skip } when the binary under test is missing, else false. */
export function skipWithoutBinary() {
  return binaryExists() ? false : `lodpipe binary not found at ${lodpipeBin} (build it or set LODPIPE_BIN)`;
}

// ---------------------------------------------------------------------------------------------
// Running the CLI

export const RUN_TIMEOUT_MS = Number(process.env.LODPIPE_TIMEOUT_MS || 120000);

/**
 * Run lodpipe with the given arguments. Never throws for a non-zero exit.
 * `prefix`: a command that runs lodpipe (e.g. ['setpriv', '--reuid=65534', ...] or a shell that sets a limit
 * first), lodpipe and its arguments appended. `bin`: another lodpipe binary (e.g. the optimized build).
 * Returns { status, signal, stdout, stderr, error, ms, cmd }.
 */
export function runLodpipe(args, { cwd = repoRoot, timeout = RUN_TIMEOUT_MS, env, prefix = [], bin = lodpipeBin } = {}) {
  const t0 = Date.now();
  const argv = [...prefix, bin, ...args];
  const r = spawnSync(argv[0], argv.slice(1), {
    cwd,
    timeout,
    encoding: 'utf8',
    maxBuffer: 64 * 1024 * 1024,
    env: { ...process.env, ...(env || {}) },
  });
  return {
    status: r.status,
    signal: r.signal,
    stdout: r.stdout ?? '',
    stderr: r.stderr ?? '',
    error: r.error ? String(r.error) : null,
    ms: Date.now() - t0,
    cmd: argv.map((a) => (/\s/.test(a) ? JSON.stringify(a) : a)).join(' '),
  };
}

/** Short description of a run for assertion messages. */
export function describeRun(r) {
  const clip = (s) => (s.length > 2000 ? s.slice(0, 2000) + `... [${s.length} chars]` : s);
  return `$ ${r.cmd}\n  status=${r.status} signal=${r.signal}${r.error ? ' error=' + r.error : ''} (${r.ms} ms)\n` +
    `  stderr: ${JSON.stringify(clip(r.stderr))}\n  stdout: ${JSON.stringify(clip(r.stdout))}`;
}

const SANITIZER_MARKERS = ['AddressSanitizer', 'runtime error:', 'LeakSanitizer', 'MemorySanitizer', 'ThreadSanitizer'];

/** Problems common to every run: crash signal, spawn error/timeout, sanitizer report. */
export function runHealthProblems(r) {
  const p = [];
  if (r.error) p.push(`could not run / timed out: ${r.error}`);
  if (r.signal) p.push(`killed by signal ${r.signal}`);
  for (const m of SANITIZER_MARKERS) if (r.stderr.includes(m)) p.push(`stderr contains sanitizer report '${m}'`);
  return p;
}

/** stderr is exactly one line "lodpipe: <FILE>: <what is wrong>" (with or without final newline). */
export function oneLineErrorProblems(stderr) {
  const p = [];
  const body = stderr.endsWith('\n') ? stderr.slice(0, -1) : stderr;
  if (body.length === 0) p.push('stderr is empty (expected one error line)');
  else if (body.includes('\n')) p.push(`stderr has ${body.split('\n').length} lines (expected exactly one)`);
  else if (!/^lodpipe: .+: .+$/.test(body)) p.push(`stderr line does not match /^lodpipe: .+: .+$/: ${JSON.stringify(body)}`);
  return p;
}

/** On success stderr may only contain warning lines. */
export function successStderrProblems(stderr) {
  const bad = stderr.split('\n').filter((l) => l.trim() !== '' && !/warning/i.test(l));
  return bad.length ? [`stderr of a successful run has non-warning line(s): ${JSON.stringify(bad.slice(0, 3))}`] : [];
}

// ---------------------------------------------------------------------------------------------
// Temp folders

const KEEP_TMP = process.env.LODPIPE_KEEP_TMP === '1';

/** A fresh empty folder; removed after the test `t` (if given) unless LODPIPE_KEEP_TMP=1. */
export function tempDir(t, prefix = 'lodpipe-test-') {
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), prefix));
  if (t && !KEEP_TMP) t.after(() => fs.rmSync(dir, { recursive: true, force: true }));
  return dir;
}

/** An empty exFAT volume (it ignores case, as a Windows or macOS share does) mounted through a loop device and
 * FUSE (exfatprogs, exfat-fuse); { mount } or { skip: why } when this machine cannot (not root, no loop device
 * or /dev/fuse). Unmounted and removed after the test. */
export function caseBlindVolume(t) {
  if (process.getuid() !== 0) return { skip: 'mounting a volume needs root' };
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'lodpipe-exfat-'));
  const image = path.join(dir, 'volume.img'), mount = path.join(dir, 'mnt');
  // the tools live in sbin, which a PATH may leave out
  const where = (cmd) => ['/usr/sbin', '/sbin', '/usr/bin', '/bin'].map((d) => path.join(d, cmd)).find((f) => fs.existsSync(f));
  const sh = (cmd, ...args) => spawnSync(where(cmd) ?? cmd, args, { encoding: 'utf8', timeout: 30000 });
  let device = null, mounted = false;
  t.after(() => {
    if (mounted && sh('umount', mount).status !== 0) sh('umount', '-l', mount); // lazily when still busy
    if (device) sh('losetup', '-d', device);
    fs.rmSync(dir, { recursive: true, force: true });
  });
  fs.mkdirSync(mount);
  fs.writeFileSync(image, '');
  fs.truncateSync(image, 64 << 20);
  const made = sh('mkfs.exfat', image);
  if (made.status !== 0) return { skip: `mkfs.exfat: ${made.error?.message ?? made.stderr.trim()}` };
  const loop = sh('losetup', '-f', '--show', image);
  if (loop.status !== 0) return { skip: `losetup: ${loop.error?.message ?? loop.stderr.trim()}` };
  device = loop.stdout.trim();
  const m = sh('mount.exfat-fuse', device, mount);
  if (m.status !== 0) return { skip: `mount.exfat-fuse: ${m.error?.message ?? m.stderr.trim()}` };
  mounted = true;
  fs.writeFileSync(path.join(mount, 'probe'), '');
  if (!fs.existsSync(path.join(mount, 'PROBE'))) throw new Error('the exFAT volume does not ignore case');
  fs.rmSync(path.join(mount, 'probe'));
  return { mount };
}

/** All files below dir, relative paths with '/' separators, sorted. */
export function listFilesRecursive(dir) {
  const out = [];
  const walk = (d, rel) => {
    for (const e of fs.readdirSync(d, { withFileTypes: true })) {
      const r = rel ? `${rel}/${e.name}` : e.name;
      if (e.isDirectory()) {
        out.push(r + '/');
        walk(path.join(d, e.name), r);
      } else out.push(r);
    }
  };
  walk(dir, '');
  return out.sort();
}

// ---------------------------------------------------------------------------------------------
// Khronos validator

let validatorModule = null;
function validator() {
  if (!validatorModule) validatorModule = require('gltf-validator');
  return validatorModule;
}

/**
 * Validate a .gltf/.glb with the Khronos glTF-Validator; external resources are read next to the file.
 * Returns { errors, warnings, infos, hints, errorCodes: {CODE: n}, warningCodes, messages, exception }.
 * A validator exception (e.g. unrecognisable data) counts as one error VALIDATOR_EXCEPTION.
 */
export async function validateFile(file) {
  const dir = path.dirname(file);
  let bytes;
  try {
    bytes = new Uint8Array(fs.readFileSync(file));
  } catch (e) {
    return { errors: 1, warnings: 0, infos: 0, hints: 0, errorCodes: { READ_FAILED: 1 }, warningCodes: {}, messages: [], exception: String(e) };
  }
  try {
    const report = await validator().validateBytes(bytes, {
      uri: path.basename(file),
      maxIssues: 0,
      externalResourceFunction: (uri) =>
        new Promise((resolve, reject) => {
          let p;
          try {
            p = path.resolve(dir, decodeURIComponent(uri));
          } catch (e) {
            reject(String(e));
            return;
          }
          fs.readFile(p, (err, data) => (err ? reject(err.toString()) : resolve(new Uint8Array(data))));
        }),
    });
    const iss = report.issues;
    const errorCodes = {};
    const warningCodes = {};
    for (const m of iss.messages) {
      if (m.severity === 0) errorCodes[m.code] = (errorCodes[m.code] || 0) + 1;
      else if (m.severity === 1) warningCodes[m.code] = (warningCodes[m.code] || 0) + 1;
    }
    return {
      errors: iss.numErrors, warnings: iss.numWarnings, infos: iss.numInfos, hints: iss.numHints,
      errorCodes, warningCodes, messages: iss.messages, exception: null,
    };
  } catch (e) {
    return { errors: 1, warnings: 0, infos: 0, hints: 0, errorCodes: { VALIDATOR_EXCEPTION: 1 }, warningCodes: {}, messages: [], exception: String(e) };
  }
}

const validationCache = new Map();
/** validateFile, memoised per path (corpus inputs are read-only). */
export function validateFileCached(file) {
  if (!validationCache.has(file)) validationCache.set(file, validateFile(file));
  return validationCache.get(file);
}

/** Error codes whose count in `out` exceeds the count in `inp` (a: "no new validator errors"). */
export function newValidatorErrors(inp, out) {
  const diffs = [];
  for (const [code, n] of Object.entries(out.errorCodes)) {
    const before = inp.errorCodes[code] || 0;
    if (n > before) {
      const ex = out.messages.filter((m) => m.severity === 0 && m.code === code).slice(0, 2)
        .map((m) => `${m.message} ${m.pointer || ''}`.trim());
      if (!ex.length && out.exception) ex.push(out.exception);
      diffs.push(`validator error ${code}: output has ${n}, input had ${before}; e.g. ${JSON.stringify(ex)}`);
    }
  }
  return diffs;
}

// ---------------------------------------------------------------------------------------------
// Raw reader: JSON + resolved buffers (no decoding of Draco/meshopt)

const GLB_MAGIC = 0x46546c67; // 'glTF'
const CHUNK_JSON = 0x4e4f534a;
const CHUNK_BIN = 0x004e4942;

export function isDataUri(uri) {
  return typeof uri === 'string' && /^data:/i.test(uri);
}

export function decodeDataUri(uri) {
  const m = /^data:([^,]*?),(.*)$/is.exec(uri);
  if (!m) throw new Error(`malformed data URI ${uri.slice(0, 40)}...`);
  if (/;base64$/i.test(m[1])) return new Uint8Array(Buffer.from(m[2], 'base64'));
  return new Uint8Array(Buffer.from(decodeURIComponent(m[2]), 'latin1'));
}

/** Parse a GLB container. Returns { json, bin } (bin: Uint8Array or null). Throws on malformed data. */
export function parseGlb(bytes) {
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  if (bytes.byteLength < 12) throw new Error('GLB shorter than its 12-byte header');
  if (dv.getUint32(0, true) !== GLB_MAGIC) throw new Error('bad GLB magic');
  if (dv.getUint32(4, true) !== 2) throw new Error(`GLB version ${dv.getUint32(4, true)}`);
  const length = dv.getUint32(8, true);
  if (length !== bytes.byteLength) throw new Error(`GLB length field ${length} != file size ${bytes.byteLength}`);
  let off = 12;
  let json = null;
  let bin = null;
  let idx = 0;
  while (off < length) {
    if (off + 8 > length) throw new Error('truncated GLB chunk header');
    const clen = dv.getUint32(off, true);
    const ctype = dv.getUint32(off + 4, true);
    if (off + 8 + clen > length) throw new Error('GLB chunk runs past the end of the file');
    const data = bytes.subarray(off + 8, off + 8 + clen);
    if (idx === 0) {
      if (ctype !== CHUNK_JSON) throw new Error('first GLB chunk is not JSON');
      json = JSON.parse(Buffer.from(data).toString('utf8'));
    } else if (idx === 1 && ctype === CHUNK_BIN) bin = data;
    off += 8 + clen;
    idx++;
  }
  if (!json) throw new Error('GLB without JSON chunk');
  return { json, bin };
}

const COMPONENT_SIZE = { 5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4 };
const COMPONENT_ARRAY = { 5120: Int8Array, 5121: Uint8Array, 5122: Int16Array, 5123: Uint16Array, 5125: Uint32Array, 5126: Float32Array };
const TYPE_SHAPE = { SCALAR: [1, 1], VEC2: [1, 2], VEC3: [1, 3], VEC4: [1, 4], MAT2: [2, 2], MAT3: [3, 3], MAT4: [4, 4] }; // [columns, rows]

/** Bytes one element of accessor acc takes in a tightly packed view (matrix columns padded to 4 bytes); 0 when unknown. */
export function accessorElementBytes(acc) {
  const csize = COMPONENT_SIZE[acc.componentType];
  const shape = TYPE_SHAPE[acc.type];
  if (!csize || !shape) return 0;
  const [cols, rows] = shape;
  return cols > 1 ? cols * Math.ceil((rows * csize) / 4) * 4 : rows * csize;
}

/**
 * Read a .gltf or .glb into { file, dir, kind, json, buffers[] } plus accessors to the binary data:
 *   viewBytes(i), imageBytes(i) -> { bytes, source }, accessorBytes(i) -> packed element bytes (sparse applied).
 * External buffers/images are read next to the file; data: URIs are decoded. Buffers that cannot be
 * resolved are null (reading a view of them throws).
 */
export function readRaw(file, { meshoptDecoder = null } = {}) {
  const bytes = new Uint8Array(fs.readFileSync(file));
  const dir = path.dirname(file);
  let json;
  let glbBin = null;
  let kind;
  const magic = bytes.byteLength >= 4 ? new DataView(bytes.buffer, bytes.byteOffset, 4).getUint32(0, true) : 0;
  if (magic === GLB_MAGIC) {
    kind = 'glb';
    ({ json, bin: glbBin } = parseGlb(bytes));
  } else {
    kind = 'gltf';
    let text = Buffer.from(bytes).toString('utf8');
    if (text.charCodeAt(0) === 0xfeff) text = text.slice(1);
    json = JSON.parse(text);
  }
  const externalFiles = [];
  const loadUri = (uri) => {
    if (isDataUri(uri)) return decodeDataUri(uri);
    const p = path.resolve(dir, decodeURIComponent(uri));
    externalFiles.push(p);
    return new Uint8Array(fs.readFileSync(p));
  };
  const buffers = (json.buffers || []).map((b, i) => {
    try {
      if (b.uri === undefined) return kind === 'glb' && i === 0 ? glbBin : null;
      return loadUri(b.uri);
    } catch {
      return null;
    }
  });
  const raw = { file, dir, kind, json, buffers, glbBin, externalFiles };

  const decodedViews = new Map();
  raw.meshoptDecoded = !!meshoptDecoder;
  raw.viewBytes = (i) => {
    const bv = json.bufferViews?.[i];
    if (!bv) throw new Error(`bufferView ${i} does not exist`);
    const mo = bv.extensions?.EXT_meshopt_compression || bv.extensions?.KHR_meshopt_compression;
    if (mo && meshoptDecoder) {
      // EXT_meshopt_compression: decode the compressed stream (the fallback buffer may hold no data)
      if (!decodedViews.has(i)) {
        const src = buffers[mo.buffer];
        if (!src) throw new Error(`meshopt source buffer ${mo.buffer} of bufferView ${i} is not available`);
        const off = mo.byteOffset || 0;
        if (off + mo.byteLength > src.byteLength) throw new Error(`meshopt stream of bufferView ${i} runs past its buffer`);
        const target = new Uint8Array(mo.count * mo.byteStride);
        meshoptDecoder.decodeGltfBuffer(target, mo.count, mo.byteStride, src.subarray(off, off + mo.byteLength), mo.mode, mo.filter || 'NONE');
        decodedViews.set(i, target);
      }
      return decodedViews.get(i);
    }
    const buf = buffers[bv.buffer];
    if (!buf) throw new Error(`buffer ${bv.buffer} of bufferView ${i} is not available`);
    const off = bv.byteOffset || 0;
    if (off + bv.byteLength > buf.byteLength) throw new Error(`bufferView ${i} runs past the end of buffer ${bv.buffer}`);
    return buf.subarray(off, off + bv.byteLength);
  };

  raw.imageBytes = (i) => {
    const img = json.images?.[i];
    if (!img) throw new Error(`image ${i} does not exist`);
    if (img.bufferView !== undefined) return { bytes: raw.viewBytes(img.bufferView), source: `bufferView ${img.bufferView}` };
    if (img.uri !== undefined) return { bytes: loadUri(img.uri), source: isDataUri(img.uri) ? 'data URI' : `uri ${img.uri}` };
    throw new Error(`image ${i} has neither uri nor bufferView`);
  };

  /** Packed bytes of accessor i (count * element size, matrix column padding removed, sparse applied). */
  raw.accessorBytes = (i) => {
    const acc = json.accessors?.[i];
    if (!acc) throw new Error(`accessor ${i} does not exist`);
    const csize = COMPONENT_SIZE[acc.componentType];
    const shape = TYPE_SHAPE[acc.type];
    if (!csize || !shape) throw new Error(`accessor ${i}: bad componentType/type`);
    const [cols, rows] = shape;
    const colBytes = rows * csize;
    const colStride = cols > 1 ? Math.ceil(colBytes / 4) * 4 : colBytes;
    const elemSize = cols * colBytes;
    const out = new Uint8Array(acc.count * elemSize);
    if (acc.bufferView !== undefined) {
      const view = raw.viewBytes(acc.bufferView);
      const stride = json.bufferViews[acc.bufferView].byteStride || cols * colStride;
      const base = acc.byteOffset || 0;
      for (let e = 0; e < acc.count; e++) {
        for (let c = 0; c < cols; c++) {
          const src = base + e * stride + c * colStride;
          if (src + colBytes > view.byteLength) throw new Error(`accessor ${i} element ${e} runs past its bufferView`);
          out.set(view.subarray(src, src + colBytes), e * elemSize + c * colBytes);
        }
      }
    }
    if (acc.sparse) {
      const s = acc.sparse;
      const isz = COMPONENT_SIZE[s.indices.componentType];
      const iv = raw.viewBytes(s.indices.bufferView);
      const ioff = s.indices.byteOffset || 0;
      const vv = raw.viewBytes(s.values.bufferView);
      const voff = s.values.byteOffset || 0;
      const idv = new DataView(iv.buffer, iv.byteOffset, iv.byteLength);
      for (let k = 0; k < s.count; k++) {
        const at = ioff + k * isz;
        const target = isz === 1 ? idv.getUint8(at) : isz === 2 ? idv.getUint16(at, true) : idv.getUint32(at, true);
        if (target >= acc.count) throw new Error(`accessor ${i}: sparse index ${target} out of range`);
        for (let c = 0; c < cols; c++) {
          const src = voff + k * elemSize + c * colBytes; // sparse values are tightly packed (no padding)
          out.set(vv.subarray(src, src + colBytes), target * elemSize + c * colBytes);
        }
      }
    }
    return out;
  };

  /** Element values of accessor i as a typed array of its component type (copy). */
  raw.accessorArray = (i) => {
    const acc = json.accessors[i];
    const b = raw.accessorBytes(i);
    const copy = new Uint8Array(b); // aligned
    return new COMPONENT_ARRAY[acc.componentType](copy.buffer, 0, copy.byteLength / COMPONENT_SIZE[acc.componentType]);
  };
  return raw;
}

// ---------------------------------------------------------------------------------------------
// glTF-Transform reader

export const COMPRESSION_EXTENSIONS = ['KHR_draco_mesh_compression', 'EXT_meshopt_compression', 'KHR_meshopt_compression'];

let meshoptPromise = null;
/** The meshoptimizer decoder (MeshoptDecoder from the meshoptimizer package), ready to use. */
export function getMeshoptDecoder() {
  if (!meshoptPromise) {
    meshoptPromise = (async () => {
      const { MeshoptDecoder } = await import('meshoptimizer/decoder');
      await MeshoptDecoder.ready;
      return MeshoptDecoder;
    })();
  }
  return meshoptPromise;
}

let ioPromise = null;
/** A NodeIO with ALL_EXTENSIONS registered and the Draco + meshopt decoders (shared, created once). */
export function getIO() {
  if (!ioPromise) {
    ioPromise = (async () => {
      const { NodeIO } = await import('@gltf-transform/core');
      const { ALL_EXTENSIONS } = await import('@gltf-transform/extensions');
      const draco3d = (await import('draco3d')).default;
      const MeshoptDecoder = await getMeshoptDecoder();
      return new NodeIO().registerExtensions(ALL_EXTENSIONS).registerDependencies({
        'draco3d.decoder': await draco3d.createDecoderModule(),
        'meshopt.decoder': MeshoptDecoder,
      });
    })();
  }
  return ioPromise;
}

/** Read a glTF/GLB (decoding Draco and meshopt) into a glTF-Transform Document. */
export async function readDocument(file) {
  const io = await getIO();
  return io.read(file);
}

// ---------------------------------------------------------------------------------------------
// Comparators. Each returns an array of difference strings (empty = equal).

const MAX_DIFFS = 20;

function fmt(v) {
  if (v === undefined) return '(absent)';
  if (typeof v === 'number') return Object.is(v, -0) ? '-0' : String(v);
  if (Array.isArray(v) && v.every((x) => typeof x === 'number')) {
    const s = '[' + v.map((x) => fmt(x)).join(',') + ']';
    return s.length > 200 ? s.slice(0, 200) + '...' : s;
  }
  const s = JSON.stringify(v);
  if (s === undefined) return String(v);
  return s.length > 200 ? s.slice(0, 200) + '...' : s;
}

function isPlainObject(v) {
  return v !== null && typeof v === 'object' && !Array.isArray(v);
}

/**
 * Deep JSON difference (objects: key-order-insensitive; arrays: order-sensitive).
 * Pushes "path: input X, output Y" strings to diffs (at most `limit`).
 */
export function diffJson(a, b, p = '', diffs = [], limit = MAX_DIFFS) {
  if (diffs.length >= limit) return diffs;
  if (Array.isArray(a) && Array.isArray(b)) {
    if (a.length !== b.length) diffs.push(`${p || '/'}: array length input ${a.length}, output ${b.length}`);
    for (let i = 0; i < Math.min(a.length, b.length) && diffs.length < limit; i++) diffJson(a[i], b[i], `${p}/${i}`, diffs, limit);
    return diffs;
  }
  if (isPlainObject(a) && isPlainObject(b)) {
    const keys = [...new Set([...Object.keys(a), ...Object.keys(b)])].sort();
    for (const k of keys) {
      if (diffs.length >= limit) break;
      if (!(k in b)) diffs.push(`${p}/${k}: input ${fmt(a[k])}, output (absent)${defaultNote(`${p}/${k}`, a[k], undefined)}`);
      else if (!(k in a)) diffs.push(`${p}/${k}: input (absent), output ${fmt(b[k])}${defaultNote(`${p}/${k}`, undefined, b[k])}`);
      else diffJson(a[k], b[k], `${p}/${k}`, diffs, limit);
    }
    return diffs;
  }
  if (a !== b) diffs.push(`${p || '/'}: input ${fmt(a)}, output ${fmt(b)}${defaultNote(p, a, b)}`);
  return diffs;
}

// Spec default values, only used to annotate a difference where one side omits a property and the other
// writes its default (still a difference under the "JSON unchanged" contract, but easy to triage).
const SPEC_DEFAULTS = {
  mode: 4, normalized: false, byteOffset: 0, translation: [0, 0, 0], rotation: [0, 0, 0, 1], scale: [1, 1, 1],
  matrix: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1], baseColorFactor: [1, 1, 1, 1], metallicFactor: 1,
  roughnessFactor: 1, emissiveFactor: [0, 0, 0], alphaMode: 'OPAQUE', alphaCutoff: 0.5, doubleSided: false,
  texCoord: 0, strength: 1, wrapS: 10497, wrapT: 10497, interpolation: 'LINEAR',
};
function defaultNote(p, a, b) {
  const key = p.split('/').pop();
  const present = a === undefined ? b : b === undefined ? a : undefined;
  if (present === undefined || !(key in SPEC_DEFAULTS)) return '';
  const d = SPEC_DEFAULTS[key];
  const eq = JSON.stringify(d) === JSON.stringify(present) || (key === 'scale' && present === 1);
  return eq ? ` [note: ${a === undefined ? 'output writes' : 'output omits'} the spec default]` : '';
}

const clone = (v) => (v === undefined ? undefined : JSON.parse(JSON.stringify(v)));

function dropEmptyExtensions(obj) {
  if (isPlainObject(obj) && isPlainObject(obj.extensions) && Object.keys(obj.extensions).length === 0) delete obj.extensions;
}

function stripCompression(obj) {
  if (isPlainObject(obj) && isPlainObject(obj.extensions)) {
    let removed = false;
    for (const e of COMPRESSION_EXTENSIONS) {
      if (e in obj.extensions) {
        delete obj.extensions[e];
        removed = true;
      }
    }
    if (removed) dropEmptyExtensions(obj);
  }
}

/**
 * The JSON sub-trees that convert must keep, with the allowed differences removed:
 * bufferView indices / byteOffsets, buffers and bufferViews themselves, compression extensions,
 * image uri/bufferView/mimeType storage form.
 */
export function contractView(json) {
  const j = clone(json);
  const v = {};
  v.asset = j.asset;
  v.scene = j.scene;
  v.scenes = j.scenes;
  v.nodes = j.nodes;
  v.meshes = j.meshes;
  for (const m of v.meshes || []) for (const prim of m?.primitives || []) stripCompression(prim);
  v.accessors = j.accessors;
  for (const a of v.accessors || []) {
    if (!isPlainObject(a)) continue;
    delete a.bufferView;
    delete a.byteOffset;
    if (isPlainObject(a.sparse)) {
      for (const part of ['indices', 'values']) {
        if (isPlainObject(a.sparse[part])) {
          delete a.sparse[part].bufferView;
          delete a.sparse[part].byteOffset;
        }
      }
    }
    stripCompression(a);
  }
  v.materials = j.materials;
  v.textures = j.textures;
  v.samplers = j.samplers;
  v.images = j.images;
  for (const im of v.images || []) {
    if (!isPlainObject(im)) continue;
    delete im.uri;
    delete im.bufferView;
    delete im.mimeType;
  }
  v.animations = j.animations;
  v.skins = j.skins;
  v.cameras = j.cameras;
  v.extensions = j.extensions;
  if (isPlainObject(v.extensions)) {
    for (const e of COMPRESSION_EXTENSIONS) delete v.extensions[e];
    if (Object.keys(v.extensions).length === 0) v.extensions = undefined;
  }
  v.extras = j.extras;
  const notCompression = (e) => !COMPRESSION_EXTENSIONS.includes(e);
  v.extensionsUsed = (j.extensionsUsed || []).filter(notCompression);
  v.extensionsRequired = (j.extensionsRequired || []).filter(notCompression);
  return v;
}

/** c. JSON sub-trees survive (input vs output). */
export function compareJson(rawIn, rawOut) {
  const a = contractView(rawIn.json);
  const b = contractView(rawOut.json);
  const diffs = [];
  for (const key of Object.keys(a)) {
    if (diffs.length >= MAX_DIFFS) break;
    const av = a[key];
    const bv = b[key];
    if (av === undefined && bv === undefined) continue;
    // An absent top-level array and an empty one mean the same thing (e.g. "animations": []).
    if (Array.isArray(av) && av.length === 0 && bv === undefined) continue;
    if (Array.isArray(bv) && bv.length === 0 && av === undefined) continue;
    if (av === undefined || bv === undefined) {
      diffs.push(`/${key}: input ${fmt(av)}, output ${fmt(bv)}`);
      continue;
    }
    diffJson(av, bv, `/${key}`, diffs);
  }
  return diffs;
}

function firstByteDiff(a, b) {
  const n = Math.min(a.byteLength, b.byteLength);
  for (let i = 0; i < n; i++) if (a[i] !== b[i]) return i;
  return a.byteLength === b.byteLength ? -1 : n;
}

/** c. image bytes identical, resolved from uri / data URI / bufferView on each side. */
export function compareImages(rawIn, rawOut) {
  const diffs = [];
  const ni = rawIn.json.images?.length || 0;
  const no = rawOut.json.images?.length || 0;
  if (ni !== no) diffs.push(`/images: input has ${ni} images, output ${no}`);
  for (let i = 0; i < Math.min(ni, no) && diffs.length < MAX_DIFFS; i++) {
    let a;
    let b;
    try {
      a = rawIn.imageBytes(i);
    } catch (e) {
      diffs.push(`/images/${i}: cannot resolve input image: ${e.message}`);
      continue;
    }
    try {
      b = rawOut.imageBytes(i);
    } catch (e) {
      diffs.push(`/images/${i}: cannot resolve output image: ${e.message}`);
      continue;
    }
    const at = firstByteDiff(a.bytes, b.bytes);
    if (at >= 0) {
      diffs.push(`/images/${i}: image bytes differ (input ${a.bytes.byteLength} bytes from ${a.source}, ` +
        `output ${b.bytes.byteLength} bytes from ${b.source}; first difference at byte ${at})`);
    }
  }
  return diffs;
}

/**
 * Accessor indices whose input data the raw reader cannot provide: Draco-compressed ones, and meshopt ones
 * when the reader was created without a meshopt decoder.
 */
export function compressedAccessorIndices(json, meshoptDecoded = false) {
  const set = new Set();
  for (const m of json.meshes || []) {
    for (const prim of m.primitives || []) {
      if (prim.extensions?.KHR_draco_mesh_compression) {
        for (const a of Object.values(prim.attributes || {})) set.add(a);
        if (prim.indices !== undefined) set.add(prim.indices);
      }
    }
  }
  const mv = new Set();
  if (!meshoptDecoded) (json.bufferViews || []).forEach((bv, i) => {
    if (bv.extensions?.EXT_meshopt_compression || bv.extensions?.KHR_meshopt_compression) mv.add(i);
  });
  (json.accessors || []).forEach((a, i) => {
    if (mv.has(a.bufferView) || mv.has(a.sparse?.indices?.bufferView) || mv.has(a.sparse?.values?.bufferView)) set.add(i);
  });
  return set;
}

function elementValues(bytes, componentType, elemIndex, elemSize) {
  const Arr = COMPONENT_ARRAY[componentType];
  const slice = new Uint8Array(bytes.subarray(elemIndex * elemSize, (elemIndex + 1) * elemSize));
  return Array.from(new Arr(slice.buffer, 0, slice.byteLength / COMPONENT_SIZE[componentType]));
}

/**
 * Every accessor's element data (read by our own reader, byte-exact) is unchanged, accessor by accessor.
 * Accessors whose input data is Draco/meshopt-compressed are skipped here (glTF-Transform checks them).
 */
export function compareAccessorData(rawIn, rawOut, { notes = null } = {}) {
  const diffs = [];
  const skip = compressedAccessorIndices(rawIn.json, rawIn.meshoptDecoded);
  const accIn = rawIn.json.accessors || [];
  const accOut = rawOut.json.accessors || [];
  if (accIn.length !== accOut.length) diffs.push(`/accessors: input has ${accIn.length}, output ${accOut.length}`);
  for (let i = 0; i < Math.min(accIn.length, accOut.length) && diffs.length < MAX_DIFFS; i++) {
    if (skip.has(i)) continue;
    let a;
    let b;
    try {
      a = rawIn.accessorBytes(i);
    } catch (e) {
      diffs.push(`/accessors/${i}: cannot read input data: ${e.message}`);
      continue;
    }
    try {
      b = rawOut.accessorBytes(i);
    } catch (e) {
      diffs.push(`/accessors/${i}: cannot read output data: ${e.message}`);
      continue;
    }
    if (accIn[i].componentType !== accOut[i].componentType || accIn[i].type !== accOut[i].type) continue; // reported by compareJson
    const tol = toleranceFor(rawIn.json, i, notes);
    if (tol.ulp && a.byteLength === b.byteLength && firstByteDiff(a, b) >= 0) {
      const name = accIn[i].name ? ` (${accIn[i].name})` : '';
      const d = diffTypedArrays(rawIn.accessorArray(i), rawOut.accessorArray(i), `/accessors/${i}${name} components`, tol);
      if (d) diffs.push(d);
      continue;
    }
    const at = firstByteDiff(a, b);
    if (at >= 0) {
      const elemSize = a.byteLength / (accIn[i].count || 1);
      const e = Math.floor(at / elemSize);
      const name = accIn[i].name ? ` (${accIn[i].name})` : '';
      if (a.byteLength !== b.byteLength) diffs.push(`/accessors/${i}${name}: data length input ${a.byteLength} bytes, output ${b.byteLength}`);
      else {
        diffs.push(`/accessors/${i}${name}: element ${e} differs: input ${fmt(elementValues(a, accIn[i].componentType, e, elemSize))}, ` +
          `output ${fmt(elementValues(b, accOut[i].componentType, e, elemSize))}`);
      }
    }
  }
  return diffs;
}

// EXT_meshopt_compression, Appendix B (Filters): "For performance reasons the results of the decoding process
// are specified to one unit in last place (ULP) in terms of the decoded data". Two conforming decoders (e.g.
// the native SSE build of libmeshoptimizer and the WASM one glTF-Transform uses) may therefore disagree by
// 1 ULP on data that went through a meshopt filter (OCTAHEDRAL, QUATERNION, EXPONENTIAL). Only there, and
// only by 1 ULP, a difference is tolerated (and reported as a note). LODPIPE_MESHOPT_EXACT=1 makes it exact.
export const MESHOPT_FILTER_ULP = process.env.LODPIPE_MESHOPT_EXACT === '1' ? 0 : 1;

/** The meshopt filter (OCTAHEDRAL/QUATERNION/EXPONENTIAL) the input data of accessor i went through, or null. */
export function meshoptFilterOf(json, accIndex) {
  const a = json?.accessors?.[accIndex];
  if (!a || a.bufferView === undefined) return null;
  const bv = json.bufferViews?.[a.bufferView];
  const mo = bv?.extensions?.EXT_meshopt_compression || bv?.extensions?.KHR_meshopt_compression;
  return mo && mo.filter && mo.filter !== 'NONE' ? mo.filter : null;
}

const f32 = new Float32Array(2);
const f32bits = new Int32Array(f32.buffer);
function withinUlp(x, y, arr, ulp) {
  if (arr instanceof Float32Array) {
    if (Number.isNaN(x) || Number.isNaN(y)) return false;
    f32[0] = x;
    f32[1] = y;
    if ((f32bits[0] < 0) !== (f32bits[1] < 0)) return x === y; // +0/-0 only
    return Math.abs(f32bits[0] - f32bits[1]) <= ulp;
  }
  return Math.abs(x - y) <= ulp;
}

/**
 * Compare two typed arrays element-wise with Object.is (NaN equals NaN, -0 differs from 0).
 * opts.ulp > 0 (meshopt-filtered data only) tolerates differences of that many ULP; opts.notes receives a
 * note when that tolerance was used.
 */
export function diffTypedArrays(a, b, label, { allowTypeChange = false, ulp = 0, notes = null, why = '' } = {}) {
  if (!a && !b) return null;
  if (!a || !b) return `${label}: input ${a ? 'present' : 'absent'}, output ${b ? 'present' : 'absent'}`;
  if (!allowTypeChange && a.constructor.name !== b.constructor.name) return `${label}: array type input ${a.constructor.name}, output ${b.constructor.name}`;
  if (a.length !== b.length) return `${label}: length input ${a.length}, output ${b.length}`;
  let tolerated = 0;
  let firstTolerated = -1;
  for (let i = 0; i < a.length; i++) {
    if (!Object.is(a[i], b[i])) {
      if (ulp > 0 && withinUlp(a[i], b[i], a, ulp)) {
        if (tolerated++ === 0) firstTolerated = i;
        continue;
      }
      return `${label}: element [${i}] input ${fmt(a[i])}, output ${fmt(b[i])}${why ? ` (${why} data: ${ulp} ULP tolerated, this is more)` : ''}`;
    }
  }
  if (tolerated && notes) {
    notes.push(`${label}: ${tolerated} of ${a.length} components differ by ${ulp} ULP (first: [${firstTolerated}] input ` +
      `${fmt(a[firstTolerated])}, output ${fmt(b[firstTolerated])}); tolerated: ${why} data, EXT_meshopt_compression specifies filters to 1 ULP`);
  }
  return null;
}

function accessorDiff(a, b, label, opts = {}) {
  if (!a && !b) return [];
  if (!a || !b) return [`${label}: input ${a ? 'present' : 'absent'}, output ${b ? 'present' : 'absent'}`];
  const d = [];
  if (a.getType() !== b.getType()) d.push(`${label}: element type input ${a.getType()}, output ${b.getType()}`);
  if (a.getNormalized() !== b.getNormalized()) d.push(`${label}: normalized input ${a.getNormalized()}, output ${b.getNormalized()}`);
  const v = diffTypedArrays(a.getArray(), b.getArray(), label, opts);
  if (v) d.push(v);
  return d;
}

/** diffTypedArrays options for input accessor index i (tolerance only for meshopt-filtered data). */
function toleranceFor(jsonIn, accIndex, notes) {
  const filter = meshoptFilterOf(jsonIn, accIndex);
  return filter && MESHOPT_FILTER_ULP > 0 ? { ulp: MESHOPT_FILTER_ULP, notes, why: `meshopt ${filter}-filtered` } : { notes };
}

/**
 * b. decoded geometry (glTF-Transform, which decodes Draco/meshopt itself): same meshes, primitives, mode,
 * material index, attributes and morph-target attributes (array type + exact values), same indices.
 */
export function compareGeometry(docIn, docOut, { jsonIn = null, notes = null } = {}) {
  const diffs = [];
  const rin = docIn.getRoot();
  const rout = docOut.getRoot();
  const matsIn = rin.listMaterials();
  const matsOut = rout.listMaterials();
  const meshesIn = rin.listMeshes();
  const meshesOut = rout.listMeshes();
  if (meshesIn.length !== meshesOut.length) diffs.push(`meshes: input ${meshesIn.length}, output ${meshesOut.length}`);
  for (let m = 0; m < Math.min(meshesIn.length, meshesOut.length) && diffs.length < MAX_DIFFS; m++) {
    const pin = meshesIn[m].listPrimitives();
    const pout = meshesOut[m].listPrimitives();
    const mname = meshesIn[m].getName() ? ` (${meshesIn[m].getName()})` : '';
    if (pin.length !== pout.length) diffs.push(`mesh ${m}${mname}: primitives input ${pin.length}, output ${pout.length}`);
    for (let p = 0; p < Math.min(pin.length, pout.length); p++) {
      const L = `mesh ${m}${mname} primitive ${p}`;
      const a = pin[p];
      const b = pout[p];
      if (a.getMode() !== b.getMode()) diffs.push(`${L}: mode input ${a.getMode()}, output ${b.getMode()}`);
      const ma = a.getMaterial() ? matsIn.indexOf(a.getMaterial()) : null;
      const mb = b.getMaterial() ? matsOut.indexOf(b.getMaterial()) : null;
      if (ma !== mb) diffs.push(`${L}: material input ${ma}, output ${mb}`);
      const ia = a.getIndices();
      const ib = b.getIndices();
      if (ia || ib) {
        const d = diffTypedArrays(ia ? Array.from(ia.getArray()) : null, ib ? Array.from(ib.getArray()) : null, `${L} indices`, { allowTypeChange: true });
        if (d) diffs.push(d);
      }
      const sa = a.listSemantics().slice().sort();
      const sb = b.listSemantics().slice().sort();
      if (sa.join() !== sb.join()) diffs.push(`${L}: attributes input [${sa}], output [${sb}]`);
      const jp = jsonIn?.meshes?.[m]?.primitives?.[p];
      for (const s of sa) {
        if (sb.includes(s)) diffs.push(...accessorDiff(a.getAttribute(s), b.getAttribute(s), `${L} ${s}`, toleranceFor(jsonIn, jp?.attributes?.[s], notes)));
      }
      const ta = a.listTargets();
      const tb = b.listTargets();
      if (ta.length !== tb.length) diffs.push(`${L}: morph targets input ${ta.length}, output ${tb.length}`);
      for (let t = 0; t < Math.min(ta.length, tb.length); t++) {
        const tsa = ta[t].listSemantics().slice().sort();
        const tsb = tb[t].listSemantics().slice().sort();
        if (tsa.join() !== tsb.join()) diffs.push(`${L} target ${t}: attributes input [${tsa}], output [${tsb}]`);
        for (const s of tsa) {
          if (tsb.includes(s)) {
            diffs.push(...accessorDiff(ta[t].getAttribute(s), tb[t].getAttribute(s), `${L} target ${t} ${s}`,
              toleranceFor(jsonIn, jp?.targets?.[t]?.[s], notes)));
          }
        }
      }
    }
  }
  return diffs.slice(0, MAX_DIFFS);
}

/** c. animation sampler input/output data and skin inverseBindMatrices data (via glTF-Transform). */
export function compareAnimationSkinData(docIn, docOut, { jsonIn = null, notes = null } = {}) {
  const diffs = [];
  const ain = docIn.getRoot().listAnimations();
  const aout = docOut.getRoot().listAnimations();
  if (ain.length !== aout.length) diffs.push(`animations: input ${ain.length}, output ${aout.length}`);
  for (let i = 0; i < Math.min(ain.length, aout.length); i++) {
    const sin = ain[i].listSamplers();
    const sout = aout[i].listSamplers();
    if (sin.length !== sout.length) diffs.push(`animation ${i}: samplers input ${sin.length}, output ${sout.length}`);
    for (let s = 0; s < Math.min(sin.length, sout.length); s++) {
      if (sin[s].getInterpolation() !== sout[s].getInterpolation()) diffs.push(`animation ${i} sampler ${s}: interpolation differs`);
      const js = jsonIn?.animations?.[i]?.samplers?.[s];
      diffs.push(...accessorDiff(sin[s].getInput(), sout[s].getInput(), `animation ${i} sampler ${s} input`, toleranceFor(jsonIn, js?.input, notes)));
      diffs.push(...accessorDiff(sin[s].getOutput(), sout[s].getOutput(), `animation ${i} sampler ${s} output`, toleranceFor(jsonIn, js?.output, notes)));
    }
  }
  const kin = docIn.getRoot().listSkins();
  const kout = docOut.getRoot().listSkins();
  if (kin.length !== kout.length) diffs.push(`skins: input ${kin.length}, output ${kout.length}`);
  for (let i = 0; i < Math.min(kin.length, kout.length); i++) {
    diffs.push(...accessorDiff(kin[i].getInverseBindMatrices(), kout[i].getInverseBindMatrices(), `skin ${i} inverseBindMatrices`,
      toleranceFor(jsonIn, jsonIn?.skins?.[i]?.inverseBindMatrices, notes)));
  }
  return diffs.slice(0, MAX_DIFFS);
}

/**
 * Output-form rules of the contract: one buffer (the BIN chunk of a .glb, `<basename>.bin` beside a
 * .gltf); images keep their storage form in both kinds (external files under their original relative
 * uri, data: URIs as data URIs, bufferViews inside); no compression extension left anywhere.
 */
export function compareStorageForm(rawIn, rawOut, outFile) {
  const diffs = [];
  const j = rawOut.json;
  const buffers = j.buffers || [];
  const views = j.bufferViews || [];
  if (buffers.length > 1) diffs.push(`output has ${buffers.length} buffers (contract: all binary data in ONE buffer)`);
  if (views.length > 0 && buffers.length !== 1) diffs.push(`output has ${views.length} bufferViews but ${buffers.length} buffers`);
  const ext = path.extname(outFile).toLowerCase();
  if (ext === '.glb') {
    if (rawOut.kind !== 'glb') diffs.push('output named .glb is not a GLB container');
    if (buffers[0] && buffers[0].uri !== undefined) diffs.push(`.glb output buffer 0 has uri ${fmt(buffers[0].uri)} (must be the embedded BIN chunk)`);
  } else {
    if (rawOut.kind !== 'gltf') diffs.push('output named .gltf is not JSON');
    const expectBin = path.basename(outFile, path.extname(outFile)) + '.bin';
    if (buffers[0] && buffers[0].uri !== expectBin) diffs.push(`.gltf output buffer 0 uri is ${fmt(buffers[0].uri)}, expected ${fmt(expectBin)}`);
  }
  // Images keep their storage form in both output kinds (a texture shared by several assets stays shared).
  (rawIn.json.images || []).forEach((imIn, i) => {
      const imOut = (j.images || [])[i];
      if (!imOut || imIn.uri === undefined) return;
      if (isDataUri(imIn.uri)) {
        if (!isDataUri(imOut.uri)) diffs.push(`image ${i}: input is a data: URI, output is ${imOut.uri !== undefined ? 'uri ' + fmt(imOut.uri) : 'bufferView ' + imOut.bufferView} (contract: data URIs stay data URIs)`);
      } else if (imOut.uri !== imIn.uri) {
        diffs.push(`image ${i}: input uri ${fmt(imIn.uri)}, output ${imOut.uri !== undefined ? 'uri ' + fmt(imOut.uri) : 'bufferView ' + imOut.bufferView} (contract: external images keep their relative uri)`);
      }
    });
  const used = [...(j.extensionsUsed || []), ...(j.extensionsRequired || [])];
  for (const e of COMPRESSION_EXTENSIONS) if (used.includes(e)) diffs.push(`output still lists ${e} in extensionsUsed/Required`);
  (j.meshes || []).forEach((m, mi) => (m.primitives || []).forEach((p, pi) => {
    for (const e of COMPRESSION_EXTENSIONS) if (p.extensions?.[e]) diffs.push(`output mesh ${mi} primitive ${pi} still has ${e}`);
  }));
  views.forEach((bv, i) => {
    for (const e of COMPRESSION_EXTENSIONS) if (bv.extensions?.[e]) diffs.push(`output bufferView ${i} still has ${e}`);
  });
  return diffs;
}

/**
 * d. files in the output folder: only OUT itself and (for .gltf) the files its JSON references.
 * Anything else (temp files, stray .bin) is reported.
 */
export function leftoverFiles(outDir, outFile, rawOut) {
  const allowed = new Set([path.relative(outDir, outFile).split(path.sep).join('/')]);
  if (rawOut) {
    // Files the output references (its .bin, external images) are not leftovers.
    const refs = [...(rawOut.json.buffers || []), ...(rawOut.json.images || [])].map((x) => x.uri).filter((u) => u !== undefined && !isDataUri(u));
    for (const u of refs) {
      let rel;
      try {
        rel = path.relative(outDir, path.resolve(path.dirname(outFile), decodeURIComponent(u))).split(path.sep).join('/');
      } catch {
        continue;
      }
      allowed.add(rel);
      // parent folders of referenced files
      const parts = rel.split('/');
      for (let k = 1; k < parts.length; k++) allowed.add(parts.slice(0, k).join('/') + '/');
    }
  }
  return listFilesRecursive(outDir).filter((f) => !allowed.has(f));
}

/** Format a list of differences for an assertion message. */
export function formatDiffs(title, diffs) {
  const shown = diffs.slice(0, 10).map((d) => '  - ' + d).join('\n');
  return `${title}: ${diffs.length}${diffs.length >= MAX_DIFFS ? '+' : ''} difference(s)\n${shown}`;
}

// ---------------------------------------------------------------------------------------------
// Whole-conversion analysis (used by roundtrip.test.mjs and, on reference outputs, compare.test.mjs)

const inputCache = new Map();
/** Input side (validator report, raw reader, glTF-Transform document), memoised per corpus file. */
export function loadInput(file) {
  if (!inputCache.has(file)) {
    inputCache.set(file, (async () => ({
      validation: await validateFile(file),
      raw: readRaw(file, { meshoptDecoder: await getMeshoptDecoder() }),
      doc: await readDocument(file),
    }))());
  }
  return inputCache.get(file);
}

/** The aspects checked for every conversion, in report order, with their subtest titles. */
export const ASPECTS = [
  ['validator', 'a. no validator error the input did not have'],
  ['geometry', 'b. decoded geometry identical (glTF-Transform)'],
  ['json', 'c. JSON sub-trees unchanged'],
  ['accessors', 'c. accessor data unchanged (byte-exact, own reader)'],
  ['animSkin', 'c. animation sampler and skin data unchanged'],
  ['images', 'c. image bytes identical'],
  ['form', 'output form: one buffer, self-contained .glb / .gltf + .bin, no compression left'],
  ['leftovers', 'd. no temp or stray files in the output folder'],
];

/**
 * Compare a convert output with its input. Returns { validator: [...], geometry: [...], ... } (see ASPECTS);
 * an exception while checking an aspect is recorded as a difference of that aspect.
 */
export async function analyzeConversion(inFile, outFile, outDir = path.dirname(outFile)) {
  const inp = await loadInput(inFile);
  const res = Object.fromEntries(ASPECTS.map(([k]) => [k, []]));
  const notes = [];
  res.notes = notes;
  const guard = async (key, fn) => {
    try {
      res[key].push(...(await fn()));
    } catch (e) {
      res[key].push(`exception: ${e && e.message ? e.message : e}`);
    }
  };
  let rawOut = null;
  let docOut = null;
  let rawErr = null;
  let docErr = null;
  try {
    rawOut = readRaw(outFile);
  } catch (e) {
    rawErr = `cannot read output with the raw reader: ${e.message}`;
  }
  try {
    docOut = await readDocument(outFile);
  } catch (e) {
    docErr = `glTF-Transform cannot read the output: ${e.message}`;
  }
  await guard('validator', async () => newValidatorErrors(inp.validation, await validateFile(outFile)));
  await guard('geometry', () => (docOut ? compareGeometry(inp.doc, docOut, { jsonIn: inp.raw.json, notes }) : [docErr]));
  await guard('json', () => (rawOut ? compareJson(inp.raw, rawOut) : [rawErr]));
  await guard('accessors', () => (rawOut ? compareAccessorData(inp.raw, rawOut, { notes }) : [rawErr]));
  await guard('animSkin', () => (docOut ? compareAnimationSkinData(inp.doc, docOut, { jsonIn: inp.raw.json, notes }) : [docErr]));
  await guard('images', () => (rawOut ? compareImages(inp.raw, rawOut) : [rawErr]));
  await guard('form', () => (rawOut ? compareStorageForm(inp.raw, rawOut, outFile) : [rawErr]));
  await guard('leftovers', () => leftoverFiles(outDir, outFile, rawOut).map((f) => `unexpected file in output folder: ${f}`));
  return res;
}

/** Output file name for an input and an output kind ('.glb' / '.gltf'). */
export function outputNameFor(inRel, kind) {
  return path.basename(inRel).replace(/\.(gltf|glb)$/i, '') + kind;
}
