// Issue 6 "must show" 2 (determinism): for EVERY valid asset of ../shared/assets/manifest.json
// (category != 'invalid'), assets/default_scene.glb and a cow with 73 morph targets, the main job's output
// is byte-identical across three separate runs with --threads 1, 2 and 8, and so is every file a .gltf
// output writes (the .bin, copied images) for the assets that are .gltf.
//
// Runs the optimized build (LODPIPE_BUILD/lodpipe, as built by `make test`) when it exists, else
// LODPIPE_BIN: three runs of the whole corpus take about 3 minutes optimized, several times that under ASan;
// the ASan build runs the same job on every asset in tests/lodchain.test.mjs.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import crypto from 'node:crypto';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import {
  corpusPath, describeRun, listFilesRecursive, lodpipeBin, manifestInputs, repoRoot, runHealthProblems, runLodpipe,
  skipWithoutBinary, successStderrProblems, tempDir,
} from './lib/gltf.mjs';
import { BUILD } from './lib/lodcheck.mjs';
import { writeMorphCow } from './lib/morphs.mjs';

const OPTIMIZED = path.join(BUILD, 'lodpipe');
const BIN = fs.existsSync(OPTIMIZED) ? OPTIMIZED : lodpipeBin;
const skip = fs.existsSync(OPTIMIZED) ? false : skipWithoutBinary();
const RUNS = [['--threads', '1'], ['--threads', '2'], ['--threads', '8']];
const TIMEOUT_MS = 600000;

const inputs = [
  ...manifestInputs((f) => f.category !== 'invalid').map((f) => ({ name: f.path, file: corpusPath(f.path) })),
  { name: 'assets/default_scene.glb', file: path.join(repoRoot, 'assets', 'default_scene.glb') },
];

/** sha256 of every file in dir: { relative name: digest }. */
function digests(dir) {
  const out = {};
  for (const f of listFilesRecursive(dir).filter((x) => !x.endsWith('/')))
    out[f] = crypto.createHash('sha256').update(fs.readFileSync(path.join(dir, f))).digest('hex');
  return out;
}

// A face-rig-like mesh: cow.glb with 70 distinct morph targets (more than the 64 lodpipe measures at once)
// and 3 that repeat earlier ones. morph_errors are measured on the job's threads, each into its own slot.
let morphDir = null;
function morphCow() {
  if (!morphDir) {
    morphDir = fs.mkdtempSync(path.join(os.tmpdir(), 'lodpipe-determinism-'));
    process.on('exit', () => fs.rmSync(morphDir, { recursive: true, force: true }));
  }
  return writeMorphCow(morphDir, 'cow_73_targets.glb', { distinct: 70, repeats: 3 });
}
inputs.push({ name: 'cow.glb with 73 morph targets (tests/lib/morphs.mjs)', get file() { return this.path ??= morphCow(); } });

test('the corpus has the assets the determinism check is about', () => {
  assert.ok(inputs.length >= 30, `${inputs.length} valid inputs`);
  for (const i of inputs) assert.ok(fs.existsSync(i.file), `${i.file} exists`);
});

for (const input of inputs) {
  test(`byte-identical output across three runs, --threads 1, 2, 8: ${input.name}`, { skip }, (t) => {
    t.diagnostic(`binary: ${BIN}`);
    const ext = /\.gltf$/i.test(input.file) ? '.gltf' : '.glb';
    const sets = [];
    for (const flags of RUNS) {
      const dir = tempDir(t);
      const out = path.join(dir, `out${ext}`);
      const r = runLodpipe([input.file, '-o', out, '--quiet', ...flags], { bin: BIN, timeout: TIMEOUT_MS });
      const p = [...runHealthProblems(r), ...successStderrProblems(r.stderr)];
      if (r.status !== 0) p.push(`exit status ${r.status}`);
      assert.deepEqual(p, [], describeRun(r));
      sets.push({ flags: flags.join(' '), files: digests(dir) });
    }
    for (const s of sets.slice(1))
      assert.deepEqual(s.files, sets[0].files, `${input.name}: ${s.flags} differs from ${sets[0].flags}`);
  });
}
