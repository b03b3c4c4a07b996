#!/usr/bin/python3
"""Pose error against range, 0.3 m to 15 m: runs `host_sim_camera` (the `host_sim
camera` command) at each range, prints a Markdown table and writes a plot.

    /usr/bin/python3 host_sim/camera/pose_range_sweep.py \
        --exe build/pose-rel/host_sim/camera/host_sim_camera \
        --frames 200 --out-dir build/pose-rel/sweep --plot docs/pose_range.png

Two scenarios per range: the goal conditions (range noise 1 %, gray
noise 2 %, 2 spurious blobs, 1 hidden marker) and a noise-free reference.
Ranges under 650 mm cannot keep every marker of this target in view at every
drawn attitude, so they run with --allow-partial (markers may leave the image).
Needs python3-matplotlib: use /usr/bin/python3, not a pyenv python.
"""
import argparse
import json
import os
import subprocess
import sys

RANGES_MM = [300, 400, 500, 600, 700, 1000, 1500, 2000, 3000, 4000, 5000, 7500, 10000, 12500,
             15000]
SCENARIOS = {
    "goal": dict(spurious=2, missing=1, depth=0.01, gray=0.02),
    "noise-free": dict(spurious=0, missing=0, depth=0.0, gray=0.0),
}
PARTIAL_BELOW_MM = 650
REUSE = False


def run(exe, out_dir, name, rng, sc, frames, seed):
    report = os.path.join(out_dir, f"{name}_{rng}.json")
    cmd = [exe, "--frames", str(frames), "--range-mm", str(rng), "--spurious",
           str(sc["spurious"]), "--missing", str(sc["missing"]), "--depth-noise",
           str(sc["depth"]), "--gray-noise", str(sc["gray"]), "--seed", str(seed),
           "--report", report]
    if rng < PARTIAL_BELOW_MM:
        cmd.append("--allow-partial")
    if not (REUSE and os.path.exists(report)):
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    with open(report) as f:
        return json.load(f)


def fmt(x, digits):
    return "–" if x is None or x < 0 else f"{x:.{digits}f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--exe", required=True, help="host_sim_camera executable")
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out-dir", required=True, help="directory for the per-range JSON reports")
    ap.add_argument("--plot", required=True, help="PNG to write")
    ap.add_argument("--reuse", action="store_true",
                    help="reuse reports already in --out-dir (re-plot without re-running)")
    args = ap.parse_args()
    global REUSE
    REUSE = args.reuse
    if not os.access(args.exe, os.X_OK):
        sys.exit(f"pose_range_sweep: --exe {args.exe}: not an executable file")
    os.makedirs(args.out_dir, exist_ok=True)

    results = {name: [] for name in SCENARIOS}
    for name, sc in SCENARIOS.items():
        for rng in RANGES_MM:
            results[name].append(run(args.exe, args.out_dir, name, rng, sc, args.frames,
                                     args.seed))
            print(f"  {name} {rng} mm done", file=sys.stderr)

    print("| range (m) | view | valid | OK | correct | rot RMS valid (deg) | rot RMS OK (deg) "
          "| pos RMS valid (mm) | pos RMS OK (mm) | centroid RMS (px) | markers seen "
          "| rot RMS noise-free | pos RMS noise-free |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for g, z in zip(results["goal"], results["noise-free"]):
        view = "partial" if g["allow_partial"] else "all"
        print(f"| {g['range_mm'] / 1000:g} | {view} | {fmt(g['valid_rate'], 3)} "
              f"| {fmt(g['ok_rate'], 3)} | {fmt(g['match_rate'], 3)} "
              f"| {fmt(g['rot_err_deg_rms'], 3)} | {fmt(g['rot_err_deg_rms_ok'], 3)} "
              f"| {fmt(g['pos_err_mm_rms'], 2)} | {fmt(g['pos_err_mm_rms_ok'], 2)} "
              f"| {fmt(g['centroid_err_px_rms'], 3)} | {fmt(g['markers_detected_mean'], 1)} "
              f"| {fmt(z['rot_err_deg_rms'], 3)} | {fmt(z['pos_err_mm_rms'], 2)} |")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 2, figsize=(11, 8), sharex=True)
    for name, style in (("goal", "o-"), ("noise-free", "s--")):
        rs = [r["range_mm"] / 1000 for r in results[name]]

        def col(key):
            return [r[key] if r[key] >= 0 else float("nan") for r in results[name]]

        ax[0, 0].plot(rs, col("rot_err_deg_rms"), style, label=f"{name}: valid frames")
        ax[0, 0].plot(rs, col("rot_err_deg_rms_ok"), style, alpha=0.5, label=f"{name}: OK frames")
        ax[0, 1].plot(rs, col("pos_err_mm_rms"), style, label=f"{name}: valid frames")
        ax[0, 1].plot(rs, col("pos_err_mm_rms_ok"), style, alpha=0.5, label=f"{name}: OK frames")
        ax[1, 0].plot(rs, col("match_rate"), style, label=f"{name}: correct matches")
        ax[1, 0].plot(rs, col("valid_rate"), style, alpha=0.4, label=f"{name}: valid pose")
        ax[1, 1].plot(rs, col("centroid_err_px_rms"), style, label=name)
    ax[0, 0].axhline(0.08, color="gray", lw=0.8, ls=":", label="goal at 0.7 m")
    ax[0, 1].axhline(1.5, color="gray", lw=0.8, ls=":", label="goal at 0.7 m")
    ax[1, 1].axhline(0.06, color="gray", lw=0.8, ls=":", label="goal (noise-free)")
    ax[0, 0].set(ylabel="rotation error RMS (deg)", yscale="log", title="Rotation")
    ax[0, 1].set(ylabel="position error RMS (mm)", yscale="log", title="Position")
    ax[1, 0].set(ylabel="fraction of frames", ylim=(0, 1.05), title="Frames")
    ax[1, 1].set(ylabel="marker image error RMS (px)", yscale="log", title="Centroids")
    ticks = [0.3, 0.5, 0.7, 1, 2, 3, 5, 7.5, 10, 15]
    for a in ax.flat:
        a.set_xscale("log")
        a.set_xticks(ticks)
        a.set_xticklabels([f"{t:g}" for t in ticks])
        a.grid(True, which="both", alpha=0.3)
        a.legend(fontsize=7)
    for a in ax[1]:
        a.set_xlabel("range to target (m)")
    fig.suptitle(f"Synthetic EPC660-class camera, paper target, {args.frames} frames per "
                 f"range; < {PARTIAL_BELOW_MM / 1000} m: markers may leave the view")
    fig.tight_layout()
    fig.savefig(args.plot, dpi=110)
    print(f"wrote {args.plot}", file=sys.stderr)


if __name__ == "__main__":
    main()
