#!/usr/bin/python3
"""Long static four-sensor traces for the drift allowance, from a real log.

Each sensor's noise is the real one-column log (e.g. the one-hour VL53L0X log of
tomisuarez2/TimeOfFlightCalibration in ../shared/traces/external), minus its mean, cut and
joined differently from how tools/real_traces.py cuts it (four disjoint quarters):
  * sensor k starts at k/4 of the log (or of the stretch given by --from/--to) and runs on
    circularly, so the four sensors are four phases of one part;
  * past the stretch's end it runs on through the stretch reversed, then forward again
    (no jump at a join: the wander continues as a mirrored path), so hours and a day can be
    built from one hour;
  * --warmup MM:TAU adds to sensor A a warm-up MM·exp(−t/TAU s) less its mean over the
    trace (a part calibrated on the whole recording's mean, as tools/real_traces.py does):
    the first half hour of the longer log of the same setup falls by about 2–3 mm;
  * --walk F adds to each sensor an independent Gaussian random walk starting at 0 (the head
    calibrated at the start) with rate F times offset_walk_um2_h (the estimator's prior,
    µm²/h), one step per row.
The plate is static at alpha = 1.5 deg, beta = -2 deg, x = 100 mm, a = 30 mm; readings are
rounded to whole mm after a uniform ±0.5 mm dither, as tools/real_traces.py does.

Usage: drift_traces.py LOG.csv OUT.csv --hours H [--from S] [--to S] [--walk F]
       [--rate UM2_H] [--seed N] [--period-ms P] [--warmup MM:TAU]
  --from/--to  seconds of the log used (its own clock: 3,600 s over its readings)
"""
import math
import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from real_traces import load  # noqa: E402  the one reader of a one-column log (errors named)

ARM_MM = 30.0
MEAN_MM = 100.0
ALPHA_DEG = 1.5
BETA_DEG = -2.0
RATE_UM2_H = 576000.0  # ATTITUDE_OFFSET_WALK_UM2_H_DEFAULT


def fail(msg):
    print(f"drift_traces: {msg}", file=sys.stderr)
    sys.exit(2)


def option(args, name, default, kind=float):
    if name in args:
        k = args.index(name)
        value = kind(args[k + 1])
        del args[k:k + 2]
        return value
    return default


def mirrored(seg, i):
    """The i-th reading of seg run forward, backward, forward, ..."""
    n = len(seg)
    lap, j = divmod(i, n)
    return seg[j] if lap % 2 == 0 else seg[n - 1 - j]


def main(argv):
    args = list(argv[1:])
    hours = option(args, "--hours", None)
    t0 = option(args, "--from", 0.0)
    t1 = option(args, "--to", None)
    walk = option(args, "--walk", 0.0)
    rate = option(args, "--rate", RATE_UM2_H)
    seed = option(args, "--seed", 23, int)
    period_ms = option(args, "--period-ms", 20, int)
    warmup = option(args, "--warmup", None, str)
    if len(args) != 2 or hours is None:
        fail("usage: drift_traces.py LOG.csv OUT.csv --hours H [--from S] [--to S] [--walk F] "
             "[--rate UM2_H] [--seed N] [--period-ms P]")
    log = load(args[0])
    per_s = len(log) / 3600.0
    lo = int(t0 * per_s)
    hi = len(log) if t1 is None else int(t1 * per_s)
    seg = log[lo:hi]
    if len(seg) < 1000:
        fail("the stretch holds fewer than 1000 readings")
    m = sum(seg) / len(seg)
    seg = [v - m for v in seg]
    rows = int(hours * 3600000 / period_ms)
    rng = random.Random(seed)
    # per-row walk step: rate um^2/h -> mm^2 per row
    step = math.sqrt(walk * rate * 1e-6 * period_ms / 3600000.0)
    ta, tb = math.tan(math.radians(ALPHA_DEG)), math.tan(math.radians(BETA_DEG))
    ideal = (MEAN_MM - ARM_MM * ta, MEAN_MM + ARM_MM * tb, MEAN_MM + ARM_MM * ta,
             MEAN_MM - ARM_MM * tb)
    shift = [k * len(seg) // 4 for k in range(4)]
    warm_mm, warm_tau = (float(v) for v in warmup.split(":")) if warmup else (0.0, 1.0)
    span_s = rows * period_ms / 1000.0
    warm_mean = warm_mm * warm_tau / span_s * (1.0 - math.exp(-span_s / warm_tau))
    w = [0.0] * 4
    os.makedirs(os.path.dirname(os.path.abspath(args[1])), exist_ok=True)
    with open(args[1], "w") as f:
        f.write("# tof-trace v1\n")
        f.write(f"# arm_mm={ARM_MM:.1f}\n# period_ms={period_ms}\n")
        # each stretch is centred on its own mean and added to the ideal distances: the
        # head is known exactly (docs/reference/trace-format.md), so the trace says so (else: uncalibrated)
        f.write("# offset_mm=0,0,0,0\n# offset_sd_mm=0,0,0,0\n# gain=1,1,1,1\n# gain_sd=0,0,0,0\n")
        f.write(f"# source={os.path.basename(args[0])} s {t0:.0f}..{hi / per_s:.0f} "
                f"walk {walk}x{rate:.0f} um2/h (tools/drift_traces.py)\n")
        f.write("t_ms,a_mm,b_mm,c_mm,d_mm,a_st,b_st,c_st,d_st,alpha_deg,beta_deg\n")
        for i in range(rows):
            r = []
            for k in range(4):
                if step > 0.0:
                    w[k] += rng.gauss(0.0, step)
                x = ideal[k] + mirrored(seg, i + shift[k]) + w[k] + rng.uniform(-0.5, 0.5)
                if k == 0 and warm_mm != 0.0:
                    x += warm_mm * math.exp(-i * period_ms / 1000.0 / warm_tau) - warm_mean
                r.append(int(math.floor(x + 0.5)))
            f.write(f"{i * period_ms},{r[0]},{r[1]},{r[2]},{r[3]},0,0,0,0,"
                    f"{ALPHA_DEG:.6f},{BETA_DEG:.6f}\n")
    print(f"trace written: {args[1]} ({rows} rows)")


if __name__ == "__main__":
    main(sys.argv)
