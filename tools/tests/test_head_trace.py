#!/usr/bin/env python3
"""tools/head_trace.py: a recording seen through a simulated head, with no fixed bias."""
import os
import subprocess
import sys
import tempfile
import unittest

TOOL = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "head_trace.py")


def fixture(path, offsets, gains):
    with open(path, "w") as f:
        f.write("# tof-trace v1\n# arm_mm=30\n")
        f.write("# sim_offset_mm=%s\n" % ",".join(str(o) for o in offsets))
        f.write("# sim_gain=%s\n" % ",".join(str(g) for g in gains))
        f.write("t_ms,a_mm,b_mm,c_mm,d_mm\n0,100,100,100,100\n")


def recording(path, rows):
    with open(path, "w") as f:
        f.write("# tof-trace v1\n# arm_mm=30\n# offset_mm=0,0,0,0\n# offset_sd_mm=0,0,0,0\n")
        f.write("t_ms,a_mm,b_mm,c_mm,d_mm,alpha_deg,beta_deg\n")
        for i, r in enumerate(rows):
            f.write("%d,%d,%d,%d,%d,0,0\n" % ((i * 20,) + tuple(r)))


def run(*args):
    return subprocess.run([sys.executable, TOOL] + list(args), capture_output=True, text=True)


def readings(path):
    rows, cols = [], None
    with open(path) as f:
        for line in f:
            if line.startswith("#"):
                continue
            if cols is None:
                cols = line.strip().split(",")
                continue
            v = line.strip().split(",")
            rows.append([int(v[cols.index(c)]) for c in ("a_mm", "b_mm", "c_mm", "d_mm")])
    return rows


class HeadTrace(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.p = lambda n: os.path.join(self.dir.name, n)

    def tearDown(self):
        self.dir.cleanup()

    def test_no_fixed_bias_from_rounding(self):
        # A constant whole-mm reading through offsets with fractions: rounding gain·r + offset
        # alone would give 100, 100, 101, 101 on every row (biases -0.3, -0.45, +0.4, +0.2);
        # spread over its millimetre, each sensor's mean is gain·r + offset.
        off, gain = [0.3, 0.45, 0.6, -0.2], [1.0, 1.0, 1.0, 1.002]
        fixture(self.p("f.csv"), off, gain)
        recording(self.p("r.csv"), [[100, 100, 100, 100]] * 20000)
        r = run(self.p("f.csv"), self.p("r.csv"), self.p("o.csv"), "--seed", "3")
        self.assertEqual(r.returncode, 0, r.stderr)
        rows = readings(self.p("o.csv"))
        for k in range(4):
            mean = sum(row[k] for row in rows) / len(rows)
            want = gain[k] * 100 + off[k]
            # the mean of 20 000 readings spread uniformly over 1 mm: sd 0.29/sqrt(20000)
            self.assertLess(abs(mean - want), 0.012, "sensor %d: mean %.4f, want %.4f" % (
                k, mean, want))

    def test_seeded(self):
        fixture(self.p("f.csv"), [0.5, 0, 0, 0], [1, 1, 1, 1])
        recording(self.p("r.csv"), [[100, 101, 102, 103]] * 200)
        outs = []
        for seed in ("1", "1", "2"):
            r = run(self.p("f.csv"), self.p("r.csv"), self.p("o.csv"), "--seed", seed)
            self.assertEqual(r.returncode, 0, r.stderr)
            outs.append(readings(self.p("o.csv")))
        self.assertEqual(outs[0], outs[1])
        self.assertNotEqual(outs[0], outs[2])

    def test_non_distances_kept_and_calibration_keys_removed(self):
        fixture(self.p("f.csv"), [5, 5, 5, 5], [1, 1, 1, 1])
        recording(self.p("r.csv"), [[0, 8190, 8191, 65535], [100, 100, 100, 100]])
        r = run(self.p("f.csv"), self.p("r.csv"), self.p("o.csv"))
        self.assertEqual(r.returncode, 0, r.stderr)
        rows = readings(self.p("o.csv"))
        self.assertEqual(rows[0], [0, 8190, 8191, 65535])
        self.assertTrue(all(104 <= v <= 106 for v in rows[1]), rows[1])
        text = open(self.p("o.csv")).read()
        self.assertNotIn("# offset_mm=", text)
        self.assertIn("# sim_offset_mm=", text)

    def test_reading_below_one_mm_is_an_error_naming_its_line(self):
        fixture(self.p("f.csv"), [-20, 0, 0, 0], [1, 1, 1, 1])
        recording(self.p("r.csv"), [[100, 100, 100, 100], [10, 100, 100, 100]])
        r = run(self.p("f.csv"), self.p("r.csv"), self.p("o.csv"))
        self.assertEqual(r.returncode, 1)
        self.assertIn("r.csv:7: column 2", r.stderr)

    def test_bad_seed_refused(self):
        fixture(self.p("f.csv"), [0, 0, 0, 0], [1, 1, 1, 1])
        recording(self.p("r.csv"), [[100, 100, 100, 100]])
        r = run(self.p("f.csv"), self.p("r.csv"), self.p("o.csv"), "--seed", "x")
        self.assertEqual(r.returncode, 1)
        self.assertIn("--seed", r.stderr)


if __name__ == "__main__":
    unittest.main()
