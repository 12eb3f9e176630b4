// Issue 4 "must show" 4: real clients load the main job's output.
//
// For every valid asset of ../shared/assets/manifest.json and assets/default_scene.glb, `lodpipe IN -o
// OUT.glb` (and OUT.gltf for a few) into a temp folder, then:
//   Babylon.js (@babylonjs/core + @babylonjs/loaders, NullEngine under Node; the loaders' MSFT_lod
//   extension is registered by importing the glTF loader): Babylon's MSFT_lod loads a node's LODs coarse to
//   fine, each replacing the previous one, and stops after `extensionOptions.MSFT_lod.maxLODsToLoad` of them.
//   So loading with maxLODsToLoad = 1, 2, ..., (longest chain + 1) must show, at stage j, for every node of
//   the default scene that carries MSFT_lod exactly the level the chain selects (the j-th coarsest: node
//   ids[L - j], or the node itself once j > L), with the triangle count of that level's index accessors;
//   the extension's onNodeLODsLoadedObservable must report every stage; and every other mesh of the scene
//   (nodes without a chain, and children of chained nodes) must stay on screen at every stage.
//   three.js (three, examples/jsm/loaders/GLTFLoader.js; three has no MSFT_lod support, so it shows the
//   full-detail nodes): parse() succeeds without an error (console.error counts as one), the default
//   scene has one object per primitive of its nodes, and every LOD node named by MSFT_lod loads through
//   parser.getDependency('node', id) with the triangle count recorded in extras.lodpipe.
// Both clients read the output from bytes; external files (.bin of a .gltf output, images beside the
// output) are handed over as data: URLs (Babylon: preprocessUrlAsync; three: LoadingManager URL modifier).
// Browser shims, kept minimal for three: `self` (GLTFLoader reads self.URL for images in bufferViews),
// `ProgressEvent` (FileLoader's progress reports while reading a .bin) and `createImageBitmap` (returns a
// 1 x 1 stand-in bitmap; image bytes are not decoded).
// Self-test: the hand-made fixture (tests/lib/lodfixture.mjs) passes; planted defects are caught (MSFT_lod
// not declared, so Babylon ignores the chain; a chained node with a child, hidden by Babylon at coarse
// stages; a LOD node naming a missing mesh).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { spawnSync } from 'node:child_process';
import {
  corpusPath, describeRun, lodpipeBin, manifestInputs, readRaw, repoRoot, runHealthProblems, runLodpipe, tempDir, skipWithoutBinary,
} from './lib/gltf.mjs';
import { modeOf, sceneNodes } from './lib/lodcheck.mjs';
import { buildFixture, writeFixture } from './lib/lodfixture.mjs';

const FAST_BIN = process.env.LODPIPE_BIN_FAST || '';
const FAST_MIN_TRIANGLES = Number(process.env.LODPIPE_FAST_MIN_TRIANGLES || 100000);
const MAIN_TIMEOUT_MS = Number(process.env.LODPIPE_MAIN_TIMEOUT_MS || 900000);
const ONLY = (process.env.LODPIPE_CLIENTS_ONLY || '').split(',').map((s) => s.trim()).filter(Boolean);

// ---------------------------------------------------------------------------------------------
// The two clients

globalThis.self ??= globalThis; // three's GLTFLoader: self.URL.createObjectURL for images in bufferViews
// three's FileLoader (the .bin of a .gltf output) reports download progress with ProgressEvent
globalThis.ProgressEvent ??= class ProgressEvent extends Event {
  constructor(type, init = {}) {
    super(type);
    this.lengthComputable = !!init.lengthComputable;
    this.loaded = init.loaded ?? 0;
    this.total = init.total ?? 0;
  }
};
globalThis.createImageBitmap ??= async (blob) => {
  if (blob && typeof blob.arrayBuffer === 'function') await blob.arrayBuffer();
  return { width: 1, height: 1, close() {} };
};

let babylon = null;
async function getBabylon() {
  if (!babylon) {
    babylon = (async () => {
      const core = await import('@babylonjs/core');
      await import('@babylonjs/loaders/glTF/index.js'); // registers the glTF loader and its extensions, MSFT_lod included
      core.Logger.LogLevels = core.Logger.ErrorLogLevel;
      const engine = new core.NullEngine();
      return { core, engine };
    })();
  }
  return babylon;
}

let threeMods = null;
async function getThree() {
  if (!threeMods) {
    threeMods = (async () => {
      const THREE = await import('three');
      const { GLTFLoader } = await import('three/examples/jsm/loaders/GLTFLoader.js');
      return { THREE, GLTFLoader };
    })();
  }
  return threeMods;
}

/** data: URL of a file referenced by uri next to `file`. */
function dataUrlFor(file, uri) {
  const p = path.resolve(path.dirname(file), decodeURIComponent(uri.replace(/^file:\/\//, '')));
  return `data:application/octet-stream;base64,${fs.readFileSync(p).toString('base64')}`;
}

/**
 * Load `file` in Babylon with maxLODsToLoad = j. Returns { shown: Map('M/P' -> [triangles...]), stages: [...],
 * error }. Shown = enabled meshes with geometry, by the glTF mesh/primitive they came from.
 */
async function babylonLoad(file, j) {
  const { core, engine } = await getBabylon();
  const scene = new core.Scene(engine);
  const stages = [];
  const errors = [];
  let complete;
  const completed = new Promise((r) => (complete = r));
  const obs = core.SceneLoader.OnPluginActivatedObservable.addOnce((plugin) => {
    plugin.onExtensionLoadedObservable.add((ext) => {
      if (ext.name === 'MSFT_lod') ext.onNodeLODsLoadedObservable.add((i) => stages.push(i));
    });
    plugin.onCompleteObservable.addOnce(() => complete());
  });
  const shown = new Map();
  try {
    // a .glb as bytes; a .gltf as "data:" + its JSON text (Babylon's documented form for JSON sources)
    const isGlb = path.extname(file).toLowerCase() === '.glb';
    const source = isGlb ? new Uint8Array(fs.readFileSync(file)) : `data:${fs.readFileSync(file, 'utf8')}`;
    await core.AppendSceneAsync(source, scene, {
      pluginExtension: path.extname(file).toLowerCase(),
      pluginOptions: {
        gltf: {
          createInstances: false,
          extensionOptions: { MSFT_lod: { maxLODsToLoad: j } },
          preprocessUrlAsync: async (url) => (/^data:/i.test(url) ? url : dataUrlFor(file, url)),
        },
      },
    });
    let timer;
    try {
      await Promise.race([completed, new Promise((_, rej) => {
        timer = setTimeout(() => rej(new Error('Babylon: no onComplete within 120 s')), 120000);
      })]);
    } finally {
      clearTimeout(timer);
    }
    for (const m of scene.meshes) {
      if (!m.isEnabled(true) || !(m.getTotalVertices() > 0)) continue;
      const ptr = (m._internalMetadata?.gltf?.pointers || []).map((p) => /^\/meshes\/(\d+)\/primitives\/(\d+)$/.exec(p)).find(Boolean);
      const key = ptr ? `${ptr[1]}/${ptr[2]}` : `? ${m.name}`;
      if (!shown.has(key)) shown.set(key, []);
      shown.get(key).push(m.getTotalIndices() / 3);
    }
  } catch (e) {
    errors.push(e && e.message ? e.message : String(e));
  } finally {
    core.SceneLoader.OnPluginActivatedObservable.remove(obs);
    scene.dispose();
  }
  return { shown, stages, errors };
}

/** Triangle count of a glTF primitive as a client draws it (triangle lists with indices), else null. */
function primTriangleCount(raw, prim) {
  if (modeOf(prim) !== 4 || prim.indices === undefined) return null;
  return raw.json.accessors[prim.indices].count / 3;
}

/**
 * What Babylon must show at stage j: per default-scene node, the level its chain selects (the node itself
 * without a chain), and every node below a chained node too (a client that swaps a node for its LOD node
 * should not lose the node's children). Returns { expected: Map('M/P' -> { chain: [tri], others: [tri] }),
 * chained: Map(node -> { ids, selected }) } where a node's primitives count as 'chain' when the node carries
 * MSFT_lod and no ancestor of it is swapped, as 'others' otherwise.
 */
function expectedAtStage(raw, j) {
  const json = raw.json;
  const expected = new Map();
  const chained = new Map();
  const seen = new Set();
  const visit = (n, hidden) => {
    if (seen.has(n) || !json.nodes?.[n]) return;
    seen.add(n);
    const node = json.nodes[n];
    let d = n;
    const ids = node.extensions?.MSFT_lod?.ids;
    const isChained = Array.isArray(ids) && ids.length > 0;
    if (isChained) {
      d = j > ids.length ? n : ids[ids.length - j];
      if (!hidden) chained.set(n, { ids, selected: d });
    }
    const M = json.nodes[d]?.mesh;
    if (M !== undefined) {
      (json.meshes[M]?.primitives || []).forEach((p, i) => {
        const key = `${M}/${i}`;
        if (!expected.has(key)) expected.set(key, { chain: [], others: [] });
        expected.get(key)[isChained && !hidden ? 'chain' : 'others'].push(primTriangleCount(raw, p));
      });
    }
    for (const c of node.children || []) visit(c, hidden || d !== n);
  };
  const scene = json.scenes?.[json.scene ?? 0];
  for (const n of scene?.nodes || []) visit(n, false);
  return { expected, chained };
}

/** Longest MSFT_lod chain of the default scene's nodes. */
function longestChain(json) {
  return Math.max(0, ...sceneNodes(json).map((n) => json.nodes[n].extensions?.MSFT_lod?.ids?.length || 0));
}

/**
 * Babylon check of one output. Returns { chain: [...], others: [...], load: [...], notes: [...] } problems:
 *   load   - Babylon failed to load a stage
 *   chain  - a chained node does not show the level its chain selects at some stage, or stages missing
 *   others - meshes of the scene missing / extra at some stage (e.g. children of a swapped node)
 */
async function babylonCheck(file) {
  const raw = readRaw(file);
  const json = raw.json;
  const L = longestChain(json);
  const res = { load: [], chain: [], others: [], notes: [] };
  for (let j = 1; j <= L + 1; j++) {
    const got = await babylonLoad(file, j);
    if (got.errors.length) {
      res.load.push(`stage ${j} (maxLODsToLoad ${j}): ${got.errors.join('; ')}`);
      continue;
    }
    const { expected, chained } = expectedAtStage(raw, j);
    const levelMeshes = new Set(); // meshes of any level of any chain
    for (const n of sceneNodes(json)) {
      const ids = json.nodes[n].extensions?.MSFT_lod?.ids || [];
      if (ids.length) [n, ...ids].forEach((x) => levelMeshes.add(json.nodes[x]?.mesh));
    }
    const keys = new Set([...expected.keys(), ...got.shown.keys()]);
    for (const k of [...keys].sort()) {
      const e = expected.get(k) || { chain: [], others: [] };
      const want = [...e.chain, ...e.others];
      const have = got.shown.get(k) || [];
      if (want.length !== have.length) {
        const bucket = want.length > have.length ? (e.others.length ? 'others' : 'chain') : levelMeshes.has(Number(k.split('/')[0])) ? 'chain' : 'others';
        res[bucket].push(`stage ${j}: mesh/primitive ${k} shown ${have.length} time(s), expected ${want.length}` +
          (bucket === 'others' && want.length > have.length ? ' (a node below a node swapped for its LOD node, or a plain node, is missing)' : ''));
        continue;
      }
      // triangle counts, where the glTF primitive is an indexed triangle list
      if (want.some((x) => x === null)) continue;
      const w = [...want].sort((x, y) => x - y).join();
      const h = [...have].sort((x, y) => x - y).join();
      if (w !== h) res.chain.push(`stage ${j}: mesh/primitive ${k} shows [${have}] triangles, the file says [${want}]`);
    }
    for (const [n, c] of chained) {
      const M = json.nodes[c.selected].mesh;
      const ok = (json.meshes[M]?.primitives || []).every((_, i) => (got.shown.get(`${M}/${i}`) || []).length > 0);
      if (!ok) res.chain.push(`stage ${j}: node ${n} should show ${c.selected === n ? 'itself' : `LOD node ${c.selected}`} (mesh ${M}); Babylon shows ${[...got.shown.keys()].filter((k) => k.startsWith(`${M}/`)).length ? 'it only partly' : 'something else'}`);
    }
    const wantStages = Math.min(j, L + 1);
    if (L > 0) {
      const s = [...new Set(got.stages)].sort((a, b) => a - b);
      if (s.join() !== [...Array(wantStages).keys()].join()) res.chain.push(`stage ${j}: MSFT_lod reported LOD stages [${s}], expected [0..${wantStages - 1}]`);
    }
    res.notes.push(`stage ${j}: ${[...chained].map(([n, c]) => `node ${n} -> ${c.selected === n ? 'itself' : `node ${c.selected}`} (mesh ${json.nodes[c.selected].mesh}, ${(json.meshes[json.nodes[c.selected].mesh].primitives || []).map((p) => primTriangleCount(raw, p) ?? 'n/a').join('+')} triangles)`).join(', ') || 'no chain'}`);
  }
  return res;
}

/**
 * three.js check of one output. Returns { load: [...], scene: [...], lods: [...], notes: [...] } problems.
 */
async function threeCheck(file) {
  const { THREE, GLTFLoader } = await getThree();
  const res = { load: [], scene: [], lods: [], notes: [] };
  const raw = readRaw(file);
  const json = raw.json;
  const bytes = fs.readFileSync(file);
  const ab = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
  const manager = new THREE.LoadingManager();
  manager.setURLModifier((url) => (/^(data|blob):/i.test(url) ? url : dataUrlFor(file, url)));
  const loader = new GLTFLoader(manager);
  const logged = [];
  const orig = { error: console.error, warn: console.warn };
  console.error = (...a) => logged.push(['error', a.map(String).join(' ')]);
  console.warn = (...a) => logged.push(['warn', a.map(String).join(' ')]);
  let gltf = null;
  try {
    gltf = await new Promise((resolve, reject) => loader.parse(ab, '', resolve, reject));
    // every LOD node of every chain loads on its own
    for (const n of sceneNodes(json)) {
      const ids = json.nodes[n].extensions?.MSFT_lod?.ids;
      const levels = json.nodes[n].extras?.lodpipe?.levels || [];
      for (const [k, id] of (ids || []).entries()) {
        try {
          const obj = await gltf.parser.getDependency('node', id);
          let tris = 0;
          obj.traverse((o) => {
            if (o.isMesh && o.geometry.index) tris += o.geometry.index.count / 3;
          });
          const want = levels[k + 1]?.triangles;
          if (tris !== want) res.lods.push(`node ${n} LOD ${k + 1} (node ${id}): three draws ${tris} triangles, extras.lodpipe records ${want}`);
        } catch (e) {
          res.lods.push(`node ${n} LOD ${k + 1} (node ${id}): ${e && e.message ? e.message : e}`);
        }
      }
    }
  } catch (e) {
    res.load.push(`GLTFLoader.parse failed: ${e && e.message ? e.message : e}`);
  } finally {
    console.error = orig.error;
    console.warn = orig.warn;
  }
  for (const [kind, text] of logged) (kind === 'error' ? res.load : res.notes).push(`console.${kind}: ${text.slice(0, 300)}`);
  if (gltf) {
    let objects = 0;
    gltf.scene.traverse((o) => {
      if (o.isMesh || o.isPoints || o.isLine) objects++;
    });
    let want = 0;
    for (const n of sceneNodes(json)) {
      const M = json.nodes[n].mesh;
      if (M !== undefined) want += (json.meshes[M]?.primitives || []).filter((p) => p.attributes?.POSITION !== undefined).length;
    }
    if (objects !== want) res.scene.push(`three's scene has ${objects} meshes/points/lines, the default scene's nodes have ${want} primitives`);
    res.notes.push(`three: ${objects} drawable objects; ${gltf.animations.length} animation(s)`);
  }
  return res;
}

// ---------------------------------------------------------------------------------------------
// Self-test on the hand-made fixture

test('self-test: the client checks pass a correct hand-made chain and catch planted defects', async (t) => {
  const cases = [
    { name: 'correct chain', expect: {} },
    { name: 'MSFT_lod not in extensionsUsed: Babylon ignores the chain', expect: { babylon: ['chain'] },
      mutate: (fx) => { delete fx.out.json.extensionsUsed; } },
    { name: 'a chained node with a child mesh: Babylon hides the child at coarse stages', expect: { babylon: ['others'] },
      mutate: (fx) => {
        const j = fx.out.json;
        j.nodes[3].mesh = 0; // "mover" now draws the box too, as a child of box_a (which carries the chain)
        j.nodes[1].children = [3];
        j.scenes[0].nodes = [0];
      } },
    { name: 'a LOD node naming a missing mesh', expect: { babylon: ['load'], three: ['lods'] },
      mutate: (fx) => { fx.out.json.nodes[5].mesh = 99; } },
  ];
  for (const c of cases) {
    await t.test(c.name, async (st) => {
      const dir = tempDir(st, 'lodpipe-clients-self-');
      const fx = buildFixture();
      if (c.mutate) c.mutate(fx);
      const { outFile } = writeFixture(dir, fx);
      const b = await babylonCheck(outFile);
      const th = await threeCheck(outFile);
      const failing = (r, keys) => keys.filter((k) => r[k].length > 0);
      for (const k of ['load', 'chain', 'others']) for (const p of b[k].slice(0, 3)) st.diagnostic(`babylon (${k}) ${p}`);
      for (const k of ['load', 'scene', 'lods']) for (const p of th[k].slice(0, 3)) st.diagnostic(`three (${k}) ${p}`);
      for (const n of b.notes) st.diagnostic(`babylon ${n}`);
      assert.deepEqual(failing(b, ['load', 'chain', 'others']), c.expect.babylon || [], 'Babylon aspects with problems');
      assert.deepEqual(failing(th, ['load', 'scene', 'lods']), c.expect.three || [], 'three aspects with problems');
    });
  }
});

// ---------------------------------------------------------------------------------------------
// Every output

const skip = skipWithoutBinary();

const GLTF_TOO = ['default_scene.glb', 'CesiumMilkTruck', 'pirate'];
const assets = [
  ...manifestInputs((f) => f.category !== 'invalid').map((f) => ({ rel: f.path, file: corpusPath(f.path), triangles: f.stats?.triangle_count ?? 0 })),
  { rel: 'assets/default_scene.glb (repo)', file: path.join(repoRoot, 'assets', 'default_scene.glb'), triangles: 63840 },
];

for (const asset of assets) {
  const kinds = GLTF_TOO.some((s) => asset.rel.includes(s)) ? ['.glb', '.gltf'] : ['.glb'];
  for (const kind of kinds) {
    const only = ONLY.length && !ONLY.some((s) => asset.rel.includes(s));
    test(`clients load ${asset.rel} -> ${kind}`, { skip: skip || (only ? 'not in LODPIPE_CLIENTS_ONLY' : false) }, async (t) => {
      const dir = tempDir(t, 'lodpipe-clients-');
      const out = path.join(dir, path.basename(asset.file).replace(/\.(gltf|glb)$/i, '') + kind);
      const args = [asset.file, '-o', out];
      let r;
      if (FAST_BIN && asset.triangles >= FAST_MIN_TRIANGLES) {
        const t0 = Date.now();
        const s = spawnSync(FAST_BIN, args, { cwd: repoRoot, timeout: MAIN_TIMEOUT_MS, encoding: 'utf8', maxBuffer: 64 << 20 });
        r = { status: s.status, signal: s.signal, stdout: s.stdout ?? '', stderr: s.stderr ?? '', error: s.error ? String(s.error) : null, ms: Date.now() - t0, cmd: [FAST_BIN, ...args].join(' ') };
      } else r = runLodpipe(args, { timeout: MAIN_TIMEOUT_MS });
      const fatal = runHealthProblems(r);
      if (r.status !== 0) fatal.push(`exit status ${r.status}`);
      else if (!fs.existsSync(out)) fatal.push('no output file');
      assert.deepEqual(fatal, [], `the main job failed\n${describeRun(r)}`);
      const json = readRaw(out).json;
      t.diagnostic(`${asset.rel} -> ${kind}: main job ${(r.ms / 1000).toFixed(1)} s; longest MSFT_lod chain ${longestChain(json)}`);
      const t0 = Date.now();
      const b = await babylonCheck(out);
      const t1 = Date.now();
      const th = await threeCheck(out);
      t.diagnostic(`Babylon ${((t1 - t0) / 1000).toFixed(1)} s, three ${((Date.now() - t1) / 1000).toFixed(1)} s`);
      for (const n of [...b.notes.map((x) => `babylon ${x}`), ...th.notes.map((x) => `three ${x}`)]) t.diagnostic(n);
      const show = (title, list) => `${title}: ${list.length} problem(s)\n${list.slice(0, 10).map((p) => `  - ${p}`).join('\n')}`;
      await t.test('Babylon.js loads every stage of the chain (maxLODsToLoad 1 .. longest chain + 1)', () => assert.deepEqual(b.load, [], show('Babylon load', b.load)));
      await t.test('Babylon.js shows, at every stage, the level each MSFT_lod chain selects, with its triangle count', () => assert.deepEqual(b.chain, [], show('Babylon MSFT_lod chain', b.chain)));
      await t.test('Babylon.js keeps every other mesh of the scene on screen at every stage (children of chained nodes included)', () => assert.deepEqual(b.others, [], show('Babylon other meshes', b.others)));
      await t.test('three.js GLTFLoader parses the output without an error', () => assert.deepEqual(th.load, [], show('three load', th.load)));
      await t.test('three.js draws one object per primitive of the default scene\'s nodes', () => assert.deepEqual(th.scene, [], show('three scene', th.scene)));
      await t.test('three.js loads every LOD node with its recorded triangle count', () => assert.deepEqual(th.lods, [], show('three LOD nodes', th.lods)));
    });
  }
}
