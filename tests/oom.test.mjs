// Out of memory (issue 6: never crash; a clear one-line error and no partial output). build/failmalloc.so
// (tests/tools/failmalloc.c), preloaded, makes allocation number N fail; each case first counts a run's
// allocations, then fails every STEP-th one in turn. Each run must:
//   - not die by a signal (std::terminate from a C++ exception, a segfault on a NULL) or hang;
//   - either exit 0 with exactly the output of the run without a failure (the program did without the
//     memory: the C++ bridges' reserve, see third_party/gltf_io/gltf_io.h), nothing else on stderr but
//     warnings;
//   - or exit 2 with one line "lodpipe: FILE: ... out of memory ...", and leave no file behind.
// Before this test, such runs ended in std::terminate (a json destructor that allocates, a bad_alloc
// thrown through the C API) or, worse, exited 0 with different output: a failed edit of the document or
// a full neighbour table in the simplifier was taken for "cannot" and silently left out.
// The optimized build counts C and C++ allocations alike (--threads 1: the same numbering every run);
// the ASan+UBSan build (LODPIPE_BIN) counts the C ones, with the sanitizers and LeakSanitizer watching
// every error path.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import {
  corpusPath, describeRun, listFilesRecursive, lodpipeBin, oneLineErrorProblems, runHealthProblems, runLodpipe,
  skipWithoutBinary, successStderrProblems, tempDir,
} from './lib/gltf.mjs';
import { BUILD } from './lib/lodcheck.mjs';

const SHIM = path.join(BUILD, 'failmalloc.so');
const PLAIN = path.join(BUILD, 'lodpipe');
const skip = skipWithoutBinary() || (!fs.existsSync(SHIM) && `${SHIM} not built (make test builds it)`) ||
  (!fs.existsSync(PLAIN) && `${PLAIN} not built`);

/** JSON reports (simplify.json, --json) time each phase: the times are the one thing two runs may differ in. */
const untimed = (text) => text.replace(/"seconds[a-z_]*":[-+0-9.eE]+/g, '"seconds":0');

/** The files below dir with their bytes (a .json without its times), for comparing two runs' outputs. */
function snapshot(dir) {
  const files = listFilesRecursive(dir).filter((f) => !f.endsWith('/'));
  const read = (f) => {
    const bytes = fs.readFileSync(path.join(dir, f));
    return f.endsWith('.json') ? Buffer.from(untimed(bytes.toString('utf8'))) : bytes;
  };
  return Object.fromEntries(files.map((f) => [f, read(f)]));
}

/**
 * The allocations to fail: 1, 1 + step, ..., and every one of the first and the last PROBE_ENDS. The
 * ends are where reading the input and writing the output allocate; a stride alone moves whenever a
 * change adds or removes an allocation, and did hide two defects there until one did (a missing external
 * .bin for a failed fopen in tinygltf's file test; a --json report that left out an output's name).
 */
const PROBE_ENDS = 16;
// LODPIPE_OOM_EVERY=1: fail every allocation of every case (a deeper sweep by hand; hours, not for CI).
// LODPIPE_OOM_SHARD=K/N: only every N-th of the probes, from the K-th (0-based), so that N processes
// share a sweep by hand between cores.
const EVERY = process.env.LODPIPE_OOM_EVERY === '1';
const SHARD = (() => {
  const m = /^(\d+)\/(\d+)$/.exec(process.env.LODPIPE_OOM_SHARD || '0/1');
  if (!m || Number(m[1]) >= Number(m[2])) throw new Error(`LODPIPE_OOM_SHARD=${process.env.LODPIPE_OOM_SHARD}: want K/N, K < N`);
  return { k: Number(m[1]), n: Number(m[2]) };
})();
function probes(total, step) {
  if (EVERY) step = 1;
  const set = new Set();
  for (let n = 1; n <= total; n += step) set.add(n);
  for (let k = 0; k < PROBE_ENDS; ++k) {
    if (1 + k <= total) set.add(1 + k);
    if (total - k >= 1) set.add(total - k);
  }
  return [...set].sort((a, b) => a - b).filter((_, i) => i % SHARD.n === SHARD.k);
}

/**
 * Runs `args` (OUTDIR standing for a fresh empty folder) once to count its allocations, then fails
 * each allocation probes() picks (step = count / runs, rounded up). Returns the problems found and a
 * tally of the outcomes.
 */
function sweep(t, bin, args, runs, asan) {
  const env = (extra) => ({
    LD_PRELOAD: SHIM,
    // the library must come before the sanitizer runtime to see malloc; ASan would refuse that order
    ...(asan ? { ASAN_OPTIONS: `${process.env.ASAN_OPTIONS || ''}:verify_asan_link_order=0` } : {}),
    ...extra,
  });
  const root = tempDir(t, 'lodpipe-oom-');
  if (typeof args === 'function') args = args(root);
  const refDir = path.join(root, 'ref');
  fs.mkdirSync(refDir);
  const countFile = path.join(root, 'count');
  const withDir = (dir) => args.map((a) => a.replaceAll('OUTDIR', dir));
  const ref = runLodpipe(withDir(refDir), { bin, env: env({ FAIL_COUNT_FILE: countFile }) });
  const problems = [];
  if (ref.status !== 0 || !fs.existsSync(countFile)) return { problems: [`reference run failed: ${describeRun(ref)}`] };
  const total = Number(fs.readFileSync(countFile, 'utf8'));
  const expected = snapshot(refDir);
  const stdoutOf = (r, dir) => untimed(r.stdout.replaceAll(dir, 'OUTDIR'));
  const refStdout = stdoutOf(ref, refDir);
  const step = Math.max(1, Math.ceil(total / runs));
  const tally = { total, step, runs: 0, same: 0, refused: 0 };
  for (const n of probes(total, step)) {
    const dir = path.join(root, `run${n}`);
    fs.mkdirSync(dir);
    const r = runLodpipe(withDir(dir), { bin, env: env({ FAIL_AT: String(n) }), timeout: 60000 });
    tally.runs++;
    const p = [...runHealthProblems(r)];
    const left = listFilesRecursive(dir);
    if (r.status === 0) {
      tally.same++;
      p.push(...successStderrProblems(r.stderr));
      const got = snapshot(dir);
      const names = Object.keys(expected);
      if (JSON.stringify(Object.keys(got)) !== JSON.stringify(names)) p.push(`exit 0 with files ${left} (expected ${names})`);
      else for (const f of names) if (!got[f].equals(expected[f])) p.push(`exit 0 but ${f} differs from the run without a failure`);
      if (stdoutOf(r, dir) !== refStdout) p.push('exit 0 but stdout differs from the run without a failure');
    } else {
      tally.refused++;
      p.push(...oneLineErrorProblems(r.stderr.split('\n').filter((l) => !/warning/.test(l)).join('\n')));
      if (r.status !== 2) p.push(`exit status ${r.status} (expected 2: out of memory)`);
      if (!/out of memory/.test(r.stderr)) p.push('the error does not say "out of memory"');
      if (left.length) p.push(`left behind: ${left.join(', ')}`);
    }
    if (p.length) problems.push(`allocation ${n} of ${total}: ${p.join('; ')}\n${describeRun(r)}`);
    fs.rmSync(dir, { recursive: true, force: true });
  }
  return { problems, tally };
}

const DUCK = corpusPath('scenes/Duck.glb');
// name, arguments, runs with the optimized build, runs with the ASan build
const CASES = [
  ['the main job, Duck', [DUCK, '-o', 'OUTDIR/duck.glb', '--threads', '1'], 250, 100],
  ['the main job, Duck as .gltf with --draco and --json', [DUCK, '-o', 'OUTDIR/duck.gltf', '--draco', '--json',
    '--threads', '1'], 150, 60],
  ['the main job, a Draco input', [corpusPath('compressed/BoxDraco/BoxDraco.gltf'), '-o', 'OUTDIR/box.glb',
    '--threads', '1'], 120, 80],
  ['simplify, Duck', ['simplify', DUCK, 'OUTDIR', '--threads', '1'], 150, 80],
  ['inspect, Duck', ['inspect', DUCK], 80, 30],
  ['the main job, CesiumMan (a skin, an animation)', [corpusPath('animated/CesiumMan.glb'), '-o', 'OUTDIR/man.glb',
    '--threads', '1'], 120, 60],
  ['check, on the main job\'s Duck', (root) => {
    const chain = path.join(root, 'duck_lod.glb');
    const r = runLodpipe([DUCK, '-o', chain, '--quiet'], { bin: PLAIN });
    assert.equal(r.status, 0, describeRun(r));
    return ['check', chain];
  }, 100, 40],
];

/**
 * `lodpipe batch` with only the batch's own allocations failing (FAIL_MAIN_ONLY: its jobs run without
 * the library; each job's own out of memory is the main job's, swept above). A batch carries on past a
 * file that fails, so a run may:
 *   - exit 0 with exactly the reference run's files (the cache manifest without its times);
 *   - or exit 2 (the batch itself could not go on) or 5 (a file failed: its line names it), with a line
 *     saying "out of memory" among lines that each name what they are about, where every file left behind
 *     is one the reference run wrote, with the same bytes (the manifest, which leaves out a failed file,
 *     only has to be JSON), and no temp file.
 * Before, the batch said "the job's summary or files could not be read back" (exit 4 for the file) when
 * it could not allocate to read a job's summary, "cannot create the output folder (Cannot allocate
 * memory)" (exit 4), "lodpipe: out of memory" naming nothing, and exited 0 after printing "out of memory"
 * when it could not check the jobs' outputs for clashes.
 */
function sweepBatch(t, bin, runs, asan) {
  const root = tempDir(t, 'lodpipe-oom-batch-');
  const src = path.join(root, 'src');
  fs.mkdirSync(path.join(src, 'sub'), { recursive: true });
  fs.copyFileSync(DUCK, path.join(src, 'Duck.glb'));
  fs.copyFileSync(corpusPath('scans/suzanne.glb'), path.join(src, 'sub', 'suzanne.glb'));
  const env = (extra) => ({
    LD_PRELOAD: SHIM, FAIL_MAIN_ONLY: '1',
    ...(asan ? { ASAN_OPTIONS: `${process.env.ASAN_OPTIONS || ''}:verify_asan_link_order=0` } : {}),
    ...extra,
  });
  const args = (out) => ['batch', src, '-o', out, '-j', '1', '--quiet'];
  const countFile = path.join(root, 'count');
  const refDir = path.join(root, 'ref');
  const ref = runLodpipe(args(refDir), { bin, env: env({ FAIL_COUNT_FILE: countFile }) });
  if (ref.status !== 0 || !fs.existsSync(countFile)) return { problems: [`reference run failed: ${describeRun(ref)}`] };
  const total = Number(fs.readFileSync(countFile, 'utf8'));
  const expected = snapshot(refDir);
  const MANIFEST = '.lodpipe-cache.json';
  const step = Math.max(1, Math.ceil(total / runs));
  const tally = { total, step, runs: 0, same: 0, refused: 0, failedFiles: 0 };
  const problems = [];
  for (const n of probes(total, step)) {
    const dir = path.join(root, `run${n}`);
    const r = runLodpipe(args(dir), { bin, env: env({ FAIL_AT: String(n) }), timeout: 120000 });
    tally.runs++;
    const p = [...runHealthProblems(r)];
    const got = fs.existsSync(dir) ? snapshot(dir) : {};
    if (r.status === 0) {
      tally.same++;
      p.push(...successStderrProblems(r.stderr));
      if (JSON.stringify(Object.keys(got)) !== JSON.stringify(Object.keys(expected))) {
        p.push(`exit 0 with files ${Object.keys(got)} (expected ${Object.keys(expected)})`);
      } else {
        for (const f of Object.keys(expected)) if (!got[f].equals(expected[f])) p.push(`exit 0 but ${f} differs`);
      }
    } else {
      tally.refused++;
      if (r.status === 5) tally.failedFiles++;
      else if (r.status !== 2) p.push(`exit status ${r.status} (expected 2 or 5: out of memory)`);
      const lines = r.stderr.split('\n').filter((l) => l && !/warning/.test(l));
      if (!lines.some((l) => /out of memory/.test(l))) p.push('no line says "out of memory"');
      for (const l of lines) if (!/^lodpipe: [^:]+: .+$/.test(l)) p.push(`a line names nothing: ${JSON.stringify(l)}`);
      for (const [f, bytes] of Object.entries(got)) {
        if (f === MANIFEST) {
          try { JSON.parse(bytes.toString('utf8')); } catch { p.push('the manifest left behind is not JSON'); }
        } else if (!expected[f]) p.push(`left behind ${f}, which the reference run did not write`);
        else if (!bytes.equals(expected[f])) p.push(`left behind ${f} with other bytes than the reference run's`);
      }
    }
    if (p.length) problems.push(`allocation ${n} of ${total}: ${p.join('; ')}\n${describeRun(r)}`);
    fs.rmSync(dir, { recursive: true, force: true });
  }
  return { problems, tally };
}

for (const [build, bin, runs, asan] of [['optimized build', PLAIN, 200, false], ['ASan build', lodpipeBin, 200, true]]) {
  test(`out of memory at any allocation of the batch itself (${build})`, { skip }, (t) => {
    const { problems, tally } = sweepBatch(t, bin, runs, asan);
    t.diagnostic(JSON.stringify(tally || {}));
    assert.deepEqual(problems.slice(0, 5), [], `${problems.length} runs went wrong`);
    assert.ok(tally.refused > 0 && tally.failedFiles > 0, 'no run was refused or failed a file: the failures did not reach the batch');
  });
}

for (const [name, args, runsPlain, runsAsan] of CASES) {
  for (const [build, bin, runs, asan] of [['optimized build', PLAIN, runsPlain, false],
    ['ASan build', lodpipeBin, runsAsan, true]]) {
    test(`out of memory at any allocation: ${name} (${build})`, { skip }, (t) => {
      const { problems, tally } = sweep(t, bin, args, runs, asan);
      t.diagnostic(JSON.stringify(tally || {}));
      assert.deepEqual(problems.slice(0, 5), [], `${problems.length} runs went wrong`);
      assert.ok(tally.refused > 0, 'no run was refused: the failures did not reach lodpipe');
    });
  }
}
