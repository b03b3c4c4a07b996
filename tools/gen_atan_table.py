#!/usr/bin/python3
"""Generates the atan node table of estimator/src/fixmath.c (fix_atan_q32_udeg).

Nodes t_k = k/64, k = 0..64, over [0, 1] (|angle| <= 45 deg). For each node:
  value  = atan(t_k)              in micro-degrees x 16, rounded
  slope  = (1/64) / (1 + t_k^2)   in micro-degrees x 16 per segment, rounded
(the derivative of atan scaled to one segment, the Hermite tangent). Between two
nodes the C code evaluates the cubic Hermite interpolant. Its error is below
h^4/384 * max|atan''''| = 7e-10 rad (0.04 udeg) for h = 1/64; the roundings of the
table and of the evaluation add < 0.3 udeg. tests/estimator/test_fixmath.c
recomputes every entry in double and checks the table against it.

Usage: tools/gen_atan_table.py  (prints the C initialiser)
"""
import math

SEGMENTS = 64
SCALE = 16 * 180e6 / math.pi  # micro-degrees x 16 per radian


def main():
    rows = []
    for k in range(SEGMENTS + 1):
        t = k / SEGMENTS
        value = round(math.atan(t) * SCALE)
        slope = round(SCALE / SEGMENTS / (1.0 + t * t))
        rows.append(f"{{{value}, {slope}}}")
    print("static const int32_t atan_nodes[ATAN_SEGMENTS + 1u][2] = {")
    for i in range(0, len(rows), 4):
        print("    " + ", ".join(rows[i:i + 4]) + ",")
    print("};")


if __name__ == "__main__":
    main()
