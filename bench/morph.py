#!/usr/bin/env python3
"""Morph-target benchmark: what `morph_errors` (README "Output format") costs in the main job.

Measurements, not pass/fail (the figures go into bench/RESULTS.md between the markers
<!-- section:morph --> and <!-- /section:morph -->, replacing that block or appending it):
  1. tests/lib/morphs.mjs writes cow.glb (../shared/assets/scans) with 52 distinct smooth morph
     targets (an ARKit-sized face rig) into bench/work/morph/;
  2. `lodpipe IN -o OUT` on cow.glb and on the 52-target file, with --threads 1 and with the default
     thread count, each --reps times (median): the peer is the same run without targets, so the cost
     of the targets is the difference, per target and as a ratio to the run without them;
  3. the outputs of --threads 1 and of the default are compared byte for byte.
Needs build/lodpipe (make all) and node.

usage: python3 bench/morph.py [--lodpipe PATH] [--targets 52] [--reps 3] [--out bench/RESULTS.md]
"""
import argparse
import datetime
import filecmp
import os
import shutil
import statistics
import subprocess
import sys
import time

from batch import BENCH, ROOT, git_commit, write_section

WORK = os.path.join(BENCH, "work", "morph")
BEGIN, END = "<!-- section:morph -->", "<!-- /section:morph -->"
T_START = time.monotonic()


def log(msg):
    sys.stderr.write("[morph bench %5.0fs] %s\n" % (time.monotonic() - T_START, msg))
    sys.stderr.flush()


def write_morph_cow(shared, targets):
    """The 52-target cow, written by the tests' own generator (same seed, same bytes every run)."""
    script = ("import { writeMorphCow } from %r; writeMorphCow(%r, 'cow_targets.glb', { distinct: %d });"
              % (os.path.join(ROOT, "tests", "lib", "morphs.mjs"), WORK, targets))
    env = dict(os.environ, LODPIPE_SHARED=shared)
    subprocess.run(["node", "--input-type=module", "-e", script], check=True, env=env)
    return os.path.join(WORK, "cow_targets.glb")


def timed(lodpipe, src, out, threads):
    cmd = [lodpipe, src, "-o", out, "--quiet"] + (["--threads", str(threads)] if threads else [])
    t0 = time.monotonic()
    r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.monotonic() - t0
    if r.returncode != 0:
        raise RuntimeError("%s: exit %d: %s" % (" ".join(cmd), r.returncode, r.stderr.strip()))
    return wall


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lodpipe", default=os.path.join(ROOT, "build", "lodpipe"))
    ap.add_argument("--shared", default=os.environ.get("LODPIPE_SHARED", os.path.join(os.path.dirname(ROOT), "shared")))
    ap.add_argument("--targets", type=int, default=52)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(BENCH, "RESULTS.md"))
    args = ap.parse_args()
    lodpipe = os.path.abspath(args.lodpipe)
    if not os.access(lodpipe, os.X_OK):
        sys.exit("morph bench: %s not found (make all)" % lodpipe)
    if os.path.exists(WORK):
        shutil.rmtree(WORK)
    os.makedirs(WORK)
    plain = os.path.join(os.path.abspath(args.shared), "assets", "scans", "cow.glb")
    morphed = write_morph_cow(os.path.abspath(args.shared), args.targets)
    load_before = os.getloadavg()
    walls = {}
    for threads in (1, 0):  # 0: the default, a thread per core
        for name, src in (("plain", plain), ("morphed", morphed)):
            out = os.path.join(WORK, "%s_t%d.glb" % (name, threads))
            walls[name, threads] = [timed(lodpipe, src, out, threads) for _ in range(args.reps)]
            log("%s, threads %s: %s s" % (name, threads or "default",
                                          ", ".join("%.2f" % w for w in walls[name, threads])))
    load_after = os.getloadavg()
    same = filecmp.cmp(os.path.join(WORK, "morphed_t1.glb"), os.path.join(WORK, "morphed_t0.glb"), shallow=False)

    lines = ["## Morph targets: the cost of morph_errors", ""]
    lines.append("%s, commit %s, this %d-core machine shared with other work; one run of `python3 bench/morph.py`. "
                 "Input: ../shared/assets/scans/cow.glb and the same with %d distinct smooth "
                 "morph targets (tests/lib/morphs.mjs, seed 1). Each row: `lodpipe IN -o OUT --quiet` "
                 "(`--threads 1`, or the default thread count), %d runs, wall clock of the process, median. "
                 "Load average (1 min) before %.2f, after %.2f."
                 % (datetime.date.today().isoformat(), git_commit(), os.cpu_count() or 1, args.targets, args.reps,
                    load_before[0], load_after[0]))
    lines.append("")
    lines.append("| threads | without targets s | with %d targets s | runs (with targets) | per target ms | "
                 "targets / no targets |" % args.targets)
    lines.append("|---|---:|---:|---|---:|---:|")
    for threads in (1, 0):
        a, b = statistics.median(walls["plain", threads]), statistics.median(walls["morphed", threads])
        lines.append("| %s | %.2f | %.2f | %s | %.0f | %.1fx |"
                     % (threads or "default", a, b, ", ".join("%.2f" % w for w in walls["morphed", threads]),
                        1000 * (b - a) / args.targets, b / a))
    lines.append("")
    lines.append("- `--threads 1` and the default wrote %s." % (
        "the same bytes" if same else "DIFFERENT bytes (a determinism defect)"))
    write_section(args.out, "\n".join(lines), BEGIN, END)
    log("wrote the morph section of %s" % args.out)
    print("\n".join(lines))
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
