#!/usr/bin/env python3
"""The demo's before/after table of a head's calibration (tools/demo.sh).

    tools/head_table.py FIXTURE.csv HEAD.cal BEFORE.report.json AFTER.report.json

Prints what the simulated head truly is (FIXTURE.csv's sim_ keys), what `host_sim calibrate`
fitted (HEAD.cal) with the error in units of its stated sd, and the consensus estimator's
figures on the same recording replayed uncalibrated and with the calibration.
"""
import json
import sys


def keys(path):
    out = {}
    with open(path) as f:
        for line in f:
            if line.startswith("#") and "=" in line:
                k, v = line[1:].strip().split("=", 1)
                out[k] = v
            elif not line.startswith("#"):
                break
    return out


def four(s):
    return [float(x) for x in s.split(",")]


def row(name, rep):
    e = rep["estimators"]["consensus"]
    c = e.get("calibration", {})
    a, b = c.get("alpha", {}), c.get("beta", {})
    n = e["ok"] + e["degraded"] + e["invalid"]
    reasons = ", ".join("%s %d" % kv for kv in sorted(e.get("reasons", {}).items()))
    print("%-13s %3d/%-3d %8.3f %8.3f %7.1f %7.2f %7.1f %7.2f  %s" % (
        name, e["ok"], n, e["rms_alpha_deg"], e["rms_beta_deg"],
        100 * a.get("within_3sd", float("nan")), 100 * a.get("beyond_6sd", float("nan")),
        100 * b.get("within_3sd", float("nan")), 100 * b.get("beyond_6sd", float("nan")),
        reasons or "-"))


def main():
    if len(sys.argv) != 5:
        sys.exit("usage: head_table.py FIXTURE.csv HEAD.cal BEFORE.report.json AFTER.report.json")
    truth, cal = keys(sys.argv[1]), keys(sys.argv[2])
    t_off, t_gain = four(truth["sim_offset_mm"]), four(truth["sim_gain"])
    c_off, c_osd = four(cal["offset_mm"]), four(cal["offset_sd_mm"])
    c_gain = four(cal["gain"]) if "gain" in cal else [1.0] * 4
    c_gsd = four(cal["gain_sd"]) if "gain_sd" in cal else [float("nan")] * 4
    print("sensor  offset true / fitted (mm)   err/sd   gain true / fitted       err/sd")
    for k, s in enumerate("ABCD"):
        print("  %s    %9.3f / %9.3f  %7.2f   %.6f / %.6f  %7.2f" % (
            s, t_off[k], c_off[k], (c_off[k] - t_off[k]) / c_osd[k], t_gain[k], c_gain[k],
            (c_gain[k] - t_gain[k]) / c_gsd[k]))
    print()
    print("consensus on the recording through this head (window 100, tumbling):")
    print("head           ok/all   RMS α°   RMS β°  α≤3sd%  α>6sd%  β≤3sd%  β>6sd%  why")
    row("uncalibrated", json.load(open(sys.argv[3])))
    row("calibrated", json.load(open(sys.argv[4])))


if __name__ == "__main__":
    main()
