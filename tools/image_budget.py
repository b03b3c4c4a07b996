#!/usr/bin/python3
"""Flash and RAM of a firmware image by part, from the linker's map file.

Every input section the linker placed (the map's "Linker script and memory map" part;
sections --gc-sections dropped are listed before it and not counted) is charged to the
part it came from: a folder of ours (estimator, firmware, drivers, telemetry, hal, boards),
or the toolchain's libgcc and libc (newlib-nano). Flash is what is programmed: code,
read-only data and the initial values of .data; RAM is .data, .bss, .noinit and the stack
the linker script reserves. Alignment fill between sections is charged to `fill`.

With --elf (a link-time optimised image, whose map names only the link's partitions), the
parts come from the ELF's debug information instead: each code byte is charged to the source
file its line-table row names (code inlined from another file goes to that file), each data
object to the file that defines it (nm -l); bytes neither names (merged strings, alignment)
are `unattributed`. The image's totals are its sections' sizes either way.

With --stack (the image check's JSON, tools/stack_check.py --json), the static worst-case
stack is printed with its margin.

Usage: image_budget.py IMAGE.map [--elf IMAGE.elf [--tools PREFIX]] [--stack IMAGE.stack.json]
                       [--files] [--markdown] [--flash-budget BYTES] [--ram-budget BYTES]
"""
import argparse
import json
import os
import re
import subprocess
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
        if lib in ("gcc", "c_nano", "c", "g_nano", "g", "nosys", "m"):
            return ("libgcc" if lib == "gcc" else "libc (newlib-nano)"), member
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


SOURCE_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
HEADER_RE = re.compile(r"^(/\S+|\S+/\S+):(\[\+\+\])?$")
ROW_RE = re.compile(r"^(\S+)\s+(\d+|-)\s+(0x[0-9a-f]+)")


def part_of_source(path):
    """(part, file) of a source path named by the debug information."""
    if "newlib" in path:
        return "libc (newlib-nano)", os.path.basename(path)
    if "libgcc" in path:
        return "libgcc", os.path.basename(path)
    rel = os.path.relpath(path, SOURCE_ROOT) if path.startswith("/") else path
    if rel.startswith(".."):
        return os.path.basename(path), os.path.basename(path)
    top = rel.split("/")[0]
    if rel.startswith("firmware/telemetry/"):
        top = "telemetry"
    return top, "/".join(rel.split("/")[1:]) if top != "telemetry" else rel.split("/")[-1]


def run_tool(cmd):
    try:
        return subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    except (OSError, subprocess.CalledProcessError) as e:
        sys.exit(f"image_budget: {' '.join(cmd)} failed: {e}")


def variables_by_unit(elf, prefix):
    """{variable name: {source paths of the compile units declaring it}} from the ELF's
    debug information (readelf --debug-dump=info)."""
    file_scope, local, unit, in_var, in_unit, depth = {}, {}, None, False, False, 0
    for line in run_tool([prefix + "readelf", "--debug-dump=info", elf]).splitlines():
        if "(DW_TAG_" in line:
            in_unit = "(DW_TAG_compile_unit)" in line
            in_var = "(DW_TAG_variable)" in line
            m = re.match(r"\s*<(\d+)><", line)
            depth = int(m.group(1)) if m else 0
            continue
        if "DW_AT_name" not in line:
            continue
        name = line.rsplit(": ", 1)[-1].strip()
        if in_unit:
            unit = name if name.startswith("/") else None
        elif in_var and unit is not None:
            (file_scope if depth == 1 else local).setdefault(name, set()).add(unit)
    # a name defined at file scope is that object; a function's static only where none is
    for name, units in local.items():
        file_scope.setdefault(name, units)
    return file_scope


def parse_elf(elf, prefix):
    """{(part, file): [flash, ram]} from the ELF's line table (code) and symbols (data); the
    section sizes (size -A) settle the rest under `unattributed`."""
    sections = {}
    for line in run_tool([prefix + "size", "-A", elf]).splitlines():
        f = line.split()
        if len(f) >= 3 and f[0] in SECTION_COST and f[1].isdigit():
            sections[f[0]] = (int(f[1]), int(f[2]))
    text_lo, text_hi = sections[".text"][1], sections[".text"][1] + sections[".text"][0]
    cost, charged = {}, {}

    def add(key, out, n):
        flash, ram = SECTION_COST[out]
        entry = cost.setdefault(key, [0, 0])
        entry[0] += n if flash else 0
        entry[1] += n if ram else 0
        charged[out] = charged.get(out, 0) + n

    # code: consecutive line-table rows of one sequence; a row's bytes run to the next row
    current, prev = None, None
    for line in run_tool([prefix + "objdump", "--dwarf=decodedline", elf]).splitlines():
        m = HEADER_RE.match(line.strip())
        if m:
            current = m.group(1)
            continue
        m = ROW_RE.match(line)
        if not m or current is None:
            continue
        addr = int(m.group(3), 16)
        if prev is not None and text_lo <= prev[1] < text_hi and addr > prev[1]:
            add(part_of_source(prev[0]), ".text", min(addr, text_hi) - prev[1])
        prev = None if m.group(2) == "-" else (current, addr)
    # data objects: the file of their definition (nm -l), else, for a link-time optimised
    # image whose data carry no line, the compile unit whose debug information declares a
    # variable of that name (the part is what counts: a name two parts share stays unattributed)
    declared = variables_by_unit(elf, prefix)
    for line in run_tool([prefix + "nm", "-S", "-l", "--defined-only", elf]).splitlines():
        f = line.split()
        if len(f) < 4 or f[2] not in "rRdDbB":
            continue
        addr, n = int(f[0], 16), int(f[1], 16)
        out = next((o for o, (sz, a) in sections.items() if a <= addr < a + sz), None)
        if out is None or out == ".text" and text_lo <= addr < text_hi and f[2] in "tT":
            continue
        if len(f) >= 5:
            add(part_of_source(f[4].rsplit(":", 1)[0]), out, n)
            continue
        units = declared.get(f[3].split(".")[0], set())
        parts = {part_of_source(u) for u in units}
        add(parts.pop() if len({p for p, _ in parts}) == 1 else ("unattributed", "-"), out, n)
    for out, (sz, _) in sections.items():
        if sz > charged.get(out, 0):
            if out == ".stack":
                add(("stack (reserved)", "-"), out, sz - charged.get(out, 0))
            else:
                add(("unattributed", "-"), out, sz - charged.get(out, 0))
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
    ap.add_argument("--elf", help="parts from this ELF's debug information (link-time optimised)")
    ap.add_argument("--tools", default="arm-none-eabi-", help="binutils prefix for --elf")
    ap.add_argument("--files", action="store_true", help="one row per source file")
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument("--flash-budget", type=int, default=65536)
    ap.add_argument("--ram-budget", type=int, default=16384)
    args = ap.parse_args()
    cost = parse_elf(args.elf, args.tools) if args.elf else parse(args.map)
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
