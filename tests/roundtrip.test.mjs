// Issue "must show" 1: `lodpipe convert IN OUT` loses nothing.
// For every valid corpus asset (manifest category != 'invalid') and both output kinds (.glb, .gltf):
//   a. no Khronos validator error the input did not have (per code: output count <= input count)
//   b. decoded geometry identical, read independently with glTF-Transform (decodes Draco/meshopt itself)
//   c. JSON sub-trees unchanged (materials, textures, samplers, images, animations, skins, cameras, scenes,
//      nodes, meshes, accessors, asset, extensions, extras, extensionsUsed/Required) except the differences
//      the contract allows; accessor / animation / skin data and image bytes identical
//   d. nothing but the output (and, for .gltf, the files it references) in the output folder
// plus `lodpipe inspect` on every valid asset (exit 0, non-empty stdout).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import {
  ASPECTS, analyzeConversion, corpusPath, describeRun, formatDiffs, manifestInputs, outputNameFor,
  runHealthProblems, runLodpipe, skipWithoutBinary, successStderrProblems, tempDir,
} from './lib/gltf.mjs';

const skip = skipWithoutBinary();
const valid = manifestInputs((f) => f.category !== 'invalid');
const KINDS = ['.glb', '.gltf'];

test('convert round trip keeps everything (every valid asset x .glb/.gltf)', { skip }, async (t) => {
  for (const f of valid) {
    for (const kind of KINDS) {
      await t.test(`${f.path} -> ${kind}`, async (st) => {
        const input = corpusPath(f.path);
        const dir = tempDir(st);
        const out = path.join(dir, outputNameFor(f.path, kind));
        const r = runLodpipe(['convert', input, out]);
        const fatal = runHealthProblems(r).filter((p) => !p.includes('sanitizer'));
        if (r.status !== 0) fatal.push(`exit status ${r.status} (expected 0)`);
        else if (!fs.existsSync(out)) fatal.push(`exit 0 but no output file ${path.basename(out)}`);
        assert.deepEqual(fatal, [], `convert failed\n${describeRun(r)}`);

        await st.test('stderr: no sanitizer report, only warning lines', () => {
          const p = [...runHealthProblems(r), ...successStderrProblems(r.stderr)];
          assert.deepEqual(p, [], describeRun(r));
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
  }
});

test('inspect succeeds on every valid asset', { skip }, async (t) => {
  for (const f of valid) {
    await t.test(f.path, () => {
      const r = runLodpipe(['inspect', corpusPath(f.path)]);
      const p = [...runHealthProblems(r), ...successStderrProblems(r.stderr)];
      if (r.status !== 0) p.push(`exit status ${r.status} (expected 0)`);
      if (r.stdout.trim() === '') p.push('stdout is empty (expected a per-mesh summary)');
      assert.deepEqual(p, [], describeRun(r));
    });
  }
});
