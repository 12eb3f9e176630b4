// Issue 6 "must show" 2 (hostile input and safe writes), with the binary under test (make test: the
// ASan+UBSan build, LeakSanitizer on):
// 1. Degenerate geometry (tests/tools/make_degenerate.py): zero-area and duplicate triangles, unreferenced
//    vertices, NaN/Inf in non-position attributes, one-triangle meshes, empty primitives, a zero bbox
//    diagonal, collinear meshes, tiny and huge scales, strip restarts. The main job exits 0 with the
//    case's warning, no new validator error, and the chain passes `lodpipe check` and every aspect of
//    tests/lib/lodcheck.mjs analyzeChain (CGAL-proven Hausdorff bound included).
// 2. The regression corpus tests/regressions/ (inputs that once broke lodpipe, each listed in its
//    manifest.json with the exit code expected now): the main job, `check` on its output, and each fuzz
//    harness (build/fuzz/fuzz_*, when built) on the file.
// 3. Limits: a node chain deeper than the cap, a node cycle, uris that leave the input's folder (refused,
//    accepted with --allow-external-uris), JSON nested absurdly deep, a number beyond a double's range,
//    declared counts and lengths far beyond the file: a one-line error and exit 2, quickly (nothing is
//    allocated from a declared size).
// 4. Safe writes: overwrite refusal (exit 1, input unchanged; --force writes), a missing output folder
//    (reported before the input is read), a read-only folder (as root, where permissions do not stop
//    writes: lodpipe runs as user nobody through
//    setpriv; plus a folder of /proc, where nobody can create a file) and a full disk (ulimit -f, and a
//    16 KiB tmpfs when this machine lets us mount one): exit 4, one line, no partial or temp file, an
//    existing output left as it was.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { spawnSync } from 'node:child_process';
import {
  caseBlindVolume, corpusPath, describeRun, listFilesRecursive, newValidatorErrors, oneLineErrorProblems, parseGlb, repoRoot,
  runHealthProblems, runLodpipe, skipWithoutBinary, successStderrProblems, tempDir, validateFileCached,
} from './lib/gltf.mjs';
import { BUILD, CHAIN_ASPECTS, analyzeChain, formatProblems, hausdorffAvailable } from './lib/lodcheck.mjs';
import { pack, writeGlb } from './lib/lodfixture.mjs';

const skip = skipWithoutBinary();
const REGRESSIONS = path.join(repoRoot, 'tests', 'regressions');
const DUCK = corpusPath('scenes/Duck.glb');
const isRoot = typeof process.getuid === 'function' && process.getuid() === 0;

/** A main-job run that must succeed: exit 0, only warnings on stderr, the output exists. */
function mainJobProblems(r, out) {
  const p = [...runHealthProblems(r), ...successStderrProblems(r.stderr)];
  if (r.status !== 0) p.push(`exit status ${r.status} (expected 0)`);
  else if (!fs.existsSync(out)) p.push('exit 0 but no output file');
  return p;
}

/** `lodpipe check` on an output: exit 0 and no row marked NO. */
function checkProblems(out) {
  const r = runLodpipe(['check', out, '--quiet']);
  const p = [...runHealthProblems(r)];
  if (r.status !== 0) p.push(`check: exit status ${r.status}: ${r.stderr.trim()}`);
  if (/\bNO\b/.test(r.stdout)) p.push(`check marks a level: ${r.stdout}`);
  return p;
}

/** An error run: the expected exit code, one line naming `name`, nothing left in `dir` beyond `keep`. */
function refusalProblems(r, code, name, dir, keep = []) {
  const p = [...runHealthProblems(r), ...oneLineErrorProblems(r.stderr)];
  if (r.status !== code) p.push(`exit status ${r.status} (expected ${code})`);
  if (name && !r.stderr.includes(name)) p.push(`stderr does not name ${name}`);
  if (dir) {
    const left = listFilesRecursive(dir).filter((f) => !keep.includes(f));
    if (left.length) p.push(`files left behind: ${JSON.stringify(left)}`);
  }
  return p;
}

// ---------------------------------------------------------------------------------------------
// 1. Degenerate geometry

test('degenerate geometry: handled with a warning, the bound still holds', { skip }, async (t) => {
  const dir = tempDir(t);
  const gen = spawnSync('python3', [path.join(repoRoot, 'tests', 'tools', 'make_degenerate.py'), dir], { encoding: 'utf8' });
  assert.equal(gen.status, 0, gen.stderr);
  const cases = JSON.parse(fs.readFileSync(path.join(dir, 'cases.json'), 'utf8'));
  assert.ok(Object.keys(cases).length >= 10, 'the generator writes every case');
  for (const [file, c] of Object.entries(cases)) {
    await t.test(`${file}: ${c.what}`, async (st) => {
      const input = path.join(dir, file);
      const out = path.join(tempDir(st), 'out.glb');
      const r = runLodpipe([input, '-o', out, '--json']);
      assert.deepEqual(mainJobProblems(r, out), [], describeRun(r));
      if (c.warning) assert.ok(r.stderr.includes('warning') && r.stderr.includes(c.warning), `expected a warning containing "${c.warning}": ${describeRun(r)}`);
      assert.deepEqual(checkProblems(out), []);
      assert.ok(hausdorffAvailable(), `${BUILD}/hausdorff is not built (make hausdorff): the chain's soundness cannot be checked`);
      const res = await analyzeChain({ inFile: input, outFile: out, summary: JSON.parse(r.stdout) });
      for (const n of res.notes || []) st.diagnostic(n);
      const tolerated = c.tolerate ? new RegExp(c.tolerate) : null;
      const bad = CHAIN_ASPECTS.map(([k, title]) => {
        const kept = res.problems[k].filter((m) => !(tolerated && tolerated.test(m)));
        if (kept.length < res.problems[k].length) st.diagnostic(`tolerated (${c.tolerate_why}): ${res.problems[k].length - kept.length} line(s) of "${title}"`);
        return kept.length ? formatProblems(title, kept) : null;
      }).filter(Boolean);
      assert.deepEqual(bad, []);
    });
  }
});

// ---------------------------------------------------------------------------------------------
// 2. The regression corpus

const regressionManifest = JSON.parse(fs.readFileSync(path.join(REGRESSIONS, 'manifest.json'), 'utf8'));

test('tests/regressions: every file is listed in its manifest with an expectation', () => {
  const files = fs.readdirSync(REGRESSIONS).filter((f) => f !== 'manifest.json').sort();
  assert.deepEqual(files, Object.keys(regressionManifest).sort());
  for (const [f, e] of Object.entries(regressionManifest))
    assert.ok(Array.isArray(e.exit) && e.exit.length && e.what && e.found_by, `${f}: needs exit, what, found_by`);
});

for (const [file, e] of Object.entries(regressionManifest)) {
  test(`regression ${file}: ${e.what.slice(0, 80)}`, { skip }, async (t) => {
    const input = path.join(REGRESSIONS, file);
    await t.test(`main job: exit ${e.exit.join('/')}`, (st) => {
      const dir = tempDir(st);
      const out = path.join(dir, 'out.glb');
      const r = runLodpipe([input, '-o', out]);
      const p = [...runHealthProblems(r)];
      if (!e.exit.includes(r.status)) p.push(`exit status ${r.status} (expected ${e.exit.join(' or ')})`);
      if (r.status === 0) {
        p.push(...successStderrProblems(r.stderr), ...checkProblems(out));
        if (e.warning && !r.stderr.includes(e.warning)) p.push(`no warning containing "${e.warning}"`);
      } else {
        p.push(...oneLineErrorProblems(r.stderr));
        if (e.error && !r.stderr.includes(e.error)) p.push(`the error does not say "${e.error}"`);
        if (listFilesRecursive(dir).length) p.push('files left behind');
      }
      assert.deepEqual(p, [], describeRun(r));
    });
    for (const harness of ['load', 'pipeline']) {
      const bin = path.join(BUILD, 'fuzz', `fuzz_${harness}`);
      const why = fs.existsSync(bin) ? false : `${bin} not built (make fuzz-build)`;
      await t.test(`fuzz_${harness} runs it cleanly`, { skip: why }, () => {
        const r = spawnSync(bin, [input], { encoding: 'utf8', timeout: 120000 });
        assert.equal(r.status, 0, `${bin} ${input}: status ${r.status} signal ${r.signal}\n${(r.stderr || '').slice(-3000)}`);
      });
    }
  });
}

// ---------------------------------------------------------------------------------------------
// 3. Limits

/** A one-triangle scene: { json, bin } to mutate. */
function triangleModel() {
  const positions = new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0]);
  const indices = new Uint16Array([0, 1, 2, 0]);
  return pack({
    json: {
      asset: { version: '2.0' }, scene: 0, scenes: [{ nodes: [0] }], nodes: [{ mesh: 0 }],
      meshes: [{ primitives: [{ attributes: { POSITION: 0 }, indices: 1 }] }],
      accessors: [{ componentType: 5126, type: 'VEC3', min: [0, 0, 0], max: [1, 1, 0] }, { componentType: 5123, type: 'SCALAR' }],
    },
    datas: [positions, indices.subarray(0, 3)],
  });
}

/** The model as a .gltf whose buffer sits in `binUri` (written at binPath). */
function writeGltfWithExternalBuffer(file, binUri, binPath) {
  const m = triangleModel();
  fs.mkdirSync(path.dirname(binPath), { recursive: true });
  fs.mkdirSync(path.dirname(file), { recursive: true });
  fs.writeFileSync(binPath, m.bin);
  m.json.buffers[0].uri = binUri;
  fs.writeFileSync(file, JSON.stringify(m.json));
}

const LIMIT_TIMEOUT_MS = 30000; // a refusal must not first allocate or walk what the file declares

function assertRefused(st, input, code, needle) {
  const dir = tempDir(st);
  const r = runLodpipe(['convert', input, path.join(dir, 'out.glb')], { timeout: LIMIT_TIMEOUT_MS });
  const p = refusalProblems(r, code, path.basename(input), dir);
  if (needle && !needle.test(r.stderr)) p.push(`stderr does not match ${needle}`);
  assert.deepEqual(p, [], describeRun(r));
}

test('limits: refused before allocation, with a one-line error', { skip }, async (t) => {
  const dir = tempDir(t);

  await t.test('a node chain 5000 deep (cap 4096) -> exit 2', (st) => {
    const m = triangleModel();
    m.json.nodes = Array.from({ length: 5000 }, (_, i) => (i < 4999 ? { children: [i + 1] } : { mesh: 0 }));
    const f = path.join(dir, 'deep_nodes.glb');
    writeGlb(f, m.json, m.bin);
    assertRefused(st, f, 2, /deeper than/);
  });

  await t.test('a node cycle 0 -> 1 -> 2 -> 0 -> exit 2', (st) => {
    const m = triangleModel();
    m.json.nodes = [{ children: [1], mesh: 0 }, { children: [2] }, { children: [0] }];
    m.json.scenes = [{ nodes: [] }];
    const f = path.join(dir, 'cycle.glb');
    writeGlb(f, m.json, m.bin);
    assertRefused(st, f, 2, /cycle|parent/);
  });

  await t.test('a buffer uri "../x.bin" -> exit 2; accepted with --allow-external-uris', (st) => {
    const sub = path.join(dir, 'escape', 'inner');
    const f = path.join(sub, 'escape.gltf');
    writeGltfWithExternalBuffer(f, '../outside.bin', path.join(dir, 'escape', 'outside.bin'));
    assertRefused(st, f, 2, /outside the input's folder/);
    const out = path.join(tempDir(st), 'out.glb');
    const r = runLodpipe(['convert', '--allow-external-uris', f, out]);
    assert.deepEqual(mainJobProblems(r, out), [], describeRun(r));
  });

  await t.test('an absolute buffer uri and a percent-encoded "..": exit 2', (st) => {
    const abs = path.join(dir, 'absolute.gltf');
    writeGltfWithExternalBuffer(abs, path.join(dir, 'abs.bin'), path.join(dir, 'abs.bin'));
    assertRefused(st, abs, 2, /outside the input's folder/);
    const sub = path.join(dir, 'enc', 'inner');
    const enc = path.join(sub, 'encoded.gltf');
    writeGltfWithExternalBuffer(enc, '%2E%2E/enc.bin', path.join(dir, 'enc', 'enc.bin'));
    assertRefused(st, enc, 2, /outside the input's folder/);
  });

  await t.test('an image uri "../t.png" -> exit 2', (st) => {
    const m = triangleModel();
    m.json.buffers[0].uri = `data:application/octet-stream;base64,${m.bin.toString('base64')}`;
    m.json.images = [{ uri: '../t.png' }];
    fs.mkdirSync(path.join(dir, 'img'), { recursive: true });
    fs.writeFileSync(path.join(dir, 't.png'), Buffer.from([0x89, 0x50, 0x4e, 0x47]));
    const f = path.join(dir, 'img', 'image_escape.gltf');
    fs.writeFileSync(f, JSON.stringify(m.json));
    assertRefused(st, f, 2, /outside the input's folder/);
  });

  // "%00" decodes to a NUL, where the file system ends the name: "good.bin%00.png" read good.bin (QA). Refused,
  // as is an empty uri (it said "points outside the input's folder").
  await t.test('a uri decoding to a NUL byte, an empty uri, a data uri without base64 -> exit 2 naming the object', (st) => {
    const dir = tempDir(st);
    const m = triangleModel();
    fs.writeFileSync(path.join(dir, 'good.bin'), m.bin);
    for (const [name, uri, needle] of [['nul.gltf', 'good.bin%00.png', /buffers\[0\]\.uri "good\.bin%00\.png" decodes to a name with a NUL byte/],
      ['empty.gltf', '', /buffers\[0\]\.uri is empty/],
      ['no_base64.gltf', 'data:application/octet-stream,AAAA', /buffers\[0\]\.uri is a data: uri without ";base64,"/]]) {
      m.json.buffers[0].uri = uri;
      const f = path.join(dir, name);
      fs.writeFileSync(f, JSON.stringify(m.json));
      assertRefused(st, f, 2, needle);
    }
  });

  // With the flag, images outside the input's folder are read where they are (a relative "..", an absolute
  // path, a file:// uri) and the output refers to the same files: the relative one rewritten for the output's
  // folder, the others kept; nothing is written outside the output folder. Another scheme cannot be read.
  await t.test('--allow-external-uris: "../", absolute and file:// images are read and still reached from the output', (st) => {
    const root = tempDir(st);
    const m = triangleModel();
    m.json.buffers[0].uri = `data:application/octet-stream;base64,${m.bin.toString('base64')}`;
    const png = fs.readFileSync(corpusPath('scenes/CesiumMilkTruck/CesiumMilkTruck.png'));
    fs.mkdirSync(path.join(root, 'assets', 'models'), { recursive: true });
    fs.mkdirSync(path.join(root, 'build', 'lod'), { recursive: true });
    fs.writeFileSync(path.join(root, 'assets', 'rel.png'), png);
    fs.writeFileSync(path.join(root, 'abs.png'), png);
    const absPath = path.join(root, 'abs.png');
    m.json.images = [{ uri: '../rel.png' }, { uri: absPath }, { uri: `file://${absPath}` }];
    m.json.textures = m.json.images.map((_, i) => ({ source: i }));
    const f = path.join(root, 'assets', 'models', 'm.gltf');
    fs.writeFileSync(f, JSON.stringify(m.json));
    assertRefused(st, f, 2, /outside the input's folder/);
    for (const out of [path.join(root, 'build', 'lod', 'm.gltf'), path.join(root, 'assets', 'models', 'm_out.glb')]) {
      const r = runLodpipe(['convert', '--allow-external-uris', f, out]);
      assert.equal(r.status, 0, describeRun(r));
      const j = out.endsWith('.glb') ? parseGlb(fs.readFileSync(out)).json : JSON.parse(fs.readFileSync(out, 'utf8'));
      const uris = j.images.map((i) => i.uri);
      assert.deepEqual(uris.slice(1), [absPath, `file://${absPath}`], 'absolute and file:// uris kept');
      assert.ok(fs.readFileSync(path.resolve(path.dirname(out), decodeURIComponent(uris[0]))).equals(png), `${uris[0]} from ${out} reaches the texture`);
      const back = runLodpipe(['inspect', '--allow-external-uris', out]);
      assert.equal(back.status, 0, `the output reads back: ${describeRun(back)}`);
    }
    assert.deepEqual(listFilesRecursive(path.join(root, 'build')).sort(), ['lod/', 'lod/m.bin', 'lod/m.gltf'], 'nothing copied or written elsewhere');
    m.json.images = [{ uri: 'http://example.com/t.png' }];
    m.json.textures = [{ source: 0 }];
    fs.writeFileSync(f, JSON.stringify(m.json));
    const web = runLodpipe(['convert', '--allow-external-uris', f, path.join(root, 'build', 'web.glb')]);
    assert.deepEqual(refusalProblems(web, 4, 'not a local file', null), [], describeRun(web));
  });

  await t.test('JSON nested 100,000 deep in extras -> exit 2; 400 deep is kept', (st) => {
    const deep = (d) => `{"asset":{"version":"2.0"},"extras":${'['.repeat(d)}${']'.repeat(d)}}`;
    const f = path.join(dir, 'deep_json.gltf');
    fs.writeFileSync(f, deep(100000));
    assertRefused(st, f, 2, /deeper than/);
    const ok = path.join(dir, 'nested_json.gltf');
    fs.writeFileSync(ok, deep(400));
    const out = path.join(tempDir(st), 'out.gltf');
    const r = runLodpipe(['convert', ok, out]);
    assert.deepEqual(mainJobProblems(r, out), [], describeRun(r));
  });

  // An object of n keys costs n^2 in the reader's order-keeping objects (QA: 500k keys in extras, 7 MB, took
  // 7 minutes): more than 16,384 members is refused at once, naming the byte; 16,384 is kept.
  await t.test('a JSON object of more than 16,384 members -> exit 2 at once; 16,384 kept', (st) => {
    const keys = (n) => `{"asset":{"version":"2.0"},"extras":{${Array.from({ length: n }, (_, i) => `"k${i}":${i}`).join(',')}}}`;
    const f = path.join(dir, 'many_keys.gltf');
    fs.writeFileSync(f, keys(500000));
    assertRefused(st, f, 2, /JSON has an object with more than 16384 members \(at byte \d+\)/);
    const ok = path.join(dir, 'keys_16384.gltf');
    fs.writeFileSync(ok, keys(16384));
    const out = path.join(tempDir(st), 'out.gltf');
    const r = runLodpipe(['convert', ok, out]);
    assert.deepEqual(mainJobProblems(r, out), [], describeRun(r));
    assert.equal(Object.keys(JSON.parse(fs.readFileSync(out, 'utf8')).extras).length, 16384);
  });

  // A JSON number no double holds (QA: the validator passes 1e400; lodpipe exited 2 with nlohmann's
  // "[json.exception.out_of_range.406]"): numbers are kept as doubles, so it is refused, naming the number
  // and where it starts. One nearer zero than any double is kept as the nearest, 0.
  await t.test('a number beyond the range of a double -> exit 2 naming it and its byte; 1e-400 kept as 0', (st) => {
    const text = (number) => `{"asset":{"version":"2.0"},"extras":{"root":"x","huge":${number}}}`;
    const at = text('').length - 2;
    for (const [name, number, shown] of [['huge.gltf', '1e400', '(1e400)'], ['huge_neg.gltf', '-1e400', '(-1e400)'],
      ['huge_int.gltf', `1${'0'.repeat(400)}`, `(1${'0'.repeat(39)}...)`]]) {
      const f = path.join(dir, name);
      fs.writeFileSync(f, text(number));
      assertRefused(st, f, 2, null);
      const r = runLodpipe([f, '-o', path.join(tempDir(st), 'out.glb')]);
      assert.equal(r.status, 2, describeRun(r));
      assert.equal(r.stderr, `lodpipe: ${f}: JSON has a number beyond the range of a double ${shown} at byte ${at} of the JSON\n`);
    }
    const tiny = path.join(dir, 'tiny.gltf');
    fs.writeFileSync(tiny, text('1e-400'));
    const out = path.join(tempDir(st), 'out.gltf');
    const r = runLodpipe(['convert', tiny, out]);
    assert.deepEqual(mainJobProblems(r, out), [], describeRun(r));
    assert.equal(JSON.parse(fs.readFileSync(out, 'utf8')).extras.huge, 0);
  });

  await t.test('an accessor declaring 2^40 elements on a 48-byte buffer -> exit 2', (st) => {
    const m = triangleModel();
    m.json.accessors[0].count = 2 ** 40;
    const f = path.join(dir, 'huge_count.glb');
    writeGlb(f, m.json, m.bin);
    assertRefused(st, f, 2, /accessors\[0\]/);
  });

  await t.test('a buffer declaring 2^50 bytes, a bufferView as long -> exit 2', (st) => {
    const m = triangleModel();
    m.json.buffers[0].byteLength = 2 ** 50;
    m.json.bufferViews[0].byteLength = 2 ** 50 - 64;
    const f = path.join(dir, 'huge_buffer.glb');
    writeGlb(f, m.json, m.bin);
    assertRefused(st, f, 2, null);
  });

  // Files past the reader's 2 GiB cap, made sparse (no disk used): a buffer and an image said "cannot read"
  // (exit 4, as if the disk failed) or "is too large" without the sizes; now exit 2 with both, from every command.
  await t.test('an external buffer, an image and a GLB over 2 GiB -> exit 2 naming the size and the cap', (st) => {
    const d = tempDir(st);
    const big = path.join(d, 'big.bin');
    fs.writeFileSync(big, '');
    fs.truncateSync(big, 2 ** 31 + 4);
    const m = triangleModel();
    writeGltfWithExternalBuffer(path.join(d, 'buffer.gltf'), 'big.bin', path.join(d, 'unused.bin'));
    const bufferJson = JSON.parse(fs.readFileSync(path.join(d, 'buffer.gltf'), 'utf8'));
    bufferJson.buffers[0].byteLength = 2 ** 31 + 4;
    fs.writeFileSync(path.join(d, 'buffer.gltf'), JSON.stringify(bufferJson));
    const sizes = /"big\.bin" is too large \(2147483652 bytes; at most 2147483648\)/;
    assertRefusedByEveryCommand(st, path.join(d, 'buffer.gltf'), 2, sizes);
    writeGltfWithExternalBuffer(path.join(d, 'image.gltf'), 'tri.bin', path.join(d, 'tri.bin'));
    const imageJson = JSON.parse(fs.readFileSync(path.join(d, 'image.gltf'), 'utf8'));
    imageJson.images = [{ uri: 'big.bin' }];
    fs.writeFileSync(path.join(d, 'image.gltf'), JSON.stringify(imageJson));
    assertRefusedByEveryCommand(st, path.join(d, 'image.gltf'), 2, sizes);
    const glb = path.join(d, 'big.glb');
    writeGlb(glb, m.json, m.bin);
    fs.truncateSync(glb, 2 ** 31 + 4);
    assertRefusedByEveryCommand(st, glb, 2, /is larger than the 2147483648-byte limit/);
  });

  await t.test('a sparse accessor declaring 2^40 substitutions -> exit 2', (st) => {
    const m = triangleModel();
    m.json.accessors[0].sparse = { count: 2 ** 40, indices: { bufferView: 1, componentType: 5123 }, values: { bufferView: 0 } };
    const f = path.join(dir, 'huge_sparse.glb');
    writeGlb(f, m.json, m.bin);
    assertRefused(st, f, 2, /accessors\[0\]/);
  });

  await t.test('a meshopt stream of 71 bytes declaring 64 GiB decoded -> exit 2 (nothing allocated)', (st) => {
    const { json, bin } = parseGlb(fs.readFileSync(corpusPath('compressed/BoxMeshopt.glb')));
    const view = json.bufferViews.find((v) => v.extensions?.EXT_meshopt_compression?.mode === 'ATTRIBUTES');
    const m = view.extensions.EXT_meshopt_compression;
    m.count = 2 ** 36 / m.byteStride;
    view.byteLength = 2 ** 36;
    json.buffers[view.buffer].byteLength = (view.byteOffset || 0) + view.byteLength;
    const f = path.join(dir, 'meshopt_bomb.glb');
    writeGlb(f, json, Buffer.from(bin));
    assertRefused(st, f, 2, /meshopt declares/);
  });

  await t.test('a triangle strip of 2^31 indices declared on a tiny view -> exit 2', (st) => {
    const m = triangleModel();
    m.json.meshes[0].primitives[0].mode = 5;
    m.json.accessors[1].count = 2 ** 31;
    const f = path.join(dir, 'huge_strip.glb');
    writeGlb(f, m.json, m.bin);
    assertRefused(st, f, 2, /accessors\[1\]/);
  });
});

// Malformed containers and buffers that once reached tinygltf or nlohmann and came back in their words
// (QA: `vector::_M_range_check`, `[json.exception.type_error.302]`, "Insufficient storage space for Chunk1",
// "File read error : ... File is empty"): each is the loader's own one-line error naming the object, exit 2,
// from the main job, inspect and convert alike, with no output.

const CHUNK_JSON = 0x4e4f534a;
const CHUNK_BIN = 0x004e4942;
const LIBRARY_TEXT = /vector::|_M_|json\.exception|tinygltf|Failed to|File read error|Insufficient storage|malformed glTF/;

/** A GLB of the given [type, bytes] chunks, in that order. */
function writeGlbChunks(file, chunks) {
  const parts = [];
  for (const [type, data] of chunks) {
    const h = Buffer.alloc(8);
    h.writeUInt32LE(data.length, 0);
    h.writeUInt32LE(type, 4);
    parts.push(h, data);
  }
  const header = Buffer.alloc(12);
  header.writeUInt32LE(0x46546c67, 0);
  header.writeUInt32LE(2, 4);
  header.writeUInt32LE(12 + parts.reduce((n, b) => n + b.length, 0), 8);
  fs.writeFileSync(file, Buffer.concat([header, ...parts]));
}

const jsonChunk = (json) => {
  const text = Buffer.from(JSON.stringify(json), 'utf8');
  return text.length % 4 ? Buffer.concat([text, Buffer.alloc(4 - (text.length % 4), 0x20)]) : text;
};

/** The main job, inspect and convert all refuse `input` with `code` and one line matching `needle`, in lodpipe's words. */
function assertRefusedByEveryCommand(st, input, code, needle) {
  for (const args of [(out) => [input, '-o', out], () => ['inspect', input], (out) => ['convert', input, out]]) {
    const dir = tempDir(st);
    const r = runLodpipe(args(path.join(dir, 'out.glb')), { timeout: LIMIT_TIMEOUT_MS });
    const p = refusalProblems(r, code, path.basename(input), dir);
    if (!needle.test(r.stderr)) p.push(`stderr does not match ${needle}`);
    if (LIBRARY_TEXT.test(r.stderr)) p.push('stderr shows a library\'s text');
    assert.deepEqual(p, [], describeRun(r));
  }
}

test('malformed containers and buffers: one line in lodpipe\'s words, from every command', { skip }, async (t) => {
  const dir = tempDir(t);

  // The GLB spec fixes the order: one JSON chunk first, at most one BIN chunk second. A second JSON chunk was
  // either ignored (after the BIN) or taken for a missing BIN ("there is none", before it).
  await t.test('a GLB with a second JSON chunk, or a BIN chunk that is not the second -> exit 2 naming the chunk', (st) => {
    const m = triangleModel();
    const cases = [['two_json.glb', [[CHUNK_JSON, jsonChunk(m.json)], [CHUNK_JSON, jsonChunk(m.json)], [CHUNK_BIN, m.bin]], /GLB chunk 1 is a second JSON chunk/],
      ['json_after_bin.glb', [[CHUNK_JSON, jsonChunk(m.json)], [CHUNK_BIN, m.bin], [CHUNK_JSON, jsonChunk(m.json)]], /GLB chunk 2 is a second JSON chunk/],
      ['late_bin.glb', [[CHUNK_JSON, jsonChunk(m.json)], [0x12345678, Buffer.alloc(4)], [CHUNK_BIN, m.bin]], /GLB chunk 2 is a BIN chunk \(a GLB has at most one, the second\)/]];
    for (const [name, chunks, needle] of cases) {
      const f = path.join(dir, name);
      writeGlbChunks(f, chunks);
      assertRefusedByEveryCommand(st, f, 2, needle);
    }
  });

  // tinygltf indexed a second, empty buffer unchecked (`vector::_M_range_check`), refused an empty BIN chunk and an
  // empty .bin in its own words, and required a data: uri to decode to byteLength bytes without saying so.
  await t.test('a buffer whose source does not hold its byteLength -> exit 2 naming the buffer and both sizes', (st) => {
    const m = triangleModel();
    const zero = JSON.parse(JSON.stringify(m.json));
    zero.buffers.push({ byteLength: 0 });
    writeGlb(path.join(dir, 'zero_length.glb'), zero, m.bin);
    assertRefusedByEveryCommand(st, path.join(dir, 'zero_length.glb'), 2, /buffers\[1\]\.byteLength is 0 \(a buffer holds at least 1 byte\)/);
    writeGlbChunks(path.join(dir, 'empty_bin.glb'), [[CHUNK_JSON, jsonChunk(m.json)], [CHUNK_BIN, Buffer.alloc(0)]]);
    assertRefusedByEveryCommand(st, path.join(dir, 'empty_bin.glb'), 2, /buffers\[0\] declares 44 bytes, but the GLB BIN chunk holds 0/);
    writeGlbChunks(path.join(dir, 'short_bin.glb'), [[CHUNK_JSON, jsonChunk(m.json)], [CHUNK_BIN, m.bin.subarray(0, 8)]]);
    assertRefusedByEveryCommand(st, path.join(dir, 'short_bin.glb'), 2, /buffers\[0\] declares 44 bytes, but the GLB BIN chunk holds 8/);
    const ext = JSON.parse(JSON.stringify(m.json));
    ext.buffers[0].uri = 'empty.bin';
    fs.writeFileSync(path.join(dir, 'empty.bin'), Buffer.alloc(0));
    fs.writeFileSync(path.join(dir, 'empty_external.gltf'), JSON.stringify(ext));
    assertRefusedByEveryCommand(st, path.join(dir, 'empty_external.gltf'), 2, /buffers\[0\]: "empty\.bin" holds 0 bytes, not the declared byteLength 44/);
    const b64 = m.bin.toString('base64');
    for (const [name, uri, needle] of [['data_longer.gltf', `data:application/octet-stream;base64,${Buffer.concat([m.bin, Buffer.alloc(3)]).toString('base64')}`, /buffers\[0\]\.uri holds 47 bytes, not the declared byteLength 44/],
      ['data_not_base64.gltf', `data:application/octet-stream;base64,${b64.slice(0, 8)}!${b64.slice(9)}`, /buffers\[0\]\.uri is not valid base64 \(at character 45\)/],
      ['data_type.gltf', `data:application/x-foo;base64,${b64}`, /buffers\[0\]\.uri is a data: uri of type "application\/x-foo"/],
      // a media type with a parameter was quoted up to its first ';': 'of type "application/octet-stream" (a buffer's is
      // application/octet-stream ...)', refusing the very type it named
      ['data_type_parameter.gltf', `data:application/octet-stream;charset=x;base64,${b64}`,
        /buffers\[0\]\.uri is a data: uri of type "application\/octet-stream;charset=x" \(a buffer's is application\/octet-stream or application\/gltf-buffer\)/]]) {
      const d = JSON.parse(JSON.stringify(m.json));
      d.buffers[0].uri = uri;
      fs.writeFileSync(path.join(dir, name), JSON.stringify(d));
      assertRefusedByEveryCommand(st, path.join(dir, name), 2, needle);
    }
    // An empty BIN chunk no buffer reads is only a validator notice (GLB_EMPTY_BIN_CHUNK): the file is read.
    const embedded = JSON.parse(JSON.stringify(m.json));
    embedded.buffers[0].uri = `data:application/octet-stream;base64,${b64}`;
    const unused = path.join(dir, 'empty_bin_unused.glb');
    writeGlbChunks(unused, [[CHUNK_JSON, jsonChunk(embedded)], [CHUNK_BIN, Buffer.alloc(0)]]);
    const out = path.join(tempDir(st), 'out.glb');
    const r = runLodpipe(['convert', unused, out]);
    assert.deepEqual(mainJobProblems(r, out), [], describeRun(r));
  });

  // GLB pads each chunk to 4 bytes. A JSON chunk without its padding (the validator's GLB_CHUNK_LENGTH_UNALIGNED;
  // tinygltf and engines read it) holds the whole document, so it is read, not refused: the output is padded like any
  // other, byte for byte the output of the padded file, and has no validator error.
  await t.test('a GLB whose JSON chunk is not padded to 4 bytes is read; its output is the padded file\'s', async (st) => {
    const duck = new Uint8Array(fs.readFileSync(corpusPath('scenes/Duck.glb')));
    const { json, bin } = parseGlb(duck);
    const text = Buffer.from(JSON.stringify(json), 'utf8');
    const bare = text.length % 4 ? text : Buffer.concat([text, Buffer.from(' ')]);
    const sub = tempDir(st);
    const padded = path.join(sub, 'padded.glb'), unaligned = path.join(sub, 'unaligned.glb');
    writeGlbChunks(padded, [[CHUNK_JSON, jsonChunk(json)], [CHUNK_BIN, Buffer.from(bin)]]);
    writeGlbChunks(unaligned, [[CHUNK_JSON, bare], [CHUNK_BIN, Buffer.from(bin)]]);
    const report = await validateFileCached(unaligned);
    assert.ok(report.errorCodes.GLB_CHUNK_LENGTH_UNALIGNED, `the input is what the validator calls unaligned: ${JSON.stringify(report.errorCodes)}`);
    const outs = [];
    for (const f of [padded, unaligned]) {
      const out = path.join(sub, `out_${path.basename(f)}`);
      const r = runLodpipe([f, '-o', out]);
      assert.deepEqual(mainJobProblems(r, out), [], describeRun(r));
      outs.push(fs.readFileSync(out));
    }
    assert.ok(outs[1].equals(outs[0]), 'the unaligned file\'s output differs from the padded one\'s');
    const outReport = await validateFileCached(path.join(sub, 'out_unaligned.glb'));
    assert.deepEqual(Object.keys(outReport.errorCodes), [], 'the output has validator errors');
  });

  // A uri was quoted whole: a 5,000-character data: uri (by tinygltf) or file name filled the terminal. A string
  // of the file is shown up to its 60th byte, then "..."; an image's bad data: uri is the loader's error too.
  await t.test('a long uri is quoted up to 60 bytes; a bad image data: uri -> exit 2 in lodpipe\'s words', (st) => {
    const m = triangleModel();
    const long = 'x'.repeat(3000);
    const embedded = `data:application/octet-stream;base64,${m.bin.toString('base64')}`;
    const cases = [['missing.gltf', { buffer: `${long}.bin` }, 4, /buffers\[0\]: cannot read "x{60}\.\.\."$/m],
      ['escape.gltf', { buffer: `../${long}.bin` }, 2, /buffers\[0\]\.uri "\.\.\/x{57}\.\.\." points outside the input's folder/],
      ['bad_base64.gltf', { buffer: `data:application/octet-stream;base64,${'!'.repeat(5000)}` }, 2, /buffers\[0\]\.uri is not valid base64 \(at character 37\)$/m],
      ['long_type.gltf', { buffer: `data:${long};base64,AAAA` }, 2, /buffers\[0\]\.uri is a data: uri of type "x{60}\.\.\." /],
      ['bad_image.gltf', { buffer: embedded, image: `data:image/png;base64,${'!'.repeat(5000)}` }, 2, /images\[0\]\.uri is not valid base64 \(at character 22\)$/m],
      ['empty_image.gltf', { buffer: embedded, image: 'data:image/png;base64,' }, 2, /images\[0\]\.uri holds no data$/m]];
    for (const [name, uris, code, needle] of cases) {
      const j = JSON.parse(JSON.stringify(m.json));
      j.buffers[0].uri = uris.buffer;
      if (uris.image) j.images = [{ uri: uris.image }];
      const sub = path.join(dir, 'long', 'in');
      fs.mkdirSync(sub, { recursive: true });
      const f = path.join(sub, name);
      fs.writeFileSync(f, JSON.stringify(j));
      assertRefusedByEveryCommand(st, f, code, needle);
      const r = runLodpipe(['inspect', f]);
      assert.ok(r.stderr.length < f.length + 200, `a short line: ${r.stderr.length} characters`);
    }
  });

  // The meshopt decoder read mode and filter as strings: a number there threw nlohmann's
  // "[json.exception.type_error.302] type must be string, but is number".
  await t.test('EXT_meshopt_compression mode or filter not a string -> exit 2 naming the property', (st) => {
    const { json, bin } = parseGlb(fs.readFileSync(corpusPath('compressed/BoxMeshopt.glb')));
    const v = json.bufferViews.findIndex((x) => x.extensions?.EXT_meshopt_compression?.mode === 'ATTRIBUTES');
    const where = `bufferViews\\[${v}\\]\\.extensions\\.EXT_meshopt_compression`;
    for (const [name, edit, needle] of [['mode_number.glb', (m) => { m.mode = 0; }, `${where}\\.mode is missing or not a string`],
      ['mode_missing.glb', (m) => { delete m.mode; }, `${where}\\.mode is missing or not a string`],
      ['filter_number.glb', (m) => { m.filter = 1; }, `${where}\\.filter must be a string`]]) {
      const j = JSON.parse(JSON.stringify(json));
      edit(j.bufferViews[v].extensions.EXT_meshopt_compression);
      const f = path.join(dir, name);
      writeGlb(f, j, Buffer.from(bin));
      assertRefusedByEveryCommand(st, f, 2, new RegExp(needle));
    }
  });

  // The extension's rules on mode, filter and stride (EXT_meshopt_compression, "for the extension object
  // to be valid"): the filter of index data and the view's own byteStride were not looked at before (a
  // view whose accessors read the decoded bytes at another stride than the stream's was decoded anyway).
  await t.test('EXT_meshopt_compression against its filter and stride rules -> exit 2 naming the bufferView', (st) => {
    const { json, bin } = parseGlb(fs.readFileSync(corpusPath('compressed/BoxMeshopt.glb')));
    const ext = (j, mode) => j.bufferViews.findIndex((x) => x.extensions?.EXT_meshopt_compression?.mode === mode);
    const attributes = ext(json, 'ATTRIBUTES'), triangles = ext(json, 'TRIANGLES');
    assert.ok(attributes >= 0 && triangles >= 0, 'test premise: BoxMeshopt has attribute and triangle streams');
    const stride = json.bufferViews[attributes].extensions.EXT_meshopt_compression.byteStride;
    for (const [name, edit, needle] of [
      ['index_filter.glb', (j) => { j.bufferViews[triangles].extensions.EXT_meshopt_compression.filter = 'OCTAHEDRAL'; },
        `bufferViews\\[${triangles}\\]: meshopt TRIANGLES data cannot have a filter \\("OCTAHEDRAL"\\)`],
      ['view_stride.glb', (j) => { j.bufferViews[attributes].byteStride = stride + 4; },
        `bufferViews\\[${attributes}\\]: byteStride ${stride + 4} differs from its meshopt byteStride ${stride}`],
      ['unknown_filter.glb', (j) => { j.bufferViews[attributes].extensions.EXT_meshopt_compression.filter = 'COLOR'; },
        `bufferViews\\[${attributes}\\]: unknown meshopt filter "COLOR"`]]) {
      const j = JSON.parse(JSON.stringify(json));
      edit(j);
      const f = path.join(dir, name);
      writeGlb(f, j, Buffer.from(bin));
      assertRefusedByEveryCommand(st, f, 2, new RegExp(needle));
    }
  });
});

// ---------------------------------------------------------------------------------------------
// 4. Safe writes

/** Runs as user nobody (setpriv), for permission tests when we are root; null when impossible. */
function asNobodyPrefix() {
  const probe = spawnSync('setpriv', ['--reuid=65534', '--regid=65534', '--clear-groups', 'true'], { encoding: 'utf8' });
  return probe.status === 0 ? ['setpriv', '--reuid=65534', '--regid=65534', '--clear-groups'] : null;
}

/**
 * A 16 KiB tmpfs mounted at dir in a private mount namespace, lodpipe run inside it, then what is left on
 * the tmpfs listed into listFile (outside it); null when this machine does not let us mount.
 */
function smallTmpfsPrefix(dir, listFile) {
  const script = 'mount -t tmpfs -o size=16k lodpipe-test "$0" || exit 99; "$@"; rc=$?; ls -A "$0" > "$LIST"; exit $rc';
  const probe = spawnSync('unshare', ['-m', 'sh', '-c', script, dir, 'true'], { encoding: 'utf8', env: { ...process.env, LIST: listFile } });
  return probe.status === 0 ? ['env', `LIST=${listFile}`, 'unshare', '-m', 'sh', '-c', script, dir] : null;
}

test('safe writes: refusal, missing and read-only folders, full disk', { skip }, async (t) => {
  await t.test('the main job refuses to overwrite its input (exit 1, input unchanged); --force writes it', (st) => {
    const dir = tempDir(st);
    const copy = path.join(dir, 'duck.glb');
    fs.copyFileSync(DUCK, copy);
    const before = fs.readFileSync(copy);
    const r = runLodpipe([copy, '-o', copy]);
    const p = refusalProblems(r, 1, 'duck.glb', dir, ['duck.glb']);
    if (!fs.readFileSync(copy).equals(before)) p.push('the input was changed');
    assert.deepEqual(p, [], describeRun(r));
    const link = path.join(dir, 'alias.glb');
    fs.symlinkSync(copy, link);
    const viaLink = runLodpipe([copy, '-o', link]);
    assert.equal(viaLink.status, 1, `a symlink to the input is the input: ${describeRun(viaLink)}`);
    const forced = runLodpipe([copy, '-o', copy, '--force']);
    assert.deepEqual(mainJobProblems(forced, copy), [], describeRun(forced));
    assert.ok(!fs.readFileSync(copy).equals(before), '--force rewrote the file');
    assert.deepEqual(listFilesRecursive(dir).sort(), ['alias.glb', 'duck.glb']);
  });

  // A .gltf output writes <OUT stem>.bin: named after one of the input's own buffers, it would replace data
  // the input needs (CesiumMilkTruck0.gltf next to CesiumMilkTruck.gltf, whose buffer is CesiumMilkTruck0.bin).
  await t.test('an output whose .bin would replace a file the input reads -> exit 1, input intact', (st) => {
    const dir = tempDir(st);
    const names = ['CesiumMilkTruck.gltf', 'CesiumMilkTruck0.bin', 'CesiumMilkTruck.png'];
    for (const f of names) fs.copyFileSync(corpusPath(`scenes/CesiumMilkTruck/${f}`), path.join(dir, f));
    const before = fs.readFileSync(path.join(dir, 'CesiumMilkTruck0.bin'));
    const input = path.join(dir, 'CesiumMilkTruck.gltf');
    for (const args of [[input, '-o', path.join(dir, 'CesiumMilkTruck0.gltf')],
                        [input, '-o', path.join(dir, 'CesiumMilkTruck0.gltf'), '--force'],
                        ['convert', input, path.join(dir, 'CesiumMilkTruck0.gltf')]]) {
      const r = runLodpipe(args);
      const p = refusalProblems(r, 1, 'CesiumMilkTruck0.bin', dir, names);
      if (!fs.readFileSync(path.join(dir, 'CesiumMilkTruck0.bin')).equals(before)) p.push('the input\'s buffer was changed');
      assert.deepEqual(p, [], `${args.join(' ')}: ${describeRun(r)}`);
    }
    // beside the input under another name: its texture is "copied" onto itself (same bytes), which is fine
    const beside = runLodpipe([input, '-o', path.join(dir, 'lod.gltf')]);
    assert.equal(beside.status, 0, describeRun(beside));
    assert.deepEqual(listFilesRecursive(dir).sort(), [...names, 'lod.bin', 'lod.gltf'].sort());
    // a GLB input named like the .bin a .gltf output writes
    const glbAsBin = path.join(dir, 'duck.bin');
    fs.copyFileSync(DUCK, glbAsBin);
    const r = runLodpipe([glbAsBin, '-o', path.join(dir, 'duck.gltf')]);
    assert.deepEqual(refusalProblems(r, 1, 'duck.bin', dir, [...names, 'lod.bin', 'lod.gltf', 'duck.bin']), [], describeRun(r));
    assert.ok(fs.readFileSync(glbAsBin).equals(fs.readFileSync(DUCK)), 'the input is unchanged');
  });

  // An image named like the .bin a .gltf output writes (uri "out.bin", -o DIR/out.gltf): the image's copy replaced
  // the buffer, and the output, exit 0, read a PNG as its geometry (QA). Two files of one output with one name and
  // other bytes are refused before anything is written.
  await t.test('an input image named like the output\'s .bin -> exit 1, nothing written', (st) => {
    const dir = tempDir(st), out = tempDir(st);
    const truck = JSON.parse(fs.readFileSync(corpusPath('scenes/CesiumMilkTruck/CesiumMilkTruck.gltf'), 'utf8'));
    truck.images[0].uri = 'out.bin';
    fs.writeFileSync(path.join(dir, 'truck.gltf'), JSON.stringify(truck));
    fs.copyFileSync(corpusPath('scenes/CesiumMilkTruck/CesiumMilkTruck0.bin'), path.join(dir, 'CesiumMilkTruck0.bin'));
    fs.copyFileSync(corpusPath('scenes/CesiumMilkTruck/CesiumMilkTruck.png'), path.join(dir, 'out.bin'));
    for (const args of [[path.join(dir, 'truck.gltf'), '-o', path.join(out, 'out.gltf')],
                        ['convert', path.join(dir, 'truck.gltf'), path.join(out, 'out.gltf')]]) {
      const r = runLodpipe(args);
      assert.deepEqual(refusalProblems(r, 1, `${path.join(out, 'out.bin')} (written with the output) would be two files`,
        out, []), [], describeRun(r));
    }
    const other = runLodpipe([path.join(dir, 'truck.gltf'), '-o', path.join(out, 'lod.gltf')]);
    assert.deepEqual(mainJobProblems(other, path.join(out, 'lod.gltf')), [], describeRun(other));
    assert.ok(fs.readFileSync(path.join(out, 'out.bin')).equals(fs.readFileSync(path.join(dir, 'out.bin'))), 'the image');
  });

  // On a case-insensitive volume (exFAT, as a Windows or macOS share) scene.gltf IS Scene.gltf, and data.bin IS
  // Data.bin; FUSE's exFAT gives each name its own inode number, so the identity check alone missed both (QA:
  // the input was replaced, exit 0). Names that differ only in case are one file where the folder ignores case.
  await t.test('on a case-insensitive volume, an output named like the input or its .bin but for case -> exit 1', (st) => {
    const vol = caseBlindVolume(st);
    if (vol.skip) return st.skip(vol.skip);
    const dir = path.join(vol.mount, 'in');
    fs.mkdirSync(dir);
    const names = ['CesiumMilkTruck.gltf', 'Data.bin', 'CesiumMilkTruck.png'];
    const truck = JSON.parse(fs.readFileSync(corpusPath('scenes/CesiumMilkTruck/CesiumMilkTruck.gltf'), 'utf8'));
    truck.buffers[0].uri = 'Data.bin';
    fs.writeFileSync(path.join(dir, names[0]), JSON.stringify(truck));
    fs.copyFileSync(corpusPath('scenes/CesiumMilkTruck/CesiumMilkTruck0.bin'), path.join(dir, 'Data.bin'));
    fs.copyFileSync(corpusPath('scenes/CesiumMilkTruck/CesiumMilkTruck.png'), path.join(dir, names[2]));
    const before = names.map((f) => fs.readFileSync(path.join(dir, f)));
    const input = path.join(dir, names[0]);
    for (const [out, name] of [['cesiummilktruck.gltf', 'refusing to overwrite the input'], ['CESIUMMILKTRUCK.GLTF',
      'refusing to overwrite the input'], ['data.gltf', 'data.bin (written with the output) is a file the input reads']]) {
      const r = runLodpipe([input, '-o', path.join(dir, out)]);
      assert.deepEqual(refusalProblems(r, 1, name, dir, names), [], `-o ${out}: ${describeRun(r)}`);
    }
    names.forEach((f, i) => assert.ok(fs.readFileSync(path.join(dir, f)).equals(before[i]), `${f} is unchanged`));
    const forced = runLodpipe([input, '-o', path.join(dir, 'cesiummilktruck.gltf'), '--force']);
    assert.equal(forced.status, 0, `--force writes over the input: ${describeRun(forced)}`);
    // an input (on a case-sensitive disk) whose images T.png and t.png would be one file in the output's folder
    const src = tempDir(st), out = path.join(vol.mount, 'out');
    fs.mkdirSync(out);
    truck.buffers[0].uri = 'CesiumMilkTruck0.bin';
    truck.images = [{ uri: 'T.png' }, { uri: 't.png' }];
    truck.textures.push({ source: 1 });
    fs.writeFileSync(path.join(src, 'two.gltf'), JSON.stringify(truck));
    fs.copyFileSync(corpusPath('scenes/CesiumMilkTruck/CesiumMilkTruck0.bin'), path.join(src, 'CesiumMilkTruck0.bin'));
    fs.copyFileSync(corpusPath('scenes/CesiumMilkTruck/CesiumMilkTruck.png'), path.join(src, 'T.png'));
    fs.copyFileSync(corpusPath('scenes/kenney/Textures/colormap.png'), path.join(src, 't.png'));
    const two = runLodpipe([path.join(src, 'two.gltf'), '-o', path.join(out, 'two.gltf')]);
    assert.deepEqual(refusalProblems(two, 1, `${path.join(out, 'T.png')} and ${path.join(out, 't.png')} (written with ` +
      'the output) are one file on this file system', out, []), [], describeRun(two));
    const elsewhere = path.join(tempDir(st), 'two.gltf');
    assert.equal(runLodpipe([path.join(src, 'two.gltf'), '-o', elsewhere]).status, 0, 'on a case-sensitive disk it is fine');
  });

  await t.test('--depfile naming OUT, IN, the config or a file IN reads, or in a missing folder -> refused before the work', (st) => {
    const dir = tempDir(st);
    const names = ['CesiumMilkTruck.gltf', 'CesiumMilkTruck0.bin', 'CesiumMilkTruck.png', 'levels.toml', 'config.bin'];
    for (const f of names.slice(0, 3)) fs.copyFileSync(corpusPath(`scenes/CesiumMilkTruck/${f}`), path.join(dir, f));
    // the config is an input too: neither the depfile nor a .gltf output's .bin may replace it
    fs.writeFileSync(path.join(dir, 'levels.toml'), '[lod]\nlevels = [2, 4]\n');
    fs.writeFileSync(path.join(dir, 'config.bin'), '[lod]\nlevels = [2, 4]\n');
    const input = path.join(dir, 'CesiumMilkTruck.gltf');
    const out = path.join(dir, 'out.glb');
    const cases = [
      [[input, '-o', out, '--depfile', out], 1, 'output'],
      [[input, '-o', out, '--depfile', input], 1, 'input'],
      [[input, '-o', out, '--depfile', path.join(dir, 'CesiumMilkTruck.png')], 1, 'CesiumMilkTruck.png'],
      [[input, '-o', path.join(dir, 'out.gltf'), '--depfile', path.join(dir, 'out.bin')], 1, 'out.bin'],
      [[input, '-o', out, '--depfile', path.join(dir, 'missing', 'x.d')], 4, 'missing'],
      [[input, '-o', out, '--config', path.join(dir, 'levels.toml'), '--depfile', path.join(dir, 'levels.toml')], 1,
        'config'],
      [[input, '-o', path.join(dir, 'config.gltf'), '--config', path.join(dir, 'config.bin')], 1, 'config.bin'],
    ];
    const before = names.map((f) => fs.readFileSync(path.join(dir, f)));
    for (const [args, code, name] of cases) {
      const r = runLodpipe(args);
      assert.deepEqual(refusalProblems(r, code, name, dir, names), [], `${args.join(' ')}: ${describeRun(r)}`);
    }
    names.forEach((f, i) => assert.ok(fs.readFileSync(path.join(dir, f)).equals(before[i]), `${f} unchanged`));
  });

  await t.test('.gltf output names that need percent-encoding: the buffer uri is encoded and reads back', (st) => {
    const dir = tempDir(st);
    for (const stem of ['a%20b', 'c#d', 'ö t', 'ab:c']) {
      const out = path.join(dir, `${stem}.gltf`);
      const r = runLodpipe([DUCK, '-o', out]);
      assert.equal(r.status, 0, describeRun(r));
      const uri = JSON.parse(fs.readFileSync(out, 'utf8')).buffers[0].uri;
      assert.equal(decodeURIComponent(uri), `${stem}.bin`, `uri ${uri}`);
      assert.match(uri.replace(/%[0-9A-F]{2}/g, ''), /^[A-Za-z0-9\-._~!$&'()*+,;=@]*$/, `uri ${uri}: a character that needs encoding`);
      const back = runLodpipe(['inspect', out]);
      assert.equal(back.status, 0, `lodpipe reads its own output: ${describeRun(back)}`);
    }
  });

  await t.test('a missing output folder -> exit 4, one line, nothing created', (st) => {
    const dir = tempDir(st);
    const r = runLodpipe([DUCK, '-o', path.join(dir, 'missing', 'out.glb')]);
    assert.deepEqual(refusalProblems(r, 4, 'missing', dir), [], describeRun(r));
  });

  await t.test('the output folder is checked before the input is read', (st) => {
    const dir = tempDir(st);
    const garbage = path.join(dir, 'garbage.glb');
    fs.writeFileSync(garbage, 'not a glb at all');
    for (const args of [[garbage, '-o', path.join(dir, 'missing', 'out.glb')],
                        ['convert', garbage, path.join(dir, 'missing', 'out.gltf')],
                        ['simplify', garbage, path.join(dir, 'missing')]]) {
      const r = runLodpipe(args);
      // an input error (exit 2) would mean the input was read first
      const p = refusalProblems(r, 4, 'missing', dir, ['garbage.glb']);
      if (!r.stderr.includes('output folder')) p.push('stderr does not say "output folder"');
      assert.deepEqual(p, [], `${args.join(' ')}: ${describeRun(r)}`);
    }
  });

  await t.test('an output "folder" that is a file -> exit 4', (st) => {
    const dir = tempDir(st);
    fs.writeFileSync(path.join(dir, 'plain'), 'x');
    const r = runLodpipe([DUCK, '-o', path.join(dir, 'plain', 'out.glb')]);
    assert.deepEqual(refusalProblems(r, 4, 'plain', dir, ['plain']), [], describeRun(r));
  });

  await t.test('a read-only folder -> exit 4, no file, an existing output untouched', (st) => {
    let prefix = [];
    if (isRoot) {
      prefix = asNobodyPrefix();
      if (!prefix) {
        st.skip('running as root and setpriv cannot drop to nobody: permissions would not stop the write');
        return;
      }
      st.diagnostic('running as root: lodpipe runs as user nobody (setpriv) so that the folder mode applies');
    }
    const dir = tempDir(st);
    const input = path.join(dir, 'in.glb');
    fs.copyFileSync(DUCK, input);
    fs.chmodSync(input, 0o644);
    const ro = path.join(dir, 'ro');
    fs.mkdirSync(ro);
    fs.writeFileSync(path.join(ro, 'out.glb'), 'old');
    fs.chmodSync(ro, 0o555);
    fs.chmodSync(dir, 0o755);
    try {
      for (const name of ['out.glb', 'new.gltf']) {
        const r = runLodpipe([input, '-o', path.join(ro, name)], { prefix });
        const p = refusalProblems(r, 4, name, ro, ['out.glb']);
        if (fs.readFileSync(path.join(ro, 'out.glb'), 'utf8') !== 'old') p.push('the existing output was changed');
        assert.deepEqual(p, [], describeRun(r));
      }
    } finally {
      fs.chmodSync(ro, 0o755); // so the folder can be removed
    }
  });

  await t.test('a folder where no file can be created (/proc/self, even for root) -> exit 4', () => {
    const r = runLodpipe([DUCK, '-o', '/proc/self/lodpipe-out.glb']);
    assert.deepEqual(refusalProblems(r, 4, '/proc/self', null), [], describeRun(r));
  });

  for (const kind of ['.glb', '.gltf']) {
    await t.test(`a full disk (ulimit -f 64 KiB) writing ${kind} -> exit 4, no partial file, an existing output untouched`, (st) => {
      const dir = tempDir(st);
      const out = path.join(dir, `out${kind}`);
      fs.writeFileSync(out, 'old');
      const r = runLodpipe([DUCK, '-o', out], { prefix: ['bash', '-c', 'ulimit -f 64 && exec "$@"', 'bash'] });
      const p = refusalProblems(r, 4, `out${kind}`, dir, [`out${kind}`]);
      if (!/File too large|No space/.test(r.stderr)) p.push('stderr does not give the reason');
      if (fs.readFileSync(out, 'utf8') !== 'old') p.push('the existing output was changed');
      assert.deepEqual(p, [], describeRun(r));
    });
  }

  await t.test('a full disk (16 KiB tmpfs) -> exit 4, nothing left on it', (st) => {
    const dir = tempDir(st);
    const listFile = path.join(tempDir(st), 'left.txt');
    const prefix = smallTmpfsPrefix(dir, listFile);
    if (!prefix) {
      st.skip('cannot mount a tmpfs here (unshare -m / mount not permitted); the ulimit cases cover a full disk');
      return;
    }
    fs.rmSync(listFile, { force: true });
    const r = runLodpipe([DUCK, '-o', path.join(dir, 'out.glb')], { prefix });
    const p = [...runHealthProblems(r), ...oneLineErrorProblems(r.stderr)];
    if (r.status !== 4) p.push(`exit status ${r.status} (expected 4)`);
    if (!/No space|File too large/.test(r.stderr)) p.push('stderr does not say the disk is full');
    if (!fs.existsSync(listFile)) p.push('the tmpfs was not listed after the run');
    else if (fs.readFileSync(listFile, 'utf8').trim()) p.push(`files left on the tmpfs: ${fs.readFileSync(listFile, 'utf8').trim()}`);
    assert.deepEqual(p, [], describeRun(r));
  });
});

// A file or mesh name is text from outside: a newline in it must not split a message into two lines
// (a CI log parser, or a batch summary that keeps the first line, would lose or misread it).
test('names with control characters stay on one line, escaped', { skip }, async (t) => {
  const dir = tempDir(t);
  const bad = path.join(dir, 'a\nb.glb');
  fs.writeFileSync(bad, 'not a glb at all');
  await t.test('an error naming such a file: one line, the newline shown as \\n', () => {
    const r = runLodpipe([bad, '-o', path.join(dir, 'out.glb')]);
    assert.deepEqual(refusalProblems(r, 2, 'a\\nb.glb', dir, ['a\nb.glb']), [], describeRun(r));
  });
  await t.test('batch: the failed file is one line in stderr and in the summary', () => {
    const src = path.join(dir, 'src');
    fs.mkdirSync(src);
    fs.copyFileSync(bad, path.join(src, 'x\ty.glb'));
    const r = runLodpipe(['batch', src, '-o', path.join(dir, 'built'), '--json']);
    assert.equal(r.status, 5, describeRun(r));
    const lines = r.stderr.trim().split('\n');
    assert.equal(lines.length, 1, describeRun(r));
    assert.match(lines[0], /x\\ty\.glb/);
    assert.deepEqual(oneLineErrorProblems(lines[0]), []);
  });
  await t.test('inspect prints file, mesh and node names on their own lines', () => {
    const { json, bin } = parseGlb(fs.readFileSync(DUCK));
    json.meshes[0].name = 'mesh\nname';
    json.nodes.forEach((n) => { n.name = 'node\r\nname\u0007'; });
    const file = path.join(dir, 'c\td.glb');
    writeGlb(file, json, bin);
    const r = runLodpipe(['inspect', file]);
    assert.equal(r.status, 0, describeRun(r));
    assert.match(r.stdout, /^file: .*c\\td\.glb$/m);
    assert.match(r.stdout, /^mesh 0 "mesh\\nname": /m);
    assert.match(r.stdout, /"node\\r\\nname\\x07"/);
    assert.ok(r.stdout.split('\n').every((l) => l === '' || /^(file|scenes|mesh|  |LOD)/.test(l)), r.stdout);
  });
});

// Input may come through a pipe (`lodpipe <(curl ...)`, `... | lodpipe /dev/stdin`): it is read to its end. What
// a glTF references must be a regular file: a directory was "read" at an absurd size (an allocation abort under
// ASan) and a FIFO blocked the run forever. A device is never read (/dev/zero would not end).
test('non-regular files: a piped input is read; directories, FIFOs and devices are refused at once', { skip }, async (t) => {
  const truck = ['CesiumMilkTruck.gltf', 'CesiumMilkTruck0.bin', 'CesiumMilkTruck.png'];
  await t.test('a piped input (/dev/stdin) is simplified like the file', (st) => {
    const dir = tempDir(st);
    const out = path.join(dir, 'out.glb');
    const r = runLodpipe(['/dev/stdin', '-o', out], { prefix: ['sh', '-c', 'cat "$0" | "$@"', DUCK] });
    assert.deepEqual(mainJobProblems(r, out), [], describeRun(r));
    const direct = runLodpipe([DUCK, '-o', path.join(dir, 'direct.glb')]);
    assert.ok(fs.readFileSync(out).equals(fs.readFileSync(path.join(dir, 'direct.glb'))), 'same bytes as from the file');
  });
  for (const [name, make] of [['a directory', (p) => fs.mkdirSync(p)],
                              ['a FIFO', (p) => spawnSync('mkfifo', [p])]]) {
    for (const replaced of ['CesiumMilkTruck0.bin', 'CesiumMilkTruck.png']) {
      await t.test(`${replaced} is ${name} -> exit 4, one line naming it, no hang`, (st) => {
        const dir = tempDir(st);
        for (const f of truck) if (f !== replaced) fs.copyFileSync(corpusPath(`scenes/CesiumMilkTruck/${f}`), path.join(dir, f));
        make(path.join(dir, replaced));
        const r = runLodpipe([path.join(dir, 'CesiumMilkTruck.gltf'), '-o', path.join(dir, 'out.glb')], { timeout: 60000 });
        assert.deepEqual(refusalProblems(r, 4, replaced, dir, [...truck, `${replaced}/`]), [], describeRun(r));
        assert.match(r.stderr, /not a regular file/);
      });
    }
  }
  // Opening a named pipe waits for a writer: `lodpipe f.glb -o out.glb` on a stray mkfifo blocked forever. It is
  // refused before it is opened; the anonymous pipes of `|` and `<(...)` (above) are still read.
  await t.test('a named pipe (mkfifo) as input -> exit 4 at once, "not a regular file", from every command', (st) => {
    const dir = tempDir(st);
    const fifo = path.join(dir, 'f.glb');
    assert.equal(spawnSync('mkfifo', [fifo]).status, 0);
    for (const args of [[fifo, '-o', path.join(dir, 'out.glb')], ['inspect', fifo], ['convert', fifo, path.join(dir, 'out.glb')], ['check', fifo]]) {
      const r = runLodpipe(args, { timeout: 20000 });
      const p = refusalProblems(r, 4, 'f.glb', dir, ['f.glb']);
      if (!/f\.glb: is not a regular file \(a named pipe, FIFO\)$/m.test(r.stderr)) p.push('stderr does not say "is not a regular file (a named pipe, FIFO)"');
      assert.deepEqual(p, [], `${args[0]}: ${describeRun(r)}`);
    }
  });
  // `lodpipe /dev/stdin < fifo`: the shell opened the named pipe (waiting for its writer) before lodpipe ran, so it
  // is read like any pipe; a named pipe that is lodpipe's own stdout is still refused (reading it would wait on
  // lodpipe itself).
  await t.test('a named pipe as the standard input is read; one that is lodpipe\'s stdout is refused', (st) => {
    const dir = tempDir(st);
    const fifo = path.join(dir, 'f.glb');
    assert.equal(spawnSync('mkfifo', [fifo]).status, 0);
    const out = path.join(dir, 'out.glb');
    const fed = runLodpipe(['/dev/stdin', '-o', out],
                           { prefix: ['sh', '-c', 'f="$0"; d="$1"; shift; cat "$d" > "$f" & exec "$@" < "$f"', fifo, DUCK],
                             timeout: 60000 });
    assert.deepEqual(mainJobProblems(fed, out), [], describeRun(fed));
    const direct = runLodpipe([DUCK, '-o', path.join(dir, 'direct.glb')]);
    assert.ok(fs.readFileSync(out).equals(fs.readFileSync(path.join(dir, 'direct.glb'))), 'same bytes as from the file');
    const own = runLodpipe(['inspect', fifo],
                           { prefix: ['sh', '-c', 'f="$0"; cat "$f" > /dev/null & exec "$@" > "$f"', fifo], timeout: 20000 });
    assert.equal(own.status, 4, describeRun(own));
    assert.match(own.stderr, /f\.glb: is not a regular file \(a named pipe, FIFO\)$/m);
  });
  await t.test('a device as input -> exit 4 without reading it', (st) => {
    const dir = tempDir(st);
    const r = runLodpipe(['/dev/zero', '-o', path.join(dir, 'out.glb')], { timeout: 60000 });
    assert.deepEqual(refusalProblems(r, 4, '/dev/zero', dir), [], describeRun(r));
  });
});

// Invalid input that lodpipe can still process is kept as it came (no new validator error); a transform no float can
// hold is refused rather than written as null switching distances.
test('a mesh without primitives is kept as it is; a world transform beyond float range -> exit 2', { skip }, async (t) => {
  await t.test('a mesh without "primitives", used by a node: exit 0, the mesh unchanged, no new validator error', async (st) => {
    const dir = tempDir(st);
    const { json, bin } = parseGlb(fs.readFileSync(DUCK));
    json.meshes.push({ name: 'noprims', extras: { kept: true } });
    json.nodes.push({ mesh: json.meshes.length - 1, name: 'empty' });
    json.scenes[json.scene ?? 0].nodes.push(json.nodes.length - 1);
    const input = path.join(dir, 'in.glb');
    writeGlb(input, json, bin);
    const out = path.join(dir, 'out.glb');
    const r = runLodpipe([input, '-o', out]);
    assert.deepEqual(mainJobProblems(r, out), [], describeRun(r));
    const outJson = parseGlb(fs.readFileSync(out)).json;
    assert.deepEqual(outJson.meshes[json.meshes.length - 1], { name: 'noprims', extras: { kept: true } });
    assert.deepEqual(newValidatorErrors(await validateFileCached(input), await validateFileCached(out)), []);
  });
  await t.test('nine nested scales of 1e38, and one scale of 1e300: exit 2 naming the node', (st) => {
    const dir = tempDir(st);
    const { json, bin } = parseGlb(fs.readFileSync(DUCK));
    const mesh = json.nodes.find((n) => n.mesh !== undefined).mesh;
    const cases = {
      'nested.glb': [...Array.from({ length: 8 }, (_, i) => ({ children: [i + 1], scale: [1e38, 1e38, 1e38] })),
                     { mesh, scale: [1e38, 1e38, 1e38] }],
      'single.glb': [{ mesh, scale: [1e300, 1, 1] }],
    };
    for (const [name, nodes] of Object.entries(cases)) {
      const input = path.join(dir, name);
      writeGlb(input, { ...json, nodes, scenes: [{ nodes: [0] }], scene: 0, animations: undefined }, bin);
      const r = runLodpipe([input, '-o', path.join(dir, 'out.glb')]);
      assert.deepEqual(refusalProblems(r, 2, name, dir, Object.keys(cases)), [], describeRun(r));
      assert.match(r.stderr, /nodes\[\d\]: its world transform is beyond the float range/);
    }
  });
  // An instance SCALE of Infinity or NaN (a validator error) wrote "distance": null or 0 with exit 0 (QA)
  await t.test('an EXT_mesh_gpu_instancing SCALE of Infinity or NaN: exit 2 naming the node', (st) => {
    const dir = tempDir(st);
    const { json, bin } = parseGlb(fs.readFileSync(DUCK));
    const node = json.nodes.findIndex((n) => n.mesh !== undefined);
    const names = [];
    for (const [name, value] of [['inf.glb', Infinity], ['nan.glb', NaN]]) {
      const scale = Buffer.from(new Float32Array([value, 1, 1, 1, 1, 1]).buffer);
      const padded = Buffer.concat([bin, Buffer.alloc((4 - (bin.length % 4)) % 4)]);
      const j = structuredClone(json);
      j.bufferViews.push({ buffer: 0, byteOffset: padded.length, byteLength: scale.length });
      j.accessors.push({ bufferView: j.bufferViews.length - 1, componentType: 5126, count: 2, type: 'VEC3' });
      j.buffers[0].byteLength = padded.length + scale.length;
      j.nodes[node].extensions = { EXT_mesh_gpu_instancing: { attributes: { SCALE: j.accessors.length - 1 } } };
      j.extensionsUsed = [...(j.extensionsUsed || []), 'EXT_mesh_gpu_instancing'];
      const input = path.join(dir, name);
      writeGlb(input, j, Buffer.concat([padded, scale]));
      names.push(name);
      const r = runLodpipe([input, '-o', path.join(dir, 'out.glb')]);
      assert.deepEqual(refusalProblems(r, 2, name, dir, names), [], describeRun(r));
      assert.match(r.stderr, new RegExp(`nodes\\[${node}\\]\\.extensions\\.EXT_mesh_gpu_instancing: a SCALE value is NaN or infinite`));
    }
  });
});

// The end of a run (QA, README "Exit codes"): a stop signal between two renames must not leave an output half
// replaced (a new .bin beside the old .gltf); a signal the parent made lodpipe ignore stays ignored; the
// --depfile and the simplify command's files are written all or nothing with the rest; one failure class, one
// exit code, whatever else exists; a batch summary names the failure, not a warning printed before it; a camera
// that would give infinite switching distances is refused. strace injects the signal at the first rename(2).
const TRUCK_FILES = ['CesiumMilkTruck.gltf', 'CesiumMilkTruck0.bin', 'CesiumMilkTruck.png'];
// strace may be installed yet not allowed to trace (a container without ptrace): probe it
const haveStrace = spawnSync('strace', ['-o', '/dev/null', 'true']).status === 0;

function truckCopy(dir) {
  for (const f of TRUCK_FILES) fs.copyFileSync(corpusPath(`scenes/CesiumMilkTruck/${f}`), path.join(dir, f));
  return path.join(dir, 'CesiumMilkTruck.gltf');
}

/**
 * runLodpipe with `signal` delivered at the process's first rename (rename, renameat or renameat2: which one
 * glibc uses depends on the architecture); r.delivered says whether strace saw the signal arrive.
 * LeakSanitizer cannot run under ptrace.
 */
function runSignalledAtRename(args, signal, log, shellPrefix = []) {
  const calls = 'rename,renameat,renameat2';
  const r = runLodpipe(args, {
    prefix: [...shellPrefix, 'strace', '-f', '-o', log, '-e', `trace=${calls}`, '-e', `inject=${calls}:signal=${signal}:when=1`],
    env: { ASAN_OPTIONS: `${process.env.ASAN_OPTIONS ? process.env.ASAN_OPTIONS + ':' : ''}detect_leaks=0` },
  });
  r.delivered = fs.existsSync(log) && fs.readFileSync(log, 'utf8').includes(`--- ${signal} `);
  return r;
}

test('the end of a run: stops between renames, the depfile, exit codes, batch errors, the camera', { skip }, async (t) => {
  await t.test('SIGTERM at the first rename: the output is whole (new .gltf with its new .bin), then the signal', { skip: !haveStrace && 'strace not installed' }, async (st) => {
    const dir = tempDir(st);
    const input = truckCopy(dir);
    const out = path.join(dir, 'out');
    fs.mkdirSync(out);
    const target = path.join(out, 'b.gltf');
    const first = runLodpipe([input, '-o', target, '--levels', '1,3', '-q']);
    assert.equal(first.status, 0, describeRun(first));
    const before = fs.readFileSync(target);
    const r = runSignalledAtRename([input, '-o', target, '--levels', '5,20', '-q'], 'SIGTERM', path.join(dir, 'strace.log'));
    assert.ok(r.delivered, 'strace delivered the signal at a rename');
    assert.equal(r.signal, 'SIGTERM', `ends by the signal\n${describeRun(r)}`);
    assert.deepEqual(listFilesRecursive(out), ['CesiumMilkTruck.png', 'b.bin', 'b.gltf'], 'no temp file left');
    assert.ok(!fs.readFileSync(target).equals(before), 'the renames went on to the main file');
    assert.deepEqual(newValidatorErrors(await validateFileCached(input), await validateFileCached(target)), [],
      'the new .gltf and the new .bin belong together');
  });
  await t.test('SIGINT ignored by the parent (a background job of a script) stays ignored while writing', { skip: !haveStrace && 'strace not installed' }, (st) => {
    const dir = tempDir(st);
    const out = path.join(dir, 'out.glb');
    const logs = tempDir(st);
    // the control: not ignored, the same injection ends the run by SIGINT (strace does not report a signal
    // that is ignored, so this is what shows the injection happens)
    const control = runSignalledAtRename([DUCK, '-o', out, '-q'], 'SIGINT', path.join(logs, 'control.log'));
    assert.equal(control.signal, 'SIGINT', `control: ends by the signal\n${describeRun(control)}`);
    fs.rmSync(out, { force: true });
    const r = runSignalledAtRename([DUCK, '-o', out, '-q'], 'SIGINT', path.join(logs, 'ignored.log'), ['sh', '-c', 'trap "" INT; exec "$@"', 'sh']);
    assert.equal(r.status, 0, describeRun(r));
    assert.deepEqual(listFilesRecursive(dir), ['out.glb']);
  });
  await t.test('a --depfile that cannot be written: exit 4 and no OUT either; an earlier OUT left as it was', (st) => {
    const dir = tempDir(st);
    const out = path.join(dir, 'out.glb');
    fs.mkdirSync(path.join(dir, 'dep.d')); // a folder: its parent exists, the write fails at the end
    const fresh = runLodpipe([DUCK, '-o', out, '--depfile', path.join(dir, 'dep.d')]);
    assert.deepEqual(refusalProblems(fresh, 4, 'dep.d', dir, ['dep.d/']), [], describeRun(fresh));
    fs.writeFileSync(out, 'old');
    const again = runLodpipe([DUCK, '-o', out, '--depfile', path.join(dir, 'dep.d')]);
    assert.deepEqual(refusalProblems(again, 4, 'dep.d', dir, ['dep.d/', 'out.glb']), [], describeRun(again));
    assert.equal(fs.readFileSync(out, 'utf8'), 'old');
  });
  await t.test('simplify: a write failing on a later OBJ leaves none of them (ulimit -f)', (st) => {
    const dir = tempDir(st);
    const input = corpusPath('scenes/ShapeCollection.glb');
    const free = runLodpipe(['simplify', input, dir, '-q']);
    assert.equal(free.status, 0, describeRun(free));
    // the files in the order they are written (mesh by mesh, level by level): a limit the first one fits
    // under and a later one does not, so the failure comes after some files were written
    const written = listFilesRecursive(dir).filter((f) => f.endsWith('.obj'))
      .map((f) => [f, fs.statSync(path.join(dir, f)).size, f.match(/\d+/g).map(Number)])
      .sort((a, b) => a[2][0] - b[2][0] || a[2][1] - b[2][1]);
    const limitKiB = Math.ceil(written[0][1] / 1024);
    const failing = written.find(([, size]) => size > limitKiB * 1024);
    assert.ok(failing && written.indexOf(failing) > 0, `precondition: a later file exceeds ${limitKiB} KiB`);
    fs.rmSync(dir, { recursive: true });
    fs.mkdirSync(dir);
    const r = runLodpipe(['simplify', input, dir, '-q'], { prefix: ['bash', '-c', `ulimit -f ${limitKiB} && exec "$@"`, 'bash'] });
    assert.deepEqual(refusalProblems(r, 4, failing[0], dir), [], describeRun(r));
  });
  await t.test('a folder where an output file goes: exit 4 before any rename, the old files untouched', (st) => {
    const dir = tempDir(st);
    fs.mkdirSync(path.join(dir, 'out.gltf')); // the main file is renamed last: .bin and depfile would go first
    fs.writeFileSync(path.join(dir, 'out.bin'), 'old bin');
    fs.writeFileSync(path.join(dir, 'dep.d'), 'old dep');
    const r = runLodpipe([DUCK, '-o', path.join(dir, 'out.gltf'), '--depfile', path.join(dir, 'dep.d')]);
    assert.deepEqual(refusalProblems(r, 4, 'out.gltf', dir, ['out.gltf/', 'out.bin', 'dep.d']), [], describeRun(r));
    assert.deepEqual([fs.readFileSync(path.join(dir, 'out.bin'), 'utf8'), fs.readFileSync(path.join(dir, 'dep.d'), 'utf8')], ['old bin', 'old dep']);
  });
  await t.test('one exit code per failure class whether OUT exists or not: a folder 4, over the size limit 2', (st) => {
    const dir = tempDir(st);
    const folder = path.join(dir, 'dir.glb');
    fs.mkdirSync(folder);
    const big = path.join(dir, 'big.glb');
    fs.writeFileSync(big, '');
    fs.truncateSync(big, 3 * 1024 ** 3); // sparse (tmpfs and ext4 store nothing): 3 GiB declared
    const out = path.join(dir, 'out.glb');
    const p = [];
    for (const exists of [false, true]) {
      if (exists) fs.writeFileSync(out, 'old');
      for (const [input, code] of [[folder, 4], [big, 2]]) {
        for (const args of [[input, '-o', out], ['inspect', input], ['check', input]]) {
          const r = runLodpipe(args);
          p.push(...refusalProblems(r, code, path.basename(input), null).map((x) => `${args.join(' ')} (OUT ${exists ? 'present' : 'absent'}): ${x}`));
        }
      }
    }
    assert.deepEqual(p, []);
  });
  await t.test('batch --json: a failed file\'s "error" is its failure line, not a warning printed before it', (st) => {
    const dir = tempDir(st);
    const src = path.join(dir, 'src');
    fs.mkdirSync(src);
    fs.copyFileSync(corpusPath('scans/suzanne.glb'), path.join(src, 'suzanne.glb')); // loads with a warning
    const built = path.join(dir, 'built');
    // a full disk (ulimit -f 20 KiB): the job fails writing, after the warnings of loading
    const r = runLodpipe(['batch', src, '-o', built, '--json'], { prefix: ['bash', '-c', 'ulimit -f 20 && exec "$@"', 'bash'] });
    assert.equal(r.status, 5, describeRun(r));
    assert.match(r.stderr, /suzanne\.glb: warning: /, 'precondition: the job warned before failing');
    const res = JSON.parse(r.stdout).results[0];
    assert.equal(res.status, 'failed');
    assert.doesNotMatch(res.error, /warning/, res.error);
    assert.match(res.error, /cannot write .*suzanne\.glb.*File too large/, res.error);
  });
  await t.test('a camera giving infinite distances or culling everything -> exit 1, one line, nothing written', (st) => {
    const dir = tempDir(st);
    const out = path.join(dir, 'out.glb');
    const p = [];
    for (const args of [['--fov-y', '1e-320'], ['--pixel-error', '1e-320'], ['--pixel-error', '1080'],
      ['--pixel-error', '800', '--viewport-height', '720'], ['--viewport-height', '1e300']]) {
      const r = runLodpipe([DUCK, '-o', out, ...args]);
      p.push(...refusalProblems(r, 1, args[0].replace(/^--/, ''), dir).map((x) => `${args.join(' ')}: ${x}`));
    }
    const ok = runLodpipe([DUCK, '-o', out, '--pixel-error', '1079', '--fov-y', '1e-6', '-q']);
    if (ok.status !== 0) p.push(`a narrow but finite camera: ${describeRun(ok)}`);
    assert.deepEqual(p, []);
    // a rule the file keeps and the flags break names both (QA: "the command line" for a file's key)
    const config = path.join(dir, 'camera.toml');
    fs.writeFileSync(config, '[switching]\npixel_error = 800\n');
    const both = runLodpipe([DUCK, '-o', out, '--config', config, '--viewport-height', '720']);
    assert.deepEqual(refusalProblems(both, 1, 'the command line (with ', dir, ['camera.toml', 'out.glb']), [], describeRun(both));
    const file = runLodpipe([DUCK, '-o', out, '--config', config, '--viewport-height', '720', '--pixel-error', '1']);
    assert.equal(file.status, 0, `the flag mends the file: ${describeRun(file)}`);
    // a rule the file breaks on its own names the file and the line of the last key it involves (QA: no line)
    const own = path.join(dir, 'camera_own.toml');
    fs.writeFileSync(own, '# a camera\n[switching]\nviewport_height = 720\npixel_error = 800\n');
    const alone = runLodpipe([DUCK, '-o', out, '--config', own]);
    assert.deepEqual(refusalProblems(alone, 1, 'camera_own.toml:4: switching.pixel_error', dir, ['camera.toml', 'camera_own.toml', 'out.glb']), [], describeRun(alone));
  });
});

// extensionsRequired (README "What the loader accepts"): an extension that only concerns materials, or one the
// chain carries to its levels (KHR_animation_pointer, KHR_node_visibility), does not stop the run; one lodpipe
// cannot honour does (exit 2, naming it).
test('extensionsRequired: material-only and chain-carried extensions accepted, an unknown one refused', { skip }, async (t) => {
  const { json, bin } = parseGlb(fs.readFileSync(DUCK));
  for (const [ext, code] of [['KHR_materials_diffuse_transmission', 0], ['KHR_animation_pointer', 0],
    ['KHR_node_visibility', 0], ['KHR_materials_clearcoat', 0], ['EXT_lodpipe_unknown', 2]]) {
    await t.test(`${ext} -> exit ${code}`, (st) => {
      const dir = tempDir(st);
      const j = structuredClone(json);
      j.extensionsUsed = [...(j.extensionsUsed || []), ext];
      j.extensionsRequired = [...(j.extensionsRequired || []), ext];
      const input = path.join(dir, 'in.glb');
      writeGlb(input, j, bin);
      const out = path.join(dir, 'out.glb');
      const r = runLodpipe([input, '-o', out, '-q']);
      if (code === 0) {
        assert.deepEqual(mainJobProblems(r, out), [], describeRun(r));
        assert.deepEqual(parseGlb(fs.readFileSync(out)).json.extensionsRequired, j.extensionsRequired, 'kept as required');
      } else {
        assert.deepEqual(refusalProblems(r, code, ext, dir, ['in.glb']), [], describeRun(r));
      }
    });
  }
});

// Warnings an artist can act on (QA): a run prints the first 8 of the input's and says that `inspect` lists
// the rest, and inspect lists them all; a mesh's chain warnings beyond the first 4 are counted, not dropped.
test('warnings: the rest counted and pointed to, inspect lists them all', { skip }, async (t) => {
  const engine = corpusPath('scenes/2CylinderEngine.glb');
  await t.test('2CylinderEngine: 8 + "N more (lodpipe inspect lists them)"; inspect: all of them', (st) => {
    const dir = tempDir(st);
    const run = runLodpipe([engine, '-o', path.join(dir, 'out.glb')]);
    assert.equal(run.status, 0, describeRun(run));
    const lines = run.stderr.trim().split('\n').filter((l) => l.includes(': warning: '));
    const more = /warning: (\d+) more warnings \(lodpipe inspect lists them\)$/.exec(lines[lines.length - 1]);
    assert.ok(lines.length === 9 && more, describeRun(run));
    const inspect = runLodpipe(['inspect', engine]);
    assert.equal(inspect.status, 0, describeRun(inspect));
    const listed = inspect.stderr.trim().split('\n').filter((l) => l.includes(': warning: '));
    assert.equal(listed.length, 8 + Number(more[1]), describeRun(inspect));
    assert.deepEqual(listed.slice(0, 8), lines.slice(0, 8), 'the same first 8');
  });
  await t.test('six nodes of one mesh that already have MSFT_lod: 4 warnings and "2 more warnings like these"', (st) => {
    const dir = tempDir(st);
    const { json, bin } = parseGlb(fs.readFileSync(DUCK));
    const mesh = json.nodes.find((n) => n.mesh !== undefined).mesh;
    const level = json.nodes.push({ name: 'a level' }) - 1;
    const added = [...Array(6)].map((_, k) => json.nodes.push({ name: `duck ${k}`, mesh, translation: [k * 300, 0, 0],
      extensions: { MSFT_lod: { ids: [level] } } }) - 1);
    json.scenes[json.scene ?? 0].nodes.push(...added);
    json.extensionsUsed = [...(json.extensionsUsed || []), 'MSFT_lod'];
    const input = path.join(dir, 'in.glb');
    writeGlb(input, json, bin);
    const r = runLodpipe([input, '-o', path.join(dir, 'out.glb')]);
    assert.equal(r.status, 0, describeRun(r));
    const lines = r.stderr.trim().split('\n');
    assert.equal(lines.filter((l) => /nodes\[\d+\] already has MSFT_lod; left as it is/.test(l)).length, 4, describeRun(r));
    assert.match(r.stderr, /warning: mesh \d+: 2 more warnings like these/);
  });
});
