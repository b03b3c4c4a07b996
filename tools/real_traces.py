#!/usr/bin/python3
"""Build four-sensor traces with known truth from a real single-sensor VL53 log.

The noise is real: a static sensor's recording (one reading per line, e.g. the
tomisuarez2/TimeOfFlightCalibration VL53L0X log in ../shared/traces/external) is split
into four disjoint consecutive blocks, one per sensor A..D; each block minus its own mean
(the sensor's offset calibration) is added to the ideal distances of docs/explanation/architecture.md for a
known attitude schedule, with a uniform ±0.5 mm dither, and rounded to whole millimetres
as the parts report them. The slow drift, the distribution and the autocorrelation of
each block are the recording's; only the four sensors being one sensor at four times is
not real. Nothing from the source is bundled: the traces are written where asked.

Schedules (20 ms rows, a = 30 mm, x̄ = 100 mm):
  static   the paper's protocol: a new attitude (uniform ±5°) every 5 windows of 100
           rows, changed exactly at a window boundary (tumbling windows see no motion)
  moving   smooth motion: α = 3°·sin(2πt/60 s), β = 2°·sin(2πt/45 s + 1)

Usage: real_traces.py LOG.csv OUTDIR [--rows N] [--seed S]
Writes OUTDIR/real_static.csv and OUTDIR/real_moving.csv (trace v1, docs/reference/trace-format.md).
"""
import math
import os
import random
import sys

ARM_MM = 30.0
MEAN_MM = 100.0
PERIOD_MS = 20


def fail(msg):
    print(f"real_traces: {msg}", file=sys.stderr)
    sys.exit(2)


def load(path):
    """The readings of a one-column log; header lines (not numbers) are skipped."""
    values = []
    try:
        with open(path, encoding="utf-8-sig") as f:
            for line_no, line in enumerate(f, start=1):
                text = line.strip()
                if not text:
                    continue
                try:
                    values.append(float(text))
                except ValueError:
                    if values:
                        fail(f"{path}:{line_no}: '{text}' is not a reading")
    except OSError as e:
        fail(str(e))
    return values


def schedules(rows, seed):
    rng = random.Random(seed)
    static = []
    a = b = 0.0
    for i in range(rows):
        if i % 500 == 0:
            a, b = rng.uniform(-5, 5), rng.uniform(-5, 5)
        static.append((a, b))
    moving = []
    for i in range(rows):
        t = i * PERIOD_MS / 1000.0
        moving.append((3.0 * math.sin(2 * math.pi * t / 60.0),
                       2.0 * math.sin(2 * math.pi * t / 45.0 + 1.0)))
    return {"static": static, "moving": moving}


def write(path, source, noise, truth, seed):
    rng = random.Random(seed)
    with open(path, "w") as f:
        f.write("# tof-trace v1\n")
        f.write(f"# arm_mm={ARM_MM:.1f}\n# period_ms={PERIOD_MS}\n")
        # each stretch is centred on its own mean and added to the ideal distances: the
        # head is known exactly (docs/reference/trace-format.md), so the trace says so (else: uncalibrated)
        f.write("# offset_mm=0,0,0,0\n# offset_sd_mm=0,0,0,0\n# gain=1,1,1,1\n# gain_sd=0,0,0,0\n")
        f.write(f"# source=real noise of {os.path.basename(source)} (tools/real_traces.py)\n")
        f.write("t_ms,a_mm,b_mm,c_mm,d_mm,a_st,b_st,c_st,d_st,alpha_deg,beta_deg\n")
        for i, (a, b) in enumerate(truth):
            ta, tb = math.tan(math.radians(a)), math.tan(math.radians(b))
            ideal = (MEAN_MM - ARM_MM * ta, MEAN_MM + ARM_MM * tb,
                     MEAN_MM + ARM_MM * ta, MEAN_MM - ARM_MM * tb)
            r = [int(math.floor(ideal[k] + noise[k][i] + rng.uniform(-0.5, 0.5) + 0.5))
                 for k in range(4)]
            f.write(f"{i * PERIOD_MS},{r[0]},{r[1]},{r[2]},{r[3]},0,0,0,0,{a:.6f},{b:.6f}\n")


def main(argv):
    args = [a for a in argv[1:]]
    rows = None
    seed = 15
    if "--rows" in args:
        k = args.index("--rows")
        rows = int(args[k + 1])
        del args[k:k + 2]
    if "--seed" in args:
        k = args.index("--seed")
        seed = int(args[k + 1])
        del args[k:k + 2]
    if len(args) != 2:
        fail("usage: real_traces.py LOG.csv OUTDIR [--rows N] [--seed S]")
    values = load(args[0])
    block = len(values) // 4
    if rows is None:
        rows = block
    if rows < 100 or rows > block:
        fail(f"{args[0]}: {len(values)} readings give four blocks of {block}; "
             f"--rows must be 100..{block}")
    noise = []
    for k in range(4):
        seg = values[k * block:k * block + rows]
        m = sum(seg) / len(seg)
        noise.append([v - m for v in seg])
    os.makedirs(args[1], exist_ok=True)
    for name, truth in schedules(rows, seed).items():
        path = os.path.join(args[1], f"real_{name}.csv")
        write(path, args[0], noise, truth, seed)
        print(f"trace written: {path} ({rows} rows)")


if __name__ == "__main__":
    main(sys.argv)
