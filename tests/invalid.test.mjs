// Issue "must show" 2: a loader that trusts nothing.
// For every invalid/ input of the manifest, `convert` (to .glb and to .gltf) and `inspect`:
//   "Expect: reject"  -> documented exit code (2; 4 when a referenced file is missing), no signal,
//                        stderr exactly one line "lodpipe: <FILE>: <what is wrong>" naming the file,
//                        nothing (no output, no temp file) left in the output folder
//   "Expect: handle"  -> exit 0, only warning lines on stderr, an output without new validator errors
//                        (and, as everywhere, the convert contract: nothing lost), no NaN in float data
// Never a sanitizer report on stderr. Plus CLI-contract cases (usage errors, missing input, --help/--version).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import {
  ASPECTS, analyzeConversion, corpusPath, describeRun, formatDiffs, listFilesRecursive, manifestInputs,
  oneLineErrorProblems, outputNameFor, readRaw, runHealthProblems, runLodpipe, skipWithoutBinary,
  successStderrProblems, tempDir,
} from './lib/gltf.mjs';

const skip = skipWithoutBinary();
const invalid = manifestInputs((f) => f.category === 'invalid');
const KINDS = ['.glb', '.gltf'];

const isReject = (f) => String(f.expect || '').trim() === 'reject';

/** Files referenced by a .gltf input that do not exist (empty if none or not parseable). */
function missingReferencedFiles(f) {
  const file = corpusPath(f.path);
  if (!/\.gltf$/i.test(file)) return [];
  let json;
  try {
    json = JSON.parse(fs.readFileSync(file, 'utf8'));
  } catch {
    return [];
  }
  const uris = [...(Array.isArray(json.buffers) ? json.buffers : []), ...(Array.isArray(json.images) ? json.images : [])]
    .map((x) => x && x.uri).filter((u) => typeof u === 'string' && !/^data:/i.test(u));
  return uris.filter((u) => {
    try {
      return !fs.existsSync(path.resolve(path.dirname(file), decodeURIComponent(u)));
    } catch {
      return true;
    }
  });
}

/**
 * Documented exit codes of a reject input: 2 (invalid input); 4 (I/O) when a referenced file is missing
 * and that is all that is wrong (MissingBin/); 2 or 4 when the file is also invalid otherwise
 * (SchemaFailures/sceneWrongType.gltf).
 */
function expectedRejectCodes(f) {
  const missing = missingReferencedFiles(f);
  if (missing.length === 0) return [2];
  const codes = Object.keys(f.validator?.error_codes || {});
  return codes.every((c) => c === 'IO_ERROR') ? [4] : [2, 4];
}

/** Names stderr may use for the failing file: the input, or (I/O case) a missing referenced file. */
function acceptableFileNames(f, status) {
  const names = [path.basename(f.path)];
  if (status === 4) names.push(...missingReferencedFiles(f).map((u) => path.basename(decodeURIComponent(u))));
  return names;
}

function rejectProblems(f, r) {
  const p = [...runHealthProblems(r)];
  const codes = expectedRejectCodes(f);
  if (!codes.includes(r.status)) p.push(`exit status ${r.status}, expected ${codes.join(' or ')}`);
  p.push(...oneLineErrorProblems(r.stderr));
  const names = acceptableFileNames(f, r.status);
  if (!names.some((n) => r.stderr.includes(n))) p.push(`stderr does not mention ${names.map((n) => JSON.stringify(n)).join(' or ')}`);
  return p;
}

function nanProblems(outFile) {
  const raw = readRaw(outFile);
  const p = [];
  (raw.json.accessors || []).forEach((a, i) => {
    if (a.componentType !== 5126) return;
    let arr;
    try {
      arr = raw.accessorArray(i);
    } catch (e) {
      p.push(`accessor ${i}: ${e.message}`);
      return;
    }
    const k = arr.findIndex((x) => Number.isNaN(x));
    if (k >= 0) p.push(`accessor ${i}${a.name ? ` (${a.name})` : ''} has NaN at component ${k}`);
  });
  return p;
}

for (const f of invalid) {
  const input = corpusPath(f.path);
  if (isReject(f)) {
    test(`reject ${f.path}`, { skip }, async (t) => {
      for (const kind of KINDS) {
        await t.test(`convert -> ${kind}: exit ${expectedRejectCodes(f).join('/')}, one-line error, nothing left behind`, (st) => {
          const dir = tempDir(st);
          const out = path.join(dir, outputNameFor(f.path, kind));
          const r = runLodpipe(['convert', input, out]);
          const p = rejectProblems(f, r);
          const left = listFilesRecursive(dir);
          if (left.length) p.push(`output folder not empty: ${JSON.stringify(left)}`);
          assert.deepEqual(p, [], `${f.expect}: ${describeRun(r)}`);
        });
      }
      await t.test(`inspect: exit ${expectedRejectCodes(f).join('/')}, one-line error`, () => {
        const r = runLodpipe(['inspect', input]);
        assert.deepEqual(rejectProblems(f, r), [], describeRun(r));
      });
    });
  } else {
    test(`handle ${f.path} (${f.expect})`, { skip }, async (t) => {
      for (const kind of KINDS) {
        await t.test(`convert -> ${kind}`, async (st) => {
          const dir = tempDir(st);
          const out = path.join(dir, outputNameFor(f.path, kind));
          const r = runLodpipe(['convert', input, out]);
          const fatal = runHealthProblems(r);
          if (r.status !== 0) fatal.push(`exit status ${r.status} (expected 0: "${f.expect}")`);
          else if (!fs.existsSync(out)) fatal.push(`exit 0 but no output file ${path.basename(out)}`);
          assert.deepEqual(fatal, [], describeRun(r));

          await st.test('stderr: only warning lines', () => {
            assert.deepEqual(successStderrProblems(r.stderr), [], describeRun(r));
          });
          await st.test('no NaN in the output float data', () => {
            assert.deepEqual(nanProblems(out), []);
          });
          const res = await analyzeConversion(input, out, dir);
          for (const n of res.notes) st.diagnostic(`note: ${n}`);
          for (const [key, title] of ASPECTS) {
            await st.test(title, () => {
              assert.equal(res[key].length, 0, formatDiffs(`${f.path} -> ${kind}: ${title}`, res[key]));
            });
          }
        });
      }
      await t.test('inspect: exit 0, non-empty stdout', () => {
        const r = runLodpipe(['inspect', input]);
        const p = [...runHealthProblems(r), ...successStderrProblems(r.stderr)];
        if (r.status !== 0) p.push(`exit status ${r.status} (expected 0)`);
        if (r.stdout.trim() === '') p.push('stdout is empty');
        assert.deepEqual(p, [], describeRun(r));
      });
    });
  }
}

// ---------------------------------------------------------------------------------------------
// CLI contract

/** A usage error: exit 1, one line on stderr starting "lodpipe: ", nothing written to the cwd. */
function assertUsageError(t, args) {
  const cwd = tempDir(t);
  const r = runLodpipe(args, { cwd });
  const p = [...runHealthProblems(r)];
  if (r.status !== 1) p.push(`exit status ${r.status} (expected 1: usage error)`);
  const body = r.stderr.endsWith('\n') ? r.stderr.slice(0, -1) : r.stderr;
  if (!body) p.push('stderr is empty (expected a one-line usage message)');
  else if (body.includes('\n')) p.push(`stderr has ${body.split('\n').length} lines (expected one)`);
  else if (!body.startsWith('lodpipe: ')) p.push(`stderr does not start with "lodpipe: ": ${JSON.stringify(body)}`);
  const left = listFilesRecursive(cwd);
  if (left.length) p.push(`files created in the working folder: ${JSON.stringify(left)}`);
  assert.deepEqual(p, [], describeRun(r));
}

test('CLI contract', { skip }, async (t) => {
  const valid = corpusPath('scenes/Duck.glb');

  await t.test('no arguments -> exit 1', (st) => assertUsageError(st, []));
  await t.test('unknown command -> exit 1', (st) => assertUsageError(st, ['frobnicate', valid]));
  await t.test('convert without operands -> exit 1', (st) => assertUsageError(st, ['convert']));
  await t.test('convert with a missing OUT operand -> exit 1', (st) => assertUsageError(st, ['convert', valid]));
  await t.test('inspect without operand -> exit 1', (st) => assertUsageError(st, ['inspect']));
  await t.test('unknown option -> exit 1', (st) => assertUsageError(st, ['convert', '--frobnicate', valid, 'out.glb']));
  await t.test('convert to a name that is neither .glb nor .gltf -> exit 1', (st) => assertUsageError(st, ['convert', valid, 'out.obj']));
  // an option a command would ignore is refused, naming it (QA: `check --json` printed the table, exit 0)
  for (const args of [['check', valid, '--json'], ['inspect', valid, '--levels', '1'], ['inspect', '--force', valid],
    ['convert', valid, 'out.glb', '--placement', 'optimal'], ['convert', valid, 'out.glb', '--json'],
    ['simplify', valid, '.', '--draco'], ['simplify', valid, '.', '--pixel-error', '2']]) {
    const flag = args.find((a) => a.startsWith('--'));
    await t.test(`${args[0]} ${flag} -> exit 1, "does not apply"`, (st) => {
      assertUsageError(st, args);
      const r = runLodpipe(args, { cwd: tempDir(st) });
      assert.match(r.stderr, new RegExp(`${flag} does not apply to ${args[0]}`));
    });
  }
  await t.test('a file without -o -> exit 1, "no output given"', (st) => {
    assertUsageError(st, [valid]);
    assert.match(runLodpipe([valid], { cwd: tempDir(st) }).stderr, /no output given: lodpipe .*Duck\.glb -o OUT/);
  });

  await t.test('convert refuses to overwrite its input without --force (exit 1, input unchanged)', (st) => {
    const dir = tempDir(st);
    const copy = path.join(dir, 'duck.glb');
    fs.copyFileSync(valid, copy);
    const before = fs.readFileSync(copy);
    const r = runLodpipe(['convert', copy, copy]);
    const p = [...runHealthProblems(r), ...oneLineErrorProblems(r.stderr)];
    if (r.status !== 1) p.push(`exit status ${r.status} (expected 1)`);
    if (!fs.readFileSync(copy).equals(before)) p.push('the input was changed');
    assert.deepEqual(listFilesRecursive(dir), ['duck.glb']);
    assert.deepEqual(p, [], describeRun(r));
    const forced = runLodpipe(['convert', '--force', copy, copy]);
    assert.equal(forced.status, 0, describeRun(forced));
  });

  for (const cmd of ['convert', 'inspect']) {
    await t.test(`${cmd} of a nonexistent input -> exit 4 naming the file`, (st) => {
      const dir = tempDir(st);
      const missing = path.join(dir, 'no_such_file.glb');
      const args = cmd === 'convert' ? ['convert', missing, path.join(dir, 'out.glb')] : ['inspect', missing];
      const r = runLodpipe(args);
      const p = [...runHealthProblems(r), ...oneLineErrorProblems(r.stderr)];
      if (r.status !== 4) p.push(`exit status ${r.status} (expected 4: I/O error)`);
      if (!r.stderr.includes('no_such_file.glb')) p.push('stderr does not mention no_such_file.glb');
      const left = listFilesRecursive(dir);
      if (left.length) p.push(`files left in the folder: ${JSON.stringify(left)}`);
      assert.deepEqual(p, [], describeRun(r));
    });
  }

  await t.test('convert into a nonexistent folder -> exit 4, one-line error', (st) => {
    const dir = tempDir(st);
    const out = path.join(dir, 'no', 'such', 'dir', 'out.glb');
    const r = runLodpipe(['convert', valid, out]);
    const p = [...runHealthProblems(r), ...oneLineErrorProblems(r.stderr)];
    if (r.status !== 4) p.push(`exit status ${r.status} (expected 4: I/O error)`);
    const left = listFilesRecursive(dir);
    if (left.length) p.push(`files created: ${JSON.stringify(left)}`);
    assert.deepEqual(p, [], describeRun(r));
  });

  await t.test('convert with a relative OUT writes OUT, its .bin and its images into the working folder', async (st) => {
    const cwd = tempDir(st);
    const input = corpusPath('scenes/CesiumMilkTruck/CesiumMilkTruck.gltf');
    const r = runLodpipe(['convert', input, 'truck.gltf'], { cwd });
    const p = [...runHealthProblems(r), ...successStderrProblems(r.stderr)];
    if (r.status !== 0) p.push(`exit status ${r.status} (expected 0)`);
    assert.deepEqual(p, [], describeRun(r));
    assert.deepEqual(listFilesRecursive(cwd), ['CesiumMilkTruck.png', 'truck.bin', 'truck.gltf']);
    const res = await analyzeConversion(input, path.join(cwd, 'truck.gltf'), cwd);
    const bad = ASPECTS.filter(([k]) => res[k].length).map(([k, title]) => formatDiffs(title, res[k]));
    assert.deepEqual(bad, []);
  });

  for (const flag of ['--help', '--version']) {
    await t.test(`${flag} -> exit 0 with output on stdout`, () => {
      const r = runLodpipe([flag]);
      const p = [...runHealthProblems(r)];
      if (r.status !== 0) p.push(`exit status ${r.status} (expected 0)`);
      if (r.stdout.trim() === '') p.push('stdout is empty');
      assert.deepEqual(p, [], describeRun(r));
    });
  }
});
