#!/usr/bin/env python3
"""The demo's calibrated head over many fixture seeds, against an exactly known head.

    tools/demo_seeds.py [--host-sim PATH] [--seeds FIRST-LAST] [--json OUT.json]
                        [--max-ratio R]

For each seed S: `host_sim scenario fixture --seed S` builds a head with random offsets and
gains and records it in the simulated fixture, `host_sim calibrate` fits it, and
`tools/head_trace.py ... --seed S` maps the demo recording (traces/demo/realnoise_demo.csv)
through that head; the consensus estimator then replays it with the fitted calibration.
The reference is the same recording replayed with its exactly known head (offset 0,
gain 1). Prints one row per seed and the median and worst ratio of RMS errors
(calibrated / exact) for α and β; --json writes the same figures. Every step is seeded,
so the output is the same on every run of the same build. Exit status 1 if a tool fails,
or with --max-ratio R if any seed's α or β ratio exceeds R (the goal is 1.10).
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RECORDING = os.path.join(ROOT, "traces", "demo", "realnoise_demo.csv")


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("demo_seeds.py: %s failed (exit %d):\n%s" % (" ".join(cmd), r.returncode,
                                                             r.stderr.strip()))


def consensus(report_path):
    with open(report_path) as f:
        e = json.load(f)["estimators"]["consensus"]
    n = e["ok"] + e["degraded"] + e["invalid"]
    return {"ok": e["ok"], "windows": n, "rms_alpha_deg": e["rms_alpha_deg"],
            "rms_beta_deg": e["rms_beta_deg"]}


def seed_range(text):
    try:
        first, last = (int(x) for x in text.split("-"))
    except ValueError:
        raise argparse.ArgumentTypeError("'%s' is not FIRST-LAST (e.g. 1-12)" % text)
    if first < 1 or last < first:
        raise argparse.ArgumentTypeError("'%s': need 1 <= FIRST <= LAST" % text)
    return list(range(first, last + 1))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--host-sim", default=os.path.join(ROOT, "build", "host-release",
                                                       "host_sim", "app", "host_sim"),
                    help="the host_sim binary (default: the host-release build's)")
    ap.add_argument("--seeds", type=seed_range, default=seed_range("1-12"),
                    help="fixture seeds FIRST-LAST (default 1-12)")
    ap.add_argument("--json", help="write the figures to this file")
    ap.add_argument("--max-ratio", type=float,
                    help="exit status 1 if any seed's ratio to the exact head exceeds this")
    a = ap.parse_args()
    if not os.access(a.host_sim, os.X_OK):
        sys.exit("demo_seeds.py: %s: no host_sim binary (cmake --build --preset host-release"
                 " --target host_sim)" % a.host_sim)
    h = a.host_sim
    rows = []
    with tempfile.TemporaryDirectory() as d:
        p = lambda name: os.path.join(d, name)
        run([h, "replay", RECORDING, "--estimator", "consensus", "--quiet",
             "--out", p("exact.est.csv"), "--report", p("exact.json")])
        exact = consensus(p("exact.json"))
        for s in a.seeds:
            run([h, "scenario", "fixture", "--seed", str(s), "--trace-out", p("fixture.csv")])
            run([h, "calibrate", p("fixture.csv"), "--out", p("head.cal"),
                 "--report", p("head.cal.json")])
            run([sys.executable, os.path.join(ROOT, "tools", "head_trace.py"), p("fixture.csv"),
                 RECORDING, p("head.csv"), "--seed", str(s)])
            run([h, "replay", p("head.csv"), "--estimator", "consensus", "--quiet",
                 "--calibration", p("head.cal"), "--out", p("after.est.csv"),
                 "--report", p("after.json")])
            c = consensus(p("after.json"))
            c["seed"] = s
            c["alpha_ratio"] = c["rms_alpha_deg"] / exact["rms_alpha_deg"]
            c["beta_ratio"] = c["rms_beta_deg"] / exact["rms_beta_deg"]
            rows.append(c)
    summary = {}
    for k in ("alpha_ratio", "beta_ratio", "rms_alpha_deg", "rms_beta_deg"):
        v = [r[k] for r in rows]
        summary[k] = {"median": statistics.median(v), "worst": max(v)}
    out = {"exact": exact, "seeds": rows, "summary": summary}
    print("exactly known head: RMS α %.3f°  RMS β %.3f°  ok %d/%d" % (
        exact["rms_alpha_deg"], exact["rms_beta_deg"], exact["ok"], exact["windows"]))
    print("seed  ok/all   RMS α°  RMS β°  α ratio  β ratio")
    for r in rows:
        print("%4d  %3d/%-3d  %6.3f  %6.3f  %7.3f  %7.3f" % (
            r["seed"], r["ok"], r["windows"], r["rms_alpha_deg"], r["rms_beta_deg"],
            r["alpha_ratio"], r["beta_ratio"]))
    print("median α ratio %.3f, worst %.3f; median β ratio %.3f, worst %.3f" % (
        summary["alpha_ratio"]["median"], summary["alpha_ratio"]["worst"],
        summary["beta_ratio"]["median"], summary["beta_ratio"]["worst"]))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=1, sort_keys=True)
            f.write("\n")
    if a.max_ratio is not None:
        over = ["seed %d: α %.3f, β %.3f" % (r["seed"], r["alpha_ratio"], r["beta_ratio"])
                for r in rows if max(r["alpha_ratio"], r["beta_ratio"]) > a.max_ratio]
        if over:
            sys.exit("demo_seeds.py: calibrated head beyond %.2f × the exact one: %s" % (
                a.max_ratio, "; ".join(over)))
        print("every seed within %.2f × the exactly known head" % a.max_ratio)


if __name__ == "__main__":
    main()
