#!/usr/bin/env python3
"""lodpipe benchmark (`make bench`): quality and speed against meshoptimizer, into bench/RESULTS.md.

Measurements, not pass/fail: every figure comes from this run on this machine; ratios are
against the peer measured in the same run. Needs (built beforehand by `make all hausdorff`):
build/lodpipe, build/obj/ (the project's loader objects, linked into bench/work/meshopt_peer),
build/hausdorff/hausdorff (the independent CGAL measure). Plain python3, no numpy (make_big.py
uses numpy when Debian's python3-numpy is present).

Quality (issue 3, "Must show" 2), per model (bunny, fandisk, rocker-arm, igea):
  - lodpipe single level at eps = 1/64 .. 1 % of the bbox diagonal: triangles, certified bound,
    and an independent check (hausdorff --within eps) of the level against the original;
  - meshoptimizer's SMALLEST triangle count whose measured two-sided Hausdorff distance is within
    eps: a bisection (geometric) on meshopt_simplify's target count, each probe measured with
    hausdorff --within; the answer is the smallest achieved count among passing probes;
  - the 1/3/7/15 % chain for both: lodpipe's (each level from the previous, certified against
    the original); meshoptimizer's bisected the same way (level k simplified from meshopt's
    level k-1, measured against the ORIGINAL); and meshoptimizer's own reading of the chain
    (target_error = eps, target count 0) with its measured distance.
Speed and memory (issue 3, "Must show" 3): a 1.1M-triangle bunny (make_big.py, 2 rounds); per
round, lodpipe's whole 1/3/7/15 % chain (one process, wall clock, user CPU, peak RSS from wait4)
then meshopt_peer's chain (by error and at lodpipe's achieved counts); 3 rounds, medians. After
the rounds, the last round's four lodpipe levels are checked (hausdorff --within) within their
own certified bounds against the original.
Shapes (same part, after the rounds): a disc, a cone and a cylinder whose centres have 1,000
triangles around them, and a flat grid of 300 x 300 cells (bench/make_shapes.py), the same chain,
lodpipe against meshopt_peer.

usage: python3 bench/run.py [--models bunny,fandisk,...] [--skip-quality] [--skip-speed]
                            [--lodpipe PATH] [--tol 0.01] [--reps 3]
"""
import argparse
import re
import datetime
import json
import math
import os
import shlex
import shutil
import statistics
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BENCH = os.path.join(ROOT, "bench")
WORK = os.path.join(BENCH, "work")

EPS_PCT = [1 / 64, 1 / 32, 1 / 16, 1 / 8, 1 / 4, 1 / 2, 1.0]
EPS_LABEL = ["1/64", "1/32", "1/16", "1/8", "1/4", "1/2", "1"]
CHAIN_PCT = [1.0, 3.0, 7.0, 15.0]
COHEN_BUNNY = [44621, 23581, 10793, 4838, 2204, 1004, 575]
# DESIGN.md §6: research prototype and meshoptimizer on this machine class (bunny).
DESIGN_PROTO = [45659, 24578, 11019, 4816, 2070, 882, 402]
DESIGN_MESHOPT = [69263, 66168, 36001, 13379, 7191, 2501, 1361]
MODELS = ["bunny", "fandisk", "rocker-arm", "igea"]

T_START = time.monotonic()
COMMANDS = {}  # label -> an example command line, for RESULTS.md


def log(msg):
    sys.stderr.write("[bench %6.0fs] %s\n" % (time.monotonic() - T_START, msg))
    sys.stderr.flush()


def rel(path):
    return os.path.relpath(path, ROOT)


def show(cmd):
    return " ".join(shlex.quote(rel(c) if os.path.isabs(c) and c.startswith(ROOT) else c) for c in cmd)


def note_cmd(label, cmd):
    COMMANDS.setdefault(label, show(cmd))


def run(cmd, label=None, check=True):
    if label:
        note_cmd(label, cmd)
    p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if check and p.returncode != 0:
        raise RuntimeError("%s: exit %d\n%s%s" % (show(cmd), p.returncode, p.stdout[-2000:], p.stderr[-2000:]))
    return p


def run_rusage(cmd, label=None):
    """Runs cmd as a child; returns (returncode, stdout, stderr, wall, user, sys, maxrss_bytes).
    wall from CLOCK_MONOTONIC around fork/wait; CPU and peak RSS from wait4 (getrusage of the child)."""
    if label:
        note_cmd(label, cmd)
    out_path, err_path = os.path.join(WORK, ".stdout"), os.path.join(WORK, ".stderr")
    with open(out_path, "w") as fo, open(err_path, "w") as fe:
        t0 = time.monotonic()
        p = subprocess.Popen(cmd, cwd=ROOT, stdout=fo, stderr=fe)
        _, status, ru = os.wait4(p.pid, 0)
        wall = time.monotonic() - t0
        p.returncode = os.waitstatus_to_exitcode(status)
    with open(out_path) as f:
        out = f.read()
    with open(err_path) as f:
        err = f.read()
    return p.returncode, out, err, wall, ru.ru_utime, ru.ru_stime, ru.ru_maxrss * 1024


def last_json(text):
    for line in reversed(text.strip().splitlines()):
        line = line.strip()
        if line.startswith("{"):
            return json.loads(line)
    raise ValueError("no JSON in output: %r" % text[-500:])


def fmt_pct(p):
    return repr(float(p)).rstrip("0").rstrip(".") if p != int(p) else str(int(p))


# ---------------------------------------------------------------- tools

class Tools:
    def __init__(self, args):
        self.lodpipe = args.lodpipe
        self.haus = args.hausdorff
        self.shared = args.shared
        self.peer = os.path.join(WORK, "meshopt_peer")

    def build_peer(self):
        objdir = os.path.join(ROOT, "build", "obj")
        objs = sorted(os.path.join(objdir, "src", f) for f in os.listdir(os.path.join(objdir, "src"))
                      if f.endswith(".o") and f != "main.o")
        tp = os.path.join(objdir, "third_party")
        for d in sorted(os.listdir(tp)):
            objs += sorted(os.path.join(tp, d, f) for f in os.listdir(os.path.join(tp, d)) if f.endswith(".o"))
        lib = os.path.join(WORK, "liblodpipe_load.a")
        if os.path.exists(lib):
            os.remove(lib)
        # An archive, so only the loader's objects (scene, weld and what they need) are pulled in.
        run(["ar", "rcs", lib] + objs)
        run(["cc", "-std=c11", "-O2", "-g", "-Wall", "-Wextra", "-Werror", "-pthread", "-D_DEFAULT_SOURCE",
             "-D_POSIX_C_SOURCE=200809L", "-Isrc", "-Ithird_party", "-c", "bench/meshopt_peer.c",
             "-o", os.path.join(WORK, "meshopt_peer.o")], "build meshopt_peer (compile)")
        run(["g++", "-o", self.peer, os.path.join(WORK, "meshopt_peer.o"), lib,
             "-ldraco", "-lmeshoptimizer", "-lm", "-pthread"], "build meshopt_peer (link)")

    def lodpipe_ok(self):
        if not os.access(self.lodpipe, os.X_OK):
            return False
        p = subprocess.run([self.lodpipe, "--help"], capture_output=True, text=True)
        return "simplify" in (p.stdout + p.stderr)

    # -- hausdorff
    def within(self, orig, obj, eps_rel):
        """Is the two-sided Hausdorff distance <= eps_rel x diagonal? True only when proven (upper <= eps).
        The tool answers false also when its lower bound is only within its tolerance (1 % of eps) of eps;
        that case is re-measured with a tolerance 1e-4 of eps and, if still open, reported as undecided."""
        r = None
        for err in (None, eps_rel * 1e-4):
            cmd = [self.haus, "--within", repr(eps_rel)] + ([] if err is None else ["--err", "%.3g" % err]) + [orig, obj]
            p = run(cmd, "hausdorff --within" if err is None else "hausdorff --within (re-check, tighter)",
                    check=False)
            if p.returncode != 0:  # e.g. an empty level: not within any eps; the reason is kept
                return {"within": False, "capped": False, "lower_rel": math.inf, "upper_rel": None, "seconds": 0,
                        "tris": None, "error": (p.stdout.strip() or p.stderr.strip())[-300:]}
            j = last_json(p.stdout)
            r = {"within": bool(j.get("within")), "capped": bool(j.get("capped")),
                 "lower_rel": j["rel"], "upper_rel": j.get("rel_upper"), "seconds": j["seconds"],
                 "tris": j["tris_b"], "undecided": False}
            if r["within"] or r["capped"] or r["lower_rel"] > eps_rel:
                return r
        r["undecided"] = True  # lower <= eps < upper even at the tighter tolerance
        return r

    def measure(self, orig, obj, err_rel):
        p = run([self.haus, "--method", "bnb", "--err", "%.3g" % err_rel, orig, obj], "hausdorff (value)")
        j = last_json(p.stdout)
        return {"lower_rel": j["rel"], "upper_rel": j.get("rel_upper"), "capped": bool(j.get("capped")),
                "seconds": j["seconds"]}

    # -- meshopt_peer
    def peer_info(self, glb):
        return last_json(run([self.peer, "info", glb, "0"], "meshopt_peer info").stdout)

    def peer_simplify(self, glb, targets, out):
        p = run([self.peer, "simplify", glb, "0", ",".join(str(t) for t in targets), out],
                "meshopt_peer simplify (bisection probe)")
        return last_json(p.stdout)

    # -- lodpipe
    def lodpipe_simplify(self, glb, outdir, pcts, label="lodpipe simplify", extra=()):
        shutil.rmtree(outdir, ignore_errors=True)
        os.makedirs(outdir)
        cmd = [self.lodpipe, "simplify", glb, outdir, "--levels", ",".join(fmt_pct(p) for p in pcts)] + list(extra)
        rc, out, err, wall, user, sys_, rss = run_rusage(cmd, label)
        res = {"rc": rc, "wall": wall, "user": user, "sys": sys_, "maxrss": rss,
               "stderr": err.strip()[-800:], "levels": []}
        js = os.path.join(outdir, "simplify.json")
        if rc == 0 and os.path.exists(js):
            with open(js) as f:
                j = json.load(f)
            m = j["meshes"][0]
            res["diagonal"] = m.get("diagonal")
            res["input_triangles"] = m.get("triangles")
            res["seconds_weld"] = m.get("seconds_weld")
            res["seconds_setup"] = m.get("seconds_setup")
            for i, lv in enumerate(m["levels"]):
                lvl = lv.get("level", i + 1)
                eps_pct = pcts[i]
                d = {"level": lvl, "pct": eps_pct, "triangles": lv.get("triangles"),
                     "seconds": lv.get("seconds"), "raw": {k: v for k, v in lv.items() if not isinstance(v, (dict, list))},
                     "obj": os.path.join(outdir, "mesh0_level%d.obj" % lvl)}
                d["bound_pct"] = bound_pct(lv.get("eps"), lv.get("bound"), eps_pct, m.get("diagonal"))
                res["levels"].append(d)
        return res


def bound_pct(eps, bound, pct, diag):
    """simplify.json's bound as % of the diagonal, whatever unit it uses (told by its eps)."""
    if eps is None or bound is None or not diag:
        return None
    for scale in (100.0, 100.0 / diag, 1.0):  # relative fraction, absolute units, percent
        if abs(eps * scale - pct) <= 1e-6 * max(pct, 1e-12):
            return bound * scale
    return None


# ---------------------------------------------------------------- meshoptimizer bisection

class Bisector:
    """Smallest meshopt triangle count whose measured two-sided Hausdorff to the ORIGINAL is within
    eps. Probes are cached by (chain prefix, target)."""

    def __init__(self, tools, glb, orig, name, tol, max_probes):
        self.t, self.glb, self.orig, self.name = tools, glb, orig, name
        self.tol, self.max_probes = tol, max_probes
        self.cache = {}
        self.probe_seconds = 0.0

    def probe(self, prefix, target, eps_rel):
        key = (tuple(prefix), target, eps_rel)
        if key in self.cache:
            return self.cache[key]
        t0 = time.monotonic()
        out = os.path.join(WORK, "probe_%s.obj" % self.name)
        s = self.t.peer_simplify(self.glb, list(prefix) + [target], out)
        tris = s["levels"][-1]["triangles"]
        if tris == 0:  # meshopt can collapse everything; an empty level is not within any eps
            w = {"within": False, "capped": False, "lower_rel": math.inf, "upper_rel": None}
        else:
            w = self.t.within(self.orig, out, eps_rel)
        r = {"target": target, "triangles": tris, "within": w["within"], "capped": w["capped"],
             "lower_rel": w["lower_rel"], "upper_rel": w["upper_rel"]}
        self.cache[key] = r
        self.probe_seconds += time.monotonic() - t0
        return r

    def search(self, prefix, hi_target, hi_tris, eps_rel):
        """hi_target is known to pass (unchanged previous level, or a smaller eps's answer)."""
        probes = []
        first = self.probe(prefix, 1, eps_rel)
        probes.append(first)
        if first["within"]:
            lo, hi = 1, 1
        else:
            lo, hi = 1, hi_target
        def bisect(lo, hi):
            while hi - lo > 1 and hi > lo * (1 + self.tol) and len(probes) < self.max_probes:
                mid = int(round(math.sqrt(lo * hi)))
                mid = min(max(mid, lo + 1), hi - 1)
                r = self.probe(prefix, mid, eps_rel)
                probes.append(r)
                if r["within"]:
                    hi = mid
                else:
                    lo = mid
            return lo, hi
        lo, hi = bisect(lo, hi)
        # The measured distance need not be monotone in the target: look a little below the failing
        # end; if something there passes, bisect again below it (once).
        below = sorted({int(lo * f) for f in (0.97, 0.92, 0.85)} - {0, 1}, reverse=True)
        below = [t for t in below if t < lo]
        for i, t in enumerate(below):
            r = self.probe(prefix, t, eps_rel)
            probes.append(r)
            if r["within"]:
                lo, hi = bisect(max(p["target"] for p in probes if not p["within"] and p["target"] < t), t)
                break
        passing = [p for p in probes if p["within"]]
        best_tris, best_target = hi_tris, hi_target
        for p in passing:
            if p["triangles"] < best_tris:
                best_tris, best_target = p["triangles"], p["target"]
        failing = [p["triangles"] for p in probes if not p["within"] and p["triangles"] < best_tris]
        return {"triangles": best_tris, "target": best_target,
                "largest_failing": max(failing) if failing else None,
                "probes": len(probes), "capped": sum(1 for p in probes if p["capped"]),
                "nonmonotone": any((not a["within"]) and b["within"] and a["target"] > b["target"]
                                   for a in probes for b in probes),
                "resolution_hit": not (hi - lo > 1 and hi > lo * (1 + self.tol)),
                "probe_log": [(p["target"], p["triangles"], p["within"]) for p in probes]}


# ---------------------------------------------------------------- quality

def quality(tools, model, args, have_lodpipe):
    glb = os.path.join(tools.shared, "assets", "scans", model + ".glb")
    orig = glb + "#mesh=0"
    info = tools.peer_info(glb)
    tol = args.tol_big if info["triangles"] > args.big_threshold else args.tol
    log("%s: %d triangles (welded: %d vertices), diagonal %.6g; bisection tolerance %g"
        % (model, info["triangles"], info["vertices"], info["diagonal"], tol))
    res = {"model": model, "info": info, "tol": tol, "single": [], "chain": {}}
    t_model = time.monotonic()
    outroot = os.path.join(WORK, "q_" + model)

    # lodpipe single levels: the default (half-edge) and lod.placement = "optimal"
    lp_single = []
    for pct in EPS_PCT:
        if not have_lodpipe:
            lp_single.append(None)
            continue
        entry = None
        for variant, extra in (("half-edge", ()), ("optimal", ("--placement", "optimal"))):
            r = tools.lodpipe_simplify(glb, os.path.join(outroot, "lodpipe_%s_%s" % (variant, fmt_pct(pct))), [pct],
                                       "lodpipe simplify (single level)", extra)
            e = {"rc": r["rc"], "wall": r["wall"], "stderr": r["stderr"]}
            if r["rc"] == 0 and r["levels"]:
                lv = r["levels"][0]
                e.update({"triangles": lv["triangles"], "bound_pct": lv["bound_pct"], "seconds": lv["seconds"]})
                e["check"] = tools.within(orig, lv["obj"], pct / 100) if not args.no_verify else None
            if entry is None:
                entry = e
            else:
                entry["optimal"] = e
            log("%s lodpipe %s %s %%: %s triangles (rc %d, %.1f s)%s" % (
                model, variant, fmt_pct(pct), e.get("triangles"), r["rc"], r["wall"],
                "" if not e.get("check") else ", within eps: %s" % e["check"]["within"]))
        lp_single.append(entry)

    # meshoptimizer single-level bisection, eps ascending; a smaller eps's answer passes the larger eps
    bis = Bisector(tools, glb, orig, model, tol, args.max_probes)
    hi_t, hi_n = info["triangles"], info["triangles"]
    mo_single = []
    peer = (args.peer_results or {}).get(model)
    if peer:  # --reuse-peer: meshoptimizer's side of this model from the previous run
        log("%s: meshoptimizer figures reused from the previous run (--reuse-peer)" % model)
        for i, pct in enumerate(EPS_PCT):
            res["single"].append({"pct": pct, "lodpipe": lp_single[i], "meshopt": peer["single"][i]["meshopt"]})
        res["peer_reused"] = True
    for pct in EPS_PCT if not peer else ():
        t0 = time.monotonic()
        b = bis.search([], hi_t, hi_n, pct / 100)
        b["seconds"] = time.monotonic() - t0
        mo_single.append(b)
        hi_t, hi_n = b["target"], b["triangles"]
        log("%s meshopt %s %%: %d triangles (target %d, %d probes, %.0f s)"
            % (model, fmt_pct(pct), b["triangles"], b["target"], b["probes"], b["seconds"]))
    for i, pct in enumerate(EPS_PCT if not peer else ()):
        res["single"].append({"pct": pct, "lodpipe": lp_single[i], "meshopt": mo_single[i]})

    # chains
    for key, extra in (("lodpipe", ()), ("lodpipe_optimal", ("--placement", "optimal"))):
        if not have_lodpipe:
            break
        r = tools.lodpipe_simplify(glb, os.path.join(outroot, key + "_chain"), CHAIN_PCT, "lodpipe simplify (chain)",
                                   extra)
        lv_out = []
        for lv in r["levels"]:
            e = {"triangles": lv["triangles"], "bound_pct": lv["bound_pct"], "seconds": lv["seconds"]}
            e["check"] = tools.within(orig, lv["obj"], lv["pct"] / 100) if not args.no_verify else None
            lv_out.append(e)
        res["chain"][key] = {"rc": r["rc"], "wall": r["wall"], "stderr": r["stderr"], "levels": lv_out}
        log("%s %s chain: %s (rc %d)" % (model, key, [e["triangles"] for e in lv_out], r["rc"]))

    if peer:
        for key in ("meshopt_bisect", "meshopt_own"):
            res["chain"][key] = peer["chain"][key]
        res["probe_seconds"] = peer.get("probe_seconds", 0)
        res["seconds"] = time.monotonic() - t_model
        return res
    one = EPS_PCT.index(1.0)
    chain_b = [dict(mo_single[one], reused_from_single=True)]
    prefix = [mo_single[one]["target"]]
    for pct in CHAIN_PCT[1:]:
        prev = chain_b[-1]
        t0 = time.monotonic()
        b = bis.search(prefix, prev["triangles"], prev["triangles"], pct / 100)
        b["seconds"] = time.monotonic() - t0
        chain_b.append(b)
        prefix.append(b["target"])
    res["chain"]["meshopt_bisect"] = chain_b
    log("%s meshopt bisected chain: %s" % (model, [b["triangles"] for b in chain_b]))

    # meshoptimizer's own reading: target_error = eps (fraction of the diagonal), count 0
    cdir = os.path.join(outroot, "meshopt_chain")
    os.makedirs(cdir, exist_ok=True)
    p = run([tools.peer, "chain", glb, "0", "--errors", ",".join(repr(x / 100) for x in CHAIN_PCT),
             "--reps", "1", "--out", cdir], "meshopt_peer chain (by error, with outputs)")
    j = last_json(p.stdout)
    own = []
    for i, lv in enumerate(j["by_error"]["levels"]):
        if lv["triangles"] == 0:
            own.append({"triangles": 0, "result_error_pct": lv["result_error_rel_diag"] * 100,
                        "measured_lower_pct": math.inf, "measured_upper_pct": None})
            continue
        m = tools.measure(orig, os.path.join(cdir, "errors_level%d.obj" % (i + 1)), CHAIN_PCT[i] / 100 / 100)
        own.append({"triangles": lv["triangles"], "result_error_pct": lv["result_error_rel_diag"] * 100,
                    "measured_lower_pct": m["lower_rel"] * 100,
                    "measured_upper_pct": None if m["upper_rel"] is None else m["upper_rel"] * 100})
    res["chain"]["meshopt_own"] = own
    log("%s meshopt own-error chain: %s" % (model, [(o["triangles"], round(o["measured_lower_pct"], 3)) for o in own]))
    res["probe_seconds"] = bis.probe_seconds
    res["seconds"] = time.monotonic() - t_model
    return res


# ---------------------------------------------------------------- speed

def in_process(rnd):
    """lodpipe's weld + set-up + levels of one speed round (None before simplify.json had them)."""
    ws = rnd["lodpipe"].get("weld_setup_seconds")
    return None if ws is None else ws + sum(x or 0 for x in rnd["lodpipe"]["level_seconds"])


def speed(tools, args, have_lodpipe):
    big = os.path.join(WORK, "bunny_big.glb")
    src = os.path.join(tools.shared, "assets", "scans", "bunny.glb")
    mk = ["python3", os.path.join(tools.shared, "tools", "make_big.py"), src, big,
          "--rounds", "2", "--noise", "1e-4", "--seed", "1"]
    p = run(mk, "make the 1.1M-triangle mesh")
    res = {"make_big": (p.stdout + p.stderr).strip(), "rounds": [], "loadavg_before": open("/proc/loadavg").read().strip()}
    info = tools.peer_info(big)
    res["info"] = info
    log("speed: %s: %d triangles, load average %s" % (rel(big), info["triangles"], res["loadavg_before"]))
    counts = None
    errors = ",".join(repr(x / 100) for x in CHAIN_PCT)
    for r in range(args.reps):
        rnd = {"loadavg": open("/proc/loadavg").read().split()[0]}
        if have_lodpipe:
            L = tools.lodpipe_simplify(big, os.path.join(WORK, "speed_lodpipe"), CHAIN_PCT, "lodpipe simplify (speed)")
            if L["rc"] != 0:
                raise RuntimeError("lodpipe failed on %s: %s" % (rel(big), L["stderr"]))
            rnd["lodpipe"] = {k: L[k] for k in ("wall", "user", "sys", "maxrss")}
            rnd["lodpipe"]["level_seconds"] = [lv["seconds"] for lv in L["levels"]]
            rnd["lodpipe"]["weld_setup_seconds"] = (L["seconds_weld"] + L["seconds_setup"]
                                                    if L.get("seconds_weld") is not None and L.get("seconds_setup") is not None
                                                    else None)
            rnd["lodpipe"]["triangles"] = [lv["triangles"] for lv in L["levels"]]
            rnd["lodpipe"]["bound_pct"] = [lv["bound_pct"] for lv in L["levels"]]
            if counts is None:
                counts = [max(1, lv["triangles"]) for lv in L["levels"]]
            log("speed round %d lodpipe: %.2f s wall, %.2f s user, %.0f MB, levels %s"
                % (r + 1, L["wall"], L["user"], L["maxrss"] / 1e6, rnd["lodpipe"]["triangles"]))
        cmd = [tools.peer, "chain", big, "0", "--errors", errors, "--reps", "1"]
        if counts:
            cmd += ["--targets", ",".join(str(c) for c in counts)]
        rc, out, err, wall, user, sys_, rss = run_rusage(cmd, "meshopt_peer chain (speed)")
        if rc != 0:
            raise RuntimeError("meshopt_peer failed: %s" % err)
        j = last_json(out)
        rnd["meshopt"] = {"wall": wall, "user": user, "maxrss": rss, "load": j["load_seconds"],
                          "weld": j["weld_seconds"], "peak_rss_kb_self": j["peak_rss_kb"],
                          "by_error": j["by_error"]["median_seconds"],
                          "by_error_triangles": [lv["triangles"] for lv in j["by_error"]["levels"]]}
        if "by_count" in j:
            rnd["meshopt"]["by_count"] = j["by_count"]["median_seconds"]
            rnd["meshopt"]["by_count_triangles"] = [lv["triangles"] for lv in j["by_count"]["levels"]]
        log("speed round %d meshopt: by error %.3f s%s" % (
            r + 1, rnd["meshopt"]["by_error"],
            ", at lodpipe's counts %.3f s" % rnd["meshopt"]["by_count"] if "by_count" in rnd["meshopt"] else ""))
        res["rounds"].append(rnd)
    res["loadavg_after"] = open("/proc/loadavg").read().strip()
    if have_lodpipe and res["rounds"] and not args.no_verify:
        # the timed levels are what the ratio is for: each is checked within its own certified bound
        # (which lodpipe reports <= eps), after the timing so that the check's CPU does not disturb it
        res["verify"] = []
        for lv in L["levels"]:
            b = lv["bound_pct"]
            w = tools.within(big + "#mesh=0", lv["obj"], b / 100) if b is not None else {"within": False}
            res["verify"].append({"level": lv["level"], "pct": lv["pct"], "bound_pct": b, **w})
            log("speed: level %d (%s %%) within its certified bound %s %%: %s" % (
                lv["level"], fmt_pct(lv["pct"]), b, "undecided" if w.get("undecided") else w["within"]))
    res["shapes"] = shapes(tools, args, have_lodpipe)
    return res


SHAPES = [("disc", 1000), ("cone", 1000), ("cylinder", 1000), ("grid", 300)]


def shapes(tools, args, have_lodpipe):
    """The same chain on the shapes of bench/make_shapes.py (fans, a flat grid): each kind's
    lodpipe run and meshopt_peer's chain, alternated, args.reps rounds; then the last round's levels
    checked within their certified bounds."""
    out = []
    errors = ",".join(repr(x / 100) for x in CHAIN_PCT)
    for kind, segments in SHAPES:
        glb = os.path.join(WORK, "shape_%s.glb" % kind)
        p = run(["python3", os.path.join(BENCH, "make_shapes.py"), kind, str(segments), glb], "make a shape")
        item = {"kind": kind, "made": last_json(p.stdout), "rounds": []}
        L = None
        for r in range(args.reps):
            rnd = {}
            if have_lodpipe:
                L = tools.lodpipe_simplify(glb, os.path.join(WORK, "shape_%s_lodpipe" % kind), CHAIN_PCT,
                                           "lodpipe simplify (shapes)")
                if L["rc"] != 0:
                    raise RuntimeError("lodpipe failed on %s: %s" % (rel(glb), L["stderr"]))
                rnd["lodpipe"] = {"wall": L["wall"], "user": L["user"],
                                  "triangles": [lv["triangles"] for lv in L["levels"]],
                                  "bound_pct": [lv["bound_pct"] for lv in L["levels"]]}
            rc, o, err, wall, user, sys_, rss = run_rusage(
                [tools.peer, "chain", glb, "0", "--errors", errors, "--reps", "1"], "meshopt_peer chain (shapes)")
            if rc != 0:
                raise RuntimeError("meshopt_peer failed on %s: %s" % (rel(glb), err))
            j = last_json(o)
            rnd["meshopt"] = {"by_error": j["by_error"]["median_seconds"],
                              "triangles": [lv["triangles"] for lv in j["by_error"]["levels"]]}
            item["rounds"].append(rnd)
        if L and not args.no_verify:
            item["verify"] = []
            for lv in L["levels"]:
                b = lv["bound_pct"]
                item["verify"].append(tools.within(glb + "#mesh=0", lv["obj"], b / 100) if b is not None
                                      else {"within": False})
        log("shapes: %s: %s" % (kind, json.dumps(item["rounds"][-1])))
        out.append(item)
    return out


# ---------------------------------------------------------------- report

def machine(tools, have_lodpipe):
    cpu = "?"
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    mem = "?"
    with open("/proc/meminfo") as f:
        for line in f:
            if line.startswith("MemTotal"):
                mem = "%.1f GiB" % (int(line.split()[1]) / 1024 / 1024)
    def sh(cmd, strip=True):
        p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
        return p.stdout.strip() if strip else p.stdout
    # porcelain lines are "XY path": stripping the output would eat the first line's
    # leading space (an unstaged change, " M") and with it a letter of its path
    dirty = sh(["git", "status", "--porcelain", "--", "src", "third_party", "Makefile"], strip=False)
    mo = sh(["dpkg-query", "-W", "-f=${Version}", "libmeshoptimizer-dev"])
    lp_mtime = (datetime.datetime.fromtimestamp(os.path.getmtime(tools.lodpipe)).strftime("%Y-%m-%d %H:%M:%S")
                if os.path.exists(tools.lodpipe) else None)
    return {"nproc": sh(["nproc"]), "cpu": cpu, "mem": mem, "kernel": os.uname().release,
            "date": datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M:%S %Z"),
            "commit": sh(["git", "rev-parse", "--short", "HEAD"]),
            "dirty": dirty.splitlines() if dirty else [], "meshoptimizer": mo,
            "lodpipe_version": sh([tools.lodpipe, "--version"]) if have_lodpipe else None,
            "lodpipe_mtime": lp_mtime, "cc": sh(["cc", "--version"]).splitlines()[0],
            "python": sys.version.split()[0]}


def n(x):
    return "–" if x is None else "{:,}".format(x)


def pctf(x, digits=4):
    return "–" if x is None else ("%." + str(digits) + "g") % x


def med(xs):
    xs = [x for x in xs if x is not None]
    return statistics.median(xs) if xs else None


def check_cell(c):
    if not c:
        return "not checked"
    if c["within"]:
        return "yes"
    if c["capped"]:
        return "undecided (capped)"
    if c.get("undecided"):
        return "undecided (%.6g ≤ H, eps within 1e-4 of eps)" % (c["lower_rel"] * 100)
    if c.get("error"):
        return "**NO** (%s)" % c["error"].replace("|", "/").replace("`", "'")[:120]
    return "**NO** (H ≥ %.6g %%)" % (c["lower_rel"] * 100)


def summary(results, w):
    lines = []
    for q in results.get("quality", []):
        checks = [s["lodpipe"].get("check") for s in q["single"] if s["lodpipe"]]
        checks += [s["lodpipe"]["optimal"].get("check") for s in q["single"] if s["lodpipe"] and s["lodpipe"].get("optimal")]
        lpc = q["chain"].get("lodpipe")
        lpo = q["chain"].get("lodpipe_optimal")
        for c_ in (lpc, lpo):
            if c_:
                checks += [lv.get("check") for lv in c_["levels"]]
        proven = sum(1 for c in checks if c and c["within"])
        over = sum(1 for c in checks if c and not c["within"] and not c.get("undecided") and not c["capped"])
        lp = [s["lodpipe"].get("triangles") if s["lodpipe"] else None for s in q["single"]]
        mo = [s["meshopt"]["triangles"] for s in q["single"]]
        ch = [lv["triangles"] for lv in lpc["levels"]] if lpc and lpc["rc"] == 0 else None
        mc = [b["triangles"] for b in q["chain"]["meshopt_bisect"]]
        t = "%s: lodpipe %s, meshoptimizer within eps %s (eps = %s %%)" % (
            q["model"], " / ".join(n(x) for x in lp) if results["have_lodpipe"] else "–",
            " / ".join(n(x) for x in mo), ", ".join(EPS_LABEL))
        opt = [s["lodpipe"]["optimal"].get("triangles") if s["lodpipe"] and s["lodpipe"].get("optimal") else None
               for s in q["single"]]
        if any(x is not None for x in opt):
            t += "; lodpipe with `--placement optimal` %s" % " / ".join(n(x) for x in opt)
        if q["model"] == "bunny":
            t += "; Cohen 1996 %s" % " / ".join(n(x) for x in COHEN_BUNNY)
        cho = [lv["triangles"] for lv in lpo["levels"]] if lpo and lpo["rc"] == 0 else None
        t += "; chain 1/3/7/15 %%: lodpipe %s%s, meshoptimizer %s" % (
            " / ".join(n(x) for x in ch) if ch else "–",
            " (optimal placement %s)" % " / ".join(n(x) for x in cho) if cho else "", " / ".join(n(x) for x in mc))
        if results["have_lodpipe"]:
            t += "; %d of %d lodpipe levels independently proven within eps%s" % (
                proven, len(checks), ", **%d measured over eps**" % over if over else "")
        lines.append(t + ".")
    sp = results.get("speed")
    if sp and results["have_lodpipe"]:
        R = sp["rounds"]
        lw = med([r["lodpipe"]["wall"] for r in R])
        mo = med([r["meshopt"]["by_error"] for r in R])
        T = sp["info"]["triangles"]
        rss = max(r["lodpipe"]["maxrss"] for r in R)
        lines.append("1.1M triangles, chain 1/3/7/15 %%: lodpipe %.1f s wall (median of %d) vs meshopt_simplify "
                     "%.2f s: **%.1fx** (target <= 3x); lodpipe peak memory **%.0f bytes per input triangle** "
                     "(goal <= 350)." % (lw, len(R), mo, lw / mo, rss / T))
    elif sp:
        R = sp["rounds"]
        lines.append("1.1M triangles, chain 1/3/7/15 %%: meshopt_simplify %.2f s (median of %d); no lodpipe figure."
                     % (med([r["meshopt"]["by_error"] for r in R]), len(R)))
    if lines:
        w("## Summary")
        w("")
        for t in lines:
            w("- " + t)
        w("")


def report(results, args):
    m = results["machine"]
    L = []
    w = L.append
    w("# lodpipe benchmark results")
    w("")
    w("Written by `make bench` (`%s`); every figure below was measured in this one run on this machine. "
      "Measurements, not pass/fail: the issue-3 targets are quoted next to them." % results["entry"])
    for part, built in sorted(results.get("reused", {}).items()):
        w("")
        w("Exception: the %s figures come from an earlier run (`--skip-%s --reuse`), made with a lodpipe "
          "built %s; the table below describes this run." % (part, part, built))
    if results.get("peer_reused_from"):
        w("")
        w("Exception: meshoptimizer's quality figures (bisections and own-error chains) were not measured again: "
          "`--reuse-peer` took them from %s (same inputs, same peer library and measure); lodpipe's quality "
          "figures were measured in %s." % (results["peer_reused_from"],
                                            "the run they come from" if "quality" in results.get("reused", {})
                                            else "this run"))
    w("")
    w("| | |")
    w("|---|---|")
    w("| date | %s |" % m["date"])
    w("| commit | `%s`%s |" % (m["commit"], "" if not m["dirty"] else
                                " + uncommitted changes in: %s" % ", ".join("`%s`" % d[3:] for d in m["dirty"])))
    w("| lodpipe | %s |" % (("`build/lodpipe` (%s, built %s; copied to bench/work/lodpipe at the start, so "
                            "one binary made every figure)" % (m["lodpipe_version"], m["lodpipe_mtime"]))
                           if results["have_lodpipe"] else "**not available** (`build/lodpipe --help` has no `simplify`)"))
    w("| meshoptimizer | Debian libmeshoptimizer-dev %s, `meshopt_simplify`, positions only, options 0 |"
      % m["meshoptimizer"])
    w("| machine | `nproc` = %s, %s, %s RAM, Linux %s |" % (m["nproc"], m["cpu"], m["mem"], m["kernel"]))
    w("| compiler | %s; python %s |" % (m["cc"], m["python"]))
    w("| run time | %.0f s |" % results["seconds"])
    w("")
    summary(results, w)
    if not results["have_lodpipe"]:
        w("**lodpipe's `simplify` command was not available when this ran: only the meshoptimizer side is "
          "measured; lodpipe's columns are empty.**")
        w("")

    # ---- quality
    if results.get("quality"):
        w("## 1. Quality: triangles within a two-sided Hausdorff eps")
        w("")
        w("eps is a percentage of the mesh's bounding-box diagonal. **lodpipe**: `lodpipe simplify IN OUT "
          "--levels P` (one level), its triangle count and certified bound; \"checked\" = the independent CGAL "
          "measure (`build/hausdorff/hausdorff --within eps`, bnb) proved the level within eps of the original "
          "(both directions). **meshoptimizer**: the smallest triangle count whose *measured* two-sided Hausdorff "
          "distance to the original is within eps (proved by the same measure), found by a geometric bisection on "
          "`meshopt_simplify`'s target count (target_error 1.0, so the count decides), each probe measured, then "
          "three probes at 97/92/85 % of the failing end (if one passes, the bisection goes on below it, since the "
          "measured distance need not be monotone in the count); "
          "\"failing\" is the largest count below the answer that was measured over eps (where the bisection "
          "ended). Both start from the same welded indexed mesh (lodpipe's own loader and weld).")
        w("")
        for q in results["quality"]:
            info = q["info"]
            w("### %s (%s triangles, %s welded vertices, diagonal %.6g)" % (q["model"], n(info["triangles"]),
                                                                         n(info["vertices"]), info["diagonal"]))
            w("")
            bunny = q["model"] == "bunny"
            hdr = ("| eps % | lodpipe | bound % | checked | lodpipe, optimal placement | checked | meshopt | (failing) "
                   "| probes | meshopt / lodpipe |")
            sep = "|---|---:|---:|---|---:|---|---:|---:|---:|---:|"
            if bunny:
                hdr += " Cohen 1996 | DESIGN §6 prototype | DESIGN §6 meshopt |"
                sep += "---:|---:|---:|"
            w(hdr)
            w(sep)
            for i, s in enumerate(q["single"]):
                lp, mo = s["lodpipe"], s["meshopt"]
                lpt = lp.get("triangles") if lp else None
                if lp and lp["rc"] != 0:
                    lp_cell, b_cell, c_cell = "failed (exit %d)" % lp["rc"], "–", "–"
                else:
                    lp_cell = n(lpt)
                    b_cell = pctf(lp.get("bound_pct")) if lp else "–"
                    c_cell = check_cell(lp.get("check")) if lp else "–"
                ratio = "%.2f" % (mo["triangles"] / lpt) if lpt else "–"
                op = lp.get("optimal") if lp else None
                if not op:
                    o_cell, oc_cell = "–", "–"
                elif op["rc"] != 0:
                    o_cell, oc_cell = "failed (exit %d)" % op["rc"], "–"
                else:
                    o_cell, oc_cell = n(op.get("triangles")), check_cell(op.get("check"))
                row = "| %s | %s | %s | %s | %s | %s | %s%s | %s | %d%s | %s |" % (
                    EPS_LABEL[i], lp_cell, b_cell, c_cell, o_cell, oc_cell, n(mo["triangles"]),
                    " †" if mo["nonmonotone"] else "",
                    n(mo["largest_failing"]),
                    mo["probes"], " (%d capped)" % mo["capped"] if mo["capped"] else "", ratio)
                if bunny:
                    row += " %s | %s | %s |" % (n(COHEN_BUNNY[i]), n(DESIGN_PROTO[i]), n(DESIGN_MESHOPT[i]))
                w(row)
            w("")
            if bunny and results["have_lodpipe"]:
                le = [s["lodpipe"].get("triangles") if s["lodpipe"] else None for s in q["single"]]
                ok = [x is not None and x <= c for x, c in zip(le, COHEN_BUNNY)]
                w("Issue 3 asks for lodpipe's bunny counts at or below Cohen et al. 1996: %d of 7 are (%s)."
                  % (sum(ok), ", ".join("%s %%: %s" % (EPS_LABEL[i], "yes" if o else "no") for i, o in enumerate(ok))))
                lo = [s["lodpipe"]["optimal"].get("triangles") if s["lodpipe"] and s["lodpipe"].get("optimal") else None
                      for s in q["single"]]
                oko = [x is not None and x <= c for x, c in zip(lo, COHEN_BUNNY)]
                w("With `--placement optimal` (full-edge collapses that place the kept vertex where the half-edge "
                  "collapse cannot be certified; README \"Placement\"): %d of 7 (%s)."
                  % (sum(oko), ", ".join("%s %%: %s" % (EPS_LABEL[i], "yes" if o else "no") for i, o in enumerate(oko))))
                w("")
            # chain
            w("Chain 1/3/7/15 % (each level from the previous one, measured against the original):")
            w("")
            w("| level | eps % | lodpipe | bound % | checked | lodpipe, optimal placement | checked | "
              "meshopt, smallest within eps | (failing) | "
              "meshopt, target_error = eps | its own error % | its measured H % | measured H / eps |")
            w("|---|---|---:|---:|---|---:|---|---:|---:|---:|---:|---:|---:|")
            lpc = q["chain"].get("lodpipe")
            lpo = q["chain"].get("lodpipe_optimal")
            for k, pct in enumerate(CHAIN_PCT):
                lv = lpc["levels"][k] if lpc and lpc["rc"] == 0 and k < len(lpc["levels"]) else None
                mb = q["chain"]["meshopt_bisect"][k]
                mo = q["chain"]["meshopt_own"][k]
                if lpc and lpc["rc"] != 0:
                    lcell, bcell, ccell = "failed (exit %d)" % lpc["rc"], "–", "–"
                elif lv:
                    lcell, bcell, ccell = n(lv["triangles"]), pctf(lv["bound_pct"]), check_cell(lv.get("check"))
                else:
                    lcell = bcell = ccell = "–"
                if mo["triangles"] == 0:
                    own_h = "empty level | –"
                else:
                    own_h = "%.4g | %.2f" % (mo["measured_lower_pct"], mo["measured_lower_pct"] / pct)
                lo = lpo["levels"][k] if lpo and lpo["rc"] == 0 and k < len(lpo["levels"]) else None
                ocell = n(lo["triangles"]) if lo else ("failed (exit %d)" % lpo["rc"] if lpo else "–")
                occell = check_cell(lo.get("check")) if lo else "–"
                w("| %d | %g | %s | %s | %s | %s | %s | %s%s | %s | %s | %.4g | %s |" % (
                    k + 1, pct, lcell, bcell, ccell, ocell, occell, n(mb["triangles"]), " †" if mb["nonmonotone"] else "",
                    n(mb["largest_failing"]), n(mo["triangles"]), mo["result_error_pct"], own_h))
            w("")
            if any(s_["meshopt"]["nonmonotone"] for s_ in q["single"]) or any(b["nonmonotone"] for b in q["chain"]["meshopt_bisect"]):
                w("† a probe with a larger target failed while a smaller one passed: meshoptimizer's measured "
                  "distance is not monotone in the target count there, so a bisection may miss smaller passing "
                  "counts.")
                w("")
            w("(meshopt's level 1 is its 1 %% single-level answer above. \"its measured H\" is the CGAL lower "
              "bound with tolerance eps/100. %s bisection: relative resolution %g, at most %d probes per search; %s)"
              % (q["model"], q["tol"], args.max_probes,
                 "its probes were measured in the run the figures were reused from (%.0f s there); this run spent "
                 "%.0f s on lodpipe's side of this model." % (q["probe_seconds"], q["seconds"]) if q.get("peer_reused")
                 else "measuring took %.0f s of the %.0f s spent on this model." % (q["probe_seconds"], q["seconds"])))
            w("")
            if lpc and lpc["rc"] != 0:
                w("lodpipe's chain failed: `%s`" % lpc["stderr"].replace("`", "'"))
                w("")
            for i, s in enumerate(q["single"]):
                if s["lodpipe"] and s["lodpipe"]["rc"] != 0:
                    w("lodpipe at %s %% failed: `%s`" % (EPS_LABEL[i], s["lodpipe"]["stderr"].replace("`", "'")))
                    w("")

    # ---- speed
    sp = results.get("speed")
    if sp:
        info = sp["info"]
        T = info["triangles"]
        w("## 2. Speed and memory: the 1/3/7/15 %% chain on %s triangles" % n(T))
        w("")
        w("Input: `bench/work/bunny_big.glb` (make_big.py said: \"%s\"). %d rounds, each: lodpipe's whole chain in one process, then meshopt_peer's "
          "chain in one process; medians over the rounds. Wall clock = CLOCK_MONOTONIC around the process "
          "(lodpipe) or around the four `meshopt_simplify` calls (meshoptimizer); CPU and peak RSS of each "
          "process from `wait4` (getrusage of the child). meshoptimizer is single-threaded; lodpipe uses its "
          "default thread count on this %s-core machine. Load average before: %s; after: %s."
          % (sp["make_big"].replace(ROOT + "/", ""), len(sp["rounds"]), results["machine"]["nproc"],
             sp["loadavg_before"], sp["loadavg_after"]))
        w("")
        R = sp["rounds"]
        mo_err = med([r["meshopt"]["by_error"] for r in R])
        mo_cnt = med([r["meshopt"].get("by_count") for r in R])
        mo_lw = med([r["meshopt"]["load"] + r["meshopt"]["weld"] for r in R])
        mo_wall = med([r["meshopt"]["wall"] for r in R])
        w("| | median | runs |")
        w("|---|---:|---|")
        def row(label, vals, unit="s", fmt="%.3f"):
            vals_ = [v for v in vals if v is not None]
            if not vals_:
                return
            w("| %s | %s %s | %s |" % (label, fmt % statistics.median(vals_), unit, ", ".join(fmt % v for v in vals_)))
        if results["have_lodpipe"]:
            row("lodpipe: whole process, wall (load, weld, 4 levels, write OBJ + JSON)", [r["lodpipe"]["wall"] for r in R])
            row("lodpipe: whole process, user CPU", [r["lodpipe"]["user"] for r in R])
            row("lodpipe: sum of the levels' `seconds` (simplify.json)",
                [sum(x or 0 for x in r["lodpipe"]["level_seconds"]) for r in R])
            row("lodpipe: weld + set-up + levels, in process (simplify.json: no file read or written)",
                [in_process(r) for r in R])
        row("meshopt: 4 × meshopt_simplify, target_error = eps, count 0", [r["meshopt"]["by_error"] for r in R])
        row("meshopt: 4 × meshopt_simplify at lodpipe's achieved counts", [r["meshopt"].get("by_count") for r in R])
        row("meshopt_peer: load + weld (the project's loader)", [r["meshopt"]["load"] + r["meshopt"]["weld"] for r in R])
        row("meshopt_peer: whole process, wall", [r["meshopt"]["wall"] for r in R])
        row("1-minute load average at the start of the round (other work on the machine)",
            [float(r["loadavg"]) for r in R if "loadavg" in r], "", "%.2f")
        w("")
        w("Levels (triangles): meshopt by error %s; meshopt at lodpipe's counts %s%s." % (
            R[0]["meshopt"]["by_error_triangles"], R[0]["meshopt"].get("by_count_triangles", "–"),
            ("; lodpipe %s, certified bounds %% %s" % (R[0]["lodpipe"]["triangles"],
                                                       [pctf(b) for b in R[0]["lodpipe"]["bound_pct"]]))
            if results["have_lodpipe"] else ""))
        w("")
        if sp.get("verify"):
            V = sp["verify"]
            proven = sum(1 for v in V if v["within"])
            w("Independent check of the last round's levels against the %s-triangle original (`hausdorff --within "
              "BOUND`, BOUND = the level's certified bound as a fraction of the diagonal): **%d of %d proven within "
              "their certified bound**%s." % (n(T), proven, len(V), "".join(
                  "; level %d (%s %%): %s, measured [%s, %s] %% of the diagonal, %.0f s" % (
                      v["level"], fmt_pct(v["pct"]),
                      "undecided" if v.get("undecided") else "within" if v["within"] else "**NOT within**",
                      pctf(100 * v["lower_rel"], 6) if v.get("lower_rel") is not None else "?",
                      pctf(100 * v["upper_rel"], 6) if v.get("upper_rel") is not None else "?",
                      v.get("seconds") or 0) for v in V)))
            w("")
        if results["have_lodpipe"]:
            lw = med([r["lodpipe"]["wall"] for r in R])
            ls = med([sum(x or 0 for x in r["lodpipe"]["level_seconds"]) for r in R])
            lp = med([in_process(r) for r in R])
            lu = med([r["lodpipe"]["user"] for r in R])
            rss = max(r["lodpipe"]["maxrss"] for r in R)
            w("Ratios lodpipe / meshoptimizer (issue 3 target: <= 3x):")
            w("")
            w("| lodpipe | meshoptimizer | ratio |")
            w("|---|---|---:|")
            for a_lab, a in (("whole process, wall", lw), ("weld + set-up + levels, in process", lp),
                             ("sum of level seconds", ls)):
                for b_lab, b in (("4 levels by error", mo_err), ("4 levels at lodpipe's counts", mo_cnt),
                                 ("load + weld + 4 levels by error", (mo_lw + mo_err) if mo_lw is not None else None)):
                    if a is not None and b:
                        w("| %s | %s | %.2fx |" % (a_lab, b_lab, a / b))
            if lu is not None and mo_err:
                w("| whole process, user CPU | 4 levels by error (single thread, wall = CPU) | %.2fx |" % (lu / mo_err))
            w("")
            w("The strictest reading (first row: everything lodpipe does, including reading the file and writing "
              "five OBJ files, against only meshoptimizer's four calls) is the headline.")
            w("")
            w("Peak memory: lodpipe %s bytes (%.1f MB), **%.0f bytes per input triangle** (goal <= 350); "
              "meshopt_peer (same loader, welded mesh, four index buffers) %.0f bytes per input triangle."
              % (n(rss), rss / 1e6, rss / T, max(r["meshopt"]["maxrss"] for r in R) / T))
        else:
            w("lodpipe was not available: no ratio. meshoptimizer's peak RSS (peer process, loader included): "
              "%.0f bytes per input triangle." % (max(r["meshopt"]["maxrss"] for r in R) / T))
        w("")

    shapes_done = (sp or {}).get("shapes")
    if shapes_done:
        w("## 3. Shapes: fans and a flat grid")
        w("")
        w("Inputs from `bench/make_shapes.py`: a disc fanned from its centre, a closed cone (side fanned "
          "from the apex, base from its centre) and a closed cylinder of 4 rows with each cap fanned from its "
          "centre, each centre with 1,000 triangles around it (below the hub limit, 4,096, so lodpipe may "
          "move it); a flat unit square at z = 0 of 300 x 300 cells, where every collapse's quadric cost is "
          "exactly 0. Per kind %d rounds, each lodpipe's whole 1/3/7/15 %% chain (`lodpipe simplify`, one "
          "process, wall clock) then meshopt_peer's four `meshopt_simplify` calls by error; medians. The "
          "last round's lodpipe levels are checked with `hausdorff --within` their certified bound."
          % len(shapes_done[0]["rounds"]))
        w("")
        w("| mesh | triangles | lodpipe, whole process | meshopt, 4 levels | ratio | lodpipe levels | "
          "meshopt levels | levels proven within their bound |")
        w("|---|---:|---:|---:|---:|---|---|---|")
        for it in shapes_done:
            R = it["rounds"]
            mo = med([r["meshopt"]["by_error"] for r in R])
            have = all("lodpipe" in r for r in R)
            lw = med([r["lodpipe"]["wall"] for r in R]) if have else None
            ver = it.get("verify")
            w("| %s | %s | %s | %.4f s | %s | %s | %s | %s |" % (
                it["kind"], n(it["made"]["triangles"]),
                "%.2f s (%s)" % (lw, ", ".join("%.2f" % r["lodpipe"]["wall"] for r in R)) if have else "-",
                mo, "%.0fx" % (lw / mo) if have and mo > 0 else "-",
                "/".join(str(x) for x in R[-1]["lodpipe"]["triangles"]) if have else "-",
                "/".join(str(x) for x in R[-1]["meshopt"]["triangles"]),
                "%d of %d" % (sum(1 for v in ver if v.get("within")), len(ver)) if ver else "not checked"))
        w("")
        w("Not the issue's target (that is the 1.1M chain above): a measure of what lodpipe pays for a "
          "vertex of high valence, whose collapses are certified again after each collapse on the rim "
          "(README, \"Hubs\"), and for a flat part, where equal costs leave the order to the tie rule "
          "(README, \"Flat parts\").")
        w("")

    for f in results.get("failures", []):
        w("**Benchmark failure** (this part has no figures): `%s`" % f.replace("`", "'")[:1500])
        w("")
    w("## Commands")
    w("")
    w("Run from the repository root (one example of each; `…` paths are under `bench/work/`):")
    w("")
    w("```sh")
    for label, cmd in COMMANDS.items():
        w("# %s" % label)
        w(cmd)
    w("```")
    w("")
    w("Raw figures: `bench/work/results.json` (not committed).")
    return "\n".join(L) + "\n"


SECTION_RE = re.compile(r"<!-- section:([a-z]+) -->.*?<!-- /section:\1 -->\n?", re.S)


def write_results(path, text):
    """Writes RESULTS.md, keeping the sections other bench scripts own
    (<!-- section:NAME --> ... <!-- /section:NAME -->, e.g. batch.py's)."""
    kept = []
    if os.path.exists(path):
        with open(path) as f:
            kept = [m.group(0) for m in SECTION_RE.finditer(f.read())]
    with open(path, "w") as f:
        f.write(text)
        for block in kept:
            f.write("\n" + block)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lodpipe", default=os.environ.get("LODPIPE_BIN", os.path.join(ROOT, "build", "lodpipe")))
    ap.add_argument("--hausdorff", default=os.path.join(ROOT, "build", "hausdorff", "hausdorff"))
    ap.add_argument("--shared", default=os.environ.get("LODPIPE_SHARED", os.path.join(os.path.dirname(ROOT), "shared")))
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--skip-quality", action="store_true")
    ap.add_argument("--skip-speed", action="store_true")
    ap.add_argument("--no-verify", action="store_true", help="skip the independent check of lodpipe's levels")
    ap.add_argument("--tol", type=float, default=0.002, help="bisection resolution (relative target count)")
    ap.add_argument("--tol-big", type=float, default=0.005, help="resolution for meshes above --big-threshold")
    ap.add_argument("--big-threshold", type=int, default=100000)
    ap.add_argument("--max-probes", type=int, default=30)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(BENCH, "RESULTS.md"))
    ap.add_argument("--reuse-peer", action="store_true",
                    help="quality: take meshoptimizer's figures (bisections, own-error chain) of each model from "
                         "bench/work/results.json instead of measuring them again; lodpipe's are measured")
    ap.add_argument("--reuse", action="store_true",
                    help="with --skip-quality or --skip-speed: keep that part from bench/work/results.json "
                         "(the previous run), so the two parts can be measured at different times")
    ap.add_argument("--report-only", action="store_true",
                    help="rewrite RESULTS.md from bench/work/results.json without measuring")
    args = ap.parse_args()
    args.lodpipe = os.path.abspath(args.lodpipe)
    if args.report_only:  # re-render RESULTS.md from the last run's figures (no new measurement)
        with open(os.path.join(WORK, "results.json")) as f:
            results = json.load(f)
        COMMANDS.update(results.get("commands", {}))
        write_results(args.out, report(results, args))
        log("rewrote %s from bench/work/results.json" % rel(args.out))
        return
    args.shared = os.path.abspath(args.shared)
    args.peer_results, peer_from = None, None
    if args.reuse_peer:
        with open(os.path.join(WORK, "results.json")) as f:
            previous = json.load(f)
        args.peer_results = {q["model"]: q for q in previous.get("quality", [])}
        # where the reused figures were measured: carried along when they were reused already
        peer_from = previous.get("peer_reused_from") or "the run of %s (commit %s)" % (
            previous["machine"]["date"], previous["machine"]["commit"])
        if "quality" in previous.get("reused", {}) and not previous.get("peer_reused_from"):
            peer_from = "an earlier run (quality part reused by the run of %s)" % previous["machine"]["date"]
        COMMANDS.update({k: v for k, v in previous.get("commands", {}).items() if "meshopt" in k})

    os.makedirs(WORK, exist_ok=True)
    tools = Tools(args)
    for need in (tools.haus,):
        if not os.access(need, os.X_OK):
            sys.exit("bench: %s missing: run `make all hausdorff` first" % rel(need))
    tools.build_peer()
    have_lodpipe = tools.lodpipe_ok()
    for _ in range(12):  # others may be relinking build/lodpipe right now: give it a minute
        if have_lodpipe:
            break
        time.sleep(5)
        have_lodpipe = tools.lodpipe_ok()
    lodpipe_built = None
    if have_lodpipe:
        # Others may rebuild build/lodpipe while this runs: every figure comes from one snapshot.
        lodpipe_built = datetime.datetime.fromtimestamp(os.path.getmtime(args.lodpipe)).strftime("%Y-%m-%d %H:%M:%S")
        snap = os.path.join(WORK, "lodpipe")
        shutil.copy2(args.lodpipe, snap)
        tools.lodpipe = snap
    if not have_lodpipe:
        log("lodpipe simplify is NOT available (%s): meshoptimizer side only" % args.lodpipe)
    results = {"entry": "python3 bench/run.py", "have_lodpipe": have_lodpipe,
               "machine": machine(tools, have_lodpipe), "args": vars(args)}
    results["machine"]["lodpipe_mtime"] = lodpipe_built
    if not args.skip_quality:
        results["quality"] = []
        for m in args.models.split(","):
            if not m:
                continue
            try:
                results["quality"].append(quality(tools, m, args, have_lodpipe))
            except Exception as e:  # keep the other models; the failure goes into RESULTS.md
                log("%s: FAILED: %s" % (m, e))
                results.setdefault("failures", []).append("%s: %s" % (m, e))
    if not args.skip_speed:
        results["speed"] = speed(tools, args, have_lodpipe)
    previous_path = os.path.join(WORK, "results.json")
    if args.reuse and os.path.exists(previous_path):
        with open(previous_path) as f:
            previous = json.load(f)
        for part, skipped in (("quality", args.skip_quality), ("speed", args.skip_speed)):
            if skipped and part in previous:
                results[part] = previous[part]
                if part == "quality" and previous.get("peer_reused_from"):
                    results["peer_reused_from"] = previous["peer_reused_from"]
                # where the part was measured: carried along when the previous run reused it too
                results.setdefault("reused", {})[part] = (previous.get("reused", {}).get(part) or
                                                          previous.get("machine", {}).get("lodpipe_mtime"))
                COMMANDS.update({k: v for k, v in previous.get("commands", {}).items() if k not in COMMANDS})
    if args.reuse_peer and not args.skip_quality:
        results["peer_reused_from"] = peer_from
    results["seconds"] = time.monotonic() - T_START
    results["commands"] = COMMANDS
    with open(os.path.join(WORK, "results.json"), "w") as f:
        json.dump(results, f, indent=1, default=str)
    text = report(results, args)
    write_results(args.out, text)
    log("wrote %s (%.0f s)" % (rel(args.out), results["seconds"]))


if __name__ == "__main__":
    main()
