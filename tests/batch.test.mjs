// `lodpipe batch` and `--depfile` (issue 7): small batches written by bench/make_batch.py from the
// corpus (variants of a few assets: .gltf with external .bin and images, .glb with an external
// texture, Draco), run with the sanitizer build.
//  - outputs of a batch (-j 2) byte-identical to single-file runs, tree mirrored, summary counts;
//  - shards K/3 disjoint and together the whole batch; a sharded run keeps the other shards' cache;
//  - a corrupt file reported in one line while the others complete, exit 5, retried next time;
//  - the cache: unchanged -> skipped; a changed referenced .bin, a changed configuration (flag or
//    --config file), a deleted or edited output -> rebuilt; --force rebuilds all; mtime alone does not;
//  - --depfile contents (Make escaping of spaces and '#'), none on failure;
//  - usage errors.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { spawn, spawnSync } from 'node:child_process';
import {
  caseBlindVolume, corpusPath, describeRun, lodpipeBin, oneLineErrorProblems, skipWithoutBinary, repoRoot,
  runHealthProblems, runLodpipe, sharedRoot, tempDir,
} from './lib/gltf.mjs';

const skip = skipWithoutBinary();
const EXIT_SOME_FAILED = 5;

const ASSETS = [
  'scenes/kenney/pavement.glb', // .glb with an external image (Textures/colormap.png)
  'compressed/BoxDraco/BoxDraco.gltf', // Draco, .gltf + .bin
  'scenes/CesiumMilkTruck/CesiumMilkTruck.gltf', // .gltf + .bin + .png
  'animated/AnimatedMorphCube/AnimatedMorphCube.gltf', // morph targets
  'scans/suzanne.glb', // a mesh that really simplifies
];

/** Writes `variants` variants of each asset below dir (bench/make_batch.py); returns the .gltf/.glb paths relative to dir. */
function makeBatch(dir, { assets = ASSETS, variants = 2 } = {}) {
  const r = spawnSync('python3', [path.join(repoRoot, 'bench', 'make_batch.py'), dir, '--variants', String(variants),
    '--assets', assets.join(','), '--shared', sharedRoot], { encoding: 'utf8' });
  assert.equal(r.status, 0, `make_batch.py failed: ${r.stderr}`);
  return gltfFiles(dir);
}

function filesBelow(dir) {
  const out = [];
  const walk = (d, rel) => {
    for (const e of fs.readdirSync(d, { withFileTypes: true })) {
      if (e.name.startsWith('.')) continue;
      const r = rel ? `${rel}/${e.name}` : e.name;
      if (e.isDirectory()) walk(path.join(d, e.name), r);
      else out.push(r);
    }
  };
  walk(dir, '');
  return out.sort();
}

const gltfFiles = (dir) => filesBelow(dir).filter((f) => /\.(gltf|glb)$/i.test(f));

/** Runs lodpipe batch with --json; returns { run, summary, byStatus }. */
function batch(src, out, extra = []) {
  const run = runLodpipe(['batch', src, '-o', out, '--json', ...extra]);
  assert.deepEqual(runHealthProblems(run), [], describeRun(run));
  let summary;
  assert.doesNotThrow(() => { summary = JSON.parse(run.stdout); }, describeRun(run));
  const byStatus = { built: [], cached: [], failed: [] };
  for (const r of summary.results) byStatus[r.status].push(r.file);
  return { run, summary, byStatus };
}

/** Byte differences between the files of two trees (hidden files left out). */
function treeDifferences(a, b) {
  const fa = filesBelow(a), fb = filesBelow(b);
  const problems = [];
  for (const f of fa) if (!fb.includes(f)) problems.push(`only in ${a}: ${f}`);
  for (const f of fb) if (!fa.includes(f)) problems.push(`only in ${b}: ${f}`);
  for (const f of fa.filter((x) => fb.includes(x)))
    if (!fs.readFileSync(path.join(a, f)).equals(fs.readFileSync(path.join(b, f)))) problems.push(`bytes differ: ${f}`);
  return problems;
}

test('batch: outputs mirror the tree and equal single-file runs byte for byte; summary counts', { skip }, (t) => {
  const dir = tempDir(t);
  const src = path.join(dir, 'src'), out = path.join(dir, 'out'), single = path.join(dir, 'single');
  const files = makeBatch(src);
  assert.equal(files.length, ASSETS.length * 2);

  const { run, summary, byStatus } = batch(src, out, ['-j', '2']);
  assert.equal(run.status, 0, describeRun(run));
  assert.deepEqual(byStatus.built, files, 'every file built, listed in sorted order');
  assert.equal(summary.files, files.length);
  assert.equal(summary.failed, 0);
  assert.equal(summary.jobs, 2);

  let meshes = 0, trianglesIn = 0, trianglesOut = 0;
  for (const rel of files) {
    fs.mkdirSync(path.dirname(path.join(single, rel)), { recursive: true });
    const one = runLodpipe([path.join(src, rel), '-o', path.join(single, rel), '--json']);
    assert.equal(one.status, 0, describeRun(one));
    const s = JSON.parse(one.stdout);
    meshes += s.meshes.length;
    for (const m of s.meshes) {
      trianglesIn += m.triangles;
      for (const l of m.levels) trianglesOut += l.triangles;
    }
    // the main job's --json lists what it read and wrote
    assert.equal(s.inputs[0], path.join(src, rel));
    assert.equal(s.outputs[0], path.join(single, rel));
    for (const f of [...s.inputs, ...s.outputs]) assert.ok(fs.existsSync(f), `listed file ${f} exists`);
  }
  assert.deepEqual(treeDifferences(single, out), [], 'batch outputs identical to single-file outputs');
  assert.ok(filesBelow(out).some((f) => f.endsWith('Textures/colormap.png')), 'external image mirrored beside the .glb');
  assert.ok(filesBelow(out).some((f) => f.endsWith('CesiumMilkTruck.bin')), 'external .bin beside the .gltf');
  assert.equal(summary.meshes, meshes);
  assert.equal(summary.triangles_in, trianglesIn);
  assert.equal(summary.triangles_out, trianglesOut);
  assert.ok(trianglesOut > 0, 'some mesh was simplified');

  // the human-readable table (no --json) is on stdout; -j 1 gives the same bytes
  const out1 = path.join(dir, 'out1');
  const table = runLodpipe(['batch', src, '-o', out1, '-j', '1']);
  assert.equal(table.status, 0, describeRun(table));
  assert.match(table.stdout, /^built\s+10\s+/m);
  assert.match(table.stdout, /^failed\s+0\s+/m);
  assert.match(table.stdout, /files\/s/);
  // stderr is not a terminal: no progress line; only the files' own warnings, one line each
  const stray = table.stderr.split('\n').filter((l) => l && !/^lodpipe: .+: warning: /.test(l));
  assert.deepEqual(stray, [], 'no progress or other messages when stderr is not a terminal');
  assert.deepEqual(treeDifferences(out, out1), [], '-j 1 and -j 2 outputs identical');
});

test('batch: shards K/3 are disjoint and complete; a sharded run keeps the other shards cached', { skip }, (t) => {
  const dir = tempDir(t);
  const src = path.join(dir, 'src'), out = path.join(dir, 'out');
  const files = makeBatch(src, { assets: ['scenes/kenney/pavement.glb', 'compressed/BoxDraco/BoxDraco.gltf',
    'animated/AnimatedMorphCube/AnimatedMorphCube.gltf'], variants: 5 });
  const parts = [];
  for (let k = 1; k <= 3; ++k) {
    const { run, summary, byStatus } = batch(src, out, ['--shard', `${k}/3`]);
    assert.equal(run.status, 0, describeRun(run));
    assert.deepEqual(summary.shard, { index: k, count: 3 });
    assert.deepEqual(byStatus.cached, [], 'nothing of this shard was built before');
    parts.push(byStatus.built);
  }
  const all = parts.flat();
  assert.equal(new Set(all).size, all.length, `shards overlap: ${JSON.stringify(parts)}`);
  assert.deepEqual([...all].sort(), files, 'the shards together are the whole batch');
  assert.ok(parts.filter((p) => p.length > 0).length >= 2, `15 files should not all fall into one shard: ${JSON.stringify(parts)}`);
  // the same split again (deterministic), all cached now
  const again = batch(src, out, ['--shard', '2/3']);
  assert.deepEqual(again.byStatus.cached, parts[1]);
  // the whole batch: every file cached, because each shard's run kept the others' entries
  const whole = batch(src, out);
  assert.deepEqual(whole.byStatus.cached, files);
  assert.deepEqual(whole.byStatus.built, []);
});

test('batch: a corrupt file is reported in one line, the others complete, exit 5', { skip }, (t) => {
  const dir = tempDir(t);
  const src = path.join(dir, 'src'), out = path.join(dir, 'out');
  const files = makeBatch(src, { assets: ['scenes/kenney/pavement.glb', 'compressed/BoxDraco/BoxDraco.gltf'], variants: 2 });
  fs.mkdirSync(path.join(src, 'bad'));
  fs.copyFileSync(corpusPath('invalid/truncated.glb'), path.join(src, 'bad', 'truncated.glb'));
  fs.writeFileSync(path.join(src, 'bad', 'syntax.gltf'), '{"asset": {"version": "2.0"}, ');
  const bad = ['bad/syntax.gltf', 'bad/truncated.glb'];

  const { run, summary, byStatus } = batch(src, out, ['-j', '2']);
  assert.equal(run.status, EXIT_SOME_FAILED, describeRun(run));
  assert.deepEqual(byStatus.failed, bad);
  assert.deepEqual(byStatus.built, files);
  assert.equal(summary.failed, 2);
  // the built files keep no level: each warns so (a warning line, not a failure)
  const lines = run.stderr.split('\n').filter((l) => l && !l.includes(': warning: '));
  assert.equal(lines.length, 2, `one line per failed file:\n${run.stderr}`);
  for (const f of bad) {
    const line = lines.find((l) => l.startsWith(`lodpipe: ${path.join(src, f)}: `));
    assert.ok(line, `a line names ${f}:\n${run.stderr}`);
    assert.deepEqual(oneLineErrorProblems(line), []);
    const result = summary.results.find((r) => r.file === f);
    assert.equal(result.exit, 2, 'the job exit code (invalid input) is kept per file');
    assert.equal(result.error, line);
    assert.ok(!fs.existsSync(path.join(out, f)), `no output for ${f}`);
  }
  for (const f of files) assert.ok(fs.existsSync(path.join(out, f)), `${f} written`);

  // the failures are not cached: tried again, the good files come from the cache
  const again = batch(src, out);
  assert.equal(again.run.status, EXIT_SOME_FAILED);
  assert.deepEqual(again.byStatus.failed, bad);
  assert.deepEqual(again.byStatus.cached, files);

  // fixed: exit 0
  fs.rmSync(path.join(src, 'bad'), { recursive: true });
  const fixed = batch(src, out);
  assert.equal(fixed.run.status, 0, describeRun(fixed.run));
});

// A file whose meshes keep no level is not a failure: built (exit 0, no "error"), its job's warning relayed,
// as in a single-file run.
test('batch: a file where no mesh keeps a level is built, with its warning; the batch exits 0', { skip }, (t) => {
  const dir = tempDir(t);
  const src = path.join(dir, 'src'), out = path.join(dir, 'out');
  fs.mkdirSync(src);
  const data = Buffer.alloc(44);
  [0, 0, 0, 1, 0, 0, 0, 1, 0].forEach((v, i) => data.writeFloatLE(v, 4 * i));
  [0, 1, 2].forEach((v, i) => data.writeUInt16LE(v, 36 + 2 * i));
  const input = path.join(src, 'tri.gltf');
  fs.writeFileSync(input, JSON.stringify({
    asset: { version: '2.0' }, scene: 0, scenes: [{ nodes: [0] }], nodes: [{ mesh: 0 }],
    meshes: [{ primitives: [{ attributes: { POSITION: 0 }, indices: 1 }] }],
    accessors: [{ bufferView: 0, componentType: 5126, count: 3, type: 'VEC3', min: [0, 0, 0], max: [1, 1, 0] },
      { bufferView: 1, componentType: 5123, count: 3, type: 'SCALAR' }],
    bufferViews: [{ buffer: 0, byteLength: 36 }, { buffer: 0, byteOffset: 36, byteLength: 6 }],
    buffers: [{ byteLength: 44, uri: `data:application/octet-stream;base64,${data.toString('base64')}` }],
  }));
  const { run, summary, byStatus } = batch(src, out);
  assert.equal(run.status, 0, describeRun(run));
  assert.deepEqual(byStatus.built, ['tri.gltf']);
  assert.deepEqual([summary.failed, summary.meshes, summary.triangles_out], [0, 1, 0]);
  assert.equal(summary.results[0].error, undefined, 'no error for a built file');
  assert.deepEqual(run.stderr.split('\n').filter((l) => l), [`lodpipe: ${input}: warning: no mesh kept a LOD level; ` +
    'the output has no new MSFT_lod chain (1 mesh: no level removed 10 % of its triangles, lod.min_reduction)'], describeRun(run));
  assert.ok(fs.existsSync(path.join(out, 'tri.gltf')), 'the output is written');
});

test('batch cache: a changed .bin, configuration or output rebuilds; --force rebuilds all; mtime alone does not', { skip }, (t) => {
  const dir = tempDir(t);
  const src = path.join(dir, 'src'), out = path.join(dir, 'out');
  const files = makeBatch(src, { assets: ['compressed/BoxDraco/BoxDraco.gltf', 'animated/AnimatedMorphCube/AnimatedMorphCube.gltf',
    'scenes/kenney/pavement.glb'], variants: 2 });
  const first = batch(src, out);
  assert.deepEqual(first.byStatus.built, files);
  assert.ok(fs.existsSync(path.join(out, '.lodpipe-cache.json')), 'the manifest is in OUT_DIR');
  assert.deepEqual(filesBelow(out).filter((f) => f.includes('.lodpipe-')), [], 'no temp file left');
  assert.deepEqual(batch(src, out).byStatus.cached, files, 'unchanged: all cached');

  // a touch without a change of bytes keeps the cache
  const cube0 = 'animated_AnimatedMorphCube_AnimatedMorphCube/v00/AnimatedMorphCube.gltf';
  const future = new Date(Date.now() + 60_000);
  fs.utimesSync(path.join(src, cube0), future, future);
  assert.deepEqual(batch(src, out).byStatus.built, [], 'a new mtime alone does not rebuild');

  // the referenced .bin of one file changes (variant 1's positions into variant 0): only that file rebuilds
  const bin0 = path.join(src, 'animated_AnimatedMorphCube_AnimatedMorphCube/v00/AnimatedMorphCube.bin');
  const bin1 = path.join(src, 'animated_AnimatedMorphCube_AnimatedMorphCube/v01/AnimatedMorphCube.bin');
  assert.ok(!fs.readFileSync(bin0).equals(fs.readFileSync(bin1)), 'the variants differ');
  fs.copyFileSync(bin1, bin0);
  const afterBin = batch(src, out);
  assert.deepEqual(afterBin.byStatus.built, [cube0]);
  assert.equal(afterBin.byStatus.cached.length, files.length - 1);

  // the configuration: a flag, then the same flag again (cached), then a --config file
  const levels = batch(src, out, ['--levels', '2,5']);
  assert.deepEqual(levels.byStatus.built, files, '--levels changes every key');
  assert.deepEqual(batch(src, out, ['--levels', '2,5']).byStatus.cached, files);
  assert.deepEqual(batch(src, out, ['--levels', '2,5', '--threads', '1']).byStatus.cached, files,
    'threads do not change the output, so not the key');
  const toml = path.join(dir, 'pipeline.toml');
  fs.writeFileSync(toml, '[lod]\nlevels = [2, 5]\n[switching]\npixel_error = 2.0\n');
  assert.deepEqual(batch(src, out, ['--config', toml]).byStatus.built, files, 'pixel_error from a file changes every key');
  assert.deepEqual(batch(src, out, ['--config', toml]).byStatus.cached, files);

  // outputs: deleted or edited -> rebuilt
  const draco0 = 'compressed_BoxDraco_BoxDraco/v00/BoxDraco.gltf';
  fs.rmSync(path.join(out, 'compressed_BoxDraco_BoxDraco/v00/BoxDraco.bin'));
  const pave1 = 'scenes_kenney_pavement/v01/pavement.glb';
  fs.appendFileSync(path.join(out, pave1), ' ');
  const afterOut = batch(src, out, ['--config', toml]);
  assert.deepEqual(afterOut.byStatus.built, [draco0, pave1]);
  assert.ok(fs.existsSync(path.join(out, 'compressed_BoxDraco_BoxDraco/v00/BoxDraco.bin')), 'the deleted .bin is back');

  // --force
  const forced = batch(src, out, ['--config', toml, '--force']);
  assert.deepEqual(forced.byStatus.built, files);

  // a damaged manifest is a warning and an empty cache, never a failure
  fs.writeFileSync(path.join(out, '.lodpipe-cache.json'), '{"format": 1, "entries": [');
  const damaged = batch(src, out, ['--config', toml]);
  assert.equal(damaged.run.status, 0, describeRun(damaged.run));
  assert.deepEqual(damaged.byStatus.built, files);
  assert.match(damaged.run.stderr, /warning: not a lodpipe cache manifest/);
});

test('--depfile: OUT: IN, its referenced files and the config, Make-escaped; none on failure', { skip }, (t) => {
  const dir = tempDir(t);
  const folder = path.join(dir, 'my truck');
  fs.mkdirSync(folder);
  for (const f of ['CesiumMilkTruck.gltf', 'CesiumMilkTruck0.bin', 'CesiumMilkTruck.png'])
    fs.copyFileSync(corpusPath(`scenes/CesiumMilkTruck/${f}`), path.join(folder, f));
  fs.writeFileSync(path.join(dir, 'pipe$line.toml'), '[lod]\nlevels = [2, 6]\n');
  const run = runLodpipe(['my truck/CesiumMilkTruck.gltf', '-o', 'out #1.gltf', '--config', 'pipe$line.toml',
    '--depfile', 'truck.d'], { cwd: dir });
  assert.equal(run.status, 0, describeRun(run));
  assert.equal(fs.readFileSync(path.join(dir, 'truck.d'), 'utf8'),
    'out\\ \\#1.gltf: my\\ truck/CesiumMilkTruck.gltf my\\ truck/CesiumMilkTruck0.bin my\\ truck/CesiumMilkTruck.png pipe$$line.toml\n');

  // a .glb without external files and no config: just OUT: IN
  fs.copyFileSync(corpusPath('scans/suzanne.glb'), path.join(dir, 'suzanne.glb'));
  const glb = runLodpipe(['suzanne.glb', '-o', 'sub.glb', '--depfile', 'sub.d', '--levels', '3'], { cwd: dir });
  assert.equal(glb.status, 0, describeRun(glb));
  assert.equal(fs.readFileSync(path.join(dir, 'sub.d'), 'utf8'), 'sub.glb: suzanne.glb\n');

  // ':' escaped (QA: GNU make said "multiple target patterns"); make itself reads the names back
  fs.copyFileSync(corpusPath('scans/suzanne.glb'), path.join(dir, 'in:put.glb'));
  fs.writeFileSync(path.join(dir, 'a:b.toml'), '[lod]\nlevels = [3]\n');
  const colon = runLodpipe(['in:put.glb', '-o', 'o:1.glb', '--config', 'a:b.toml', '--depfile', 'o.d'], { cwd: dir });
  assert.equal(colon.status, 0, describeRun(colon));
  assert.equal(fs.readFileSync(path.join(dir, 'o.d'), 'utf8'), 'o\\:1.glb: in\\:put.glb a\\:b.toml\n');
  fs.writeFileSync(path.join(dir, 'Makefile'), 'include o.d\no\\:1.glb:\n\t@echo "[$@] [$^]"\n');
  // a make of its own: under `make test` the outer make's MAKELEVEL/MAKEFLAGS would make it print directories
  const env = { ...process.env };
  for (const k of ['MAKELEVEL', 'MAKEFLAGS', 'MFLAGS', 'MAKEOVERRIDES']) delete env[k];
  const make = spawnSync('make', ['-B', '-n', '--no-print-directory'], { cwd: dir, encoding: 'utf8', env });
  assert.equal(make.status, 0, make.stderr);
  assert.equal(make.stdout, 'echo "[o:1.glb] [in:put.glb a:b.toml]"\n');
  // a name ending in a backslash would be a line continuation: refused, like a line break (exit 1, nothing written)
  fs.writeFileSync(path.join(dir, 'p\\'), '[lod]\nlevels = [3]\n');
  const tail = runLodpipe(['suzanne.glb', '-o', 'tail.glb', '--config', 'p\\', '--depfile', 'tail.d', '-q'], { cwd: dir });
  assert.equal(tail.status, 1, describeRun(tail));
  assert.equal(tail.stderr, 'lodpipe: tail.d: p\\: a name ending in a backslash cannot be written to a depfile\n');
  assert.ok(!fs.existsSync(path.join(dir, 'tail.d')) && !fs.existsSync(path.join(dir, 'tail.glb')));

  // failure: no output and no depfile
  fs.copyFileSync(corpusPath('invalid/truncated.glb'), path.join(dir, 'bad.glb'));
  const bad = runLodpipe(['bad.glb', '-o', 'bad-out.glb', '--depfile', 'bad.d'], { cwd: dir });
  assert.equal(bad.status, 2, describeRun(bad));
  assert.deepEqual(oneLineErrorProblems(bad.stderr), []);
  assert.ok(!fs.existsSync(path.join(dir, 'bad.d')) && !fs.existsSync(path.join(dir, 'bad-out.glb')));
});

test('batch and depfile usage errors exit 1 with one line', { skip }, (t) => {
  const dir = tempDir(t);
  const cases = [
    ['batch', dir, '-o', dir],
    ['batch', dir],
    ['batch', dir, '-o', path.join(dir, 'o'), '--shard', '0/2'],
    ['batch', dir, '-o', path.join(dir, 'o'), '--shard', '3/2'],
    ['batch', dir, '-o', path.join(dir, 'o'), '-j', 'x'],
    // out of range whatever the size (sscanf's %u wrapped: 1/4294967297 ran as 1/1, -j 4294967296 as 0), and
    // white space before as after
    ['batch', dir, '-o', path.join(dir, 'o'), '--shard', '1/4294967297'],
    ['batch', dir, '-o', path.join(dir, 'o'), '--shard', '4294967297/4294967298'],
    ['batch', dir, '-o', path.join(dir, 'o'), '--shard', '1/99999999999999999999999999'],
    ['batch', dir, '-o', path.join(dir, 'o'), '-j', '4294967296'],
    ['batch', dir, '-o', path.join(dir, 'o'), '-j', '18446744073709551618'],
    ['batch', dir, '-o', path.join(dir, 'o'), '-j', ' 2'],
    ['batch', dir, '-o', path.join(dir, 'o'), '-j', '2 '],
    ['batch', dir, '-o', path.join(dir, 'o'), '--shard', ' 1/2'],
    ['batch', dir, '-o', path.join(dir, 'o'), '--shard', '1/ 2'],
    ['batch', dir, '-o', path.join(dir, 'o'), '--shard', '1/+2'],
    ['batch', dir, '-o', path.join(dir, 'o'), '--depfile', 'x.d'],
    [corpusPath('scans/suzanne.glb'), '-o', path.join(dir, 'x.glb'), '-j', '2'],
    ['inspect', corpusPath('scans/suzanne.glb'), '--shard', '1/2'],
    [corpusPath('scans/suzanne.glb'), '-o', path.join(dir, 'a.glb'), '-o', path.join(dir, 'b.glb')],
    [corpusPath('scans/suzanne.glb'), '-o', path.join(dir, 'a.glb'), '--depfile', 'a.d', '--depfile', 'b.d'],
    ['batch', dir, '-o', path.join(dir, 'o'), '--config', 'a.toml', '--config', 'b.toml'],
    ['simplify', corpusPath('scans/suzanne.glb'), dir, '-o', path.join(dir, 'a.glb')],
  ];
  for (const args of cases) {
    const r = runLodpipe(args);
    assert.equal(r.status, 1, describeRun(r));
    assert.equal(r.stderr.trim().split('\n').length, 1, describeRun(r));
  }
  // OUT_DIR above SRC_DIR: the output for src/a.glb would be SRC_DIR/src/a.glb, another source
  const src = path.join(dir, 'p', 'src');
  fs.mkdirSync(path.join(src, 'src'), { recursive: true });
  fs.copyFileSync(corpusPath('scans/suzanne.glb'), path.join(src, 'a.glb'));
  fs.copyFileSync(corpusPath('scenes/Duck.glb'), path.join(src, 'src', 'a.glb'));
  for (const out of [path.join(dir, 'p'), dir]) {
    const r = runLodpipe(['batch', src, '-o', out, '-j', '1']);
    assert.equal(r.status, 1, describeRun(r));
    assert.equal(r.stderr.trim().split('\n').length, 1, describeRun(r));
    assert.match(r.stderr, /must not contain the source folder/);
  }
  assert.ok(fs.readFileSync(path.join(src, 'src', 'a.glb')).equals(fs.readFileSync(corpusPath('scenes/Duck.glb'))), 'sources unchanged');
  assert.ok(fs.readFileSync(path.join(src, 'a.glb')).equals(fs.readFileSync(corpusPath('scans/suzanne.glb'))), 'sources unchanged');
  const missing = runLodpipe(['batch', path.join(dir, 'nothing'), '-o', path.join(dir, 'o2')]);
  assert.equal(missing.status, 4, describeRun(missing));
  assert.ok(!fs.existsSync(path.join(dir, 'o2')), 'no output folder for a missing source');
});

/**
 * A batch (-j 1) over a small a.glb, the bunny as b.glb and `more` small files, started through `prefix` (a
 * shell that sets up signals, or nothing); once a.glb is built (b.glb's job is running), `signal` is sent.
 * Returns { src, out, end: { code, signal } }.
 */
async function stoppedBatch(t, signal, { prefix = [], more = 0 } = {}) {
  const dir = tempDir(t);
  const src = path.join(dir, 'src');
  const out = path.join(dir, 'out');
  fs.mkdirSync(src);
  fs.copyFileSync(corpusPath('scans/suzanne.glb'), path.join(src, 'a.glb'));
  fs.copyFileSync(corpusPath('scans/bunny.glb'), path.join(src, 'b.glb'));
  for (let k = 0; k < more; ++k) fs.copyFileSync(corpusPath('scans/suzanne.glb'), path.join(src, `c${k}.glb`));
  const argv = [...prefix, lodpipeBin, 'batch', src, '-o', out, '-j', '1'];
  const child = spawn(argv[0], argv.slice(1), { stdio: 'ignore' });
  const exited = new Promise((resolve) => child.on('exit', (code, sig) => resolve({ code, signal: sig })));
  // a.glb appears when its job renames it, a moment before the job ends and the batch records it: wait
  // for b.glb's job, which the batch starts only then (a stop in between rebuilt a.glb on the next run)
  const bJob = () => processesMatching(path.join(src, 'b.glb')) !== '';
  const deadline = Date.now() + 300000;
  while (!(fs.existsSync(path.join(out, 'a.glb')) && bJob()) && Date.now() < deadline) await new Promise((r) => setTimeout(r, 50));
  assert.ok(fs.existsSync(path.join(out, 'a.glb')), 'the first file was built');
  child.kill(signal);
  return { src, out, end: await exited };
}

// Stopping a batch (kill -TERM, as a CI job's timeout does): the running job is stopped too (no process left
// behind writing into OUT_DIR), the jobs' temporary configuration and any temp file are removed, what was
// built is recorded (a rerun finds it cached), and the batch ends by the signal.
test('a batch stopped by SIGTERM stops its job, leaves no temp files, keeps what was built', { skip }, async (t) => {
  const { src, out, end } = await stoppedBatch(t, 'SIGTERM', { more: 1 });
  assert.equal(end.signal, 'SIGTERM', `the batch ends by the signal (exit ${end.code})`);
  assert.equal(processesMatching(src), '', 'no job process left');
  const left = fs.readdirSync(out).filter((f) => f.startsWith('.lodpipe-batch-') || /\.lodpipe-[A-Za-z0-9]{6}$/.test(f));
  assert.deepEqual(left, [], 'no temporary file left');
  const again = batch(src, out);
  assert.ok(again.byStatus.cached.includes('a.glb'), `a.glb is cached on the next run: ${JSON.stringify(again.byStatus)}`);
});

// A batch started with SIGTERM ignored (a script's `trap '' TERM`) and stopped by Ctrl-C: it stops its jobs with
// SIGTERM, which they must not inherit ignored (QA review), else the running job finishes its file first.
test('a batch whose parent ignores SIGTERM still stops its running job (SIGINT)', { skip }, async (t) => {
  const { out, end } = await stoppedBatch(t, 'SIGINT', { prefix: ['sh', '-c', 'trap "" TERM; exec "$@"', 'sh'] });
  assert.equal(end.signal, 'SIGINT', `the batch ends by the signal (exit ${end.code})`);
  assert.ok(!fs.existsSync(path.join(out, 'b.glb')), 'the running job was stopped, not left to finish b.glb');
});

/** The pids of the processes whose command line contains `text` (pgrep -f), one a line; '' when none.
 * Throws when pgrep cannot run (make deps installs procps), rather than read that as "none". */
function processesMatching(text) {
  const r = spawnSync('pgrep', ['-f', text], { encoding: 'utf8' });
  if (r.error) throw new Error(`pgrep -f: ${r.error.message} (make deps installs procps)`);
  if (r.status !== 0 && r.status !== 1) throw new Error(`pgrep -f exited ${r.status}: ${r.stderr.trim()}`);
  return r.stdout.trim();
}

/** Resolves when a process whose command line contains `text` runs (pgrep -f), or after 60 s. */
async function processAppears(text) {
  const running = () => processesMatching(text) !== '';
  const deadline = Date.now() + 60000;
  while (!running() && Date.now() < deadline) await new Promise((r) => setTimeout(r, 20));
  return running;
}

// A file replaced while its own job runs (QA): the job built the old bytes, so the manifest must not pair
// the output with the new bytes; it was hashed only after the job and served as "cached" from then on.
test('batch: an input replaced while its job runs is built but not cached; the next run builds the new bytes', { skip }, async (t) => {
  const dir = tempDir(t);
  const src = path.join(dir, 'src'), out = path.join(dir, 'out'), single = path.join(dir, 'single.glb');
  fs.mkdirSync(src);
  const input = path.join(src, 'm.glb');
  fs.copyFileSync(corpusPath('scans/bunny.glb'), input);
  const child = spawn(lodpipeBin, ['batch', src, '-o', out, '-j', '1', '--json'], { stdio: ['ignore', 'pipe', 'pipe'] });
  let stderr = '';
  child.stderr.on('data', (d) => { stderr += d; });
  const exited = new Promise((resolve) => child.on('exit', (code) => resolve(code)));
  const jobRuns = await processAppears(input);
  assert.ok(jobRuns(), 'the job for m.glb started');
  // replaced in one step (a rename), as an editor or a checkout does, while the job runs (the bunny takes seconds)
  fs.copyFileSync(corpusPath('scans/fandisk.glb'), path.join(src, '.m.tmp'));
  fs.renameSync(path.join(src, '.m.tmp'), input);
  assert.ok(jobRuns(), 'the job was still running when its input was replaced');
  assert.equal(await exited, 0, stderr);
  assert.match(stderr, new RegExp(`^lodpipe: ${input.replace(/[.*+?^${}()|[\]\\]/g, '\\$&')}: warning: changed while its job ran; `, 'm'));

  const next = batch(src, out, ['-j', '1']);
  assert.deepEqual(next.byStatus.built, ['m.glb'], 'not served from the cache');
  const one = runLodpipe([input, '-o', single]);
  assert.equal(one.status, 0, describeRun(one));
  assert.ok(fs.readFileSync(path.join(out, 'm.glb')).equals(fs.readFileSync(single)), 'the output is the new input\'s');
  assert.deepEqual(batch(src, out, ['-j', '1']).byStatus.cached, ['m.glb'], 'settled: cached once built from stable bytes');
});

// No glTF file at all (first run, and again once the only file is gone, with a manifest): a batch of 0 files,
// exit 0. UBSan stopped it with exit 1 (qsort and bsearch given the NULL list), which also hid other bugs.
test('batch: a folder without glTF files is an empty batch, exit 0', { skip }, (t) => {
  const dir = tempDir(t);
  const src = path.join(dir, 'src'), out = path.join(dir, 'out');
  fs.mkdirSync(src);
  const empty = batch(src, out);
  assert.equal(empty.run.status, 0, describeRun(empty.run));
  assert.equal(empty.summary.files, 0);
  fs.copyFileSync(corpusPath('scans/suzanne.glb'), path.join(src, 'a.glb'));
  assert.deepEqual(batch(src, out).byStatus.built, ['a.glb']);
  fs.rmSync(path.join(src, 'a.glb'));
  const gone = batch(src, out);
  assert.equal(gone.run.status, 0, describeRun(gone.run));
  assert.equal(gone.summary.files, 0);
});

// The jobs' configuration cannot be written (a full disk; here a file size limit of 0, SIGXFSZ ignored so that
// the write fails with EFBIG): exit 4 in one line, and the empty temp file it had created is removed.
test('batch: a jobs\' configuration that cannot be written leaves no temp file (exit 4)', { skip }, (t) => {
  const dir = tempDir(t);
  const src = path.join(dir, 'src'), out = path.join(dir, 'out');
  fs.mkdirSync(src);
  fs.mkdirSync(out);
  fs.copyFileSync(corpusPath('scans/suzanne.glb'), path.join(src, 'a.glb'));
  const r = spawnSync('sh', ['-c', 'trap "" XFSZ; ulimit -f 0; exec "$@"', 'sh', lodpipeBin, 'batch', src, '-o', out],
    { encoding: 'utf8' });
  assert.equal(r.status, 4, r.stderr);
  assert.deepEqual(oneLineErrorProblems(r.stderr), []);
  assert.match(r.stderr, /\.lodpipe-batch-\w+\.toml: cannot write \(File too large\)/);
  assert.deepEqual(fs.readdirSync(out), [], 'nothing left in OUT_DIR');
});

// A manifest path that cannot be written (a folder there) is reported before any job runs (QA: it was found only
// after every file was built, exit 4 with a JSON summary saying failed 0).
test('batch: a cache manifest that cannot be written is refused before the work (exit 4)', { skip }, (t) => {
  const dir = tempDir(t);
  const src = path.join(dir, 'src'), out = path.join(dir, 'out');
  fs.mkdirSync(src);
  fs.mkdirSync(path.join(out, '.lodpipe-cache.json'), { recursive: true });
  fs.copyFileSync(corpusPath('scans/suzanne.glb'), path.join(src, 'a.glb'));
  const r = runLodpipe(['batch', src, '-o', out, '--json']);
  assert.equal(r.status, 4, describeRun(r));
  assert.deepEqual(oneLineErrorProblems(r.stderr), []);
  assert.equal(r.stderr, `lodpipe: ${path.join(out, '.lodpipe-cache.json')}: cannot write the cache manifest (Is a directory)\n`);
  assert.equal(r.stdout, '', 'no summary: nothing ran');
  assert.deepEqual(fs.readdirSync(out), ['.lodpipe-cache.json'], 'no job ran');
});

// Hand-corrupted numbers in the manifest (QA: trusted, and shown wrapped in the --json summary): an entry with
// any number out of range is a cache miss; the file is built again and the summary has its real counts.
test('batch: a manifest entry with an out-of-range number is a cache miss', { skip }, (t) => {
  const dir = tempDir(t);
  const src = path.join(dir, 'src'), out = path.join(dir, 'out');
  fs.mkdirSync(src);
  const names = ['a.glb', 'b.glb', 'c.glb', 'd.glb', 'e.glb'];
  for (const f of names) fs.copyFileSync(corpusPath('scans/suzanne.glb'), path.join(src, f));
  const first = batch(src, out, ['-j', '2']);
  assert.deepEqual(first.byStatus.built, names);
  const manifestPath = path.join(out, '.lodpipe-cache.json');
  const manifest = JSON.parse(fs.readFileSync(manifestPath, 'utf8'));
  const entry = (f) => manifest.entries.find((e) => e.source === f);
  entry('a.glb').meshes = -1;
  entry('b.glb').triangles_out = 1e30;
  entry('c.glb').seconds = -1e308;
  entry('d.glb').triangles_in = 2.5;
  fs.writeFileSync(manifestPath, JSON.stringify(manifest));
  const again = batch(src, out, ['-j', '2']);
  assert.equal(again.run.status, 0, describeRun(again.run));
  assert.deepEqual(again.byStatus.built, ['a.glb', 'b.glb', 'c.glb', 'd.glb']);
  assert.deepEqual(again.byStatus.cached, ['e.glb'], 'an intact entry stays cached');
  for (const k of ['meshes', 'triangles_in', 'triangles_out']) assert.equal(again.summary[k], first.summary[k], k);
  for (const r of again.summary.results) assert.ok(r.seconds >= 0 && r.meshes === 1, JSON.stringify(r));
});

/** Writes dir/name.gltf + dir/name.bin from a corpus .glb (lodpipe convert). */
function convertTo(dir, name, asset) {
  const r = runLodpipe(['convert', corpusPath(asset), path.join(dir, `${name}.gltf`)]);
  assert.equal(r.status, 0, describeRun(r));
}

/** Waits 30 ms: a referenced file whose change time is not before its job's launch (the kernel's coarse clock,
 * a few ms a tick) counts as changed while the job ran, and its file is built but not cached. */
function waitPastCoarseClock() {
  Atomics.wait(new Int32Array(new SharedArrayBuffer(4)), 0, 0, 30);
}

/** A temp folder with src/ (empty), out/ (not made) and mk/ holding s.gltf + s.bin (suzanne). */
function collisionFolders(t) {
  const dir = tempDir(t);
  const src = path.join(dir, 'src'), out = path.join(dir, 'out'), mk = path.join(dir, 'mk');
  fs.mkdirSync(src);
  fs.mkdirSync(mk);
  convertTo(mk, 's', 'scans/suzanne.glb');
  return { dir, src, out, mk };
}

// Two files writing the same output (QA): a.gltf and a.GLTF both write a.bin; with draco.fallback a.glb writes
// a.fallback.bin, a.fallback.gltf's .bin. One output was silently wrong, exit 0, and the cache never settled.
// The later file in byte order fails before it runs, naming both; the earlier one is built and then cached.
test('batch: files whose outputs would collide: the later one fails, naming both; exit 5', { skip }, (t) => {
  const { dir, src, out, mk } = collisionFolders(t);
  convertTo(mk, 'c', 'scans/spot.glb');
  for (const f of ['s.bin', 'c.bin']) fs.copyFileSync(path.join(mk, f), path.join(src, f));
  fs.copyFileSync(path.join(mk, 's.gltf'), path.join(src, 'a.gltf'));
  fs.copyFileSync(path.join(mk, 'c.gltf'), path.join(src, 'a.GLTF')); // 'a.GLTF' < 'a.gltf' in byte order
  waitPastCoarseClock(); // else a fast build can launch in the tick c.bin was copied in: built again, not cached
  for (let run = 0; run < 2; ++run) {
    const r = batch(src, out, ['-j', '2']);
    assert.equal(r.run.status, EXIT_SOME_FAILED, describeRun(r.run));
    assert.deepEqual(r.byStatus[run ? 'cached' : 'built'], ['a.GLTF'], `run ${run}`);
    assert.deepEqual(r.byStatus.failed, ['a.gltf']);
    const line = `lodpipe: ${path.join(src, 'a.gltf')}: writes ${path.join(out, 'a.bin')}, as ${path.join(src, 'a.GLTF')} does; ` +
      'not built (rename one of them)';
    assert.equal(r.summary.results.find((x) => x.file === 'a.gltf').error, line);
    assert.ok(r.run.stderr.split('\n').includes(line), r.run.stderr);
    assert.equal(r.summary.results.find((x) => x.file === 'a.gltf').exit, 1);
  }
  const single = path.join(dir, 'single');
  fs.mkdirSync(single);
  assert.equal(runLodpipe([path.join(src, 'a.GLTF'), '-o', path.join(single, 'a.GLTF')]).status, 0);
  assert.ok(fs.readFileSync(path.join(out, 'a.bin')).equals(fs.readFileSync(path.join(single, 'a.bin'))), 'a.bin is a.GLTF\'s');

  // draco.fallback: a.glb's a.fallback.bin is a.fallback.gltf's .bin
  const src2 = path.join(dir, 'src2'), out2 = path.join(dir, 'out2');
  fs.mkdirSync(src2);
  fs.copyFileSync(path.join(mk, 'c.bin'), path.join(src2, 'c.bin'));
  fs.copyFileSync(path.join(mk, 'c.gltf'), path.join(src2, 'a.fallback.gltf'));
  fs.copyFileSync(corpusPath('scans/suzanne.glb'), path.join(src2, 'a.glb'));
  const toml = path.join(dir, 'fallback.toml');
  fs.writeFileSync(toml, '[draco]\nenabled = true\nfallback = true\n');
  const fb = batch(src2, out2, ['--config', toml]);
  assert.equal(fb.run.status, EXIT_SOME_FAILED, describeRun(fb.run));
  assert.deepEqual(fb.byStatus.built, ['a.fallback.gltf']);
  assert.deepEqual(fb.byStatus.failed, ['a.glb']);
  assert.match(fb.summary.results[1].error, /: writes .*a\.fallback\.bin, as .*a\.fallback\.gltf does;/);
});

// A texture named like another file's output (an image uri "b.bin" beside b.gltf, whose buffer is b.bin): the
// texture copy and the buffer replace each other. Found when the jobs have written: both files fail, each line
// naming the other (the earlier one's file was replaced), and neither is cached.
test('batch: a texture that another file\'s output replaces fails both files', { skip }, (t) => {
  const { dir, src, out, mk } = collisionFolders(t);
  fs.copyFileSync(path.join(mk, 's.bin'), path.join(src, 'b.bin'));
  fs.writeFileSync(path.join(src, 'b.gltf'), fs.readFileSync(path.join(mk, 's.gltf'), 'utf8').replace('"s.bin"', '"b.bin"'));
  const truck = JSON.parse(fs.readFileSync(corpusPath('scenes/CesiumMilkTruck/CesiumMilkTruck.gltf'), 'utf8'));
  truck.images[0].uri = 'b.bin';
  fs.writeFileSync(path.join(src, 'a.gltf'), JSON.stringify(truck));
  fs.copyFileSync(corpusPath('scenes/CesiumMilkTruck/CesiumMilkTruck0.bin'), path.join(src, 'CesiumMilkTruck0.bin'));
  for (let run = 0; run < 2; ++run) {
    const r = batch(src, out, ['-j', '1']);
    assert.equal(r.run.status, EXIT_SOME_FAILED, describeRun(r.run));
    assert.deepEqual(r.byStatus.failed, ['a.gltf', 'b.gltf'], `run ${run}`);
    const [a, b] = r.summary.results.map((x) => x.error);
    assert.equal(a, `lodpipe: ${path.join(src, 'a.gltf')}: its ${path.join(out, 'b.bin')} was replaced by the one ` +
      `${path.join(src, 'b.gltf')} writes; not recorded (rename one of them)`);
    assert.equal(b, `lodpipe: ${path.join(src, 'b.gltf')}: writes ${path.join(out, 'b.bin')}, as ${path.join(src, 'a.gltf')} ` +
      'does; not recorded (rename one of them)');
  }
});

/** src/a/m.glb (cow) and src/b/m.glb (suzanne) under a temp folder, and out/ whose folder b is a symlink to
 * `target` (relative to out/); returns { dir, src, out }. */
function linkedOutputFolder(t, target) {
  const dir = tempDir(t);
  const src = path.join(dir, 'src'), out = path.join(dir, 'out');
  for (const d of ['src/a', 'src/b', 'out']) fs.mkdirSync(path.join(dir, d), { recursive: true });
  fs.symlinkSync(target, path.join(out, 'b'));
  fs.copyFileSync(corpusPath('scans/cow.glb'), path.join(src, 'a', 'm.glb'));
  fs.copyFileSync(corpusPath('scans/suzanne.glb'), path.join(src, 'b', 'm.glb'));
  return { dir, src, out };
}

/** Two batch runs (-j 2): exit 5, a/m.glb built then cached, b/m.glb failed with the error `line`; then
 * `check(r)` on each run. */
function assertLaterFileFails(src, out, line, check) {
  for (let run = 0; run < 2; ++run) {
    const r = batch(src, out, ['-j', '2']);
    assert.equal(r.run.status, EXIT_SOME_FAILED, describeRun(r.run));
    assert.deepEqual(r.byStatus[run ? 'cached' : 'built'], ['a/m.glb'], `run ${run}`);
    assert.deepEqual(r.byStatus.failed, ['b/m.glb'], `run ${run}`);
    assert.equal(r.summary.results.find((x) => x.file === 'b/m.glb').error, line);
    check(r);
  }
}

// Two names, one file (QA): with a folder of OUT_DIR that is a symlink to another (out/b -> a), src/a/m.glb and
// src/b/m.glb wrote the same file; both were recorded as built, exit 0, and each run rebuilt one of them. Claims
// are compared by the file a name reaches (its folder's real path): the later file fails before it runs, naming
// both paths, and the earlier one is built, then cached.
test('batch: two outputs that are one file through a symlinked output folder: the later fails; exit 5', { skip }, (t) => {
  const { dir, src, out } = linkedOutputFolder(t, 'a');
  fs.mkdirSync(path.join(out, 'a'));
  const line = `lodpipe: ${path.join(src, 'b/m.glb')}: writes ${path.join(out, 'b/m.glb')}, which is ` +
    `${path.join(out, 'a/m.glb')} on this file system, as ${path.join(src, 'a/m.glb')} does; not built (rename one of them)`;
  assertLaterFileFails(src, out, line, (r) => assert.ok(r.run.stderr.split('\n').includes(line), r.run.stderr));
  const single = path.join(dir, 'single.glb');
  assert.equal(runLodpipe([path.join(src, 'a', 'm.glb'), '-o', single]).status, 0);
  assert.ok(fs.readFileSync(path.join(out, 'a', 'm.glb')).equals(fs.readFileSync(single)), 'out/a/m.glb is src/a/m.glb\'s');
});

// A folder of OUT_DIR that links into SRC_DIR (out/b -> ../src/a): src/b/m.glb's output was src/a/m.glb, a
// source, replaced with exit 0 (QA). An output that reaches a file inside SRC_DIR (and outside OUT_DIR) fails its
// file before it runs; the source is unchanged.
test('batch: an output folder that links into the source folder: that file fails, no source is replaced', { skip }, (t) => {
  const { src, out } = linkedOutputFolder(t, path.join('..', 'src', 'a'));
  const line = `lodpipe: ${path.join(src, 'b/m.glb')}: writes ${path.join(out, 'b/m.glb')}, which is ` +
    `${path.join(fs.realpathSync(src), 'a/m.glb')} in the source folder; not built (a folder of OUT_DIR links into SRC_DIR)`;
  assertLaterFileFails(src, out, line, () => assert.ok(
    fs.readFileSync(path.join(src, 'a', 'm.glb')).equals(fs.readFileSync(corpusPath('scans/cow.glb'))), 'src/a/m.glb is unchanged'));
});

// The same on a case-insensitive file system (QA): Foo.glb and foo.glb, and A/m.glb and a/m.glb, were one file
// each, silently, as above. batch probes OUT_DIR's file system and compares names in ASCII lower case on one that
// ignores case: the later file fails before it runs. Textures, which a first run cannot claim before its jobs
// run, are caught after them (T.png and t.png with other bytes): the later file fails, and the earlier one too
// unless its file holds its own bytes; a failed file is not cached.
test('batch: on a case-insensitive volume, names that differ only in case are one file', { skip }, (t) => {
  const vol = caseBlindVolume(t);
  if (vol.skip) return t.skip(vol.skip);
  const dir = tempDir(t);
  const src = path.join(dir, 'src'), out = path.join(vol.mount, 'out');
  for (const d of ['src/A', 'src/a', 'src/tex']) fs.mkdirSync(path.join(dir, d), { recursive: true });
  fs.copyFileSync(corpusPath('scans/cow.glb'), path.join(src, 'Foo.glb'));
  fs.copyFileSync(corpusPath('scans/suzanne.glb'), path.join(src, 'foo.glb'));
  fs.copyFileSync(corpusPath('scans/cow.glb'), path.join(src, 'A', 'm.glb'));
  fs.copyFileSync(corpusPath('scans/suzanne.glb'), path.join(src, 'a', 'm.glb'));
  const truck = JSON.parse(fs.readFileSync(corpusPath('scenes/CesiumMilkTruck/CesiumMilkTruck.gltf'), 'utf8'));
  fs.copyFileSync(corpusPath('scenes/CesiumMilkTruck/CesiumMilkTruck0.bin'), path.join(src, 'tex', 'CesiumMilkTruck0.bin'));
  fs.copyFileSync(corpusPath('scenes/CesiumMilkTruck/CesiumMilkTruck.png'), path.join(src, 'tex', 'T.png'));
  fs.copyFileSync(corpusPath('scenes/kenney/Textures/colormap.png'), path.join(src, 'tex', 't.png'));
  for (const [name, uri] of [['x.gltf', 'T.png'], ['y.gltf', 't.png']]) {
    truck.images[0].uri = uri;
    fs.writeFileSync(path.join(src, 'tex', name), JSON.stringify(truck));
  }
  const p = (root, rel) => path.join(root, rel);
  const planned = (later, earlier) => `lodpipe: ${p(src, later)}: writes ${p(out, later)}, which is ` +
    `${p(out, earlier)} on this file system, as ${p(src, earlier)} does; not built (rename one of them)`;
  const r = batch(src, out, ['-j', '2']);
  assert.equal(r.run.status, EXIT_SOME_FAILED, describeRun(r.run));
  const result = (file) => r.summary.results.find((x) => x.file === file);
  assert.deepEqual(r.byStatus.built.filter((f) => f !== 'tex/x.gltf'), ['A/m.glb', 'Foo.glb']);
  assert.deepEqual(r.byStatus.failed.filter((f) => f !== 'tex/x.gltf'), ['a/m.glb', 'foo.glb', 'tex/y.gltf']);
  assert.equal(result('foo.glb').error, planned('foo.glb', 'Foo.glb'));
  assert.equal(result('a/m.glb').error, planned('a/m.glb', 'A/m.glb'));
  assert.equal(result('tex/y.gltf').error, `lodpipe: ${p(src, 'tex/y.gltf')}: writes ${p(out, 'tex/t.png')}, which is ` +
    `${p(out, 'tex/T.png')} on this file system, as ${p(src, 'tex/x.gltf')} does; not recorded (rename one of them)`);
  // the two jobs run at once: x.gltf stays built when its T.png was written last, else it fails too; either way
  // nothing recorded is wrong (each job's record holds the bytes it wrote, not what it finds on disk later)
  if (result('tex/x.gltf').status === 'built') {
    assert.ok(fs.readFileSync(p(out, 'tex/T.png')).equals(fs.readFileSync(p(src, 'tex/T.png'))), 'T.png is x.gltf\'s');
  } else {
    assert.equal(result('tex/x.gltf').error, `lodpipe: ${p(src, 'tex/x.gltf')}: its ${p(out, 'tex/T.png')} was ` +
      `replaced by the one ${p(src, 'tex/y.gltf')} writes; not recorded (rename one of them)`);
  }
  const again = batch(src, out, ['-j', '2']);
  assert.equal(again.run.status, EXIT_SOME_FAILED, describeRun(again.run));
  assert.deepEqual(again.byStatus.cached, ['A/m.glb', 'Foo.glb'], 'the earlier files stay cached');
  const single = path.join(dir, 'Foo.glb');
  assert.equal(runLodpipe([path.join(src, 'Foo.glb'), '-o', single]).status, 0);
  assert.ok(fs.readFileSync(path.join(out, 'foo.glb')).equals(fs.readFileSync(single)), 'the one file is Foo.glb\'s');
});
