#!/usr/bin/env python3
"""Writes every table of measured figures in docs/ and README.md from the tools' output.

    tools/docs_figures.py [--check [--expensive]] [--host-sim PATH] [--build-root DIR]
                          [--only NAME,...]

A table lives between two marker lines in the Markdown:

    <!-- figures:NAME -->
    ...generated text...
    <!-- /figures:NAME -->

and NAME is one of the generators below. Without --check the text between the markers is
replaced by what the generator produces now; with --check nothing is written, and every
block whose figures differ is printed as a unified diff with the command that regenerates
it (exit status 1). A generator whose input is missing (no bench.json, no m0plus image) is
skipped with a line saying which and how to make it; --check then checks the rest and says
how many blocks it skipped (exit status 77 when it could check none: ctest's skip).

Generators (every one deterministic for a given build: seeded simulations, exact
instruction counts under QEMU -icount, linked image sizes):
  demo            the demo replay's summary per estimator (host_sim replay, bundled trace)
  demo-head       the demo's head as built, uncalibrated and calibrated (fixture seed 7)
  demo-seeds      the demo's calibrated head over fixture seeds 1-12 (tools/demo_seeds.py)
  fault-campaign  host_sim campaign --seed 1
  bench           instruction counts from build/qemu/bench.json
  images          flash, RAM and worst-case stack of the m4 and m0plus flight images
  calibration-report  the sd on real recordings (tools/calibration_report.py; the same log)
  bench-calibration, bench-calibration-1002, bench-calibration-loose
                  heads calibrated exactly, as stated, off by their sd, and not at all
                  (bench_calibration, seeds 1001-1003)
  drift           long static recordings (tools/drift_report.py --quick; the same log;
                  about 2 minutes: --check runs it only with --expensive)
  bus-bench       the driver's bring-up time and bus load (tests/drivers/drv_bench_bus)
  fixture-calibration
                  the calibration fit over 100 seeds of each fixture scenario
                  (tests/calibrate/measure_fixture.sh; expensive, like drift)
  ramps, ramps-summary
                  the sd row by row on ramps (tests/estimator/test_est_ramps --table)
  bench-steps     step detection delays (bench_estimator --steps --seeds 100)
  ref-tracking, ref-tracking-sweep
                  the Kalman filter against the optimal filter (tests/reference/ref_tracking;
                  the sweep: --sweep 6 15, held-out seeds)
  bench-estimator the estimator benchmark, bench_estimator --seeds 50 (needs the real
                  VL53L0X log beside the repository: docs/reference/scenarios.md)
"""
import argparse
import difflib
import glob
import json
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PY = "/usr/bin/python3"
DEMO_TRACE = os.path.join(ROOT, "traces", "demo", "realnoise_demo.csv")
MARK = re.compile(r"^<!-- figures:([a-z0-9-]+) -->$")
REGENERATE = "tools/docs_figures.py (after cmake --build --preset host-release --target host_sim" \
             "; bench and images: cmake --build --preset qemu --target bench and the m4, m0plus" \
             " presets built)"


class Missing(Exception):
    """A generator's input is not there: the block is skipped, loudly."""


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("docs_figures.py: %s failed (exit %d):\n%s" % (" ".join(cmd), r.returncode,
                                                              r.stderr.strip()))
    return r.stdout


def find_exe(a, name):
    """A program of the host_sim's build tree (build/<preset>/), wherever its CMake folder
    puts it (tests/<component>/, host_sim/...)."""
    tree = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(a.host_sim))))
    for d, subdirs, files in os.walk(tree):
        subdirs[:] = [x for x in subdirs if x != "CMakeFiles"]
        if name in files and os.access(os.path.join(d, name), os.X_OK):
            return os.path.join(d, name)
    raise Missing("%s: not built in %s (cmake --build --preset host-release --target %s)"
                  % (name, tree, name))


def need_host_sim(a):
    if not os.access(a.host_sim, os.X_OK):
        raise Missing("%s: no host_sim (cmake --build --preset host-release --target host_sim)"
                      % a.host_sim)
    return a.host_sim


def summary_rows(report):
    rows = ["| estimator | RMS α ° | max α ° | RMS β ° | max β ° | ok | degraded | invalid |"
            " α err/sd | β err/sd |",
            "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for name in ("consensus", "consensus-paper", "kalman", "mean"):
        e = report["estimators"][name]
        c = e.get("calibration", {})
        rows.append("| `%s` | %.3f | %.3f | %.3f | %.3f | %d | %d | %d | %.2f | %.2f |" % (
            name, e["rms_alpha_deg"], e["max_alpha_deg"], e["rms_beta_deg"], e["max_beta_deg"],
            e["ok"], e["degraded"], e["invalid"],
            c.get("alpha", {}).get("rms_err_over_rms_sd", float("nan")),
            c.get("beta", {}).get("rms_err_over_rms_sd", float("nan"))))
    return rows


def gen_demo(a):
    h = need_host_sim(a)
    with tempfile.TemporaryDirectory() as d:
        rep = os.path.join(d, "r.json")
        run([h, "replay", DEMO_TRACE, "--estimator", "consensus", "--quiet",
             "--out", os.path.join(d, "e.csv"), "--report", rep])
        with open(rep) as f:
            report = json.load(f)
    rows = summary_rows(report)
    rows.append("")
    rows.append("`host_sim replay traces/demo/realnoise_demo.csv --estimator consensus` "
                "(window 100, tumbling; 50 windows). err/sd: RMS error over RMS stated sd.")
    return "\n".join(rows)


def gen_demo_head(a):
    h = need_host_sim(a)
    with tempfile.TemporaryDirectory() as d:
        p = lambda n: os.path.join(d, n)
        run([h, "scenario", "fixture", "--seed", "7", "--trace-out", p("fixture.csv")])
        run([h, "calibrate", p("fixture.csv"), "--out", p("head.cal"), "--report", p("cal.json")])
        run([sys.executable, os.path.join(ROOT, "tools", "head_trace.py"), p("fixture.csv"),
             DEMO_TRACE, p("head.csv"), "--seed", "7"])
        run([h, "replay", p("head.csv"), "--quiet", "--out", p("b.csv"), "--report", p("b.json")])
        run([h, "replay", p("head.csv"), "--quiet", "--calibration", p("head.cal"),
             "--out", p("a.csv"), "--report", p("a.json")])
        out = ["| head | ok / windows | RMS α ° | RMS β ° | α within 3 sd | α beyond 6 sd |"
               " reasons not `ok` (windows) |",
               "| --- | ---: | ---: | ---: | ---: | ---: | --- |"]
        for name, f in (("uncalibrated", "b.json"), ("calibrated", "a.json")):
            with open(p(f)) as fh:
                e = json.load(fh)["estimators"]["consensus"]
            al = e.get("calibration", {}).get("alpha", {})
            reasons = ", ".join("%s %d" % kv for kv in sorted(e.get("reasons", {}).items()))
            out.append("| %s | %d / %d | %.3f | %.3f | %.0f %% | %.0f %% | %s |" % (
                name, e["ok"], e["ok"] + e["degraded"] + e["invalid"], e["rms_alpha_deg"],
                e["rms_beta_deg"], 100 * al.get("within_3sd", float("nan")),
                100 * al.get("beyond_6sd", float("nan")), reasons or "-"))
    out.append("")
    out.append("Consensus estimator, fixture seed 7, dither seed 7 (what `tools/demo.sh` runs).")
    return "\n".join(out)


def gen_demo_seeds(a):
    h = need_host_sim(a)
    with tempfile.TemporaryDirectory() as d:
        j = os.path.join(d, "s.json")
        run([sys.executable, os.path.join(ROOT, "tools", "demo_seeds.py"), "--host-sim", h,
             "--seeds", "1-12", "--json", j])
        with open(j) as f:
            s = json.load(f)
    ex = s["exact"]
    out = ["| head | ok / windows | RMS α ° | RMS β ° | α / exact | β / exact |",
           "| --- | ---: | ---: | ---: | ---: | ---: |",
           "| exactly known | %d / %d | %.3f | %.3f | 1 | 1 |" % (
               ex["ok"], ex["windows"], ex["rms_alpha_deg"], ex["rms_beta_deg"])]
    for r in s["seeds"]:
        out.append("| fixture seed %d, calibrated | %d / %d | %.3f | %.3f | %.3f | %.3f |" % (
            r["seed"], r["ok"], r["windows"], r["rms_alpha_deg"], r["rms_beta_deg"],
            r["alpha_ratio"], r["beta_ratio"]))
    sm = s["summary"]
    out.append("")
    out.append("Median α / exact %.3f, worst %.3f; median β / exact %.3f, worst %.3f "
               "(`tools/demo_seeds.py --seeds 1-12`)." % (
                   sm["alpha_ratio"]["median"], sm["alpha_ratio"]["worst"],
                   sm["beta_ratio"]["median"], sm["beta_ratio"]["worst"]))
    return "\n".join(out)


def gen_fault_campaign(a):
    h = need_host_sim(a)
    with tempfile.TemporaryDirectory() as d:
        md = os.path.join(d, "c.md")
        run([h, "campaign", "--seed", "1", "--markdown", md])
        with open(md) as f:
            return f.read().strip()


def bench_json(a):
    path = os.path.join(a.build_root, "qemu", "bench.json")
    if not os.path.exists(path):
        raise Missing("%s not found (cmake --preset qemu && cmake --build --preset qemu"
                      " --target bench)" % path)
    with open(path) as f:
        return json.load(f)


def gen_bench(a):
    b = bench_json(a)
    cols = []
    for r in b["results"]:
        key = (r["cpu"], r["impl"])
        if key not in cols:
            cols.append(key)
    ops = []
    for r in b["results"]:
        if r["op"] not in ops:
            ops.append(r["op"])
    val = {(r["cpu"], r["impl"], r["op"]): r["insn"] for r in b["results"]}
    out = ["| op | " + " | ".join("%s %s" % c for c in cols) + " |",
           "| --- |" + " ---: |" * len(cols)]
    for op in ops:
        cells = [("{:,}".format(val[(c[0], c[1], op)]).replace(",", " ")
                  if (c[0], c[1], op) in val else "—") for c in cols]
        out.append("| `%s` | %s |" % (op, " | ".join(cells)))
    out.append("")
    out.append("Executed instructions per operation, `cmake --build --preset qemu --target bench`"
               " (build/qemu/bench.json); `fixed` is the project's code, `float` the plain-float"
               " baseline.")
    return "\n".join(out)


def image_figures(elf):
    if not os.path.exists(elf):
        raise Missing("%s not found (build its preset)" % elf)
    size = run(["arm-none-eabi-size", "-B", elf]).splitlines()[1].split()
    text, data, bss = int(size[0]), int(size[1]), int(size[2])
    stack_json = elf[:-4] + ".stack.json"
    if not os.path.exists(stack_json):
        raise Missing("%s not found (written at the image's link)" % stack_json)
    with open(stack_json) as f:
        s = json.load(f)
    return text + data, data + bss, s["stack_bytes_max"]


def gen_images(a):
    images = (("m4", "NUCLEO-L476RG (Cortex-M4F)", "nucleo-l476rg"),
              ("m0plus", "NUCLEO-G071RB (Cortex-M0+)", "nucleo-g071rb"))
    out = ["| preset | board | flash B | RAM B (stack reserve included) | worst-case stack B |",
           "| --- | --- | ---: | ---: | ---: |"]
    for preset, board, folder in images:
        elf = os.path.join(a.build_root, preset, "boards", folder, "firmware-%s.elf" % folder)
        flash, ram, stack = image_figures(elf)
        out.append("| `%s` | %s | %d | %d | %d |" % (preset, board, flash, ram, stack))
    out.append("")
    out.append("Budget: flash ≤ 65 536 B, RAM ≤ 16 384 B. `cmake --build --preset m4 --target size`"
               " (and m0plus); the stack from GCC's call graph (`tools/stack_check.py`).")
    return "\n".join(out)


def gen_bench_estimator(a):
    exe = find_exe(a, "bench_estimator")
    r = subprocess.run([exe, "--seeds", "50"], capture_output=True, text=True)
    if r.returncode == 1 and "real" in r.stderr.lower():
        raise Missing("bench_estimator needs the real VL53L0X log: %s" % r.stderr.strip())
    if r.returncode != 0:
        sys.exit("docs_figures.py: %s --seeds 50 failed (exit %d):\n%s" % (
            exe, r.returncode, r.stderr.strip()))
    out = []
    for line in r.stdout.strip().split("\n"):
        if line.startswith("# "):
            continue  # the program's title: the page has its own
        if line.startswith("## "):
            line = "#" + re.sub(r"\s*\(issue \d+\)", "", line)
        out.append(line)
    while out and not out[0].strip():
        out.pop(0)
    return "\n".join(out)


def real_log():
    shared = os.environ.get("TOF_SHARED_DIR") or os.path.join(os.path.dirname(ROOT), "shared")
    log = os.path.join(shared, "traces", "external", "tomisuarez2_TimeOfFlightCalibration",
                       "static_tof_dist_data_1_h.csv")
    if not os.path.exists(log):
        raise Missing("%s not found: the one-hour VL53L0X log is not in this repository"
                      " (docs/reference/scenarios.md, \"Real noise\")" % log)
    return log


def gen_calibration_report(a):
    log = real_log()
    h = need_host_sim(a)
    with tempfile.TemporaryDirectory() as d:
        # exit status 1 means "a row misses a goal": the table is still the figures
        r = subprocess.run([PY, os.path.join(ROOT, "tools", "calibration_report.py"), h, log, d],
                           capture_output=True, text=True)
    if r.returncode not in (0, 1) or not r.stdout.startswith("|"):
        sys.exit("docs_figures.py: calibration_report.py failed (exit %d):\n%s" % (
            r.returncode, r.stderr.strip()))
    text = r.stdout
    table = []
    for line in text.split("\n"):
        if not line.startswith("|"):
            if table:
                break
            continue
        table.append(line)
    return "\n".join(table)


def bench_calibration(a, args, all_rows_only):
    exe = find_exe(a, "bench_calibration")
    rows = [l for l in run([exe] + args).split("\n") if l.startswith("|")]
    if all_rows_only:
        rows = rows[:2] + [l for l in rows[2:] if l.split("|")[3].strip() == "all"]
    return "\n".join(rows)


def ref_tracking(a, args, first_table_after):
    exe = find_exe(a, "ref_tracking")
    lines = run([exe] + args).split("\n")
    if first_table_after:
        lines = lines[next(i for i, l in enumerate(lines) if first_table_after in l):]
    table = []
    for l in lines:
        if l.startswith("|"):
            table.append(l)
        elif table:
            break
    return "\n".join(table)


def gen_bench_steps(a):
    exe = find_exe(a, "bench_estimator")
    return "\n".join(l for l in run([exe, "--steps", "--seeds", "100"]).split("\n")
                     if l.startswith("|"))


_RAMPS = {}


def ramps_output(a):
    if "text" not in _RAMPS:
        exe = find_exe(a, "test_est_ramps")
        _RAMPS["text"] = run([exe, "--table"])
    return _RAMPS["text"]


def gen_ramps(a):
    out = []
    for line in ramps_output(a).strip().split("\n"):
        if line.endswith(")") and line.split(" (")[0] in ("Tuning set", "Held-out set"):
            line = "**%s**" % line
        out.append(line)
    return "\n".join(out)


def gen_ramps_summary(a):
    """Per set, mode and estimator: the lines missing the goals and the worst figures."""
    groups, order, set_name = {}, [], None
    for line in ramps_output(a).split("\n"):
        if line.startswith("Tuning set"):
            set_name = "tuning"
        elif line.startswith("Held-out set"):
            set_name = "held out"
        if not line.startswith("| ") or line.startswith("| °/s"):
            continue
        c = [x.strip() for x in line.strip("|").split("|")]
        key = (set_name, c[3], c[4])
        if key not in groups:
            groups[key] = []
            order.append(key)
        v = [float(x) for x in c[6:16]]
        groups[key].append(v)
    out = ["| set | mode | estimator | lines missing (strict) | missing (silent) | lowest ≤3sd |"
           " highest >6sd | highest >3sd silent | highest >6sd silent |",
           "| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for key in order:
        rows = groups[key]
        strict = sum(1 for v in rows if min(v[0], v[5]) < 95.0 or max(v[1], v[6]) > 0.1)
        silent = sum(1 for v in rows if max(v[2], v[7]) > 5.0 or max(v[3], v[8]) > 0.1)
        out.append("| %s | %s | %s | %d of %d | %d | %.2f %% | %.3f %% | %.2f %% | %.3f %% |" % (
            key[0], key[1], key[2], strict, len(rows), silent,
            min(min(v[0], v[5]) for v in rows), max(max(v[1], v[6]) for v in rows),
            max(max(v[2], v[7]) for v in rows), max(max(v[3], v[8]) for v in rows)))
    out.append("")
    out.append("Strict: a line with either axis below 95 % within 3 sd or above 0.1 % beyond"
               " 6 sd; silent: above 5 % beyond 3 sd or above 0.1 % beyond 6 sd without `motion`.")
    return "\n".join(out)


def gen_drift(a):
    log = real_log()
    h = need_host_sim(a)
    with tempfile.TemporaryDirectory() as d:
        # exit status 1 means "a row misses a goal": the table is still the figures
        r = subprocess.run([PY, os.path.join(ROOT, "tools", "drift_report.py"), h, log,
                            os.path.join(d, "drift"), "--quick"], capture_output=True, text=True)
    rows = [l for l in r.stdout.split("\n") if l.startswith("|")]
    if r.returncode not in (0, 1) or not rows:
        sys.exit("docs_figures.py: drift_report.py failed (exit %d):\n%s" % (
            r.returncode, r.stderr.strip()))
    return "\n".join(rows)


FIXTURE_ROWS = (
    ("fixture", "`fixture` (σ = 2 mm)"),
    ("fixture-ar1", "`fixture-ar1` (φ = 0.9, τ = 19)"),
    ("fixture-drift", "`fixture-drift` (±0.5 mm over the run)"),
    ("fixture-one-distance", "`fixture-one-distance` (100 mm; offsets only, against offset"
                             " + (gain − 1)·100)"),
    ("fixture-realnoise", "`fixture-realnoise` (the real VL53L0X recording)"),
)


def gen_fixture_calibration(a):
    real_log()  # fixture-realnoise needs it
    h = need_host_sim(a)
    out = ["| scenario | mean stated offset sd | RMS actual offset error | RMS error / sd |"
           " max \\|error\\|/sd | mean gain sd | readings per station the noise alone needs"
           " for 0.05 mm (median) | mean inflation (variance factor) |",
           "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    env = dict(os.environ, H=h)
    for name, label in FIXTURE_ROWS:
        r = subprocess.run(["sh", os.path.join(ROOT, "tests", "calibrate", "measure_fixture.sh"),
                            name, "100"], capture_output=True, text=True, env=env, cwd=ROOT)
        m = re.search(r"mean stated offset sd ([\d.]+) mm, RMS offset error ([\d.]+) mm, RMS z"
                      r" ([\d.]+), max \|z\| ([\d.]+), mean gain sd ([\w.]+), median"
                      r" readings/station for 0.05 mm (\d+), mean inflation ([\d.]+)", r.stdout)
        if r.returncode != 0 or not m:
            sys.exit("docs_figures.py: measure_fixture.sh %s failed (exit %d):\n%s%s" % (
                name, r.returncode, r.stdout, r.stderr))
        g = m.groups()
        gain = "—" if g[4] == "nan" else g[4]
        out.append("| %s | %s mm | %s mm | %s | %s | %s | %s | %s |" % (
            label, g[0], g[1], g[2], g[3], gain, "{:,}".format(int(g[5])), g[6]))
    out.append("")
    out.append("`H=build/host-release/host_sim/app/host_sim tests/calibrate/measure_fixture.sh"
               " NAME 100`: 100 seeds each, 400 fits (every sensor).")
    return "\n".join(out)


# Generators too slow for every ctest run: --check skips them unless --expensive.
EXPENSIVE = {"drift": "about 2 minutes of 4-hour replays",
             "fixture-calibration": "500 fixture runs and fits, a few minutes"}

def gen_bus_bench(a):
    """drv_bench_bus's output as it prints it; where it stops on an error, that error."""
    exe = find_exe(a, "drv_bench_bus")
    r = subprocess.run([exe], capture_output=True, text=True)
    out = [l for l in r.stdout.strip().split("\n") if not l.startswith("# drv_bench_bus")]
    out = [("#" + l) if l.startswith("## ") else l for l in out]
    while out and not out[0].strip():
        out.pop(0)
    if r.returncode != 0:
        out += ["", "**drv_bench_bus stops here** (exit status %d): `%s`" % (
            r.returncode, r.stderr.strip())]
    return "\n".join(out)


GENERATORS = {
    "bus-bench": gen_bus_bench,
    "fixture-calibration": gen_fixture_calibration,
    "drift": gen_drift,
    "ramps": gen_ramps,
    "ramps-summary": gen_ramps_summary,
    "bench-steps": gen_bench_steps,
    "ref-tracking": lambda a: ref_tracking(a, [], "test_at_the_optimum"),
    "ref-tracking-sweep": lambda a: ref_tracking(a, ["--sweep", "6", "15"], None),
    "bench-calibration": lambda a: bench_calibration(a, ["--seed", "1001", "--heads", "2000"],
                                                     False),
    "bench-calibration-1002": lambda a: bench_calibration(
        a, ["--seed", "1002", "--heads", "2000"], True),
    "bench-calibration-loose": lambda a: bench_calibration(
        a, ["--seed", "1003", "--heads", "2000", "--offset-sd-um", "214", "--gain-sd-ppm",
            "1500"], True),
    "calibration-report": gen_calibration_report, "bench-estimator": gen_bench_estimator, "demo": gen_demo, "demo-head": gen_demo_head, "demo-seeds": gen_demo_seeds,
              "fault-campaign": gen_fault_campaign, "bench": gen_bench, "images": gen_images}


def markdown_files():
    files = sorted(glob.glob(os.path.join(ROOT, "docs", "**", "*.md"), recursive=True))
    return files + [os.path.join(ROOT, "README.md")]


def blocks(path):
    """(name, first body line, end line) per marked block; a broken marker is an error."""
    with open(path) as f:
        lines = f.read().split("\n")
    found, open_at, name = [], None, None
    for n, line in enumerate(lines):
        m = MARK.match(line)
        if m:
            if open_at is not None:
                sys.exit("%s:%d: figures:%s opened inside figures:%s" % (
                    path, n + 1, m.group(1), name))
            if m.group(1) not in GENERATORS:
                sys.exit("%s:%d: no generator named '%s' (known: %s)" % (
                    path, n + 1, m.group(1), ", ".join(sorted(GENERATORS))))
            open_at, name = n, m.group(1)
        elif line.startswith("<!-- /figures:"):
            if open_at is None or line != "<!-- /figures:%s -->" % name:
                sys.exit("%s:%d: '%s' closes no open block" % (path, n + 1, line))
            found.append((name, open_at + 1, n))
            open_at = None
    if open_at is not None:
        sys.exit("%s:%d: figures:%s is never closed" % (path, open_at + 1, name))
    return lines, found


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--check", action="store_true",
                    help="write nothing; fail with a diff where the docs differ")
    ap.add_argument("--host-sim", default=os.path.join(ROOT, "build", "host-release", "host_sim",
                                                       "app", "host_sim"),
                    help="the host_sim binary (default: the host-release build's)")
    ap.add_argument("--build-root", default=os.path.join(ROOT, "build"),
                    help="folder holding the presets' builds (default: build/)")
    ap.add_argument("--only", help="comma-separated generator names (default: all)")
    ap.add_argument("--expensive", action="store_true",
                    help="--check: also the slow generators (%s)" % ", ".join(sorted(EXPENSIVE)))
    a = ap.parse_args()
    only = set(a.only.split(",")) if a.only else set(GENERATORS)
    unknown = only - set(GENERATORS)
    if unknown:
        sys.exit("docs_figures.py: --only: unknown %s (known: %s)" % (
            ", ".join(sorted(unknown)), ", ".join(sorted(GENERATORS))))
    cache, checked, skipped, differ = {}, 0, 0, 0
    for path in markdown_files():
        lines, found = blocks(path)
        if not found:
            continue
        rel = os.path.relpath(path, ROOT)
        for name, first, end in reversed(found):
            if name not in only:
                continue
            if a.check and name in EXPENSIVE and not a.expensive:
                print("SKIPPED figures:%s in %s: expensive (%s); check it with"
                      " tools/docs_figures.py --check --expensive --only %s" % (
                          name, rel, EXPENSIVE[name], name))
                skipped += 1
                continue
            if name not in cache:
                try:
                    cache[name] = GENERATORS[name](a)
                except Missing as e:
                    cache[name] = e
            text = cache[name]
            if isinstance(text, Missing):
                print("SKIPPED figures:%s in %s: %s" % (name, rel, text))
                skipped += 1
                continue
            new = text.split("\n")
            old = lines[first:end]
            checked += 1
            if old != new:
                differ += 1
                if a.check:
                    sys.stdout.writelines(difflib.unified_diff(
                        [l + "\n" for l in old], [l + "\n" for l in new],
                        "%s (figures:%s, committed)" % (rel, name),
                        "%s (figures:%s, what the code gives)" % (rel, name)))
                lines[first:end] = new
        if not a.check:
            with open(path, "w") as f:
                f.write("\n".join(lines))
    if a.check:
        print("docs_figures: %d block(s) checked, %d differ, %d skipped" % (
            checked, differ, skipped))
        if differ:
            print("regenerate with: " + REGENERATE)
            sys.exit(1)
        if checked == 0:
            sys.exit(77)
    else:
        print("docs_figures: %d block(s) written (%d changed), %d skipped" % (
            checked, differ, skipped))


if __name__ == "__main__":
    main()
