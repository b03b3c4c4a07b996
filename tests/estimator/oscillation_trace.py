#!/usr/bin/python3
"""A librating plate as a trace v1 file, and the score of host_sim's estimates on it.

  oscillation_trace.py write OUT.csv --freq HZ --amp DEG --sigma MM [--seed S] [--rows R]
      the plate tilts about a random axis through its centre, α = A cos ψ sin(2π f t + φ),
      β = A sin ψ sin(2π f t + φ), x̄ fixed in 100..400 mm, a = 30 mm, 50 rows/s, white
      Gaussian noise σ on every reading rounded to whole mm, an exactly known head (offsets
      and gains stated exact), truth in alpha_deg, beta_deg, distance_mm.
  oscillation_trace.py score TRACE.csv EST.csv
      per answered value (α, β, x̄) against the truth at the row's t_ms: `ok` values beyond
      6 sd (goal 0), values beyond 6 sd whose why does not say motion (goal <= 0.1 %).

The same generator as tests/estimator/test_oscillation.c, through host_sim's whole pipeline
(simulated parts and bus, the firmware's estimator): host_sim replay OUT.csv --estimator
consensus|kalman --window N --mode sliding|tumbling --out EST.csv.
"""
import csv
import math
import random
import sys


def write(path, freq, amp, sigma, seed, rows):
    rng = random.Random(seed)
    psi = 2 * math.pi * rng.random()
    phase = 2 * math.pi * rng.random()
    xm = 100 + 300 * rng.random()
    with open(path, "w") as f:
        f.write("# tof-trace v1\n# arm_mm=30.0\n# period_ms=20\n")
        f.write("# offset_mm=0,0,0,0\n# offset_sd_mm=0,0,0,0\n# gain=1,1,1,1\n# gain_sd=0,0,0,0\n")
        f.write("t_ms,a_mm,b_mm,c_mm,d_mm,alpha_deg,beta_deg,distance_mm\n")
        for i in range(rows):
            s = math.sin(2 * math.pi * freq * i * 0.02 + phase)
            al = amp * math.cos(psi) * s
            be = amp * math.sin(psi) * s
            ta = 30 * math.tan(math.radians(al))
            tb = 30 * math.tan(math.radians(be))
            x = [xm - ta, xm + tb, xm + ta, xm - tb]
            r = [max(1, round(v + sigma * rng.gauss(0, 1))) for v in x]
            f.write("%d,%d,%d,%d,%d,%.6f,%.6f,%.4f\n" % (i * 20, *r, al, be, xm))


def score(trace, est):
    truth = {}
    with open(trace) as f:
        rows = csv.DictReader(line for line in f if not line.startswith("#"))
        for r in rows:
            truth[int(r["t_ms"])] = (float(r["alpha_deg"]), float(r["beta_deg"]),
                                     float(r["distance_mm"]))
    answered = ok6 = unsaid6 = beyond6 = windows = ok = 0
    with open(est) as f:
        for r in csv.DictReader(f):
            t = truth[int(r["t_ms"])]
            windows += 1
            ok += r["status"] == "ok"
            for i, (v, s) in enumerate((("alpha_deg", "alpha_sd_deg"), ("beta_deg", "beta_sd_deg"),
                                        ("distance_mm", "distance_sd_mm"))):
                if r[v] == "" or r[s] == "" or float(r[s]) <= 0:
                    continue
                answered += 1
                if abs(float(r[v]) - t[i]) > 6 * float(r[s]):
                    beyond6 += 1
                    ok6 += r["status"] == "ok"
                    unsaid6 += "motion" not in r["why"]
    print("estimates %d, ok %.1f %%, values %d, beyond 6 sd %d, ok beyond 6 sd %d, "
          "unsaid beyond 6 sd %d (%.3f %%)" % (windows, 100.0 * ok / max(windows, 1), answered,
                                                beyond6, ok6, unsaid6,
                                                100.0 * unsaid6 / max(answered, 1)))


def main(argv):
    if len(argv) >= 3 and argv[1] == "score":
        score(argv[2], argv[3])
        return 0
    if len(argv) >= 3 and argv[1] == "write":
        opts = {"--freq": None, "--amp": None, "--sigma": None, "--seed": "1", "--rows": "3000"}
        it = iter(argv[3:])
        for k in it:
            if k not in opts:
                sys.exit("oscillation_trace.py: unknown option %s" % k)
            opts[k] = next(it, None)
        if None in opts.values():
            sys.exit("oscillation_trace.py: write needs --freq, --amp and --sigma")
        write(argv[2], float(opts["--freq"]), float(opts["--amp"]), float(opts["--sigma"]),
              int(opts["--seed"]), int(opts["--rows"]))
        return 0
    sys.exit(__doc__)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
