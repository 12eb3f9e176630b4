// Runs every C unit-test program (tests/unit/test_*.c, built with the
// sanitizers into build/asan/) as one subtest each; a program passes when it
// exits 0, and its own "not ok" lines are shown on failure.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { spawnSync } from 'node:child_process';
import { readdirSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const build = process.env.LODPIPE_BUILD || path.join(repo, 'build');
const sources = readdirSync(path.join(repo, 'tests', 'unit')).filter((f) => /^test_.*\.c$/.test(f));

test('there are unit-test programs', () => assert.ok(sources.length > 0));

for (const source of sources) {
  const name = source.replace(/\.c$/, '');
  test(`unit: ${name}`, () => {
    // a guard against a hang, not a speed test: test_simplify alone takes about 7.5
    // minutes under the sanitizers here, and over 10 when the other test files
    // share the two cores (a CI simulation of 95b35ed stopped it at 600 s)
    const r = spawnSync(path.join(build, 'asan', name), [], { encoding: 'utf8', timeout: 1_800_000 });
    assert.equal(r.error, undefined, `cannot run ${name}: ${r.error}`);
    const failures = (r.stdout || '').split('\n').filter((l) => /^not ok|^#   /.test(l));
    assert.equal(r.status, 0, `${name} failed (status ${r.status}, signal ${r.signal}):\n${failures.join('\n')}\n${r.stderr}`);
    assert.match(r.stdout, /# \d+ passed, 0 failed/);
  });
}
