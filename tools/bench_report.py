#!/usr/bin/python3
"""Collect the on-target benchmark into bench.json (docs/reference/performance.md).

Runs each benchmark image under QEMU with -icount shift=7 (exact instruction
counts, boards/mps2/insn_counter.h), parses its "BENCH cpu impl op insn" lines,
then builds the m4 preset and adds its image figures: flash (text + data), RAM
(data + bss, the reserved stack included) and the worst-case stack depth from the
call graph (tools/stack_check.py).

Usage: bench_report.py --qemu QEMU --out bench.json --source-dir DIR IMAGE=BOARD=CPU ...
"""
import argparse
import json
import os
import re
import subprocess
import sys


def run(cmd, **kw):
    r = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if r.returncode != 0:
        sys.exit(f"bench_report: {' '.join(cmd)} failed ({r.returncode}):\n{r.stdout}{r.stderr}")
    return r.stdout


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--qemu", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--source-dir", required=True)
    ap.add_argument("--m4-build-dir", help="build folder of the m4 preset (default build/m4)")
    ap.add_argument("--pose-script", help="tests/pose/qemu_insn/run.sh: camera pose frames on M4")
    ap.add_argument("--pose-out", help="build folder for the pose benchmark")
    ap.add_argument("images", nargs="+")
    a = ap.parse_args()
    results = []
    for spec in a.images:
        image, board, cpu = spec.split("=")
        out = run([a.qemu, "-M", board, "-nographic", "-monitor", "none", "-serial", "none",
                   "-icount", "shift=7", "-semihosting-config", "enable=on,target=native",
                   "-kernel", image], timeout=600)
        lines = re.findall(r"^BENCH (\S+) (\S+) (\S+) (\d+)$", out, re.M)
        if not lines:
            sys.exit(f"bench_report: {image} printed no BENCH lines:\n{out}")
        for c, impl, op, insn in lines:
            if c != cpu:
                sys.exit(f"bench_report: {image} reports cpu {c}, expected {cpu}")
            results.append({"cpu": c, "impl": impl, "op": op, "insn": int(insn)})

    if a.pose_script:
        # The camera pose pipeline (pose/, float on the M4F's FPU): one frame at
        # about 0.7 m and one at about 3 m, instructions for the whole pipeline.
        out = run(["bash", a.pose_script] + ([a.pose_out] if a.pose_out else []), timeout=900)
        for block in re.findall(r"frame \d+\n((?:  .*\n?)+)", out):
            fields = dict(line.split() for line in block.strip().splitlines())
            range_mm = round(int(fields["t_z_um"]) / 1e6, 1)
            results.append({"cpu": "cortex-m4", "impl": "float",
                            "op": f"pose_frame_{range_mm}m", "insn": int(fields["insn_process"])})

    src = a.source_dir
    m4 = a.m4_build_dir or os.path.join(src, "build", "m4")
    run(["cmake", "--preset", "m4", "-B", m4], cwd=src)
    run(["cmake", "--build", m4], cwd=src)
    elf = os.path.join(m4, "boards", "nucleo-l476rg", "firmware-nucleo-l476rg.elf")
    size = run(["arm-none-eabi-size", "-B", elf]).splitlines()[1].split()
    text, data, bss = int(size[0]), int(size[1]), int(size[2])
    # The worst-case stack the link itself computed and checked (tools/stack_check.py, run
    # by tof_image() after every link of the image).
    with open(elf[:-4] + ".stack.json") as f:
        stack = json.load(f)["stack_bytes_max"]
    doc = {"results": results,
           "image": {"preset": "m4", "flash_bytes": text + data, "ram_bytes": data + bss,
                     "stack_bytes_max": stack}}
    with open(a.out, "w") as f:
        json.dump(doc, f, indent=1)
    print(f"{'cpu':<10} {'impl':<6} {'op':<10} {'insn':>9}")
    for r in results:
        print(f"{r['cpu']:<10} {r['impl']:<6} {r['op']:<10} {r['insn']:>9}")
    print(f"m4 image: flash {text + data} B, RAM {data + bss} B (stack reserve included), "
          f"worst-case stack {stack} B")
    print(f"written: {a.out}")


if __name__ == "__main__":
    main()
