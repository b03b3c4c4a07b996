#!/usr/bin/env python3
"""Line coverage of board sources under the twin, from executed addresses.

gcov does not run on the target, so the twin records which flash halfwords it executed
(tof_twin --coverage FILE: "start end" ranges per line) and this tool maps them onto the
ELF's DWARF line table (arm-none-eabi-objdump --dwarf=decodedline). A source line counts
when the line table gives it code; it is executed when the halfword at any of its
addresses was. Several coverage files of runs of the same ELF are merged.

    tools/twin_coverage.py --elf FIRMWARE.elf --dir boards/stm32 COV1 [COV2 ...]
        [--min 90] [--json OUT]

Prints the percentage per file and in total, and every line not executed with its text.
Exit status 1 if the total is below --min.
"""
import argparse
import bisect
import json
import os
import subprocess
import sys


def load_ranges(paths):
    ranges = []
    for p in paths:
        with open(p, encoding="ascii") as f:
            for n, line in enumerate(f, 1):
                if line.startswith("#") or not line.strip():
                    continue
                parts = line.split()
                if len(parts) != 2:
                    sys.exit(f"{p}:{n}: expected 'start end'")
                ranges.append((int(parts[0], 16), int(parts[1], 16)))
    ranges.sort()
    merged = []
    for s, e in ranges:
        if merged and s <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(merged[-1][1], e))
        else:
            merged.append((s, e))
    return merged


def executed(merged, starts, addr):
    i = bisect.bisect_right(starts, addr) - 1
    return i >= 0 and merged[i][0] <= addr < merged[i][1]


def line_table(objdump, elf):
    out = subprocess.run([objdump, "--dwarf=decodedline", elf], check=True,
                         capture_output=True, text=True).stdout
    rows = []  # (basename, line, address)
    for text in out.splitlines():
        parts = text.split()
        if len(parts) < 3 or not parts[2].startswith("0x"):
            continue
        if parts[1] == "-" or not parts[1].isdigit():
            continue
        rows.append((os.path.basename(parts[0]), int(parts[1]), int(parts[2], 16)))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--elf", required=True)
    ap.add_argument("--dir", required=True, help="source folder whose files are counted")
    ap.add_argument("--objdump", default="arm-none-eabi-objdump")
    ap.add_argument("--min", type=float, default=0.0)
    ap.add_argument("--json")
    ap.add_argument("coverage", nargs="+")
    a = ap.parse_args()

    names = {f for f in os.listdir(a.dir) if f.endswith((".c", ".h"))}
    merged = load_ranges(a.coverage)
    starts = [s for s, _ in merged]
    lines = {}  # (file, line) -> executed
    for name, line, addr in line_table(a.objdump, a.elf):
        if name not in names:
            continue
        key = (name, line)
        lines[key] = lines.get(key, False) or executed(merged, starts, addr)
    if not lines:
        sys.exit(f"no line of {a.dir} in the line table of {a.elf}")

    per_file = {}
    for (name, _), hit in lines.items():
        tot, ok = per_file.get(name, (0, 0))
        per_file[name] = (tot + 1, ok + (1 if hit else 0))
    total = len(lines)
    hit = sum(1 for v in lines.values() if v)
    for name in sorted(per_file):
        tot, ok = per_file[name]
        print(f"{name:28s} {ok:4d}/{tot:4d}  {100.0 * ok / tot:5.1f} %")
    pct = 100.0 * hit / total
    print(f"{'total':28s} {hit:4d}/{total:4d}  {pct:5.1f} %  ({a.dir}, {a.elf})")
    missed = sorted(k for k, v in lines.items() if not v)
    if missed:
        print("not executed:")
    for name, line in missed:
        try:
            with open(os.path.join(a.dir, name), encoding="utf-8") as f:
                text = f.read().splitlines()[line - 1].strip()
        except (OSError, IndexError):
            text = "?"
        print(f"  {a.dir}/{name}:{line}: {text}")
    if a.json:
        with open(a.json, "w", encoding="ascii") as f:
            json.dump({"lines": total, "executed": hit, "percent": round(pct, 2),
                       "missed": [f"{n}:{l}" for n, l in missed]}, f, indent=1)
    return 1 if pct < a.min else 0


if __name__ == "__main__":
    sys.exit(main())
