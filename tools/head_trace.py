#!/usr/bin/env python3
"""A recording seen through a simulated head as built (the demo's second half).

    tools/head_trace.py FIXTURE.csv RECORDING.csv OUT.csv [--seed S]

FIXTURE.csv is a `host_sim scenario fixture...` trace: its `sim_offset_mm` and `sim_gain`
keys say what the simulated head truly is. RECORDING.csv is a trace of an exactly known
head (`offset_mm=0,...`, e.g. traces/demo/realnoise_demo.csv). OUT.csv is the recording
as that head reports it, raw = gain * (reading + u) + offset rounded to whole mm
(docs/explanation/calibration-model.md; the recording's own noise is scaled by the gain
too, as a real part's would be), with the
recording's calibration keys removed: an uncalibrated head, as a logger writes it. The
truth columns are kept. Readings a part never gives as a distance (0, 8190 and above)
are kept as they are.

u is uniform in [-0.5, 0.5) from a generator seeded by --seed (default 1): a whole-mm
reading stands for any distance within its millimetre. Without u the second rounding
would be a fixed function of the reading, not dithered by the noise, and would leave
each sensor a constant bias of up to half a millimetre that no calibration sees (0.78°
of α on fixture seed 1).
"""
import math
import random
import sys

CAL_KEYS = ("offset_mm", "offset_sd_mm", "gain", "gain_sd", "offset_gain_corr", "calibration")


def fail(msg):
    sys.exit("head_trace.py: " + msg)


def head_of(path):
    keys = {}
    with open(path) as f:
        for n, line in enumerate(f, 1):
            if not line.startswith("#"):
                break
            if "=" in line:
                k, v = line[1:].strip().split("=", 1)
                keys[k] = (v, n)
    try:
        off = [float(x) for x in keys["sim_offset_mm"][0].split(",")]
        gain = [float(x) for x in keys["sim_gain"][0].split(",")]
    except KeyError as e:
        fail("%s: no %s key (not a host_sim fixture trace)" % (path, e.args[0]))
    except ValueError:
        fail("%s: sim_offset_mm / sim_gain are not four numbers" % path)
    if len(off) != 4 or len(gain) != 4:
        fail("%s: sim_offset_mm / sim_gain need four values (A, B, C, D)" % path)
    return off, gain


def main():
    args = sys.argv[1:]
    if args and args[0] in ("--help", "-h"):
        print("usage: head_trace.py FIXTURE.csv RECORDING.csv OUT.csv [--seed S]\n")
        print(__doc__.strip())
        return
    seed = 1
    if len(args) == 5 and args[3] == "--seed":
        try:
            seed = int(args[4])
        except ValueError:
            fail("--seed: not an integer '%s'" % args[4])
        args = args[:3]
    if len(args) != 3:
        fail("usage: head_trace.py FIXTURE.csv RECORDING.csv OUT.csv [--seed S]")
    sys.argv[1:] = args
    rng = random.Random(seed)
    off, gain = head_of(sys.argv[1])
    out = []
    cols = None
    with open(sys.argv[2]) as f:
        for n, line in enumerate(f, 1):
            line = line.rstrip("\n")
            if line.startswith("#"):
                key = line[1:].strip().split("=", 1)[0]
                if key not in CAL_KEYS:
                    out.append(line)
                continue
            if cols is None:
                cols = line.split(",")
                try:
                    idx = [cols.index(c) for c in ("a_mm", "b_mm", "c_mm", "d_mm")]
                except ValueError:
                    fail("%s:%d: header lacks a_mm..d_mm" % (sys.argv[2], n))
                # what the head truly is, as a fixture trace says it (the demo's table reads it)
                out.append("# sim_offset_mm=" + ",".join("%.6f" % o for o in off))
                out.append("# sim_gain=" + ",".join("%.8f" % g for g in gain))
                out.append(line)
                continue
            v = line.split(",")
            for k, i in enumerate(idx):
                try:
                    r = int(v[i])
                except ValueError:
                    fail("%s:%d: column %d: not an integer range '%s'" % (sys.argv[2], n, i + 1, v[i]))
                if 0 < r < 8190:
                    spread = r + rng.random() - 0.5
                    raw = int(math.floor(gain[k] * spread + off[k] + 0.5))
                    if raw < 1:
                        fail("%s:%d: column %d: %d mm through this head is %d mm, not a"
                             " distance a part reports" % (sys.argv[2], n, i + 1, r, raw))
                    v[i] = str(raw)
            out.append(",".join(v))
    with open(sys.argv[3], "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
