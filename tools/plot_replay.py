#!/usr/bin/python3
"""Plot a host_sim replay like Fig. 5 / Fig. 7 of the first paper.

Input: the long-format CSV host_sim writes next to the figure
(t_ms,estimator,alpha_deg,beta_deg,distance_mm,status,true_alpha_deg,true_beta_deg,
alpha_sd_deg,beta_sd_deg; columns found by name, the sd ones optional), one row per
estimate per estimator. Output: a PNG with alpha and beta estimates and truth against
time (top), and their errors (bottom), one line per estimator, each with a shaded band
of ±2 sd (the estimate's own standard deviation) where the file has it.

Usage: plot_replay.py DATA.csv FIG.png [--title TEXT]
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def fail(msg):
    print(f"plot_replay: {msg}", file=sys.stderr)
    sys.exit(2)


def parse_float(text):
    return float(text) if text not in ("", None) else None


def load(path):
    series = {}
    truth = {}
    try:
        with open(path, newline="") as f:
            reader = csv.DictReader(f)
            need = {"t_ms", "estimator", "alpha_deg", "beta_deg", "status",
                    "true_alpha_deg", "true_beta_deg"}
            missing = need - set(reader.fieldnames or [])
            if missing:
                fail(f"{path}:1: missing columns {sorted(missing)}")
            for line, row in enumerate(reader, start=2):
                try:
                    t = int(row["t_ms"]) / 1000.0
                    a = parse_float(row["alpha_deg"])
                    b = parse_float(row["beta_deg"])
                    ta = parse_float(row["true_alpha_deg"])
                    tb = parse_float(row["true_beta_deg"])
                except ValueError as e:
                    fail(f"{path}:{line}: {e}")
                try:
                    sa = parse_float(row.get("alpha_sd_deg"))
                    sb = parse_float(row.get("beta_sd_deg"))
                except ValueError as e:
                    fail(f"{path}:{line}: {e}")
                s = series.setdefault(row["estimator"],
                                      {"t": [], "a": [], "b": [], "sa": [], "sb": []})
                s["t"].append(t)
                s["a"].append(a)
                s["b"].append(b)
                s["sa"].append(sa)
                s["sb"].append(sb)
                if ta is not None or tb is not None:
                    truth[t] = (ta, tb)
    except OSError as e:
        fail(str(e))
    return series, truth


def main(argv):
    if len(argv) < 3:
        fail("usage: plot_replay.py DATA.csv FIG.png [--title TEXT]")
    data, out = argv[1], argv[2]
    title = argv[argv.index("--title") + 1] if "--title" in argv else "host_sim replay"
    series, truth = load(data)
    if not series:
        fail(f"{data}: no estimates to plot")
    fig, axes = plt.subplots(2, 2, figsize=(13, 7.5), sharex=True)
    for col, (key, tkey, name) in enumerate((("a", 0, "α"), ("b", 1, "β"))):
        top, bottom = axes[0][col], axes[1][col]
        if truth:
            tt = sorted(truth)
            top.plot(tt, [truth[t][tkey] for t in tt], "k-", lw=2.0, label="truth", zorder=1)
        for est, s in series.items():
            pts = [(t, v, sd) for t, v, sd in zip(s["t"], s[key], s["s" + key])
                   if v is not None]
            if not pts:
                continue
            line, = top.plot([p[0] for p in pts], [p[1] for p in pts], ".-", ms=3, lw=0.8,
                             label=est)
            band = [p for p in pts if p[2] is not None]
            if band:  # ±2 sd around the estimate
                top.fill_between([p[0] for p in band], [p[1] - 2 * p[2] for p in band],
                                 [p[1] + 2 * p[2] for p in band], color=line.get_color(),
                                 alpha=0.15, lw=0)
            if truth:
                errs = [(t, v - truth[t][tkey], sd) for t, v, sd in pts
                        if t in truth and truth[t][tkey] is not None]
                bottom.plot([e[0] for e in errs], [e[1] for e in errs], ".-", ms=3, lw=0.8,
                            label=est, color=line.get_color())
                eband = [e for e in errs if e[2] is not None]
                if eband:  # the error should stay inside its ±2 sd band about 95 % of the time
                    bottom.fill_between([e[0] for e in eband], [e[1] - 2 * e[2] for e in eband],
                                        [e[1] + 2 * e[2] for e in eband],
                                        color=line.get_color(), alpha=0.15, lw=0)
        top.set_ylabel(f"{name} [deg]")
        top.grid(True, alpha=0.3)
        bottom.set_ylabel(f"{name} error [deg] (band: ±2 sd)")
        bottom.set_xlabel("time [s]")
        bottom.grid(True, alpha=0.3)
        bottom.axhline(0.0, color="k", lw=0.5)
    axes[0][0].legend(fontsize=8, loc="best")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"plot written: {out}")


if __name__ == "__main__":
    main(sys.argv)
