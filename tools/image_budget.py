#!/usr/bin/python3
"""Flash and RAM of a firmware image by part, from the linker's map file.

Every input section the linker placed (the map's "Linker script and memory map" part;
sections --gc-sections dropped are listed before it and not counted) is charged to the
part it came from: a folder of ours (estimator, firmware, drivers, telemetry, hal, boards),
or the toolchain's libgcc and libc (newlib-nano). Flash is what is programmed: code,
read-only data and the initial values of .data; RAM is .data, .bss, .noinit and the stack
the linker script reserves. Alignment fill between sections is charged to `fill`.

With --stack (the image check's JSON, tools/stack_check.py --json), the static worst-case
stack is printed with its margin.

Usage: image_budget.py IMAGE.map [--stack IMAGE.stack.json] [--files] [--markdown]
                       [--flash-budget BYTES] [--ram-budget BYTES]
"""
import argparse
import json
import os
import re
import sys

# Output sections and what they cost: (flash, ram).
SECTION_COST = {
    ".vectors": (True, False),
    ".text": (True, False),
    ".rodata": (True, False),
    ".ARM.exidx": (True, False),
    ".ARM.extab": (True, False),
    ".data": (True, True),
    ".bss": (False, True),
    ".noinit": (False, True),
    ".stack": (False, True),
}
OUT_RE = re.compile(r"^(\.[\w.]+)\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)")
IN_FULL_RE = re.compile(r"^ (\S+)\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*)$")
IN_NAME_RE = re.compile(r"^ (\.\S+|COMMON)\s*$")
IN_REST_RE = re.compile(r"^\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*)$")
FILL_RE = re.compile(r"^ \*fill\*\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)")
ARCHIVE_RE = re.compile(r"lib([\w-]+?)(?:_cortex-m\w+)?\.a\((.+?)(?:\.obj|\.o)?\)$")


def part_of(path):
    """(part, file) of an input file named in the map."""
    m = ARCHIVE_RE.search(path)
    if m:
        lib, member = m.group(1), m.group(2)
        if lib in ("gcc", "c_nano", "c", "nosys", "m"):
            return ("libc (newlib-nano)" if lib.startswith("c") else "lib" + lib), member
        return lib, member
    if "/boards/" in path or path.startswith("boards/"):
        rel = path.split(".dir/", 1)[-1].replace("__/", "")
        return "boards", re.sub(r"\.obj$", "", rel)
    if path.startswith("linker stubs") or "stubs" in path:
        return "linker", path
    return os.path.basename(path), os.path.basename(path)


def parse(map_path):
    """{(part, file): [flash, ram]} of the placed input sections. The output sections' own
    sizes (what the image holds) settle any difference under `merged strings`: the map lists
    a mergeable string section at its size before the linker merged it."""
    cost, placed, totals = {}, {}, {}
    out = None
    with open(map_path, encoding="utf-8", errors="replace") as f:
        lines = f.read().split("\n")
    try:
        start = lines.index("Linker script and memory map")
    except ValueError:
        sys.exit(f"{map_path}: no 'Linker script and memory map' part: not a GNU ld map")

    def add(key, size):
        if size == 0:
            return
        flash, ram = SECTION_COST[out]
        entry = cost.setdefault(key, [0, 0])
        entry[0] += size if flash else 0
        entry[1] += size if ram else 0
        placed[out] = placed.get(out, 0) + size

    pending = None
    for line in lines[start + 1:]:
        m = OUT_RE.match(line)
        if m:
            out, pending = m.group(1), None
            if out in SECTION_COST:
                totals[out] = totals.get(out, 0) + int(m.group(3), 16)
            if out == ".stack":
                add(("stack (reserved)", "-"), int(m.group(3), 16))
            continue
        if out not in SECTION_COST or out == ".stack":
            continue
        m = FILL_RE.match(line)
        if m:
            add(("fill", "-"), int(m.group(2), 16))
            continue
        m = IN_FULL_RE.match(line)
        if m and m.group(1).startswith((".", "COMMON")):
            add(part_of(m.group(4)), int(m.group(3), 16))
            pending = None
            continue
        m = IN_NAME_RE.match(line)
        if m:
            pending = m.group(1)
            continue
        m = IN_REST_RE.match(line)
        if m and pending is not None:
            add(part_of(m.group(3)), int(m.group(2), 16))
            pending = None
    for out, total in totals.items():
        if total != placed.get(out, 0):
            flash, ram = SECTION_COST[out]
            entry = cost.setdefault(("merged strings", "-"), [0, 0])
            entry[0] += total - placed.get(out, 0) if flash else 0
            entry[1] += total - placed.get(out, 0) if ram else 0
    return cost


def table(rows, markdown):
    head = ("part", "flash_bytes", "ram_bytes")
    if markdown:
        out = ["| part | flash B | RAM B |", "|---|---:|---:|"]
        out += [f"| {p} | {f} | {r} |" for p, f, r in rows]
        return "\n".join(out)
    width = max(len(head[0]), *(len(p) for p, _, _ in rows))
    out = [f"{head[0]:<{width}}  {head[1]:>11}  {head[2]:>9}"]
    out += [f"{p:<{width}}  {f:>11}  {r:>9}" for p, f, r in rows]
    return "\n".join(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("map")
    ap.add_argument("--stack", help="the image check's stack JSON (stack_check.py --json)")
    ap.add_argument("--files", action="store_true", help="one row per source file")
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument("--flash-budget", type=int, default=65536)
    ap.add_argument("--ram-budget", type=int, default=16384)
    args = ap.parse_args()
    cost = parse(args.map)
    by = {}
    for (part, name), (flash, ram) in cost.items():
        key = f"{part}/{name}" if args.files and name != "-" else part
        entry = by.setdefault(key, [0, 0])
        entry[0] += flash
        entry[1] += ram
    rows = sorted(((k, v[0], v[1]) for k, v in by.items()), key=lambda r: (-r[1], -r[2], r[0]))
    flash = sum(v[0] for v in by.values())
    ram = sum(v[1] for v in by.values())
    rows.append(("total", flash, ram))
    name = os.path.basename(args.map).rsplit(".", 1)[0]
    print(f"image {name}: flash {flash} B of {args.flash_budget} ({args.flash_budget - flash} B "
          f"free), RAM {ram} B of {args.ram_budget} with the stack "
          f"({args.ram_budget - ram} B free)")
    if args.stack:
        with open(args.stack, encoding="utf-8") as f:
            st = json.load(f)
        worst, limit = st["stack_bytes_max"], st["limit"]
        print(f"stack: static worst case {worst} B of {limit} reserved "
              f"({limit - worst} B, {100 * (limit - worst) // limit} % free)")
    print(table(rows, args.markdown))
    return 0


if __name__ == "__main__":
    sys.exit(main())
