#!/usr/bin/python3
"""The drift model of docs/explanation/estimators.md "Drift since the start", measured.

Reads a one-column static log (e.g. ../shared/traces/external/tomisuarez2_TimeOfFlightCalibration/
static_tof_dist_data_1_h.csv: one VL53L0X, 200,244 readings over 3,600 s) and prints
  * the overlapping Allan deviation of block means for tau from about 1 s to 30 min, beside
    the white-noise prediction sigma/sqrt(m);
  * the structure function of 2 s block means, S(L) = E[(m(t+L) - m(t))^2] - 2 s^2/m: the
    offset change of a window L after another, beyond white noise;
  * the random-walk rate q (mm^2/s) of the Allan variance's slope, sigma_A^2 = h + q tau/3:
    between its ends tau = 36 s and 15 min (the default offset_walk_um2_h), and by least
    squares over log-spaced tau = 36 s .. 15 min (white noise is under 5 % of sigma_A^2 there,
    and the longest tau still has 40 overlapping pairs) and its value in um^2/h, the
    estimator's offset_walk_um2_h;
  * with --split S: the same fit on the first S seconds only, and the structure function of
    the rest against the model, so a rate learnt on one part is checked on another.
Pure Python (no numpy): prefix sums, O(n) per tau.

Usage: drift_allan.py LOG.csv [--duration SECONDS] [--split SECONDS]
"""
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from real_traces import load  # noqa: E402  the one reader of a one-column log


def fail(msg):
    print(f"drift_allan: {msg}", file=sys.stderr)
    sys.exit(2)


def allan(x, m):
    """Overlapping Allan variance of block means of m readings (stride m/20)."""
    c = [0.0]
    for v in x:
        c.append(c[-1] + v)
    total, count = 0.0, 0
    for i in range(0, len(x) - 2 * m + 1, max(1, m // 20)):
        a = (c[i + m] - c[i]) / m
        b = (c[i + 2 * m] - c[i + m]) / m
        total += (b - a) ** 2
        count += 1
    return (total / (2 * count), count) if count else (float("nan"), 0)


def fit_rate(x, period_s, lo_s=36.0, hi_s=900.0):
    """sigma_A^2 = h + q tau / 3 by least squares over log-spaced tau in [lo, hi]."""
    pts = []
    tau = lo_s
    while tau <= hi_s * 1.0001:
        m = max(2, int(round(tau / period_s)))
        av, n = allan(x, m)
        if n >= 4:
            pts.append((m * period_s, av))
        tau *= 10 ** 0.125
    n = len(pts)
    st = sum(t for t, _ in pts)
    sa = sum(a for _, a in pts)
    stt = sum(t * t for t, _ in pts)
    sta = sum(t * a for t, a in pts)
    slope = (n * sta - st * sa) / (n * stt - st * st)
    h = (sa - slope * st) / n
    return 3.0 * slope, h, pts


def structure(x, period_s, m, lags_s):
    nb = len(x) // m
    means = [sum(x[i * m:(i + 1) * m]) / m for i in range(nb)]
    white = sum(sum((v - means[i]) ** 2 for v in x[i * m:(i + 1) * m]) / (m - 1)
                for i in range(nb)) / nb / m
    rows = []
    for lag_s in lags_s:
        lag = int(round(lag_s / (m * period_s)))
        if lag < 1 or lag >= nb:
            continue
        d = [(means[i + lag] - means[i]) ** 2 for i in range(nb - lag)]
        rows.append((lag * m * period_s, sum(d) / len(d) - 2 * white, len(d)))
    return white, rows


def main(argv):
    args = list(argv[1:])
    if "--help" in args or "-h" in args:
        print(__doc__.strip())
        return 0
    duration = 3600.0
    split = None
    for flag in ("--duration", "--split"):
        if flag in args:
            k = args.index(flag)
            value = float(args[k + 1])
            del args[k:k + 2]
            if flag == "--duration":
                duration = value
            else:
                split = value
    if len(args) != 1:
        fail("usage: drift_allan.py LOG.csv [--duration SECONDS] [--split SECONDS]")
    x = load(args[0])
    if len(x) < 1000:
        fail(f"{args[0]}: {len(x)} readings, too few")
    period = duration / len(x)
    mean = sum(x) / len(x)
    sd = math.sqrt(sum((v - mean) ** 2 for v in x) / (len(x) - 1))
    print(f"{args[0]}: {len(x)} readings over {duration:.0f} s (period {1000 * period:.2f} ms), "
          f"mean {mean:.3f} mm, sd {sd:.3f} mm")
    print("\n| tau (s) | Allan dev (mm) | white sigma/sqrt(m) (mm) | pairs |")
    print("|---|---|---|---|")
    for tau in (1, 2, 4, 9, 18, 36, 90, 180, 360, 900, 1800):
        m = max(1, int(round(tau / period)))
        av, n = allan(x, m)
        if n:
            print(f"| {m * period:.1f} | {math.sqrt(av):.4f} | {sd / math.sqrt(m):.4f} | {n} |")
    a36, _ = allan(x, max(2, int(round(36.0 / period))))
    a900, _ = allan(x, max(2, int(round(900.0 / period))))
    q2p = 3.0 * (a900 - a36) / (900.0 - 36.0)
    print(f"\nrandom-walk slope between tau = 36 s and 900 s: q = 3 (sigma_A^2(900) - sigma_A^2(36)) / 864 s "
          f"= {q2p:.3e} mm^2/s = {q2p * 1e6 * 3600:.0f} um^2/h (the default offset_walk_um2_h)")
    q, h, _ = fit_rate(x, period)
    print(f"\nrandom-walk fit sigma_A^2 = h + q tau/3 over 36 s .. 900 s: q = {q:.3e} mm^2/s "
          f"= {q * 1e6 * 3600:.0f} um^2/h, floor h = {h:.4f} mm^2 (sigma_A {math.sqrt(max(h, 0)):.3f} mm)")
    m = max(2, int(round(2.0 / period)))
    white, rows = structure(x, period, m, (2, 4, 9, 18, 36, 90, 180, 360, 900, 1800, 2700))
    print(f"\nstructure function of {m * period:.1f} s block means (white part {white:.4f} mm^2 each):")
    print("| lag (s) | S(L) (mm^2) | sqrt (mm) | walk q0*L (mm^2) | pairs |")
    print("|---|---|---|---|---|")
    for lag, s, n in rows:
        print(f"| {lag:.0f} | {s:.4f} | {math.sqrt(max(s, 0)):.3f} | {q * lag:.4f} | {n} |")
    if split is not None:
        cut = int(split / period)
        if cut < 1000 or cut > len(x) - 1000:
            fail("--split leaves too few readings on one side")
        q1, h1, _ = fit_rate(x[:cut], period, hi_s=min(900.0, split / 4))
        print(f"\nfirst {split:.0f} s: q = {q1:.3e} mm^2/s ({q1 * 1e6 * 3600:.0f} um^2/h), h = {h1:.4f}")
        q2, h2, _ = fit_rate(x[cut:], period, hi_s=min(900.0, (duration - split) / 4))
        print(f"the rest ({duration - split:.0f} s): q = {q2:.3e} mm^2/s "
              f"({q2 * 1e6 * 3600:.0f} um^2/h), h = {h2:.4f}")


if __name__ == "__main__":
    main(sys.argv)
