#!/usr/bin/env python3
"""Draco benchmark (issue 5, "Must show" 2): output bytes with and without Draco, against
`gltf-transform draco` (npm @gltf-transform/cli, tests/node_modules) at the same quantization bits,
measured in the same run. Writes its section between <!-- section:draco --> and
<!-- /section:draco --> in bench/RESULTS.md (replaced when present, appended otherwise).

Per asset (every valid asset of ../shared/assets/manifest.json and assets/default_scene.glb):
  - input bytes (the file and every file it references: buffers, images);
  - LOD0 alone: `lodpipe convert IN OUT` (uncompressed), `lodpipe convert IN OUT --draco` (every mesh
    of the default scene compressed as it is, lodpipe's per-primitive grids) and
    `gltf-transform draco IN OUT` (every mesh, its per-mesh grid);
  - the whole chain: `lodpipe IN -o OUT` and `lodpipe IN -o OUT --draco` (each level encoded with its own
    vertices, the levels simplified within eps minus the quantization budget), and
    `gltf-transform draco` applied to lodpipe's uncompressed chain (the same levels as the first run,
    which share one vertex buffer per mesh; gltf-transform encodes each level primitive with the
    vertices it uses);
  - the wall time of each command (a whole process: load, work, write; for lodpipe's chain it is
    dominated by the simplifier, so the Draco stage's own cost is the difference of the two chain runs).
Quantization bits: position 14, normal 10, texcoord 12, colour 8, generic 12, speed 5 for both tools
(lodpipe may raise position bits per mesh; the JSON summary says when).

usage: python3 bench/draco.py [--assets SUBSTR,...] [--lodpipe PATH] [--out bench/RESULTS.md]
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.environ.get("LODPIPE_SHARED", os.path.join(os.path.dirname(ROOT), "shared"))
GLTF_TRANSFORM = os.path.join(ROOT, "tests", "node_modules", ".bin", "gltf-transform")
BITS = {"position": 14, "normal": 10, "texcoord": 12, "color": 8, "generic": 12}
SPEED = 5
BEGIN, END = "<!-- section:draco -->", "<!-- /section:draco -->"


def log(msg):
    sys.stderr.write("[draco bench] %s\n" % msg)
    sys.stderr.flush()


def timed(cmd):
    t0 = time.monotonic()
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    seconds = time.monotonic() - t0
    if r.returncode != 0:
        raise RuntimeError("%s: exit %d: %s" % (" ".join(cmd), r.returncode, r.stderr.strip()[:300]))
    return seconds, r.stdout


def file_set_bytes(path):
    """Bytes of a glTF file plus the files its buffers and images reference (each once)."""
    total = os.path.getsize(path)
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] == b"glTF":
        length = int.from_bytes(data[12:16], "little")
        doc = json.loads(data[20:20 + length])
    else:
        doc = json.loads(data.decode("utf-8-sig"))
    seen = set()
    for item in doc.get("buffers", []) + doc.get("images", []):
        uri = item.get("uri")
        if not uri or uri.startswith("data:"):
            continue
        from urllib.parse import unquote
        p = os.path.normpath(os.path.join(os.path.dirname(path), unquote(uri)))
        if p not in seen and os.path.exists(p):
            seen.add(p)
            total += os.path.getsize(p)
    return total


def assets(only):
    with open(os.path.join(SHARED, "assets", "manifest.json")) as f:
        manifest = json.load(f)
    out = [("assets/default_scene.glb", os.path.join(ROOT, "assets", "default_scene.glb"), 63840)]
    for e in manifest["files"]:
        if e["category"] == "invalid" or not e["path"].lower().endswith((".gltf", ".glb")):
            continue
        out.append((e["path"], os.path.join(SHARED, "assets", e["path"]), e["stats"]["triangle_count"]))
    if only:
        out = [a for a in out if any(s in a[0] for s in only)]
    return out


def gltf_transform(src, dst):
    return timed(["nice", GLTF_TRANSFORM, "draco", src, dst, "--method", "edgebreaker",
                  "--encode-speed", str(SPEED), "--decode-speed", str(SPEED),
                  "--quantize-position", str(BITS["position"]), "--quantize-normal", str(BITS["normal"]),
                  "--quantize-texcoord", str(BITS["texcoord"]), "--quantize-color", str(BITS["color"]),
                  "--quantize-generic", str(BITS["generic"])])[0]


def triangle_count(lodpipe, path):
    """Triangles in path's meshes as `lodpipe inspect` counts them (its load decodes Draco streams)."""
    _, out = timed([lodpipe, "inspect", path])
    return sum(int(m) for m in re.findall(r"^  primitive \d+: .*?, (\d+) triangles", out, re.M))


def measure(lodpipe, rel, path, work):
    d = os.path.join(work, rel.replace("/", "_"))
    os.makedirs(d, exist_ok=True)
    o = lambda name: os.path.join(d, name)  # noqa: E731
    row = {"asset": rel, "input": file_set_bytes(path)}
    row["t_convert"], _ = timed(["nice", lodpipe, "convert", path, o("convert.glb"), "-q"])
    row["convert"] = file_set_bytes(o("convert.glb"))
    row["t_convert_draco"], _ = timed(["nice", lodpipe, "convert", path, o("convert_draco.glb"), "--draco", "-q"])
    row["convert_draco"] = file_set_bytes(o("convert_draco.glb"))
    row["t_gt_lod0"] = gltf_transform(path, o("gt_lod0.glb"))
    row["gt_lod0"] = file_set_bytes(o("gt_lod0.glb"))
    # edgebreaker cannot hold a triangle with a repeated index: gltf-transform drops such triangles,
    # lodpipe keeps them (sequential connectivity), which can cost it bytes
    row["triangles"] = triangle_count(lodpipe, path)
    row["lost_lodpipe"] = row["triangles"] - triangle_count(lodpipe, o("convert_draco.glb"))
    row["lost_gt"] = row["triangles"] - triangle_count(lodpipe, o("gt_lod0.glb"))
    row["t_chain"], _ = timed(["nice", lodpipe, path, "-o", o("chain.glb"), "-q"])
    row["chain"] = file_set_bytes(o("chain.glb"))
    row["t_chain_draco"], summary = timed(["nice", lodpipe, path, "-o", o("chain_draco.glb"), "--draco", "--json", "-q"])
    row["chain_draco"] = file_set_bytes(o("chain_draco.glb"))
    s = json.loads(summary)
    row["raised"] = sum(1 for m in s["meshes"] if m.get("draco", {}).get("raised"))
    row["t_gt_chain"] = gltf_transform(o("chain.glb"), o("gt_chain.glb"))
    row["gt_chain"] = file_set_bytes(o("gt_chain.glb"))
    return row


def kb(n):
    return "%.1f" % (n / 1024.0)


def ratio(a, b):
    return "%.2f" % (a / b) if b else "-"


def render(rows, failures, started, lodpipe):
    lines = [BEGIN, "## Draco compression (issue 5)", ""]
    lines.append("`python3 bench/draco.py` on %s (this 2-core machine, shared; one run, `nice`). Bytes are the "
                 "output file plus every file it references (images included, so texture-heavy assets compress "
                 "little overall). Quantization for both tools: position %d, normal %d, texcoord %d, colour %d, "
                 "generic %d bits, speed %d. gltf-transform: npm @gltf-transform/cli 4.5.1 (`gltf-transform draco`, "
                 "edgebreaker, per-mesh grid). lodpipe: %s."
                 % (started, BITS["position"], BITS["normal"], BITS["texcoord"], BITS["color"], BITS["generic"],
                    SPEED, os.path.relpath(lodpipe, ROOT)))
    lines.append("")
    lines.append("- *LOD0 alone*: `lodpipe convert` (uncompressed), `lodpipe convert --draco` and `gltf-transform "
                 "draco` on the input. *Chain*: `lodpipe IN -o OUT` without and with `--draco`, and `gltf-transform "
                 "draco` on lodpipe's uncompressed chain (its levels, not the `--draco` run's: with Draco lodpipe "
                 "simplifies each level to eps minus the quantization budget, so its levels can differ slightly).")
    lines.append("- ratio = lodpipe --draco bytes / gltf-transform bytes (below 1: lodpipe smaller). A chain with Draco "
                 "cannot share vertices between levels, so each level carries its own (compressed) copy of the "
                 "vertices it uses.")
    lines.append("- LOD0 triangles: the input's, counted by `lodpipe inspect`; lost: how many fewer the Draco file "
                 "decodes to (`lodpipe inspect` decodes it). Draco's edgebreaker cannot hold a triangle with a "
                 "repeated index; lodpipe keeps such triangles by encoding their primitive with sequential "
                 "connectivity (larger), gltf-transform's edgebreaker drops them.")
    lines.append("")
    lines.append("| asset | input KiB | LOD0 KiB | LOD0 draco KiB | gltf-transform LOD0 KiB | ratio | chain KiB | "
                 "chain draco KiB | gltf-transform chain KiB | ratio | bits raised | LOD0 triangles | lost by lodpipe | "
                 "lost by gltf-transform |")
    lines.append("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    tot = {k: 0 for k in ("input", "convert", "convert_draco", "gt_lod0", "chain", "chain_draco", "gt_chain")}
    for r in rows:
        for k in tot:
            tot[k] += r[k]
        lines.append("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %d | %d | %d | %d |" % (
            r["asset"], kb(r["input"]), kb(r["convert"]), kb(r["convert_draco"]), kb(r["gt_lod0"]),
            ratio(r["convert_draco"], r["gt_lod0"]), kb(r["chain"]), kb(r["chain_draco"]), kb(r["gt_chain"]),
            ratio(r["chain_draco"], r["gt_chain"]), r["raised"], r["triangles"], r["lost_lodpipe"], r["lost_gt"]))
    if rows:
        lines.append("| **all** | %s | %s | %s | %s | %s | %s | %s | %s | %s | | | | |" % (
            kb(tot["input"]), kb(tot["convert"]), kb(tot["convert_draco"]), kb(tot["gt_lod0"]),
            ratio(tot["convert_draco"], tot["gt_lod0"]), kb(tot["chain"]), kb(tot["chain_draco"]),
            kb(tot["gt_chain"]), ratio(tot["chain_draco"], tot["gt_chain"])))
    lines.append("")
    lines.append("Encode times, seconds of wall clock per command (whole process; node start-up included for "
                 "gltf-transform):")
    lines.append("")
    lines.append("| asset | lodpipe convert | lodpipe convert --draco | gltf-transform LOD0 | lodpipe chain | "
                 "lodpipe chain --draco | gltf-transform on the chain |")
    lines.append("|---|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        lines.append("| %s | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |" % (
            r["asset"], r["t_convert"], r["t_convert_draco"], r["t_gt_lod0"], r["t_chain"], r["t_chain_draco"],
            r["t_gt_chain"]))
    if failures:
        lines.append("")
        lines.append("Not measured:")
        for rel, why in failures:
            lines.append("- %s: %s" % (rel, why))
    lines.append(END)
    return "\n".join(lines) + "\n"


def write_section(out, section):
    text = open(out).read() if os.path.exists(out) else ""
    if BEGIN in text and END in text:
        head, rest = text.split(BEGIN, 1)
        tail = rest.split(END, 1)[1]
        text = head + section.rstrip("\n") + tail
    else:
        text = text.rstrip("\n") + ("\n\n" if text else "") + section
    with open(out, "w") as f:
        f.write(text)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--assets", default="", help="comma-separated substrings of asset paths")
    ap.add_argument("--lodpipe", default=os.path.join(ROOT, "build", "lodpipe"))
    ap.add_argument("--out", default=os.path.join(ROOT, "bench", "RESULTS.md"))
    args = ap.parse_args()
    if not os.path.exists(GLTF_TRANSFORM):
        sys.exit("bench/draco.py: %s missing (run make deps)" % GLTF_TRANSFORM)
    started = time.strftime("%Y-%m-%d")
    work = tempfile.mkdtemp(prefix="lodpipe-draco-bench-")
    rows, failures = [], []
    try:
        for rel, path, triangles in assets([s for s in args.assets.split(",") if s]):
            log("%s (%d triangles)" % (rel, triangles))
            try:
                rows.append(measure(args.lodpipe, rel, path, work))
            except Exception as e:  # keep the others; the failure goes into RESULTS.md
                failures.append((rel, str(e)[:300]))
                log("  failed: %s" % e)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    write_section(args.out, render(rows, failures, started, args.lodpipe))
    log("wrote %s" % args.out)


if __name__ == "__main__":
    main()
