#!/usr/bin/python3
"""Worst-case stack depth of a firmware image from GCC's call-graph files.

Every firmware object is compiled with -fstack-usage -fcallgraph-info=su, which
writes a .ci file per object: one node per function with its frame size, one edge
per call. This tool joins them, walks the call graph from the entry points and
reports the deepest path, failing when it exceeds the stack the linker script
reserves.

Rules (an upper bound under the project's rules, not a proof):
- a frame marked dynamic and not bounded is an error (the project has no VLAs/alloca);
- recursion (a function twice on one path through direct calls) is an error;
- an indirect call (the ops structs' function pointers) may reach any function whose
  address is taken: with --elf, the functions whose (Thumb) address appears as a
  word anywhere in the image (ops tables, literal pools); without it, any function
  no one calls directly. A function already on the path is skipped there;
- ... narrowed by the member it goes through (docs/explanation/architecture.md: every function pointer is an
  ops-struct member, `x->ops->now_us(...)`): with --narrow, a call through member `m`
  reaches the functions the image's sources (the files of its linked functions, and the
  .c files beside them: a file holding only an ops table has no function a call graph
  names) store into a member named `m` (`.m = f` or `->m = f`) plus every address-taken function
  stored nowhere under a name. It stays
  "any address-taken function" when the call's statement names no member or also calls
  through a variable (a lower-case name that is no function of the image, no direct call
  target and no inline function of a header: UPPER_CASE names are macros by the project's
  convention) or through an expression (`(*fp)(`, `tbl[i](`, a cast), when `m` is ever
  assigned something other than a function name, or when the source cannot be read (a
  statement calling through several members reaches the functions of all of them). A
  static function matches a store of its name only in its own file or in a header;
- functions without a .ci (newlib, libgcc) are charged LIB_FRAME bytes each;
- interrupts: the deepest handler plus the exception frame (EXC_FRAME bytes, the
  extended frame with FP state) is added on top of the deepest thread path.

Usage: stack_check.py --root BUILD_DIR --match SUBSTR [--match ...] --map IMAGE.map
                      --limit BYTES [--json OUT] [--entry NAME ...] [--handler NAME ...]
                      [--min-free-percent P]
"""
import argparse
import json
import os
import re
import sys

LIB_FRAME = 64
SOURCE_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXC_FRAME = 104  # 8 core words + 18 FP words (ARMv7-M ARM B1.5.7), rounded to 8

MEMBER_CALL_RE = re.compile(r"(?:->|\.)\s*([A-Za-z_]\w*)\s*\(")
MEMBER_STORE_RE = re.compile(r"(?:->|\.)\s*([A-Za-z_]\w*)\s*=(?!=)\s*([^,;}]*)")
FUNC_NAME_RE = re.compile(r"&?\s*([A-Za-z_]\w*)\s*$")
NODE_FILE_RE = re.compile(r"\\n([^\\]+\.[ch]):\d+:\d+")
NODE_RE = re.compile(r'node: \{ title: "([^"]+)" label: "([^"]*)"')
EDGE_RE = re.compile(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)" label: "([^"]*)"')
FRAME_RE = re.compile(r"\\n(\d+) bytes \(([^)]*)\)")


def load(root, matches):
    frames, calls, errors, sources = {}, {}, [], {}
    for dirpath, _, files in os.walk(root):
        for name in files:
            if not name.endswith(".ci"):
                continue
            path = os.path.join(dirpath, name)
            if matches and not any(m in path for m in matches):
                continue
            with open(path, encoding="utf-8", errors="replace") as f:
                for line in f:
                    m = NODE_RE.search(line)
                    if m:
                        fm = FRAME_RE.search(m.group(2))
                        where = NODE_FILE_RE.search(m.group(2))
                        if fm and where:  # a definition (a declaration has no frame)
                            sources[m.group(1)] = where.group(1)
                        if fm:
                            size, kind = int(fm.group(1)), fm.group(2)
                            if "dynamic" in kind and "bounded" not in kind:
                                errors.append(f"{m.group(1)}: unbounded dynamic stack ({kind})")
                            frames[m.group(1)] = max(size, frames.get(m.group(1), 0))
                        continue
                    m = EDGE_RE.search(line)
                    if m:
                        calls.setdefault(m.group(1), []).append((m.group(2), m.group(3)))
    return frames, calls, errors, sources


def linked_functions(map_path):
    """The functions the linker kept (-ffunction-sections: .text.<name>), each with the
    source files (basenames, from the object `X.c.obj` named on the section's line or the
    next) it was kept from: two static functions of one name in two files (the flight
    flash driver's and the simulated one's) are told apart."""
    kept, in_map, pending = {}, False, None
    with open(map_path, encoding="utf-8", errors="replace") as f:
        for line in f:
            if line.startswith("Linker script and memory map"):
                in_map = True
                continue
            if not in_map:
                continue
            m = re.match(r"\s+\.text\.(?:startup\.|unlikely\.|hot\.)?([A-Za-z_]\w*)", line)
            if m:
                pending = m.group(1)
                kept.setdefault(pending, set())
            o = re.search(r"([\w.+-]+)\.obj\)?\s*$", line)
            if pending is not None and o:
                kept[pending].add(o.group(1))
                pending = None
            elif not m:
                pending = None
    return kept


def is_linked(frame, sources, kept):
    """A call-graph node the image holds: its name kept and, for a static function (title
    path:name), kept from its own file (when the map names the file)."""
    name = frame.split(":")[-1].split(".")[0]
    if name not in kept:
        return False
    files = kept[name]
    return ":" not in frame or not files or os.path.basename(sources.get(frame, "")) in files


def address_taken(elf):
    """Functions whose Thumb address (odd) is stored as a word in the linked image."""
    import subprocess
    import tempfile
    nm = subprocess.run(["arm-none-eabi-nm", "--defined-only", elf], capture_output=True,
                        text=True, check=True).stdout
    funcs = {}
    for line in nm.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[1] in "Tt":
            funcs.setdefault(int(parts[0], 16), set()).add(parts[2].split(".")[0])
    with tempfile.NamedTemporaryFile(suffix=".bin") as tmp:
        subprocess.run(["arm-none-eabi-objcopy", "-O", "binary", "--only-section=.text",
                        "--only-section=.data", elf, tmp.name], check=True)
        blob = open(tmp.name, "rb").read()
    taken = set()
    for i in range(0, len(blob) - 3, 2):  # literal pools are 4-aligned, tables too; 2 is safe
        word = int.from_bytes(blob[i:i + 4], "little")
        if word & 1 and (word & ~1) in funcs:
            taken |= funcs[word & ~1]
    return taken


def image_stores(files, frames):
    """member_stores() of the image's source files, plus the stores of the .c files beside
    them that name a function of the image: a file that defines only an ops table
    (firmware/src/link_storage.c) has no function a call graph names, yet stores the image's
    functions under member names. A sibling's store of anything else is not the image's."""
    stores = member_stores(files)
    if stores is None:
        return None
    names = {f.split(":")[-1].split(".")[0] for f in frames}
    siblings = set()
    for d in {os.path.dirname(p) for p in files}:
        try:
            siblings |= {os.path.join(d, n) for n in os.listdir(d) if n.endswith(".c")}
        except OSError:
            return None  # a folder we cannot read: no narrowing at all
    extra = member_stores(siblings - set(files))
    if extra is None:
        return None
    for member, values in extra.items():
        for path, value in values:
            if value in names:
                stores.setdefault(member, set()).add((path, value))
    return stores


def member_stores(sources):
    """member name -> (file, what) pairs: what the image's sources (the files of its
    linked functions) store into it, a function name, or the whole expression when it is
    not a bare name."""
    stores = {}
    for path in sources:
        try:
            with open(path, encoding="utf-8", errors="replace") as f:
                text = f.read()
        except OSError:
            return None  # a source we cannot read: no narrowing at all
        for m in MEMBER_STORE_RE.finditer(text):
            value = m.group(2).strip()
            name = FUNC_NAME_RE.fullmatch(value)
            stores.setdefault(m.group(1), set()).add((path, name.group(1) if name else value))
    return stores


CALL_THROUGH_EXPR_RE = re.compile(r"[)\]]\s*\(")
C_WORDS = {"if", "while", "for", "switch", "return", "sizeof", "do", "else", "case"}
PLAIN_CALL_RE = re.compile(r"(?<![\w.>])([A-Za-z_]\w*)\s*\(")


INLINE_DEF_RE = re.compile(r"^(?:static\s+inline|FIX_INLINE)\b[^(;=]*?\b([A-Za-z_]\w*)\s*\(", re.M)


def inline_functions(root):
    """Names of the functions headers under `root` define inline (called directly, and
    often inlined away so that no call graph names them)."""
    names = set()
    for dirpath, dirs, files in os.walk(root):
        dirs[:] = [d for d in dirs if not d.startswith(("build", "."))]
        for name in files:
            if name.endswith(".h"):
                with open(os.path.join(dirpath, name), encoding="utf-8", errors="replace") as f:
                    names.update(INLINE_DEF_RE.findall(f.read()))
    return names


def call_members(label, functions):
    """Member names called in the statement of an indirect call (label file:line:col, the
    column of the enclosing expression; the statement read up to its `;`), or None when it
    cannot be read or when it also calls through something that is neither a member nor
    a known function (a function-pointer variable or parameter: then nothing is narrowed)."""
    try:
        path, line, col = label.rsplit(":", 2)
        with open(path, encoding="utf-8", errors="replace") as f:
            lines = f.read().splitlines()[int(line) - 1:int(line) + 19]
        lines[0] = lines[0][int(col) - 1:]
    except (OSError, ValueError, IndexError):
        return None
    text, depth = "", 0
    for ch in "\n".join(lines):
        depth += (ch == "(") - (ch == ")")
        if ch == ";" and depth <= 0:
            break
        text += ch
    if CALL_THROUGH_EXPR_RE.search(text):
        return None  # (*fp)(...), table[i](...), or a cast: not narrowed
    for name in PLAIN_CALL_RE.findall(text):
        # a direct call (a function of the image, a library or inline one) or a macro
        # (UPPER_CASE, the project's convention); anything else is a pointer variable
        if name not in functions and name not in C_WORDS and not name.isupper():
            return None
    return set(MEMBER_CALL_RE.findall(text)) or None


def analyse(frames, calls, entries, handlers, taken=None, stores=None, sources=None,
            callables=frozenset()):
    called = {t for ts in calls.values() for t, _ in ts}

    def resolve(name):
        if name in frames:
            return name
        suffix = ":" + name
        hits = [f for f in frames if f.endswith(suffix)]
        return hits[0] if len(hits) == 1 else name

    if taken is not None:
        callbacks = [f for f in frames if f.split(":")[-1].split(".")[0] in taken
                     and f not in entries and f not in handlers]
    else:
        callbacks = [f for f in frames
                     if f not in called and f.split(":")[-1] not in called
                     and f not in entries and f not in handlers]
    def bare(f):
        return f.split(":")[-1].split(".")[0]

    names = {bare(f) for f in frames}
    # what a statement may call directly: the image's functions, every direct call target
    # of the call graph (libraries included) and the caller's list of inline functions
    direct = names | {bare(t) for ts in calls.values() for t, _ in ts} | set(callables)
    direct.discard("__indirect_call")

    static_memo = {}

    def is_static(cb, own):
        """cb is defined `static` in its source file own (an LTO build titles every
        function path:name, so the title alone does not say)."""
        key = (own, bare(cb))
        if key not in static_memo:
            try:
                with open(own, encoding="utf-8", errors="replace") as f:
                    text = f.read()
            except OSError:
                text = None
            pattern = r"^static\b[^;{=]*\b" + re.escape(bare(cb)) + r"\s*\("
            static_memo[key] = text is None or re.search(pattern, text, re.M) is not None
        return static_memo[key]

    def matches(cb, store):
        """A stored (file, name) is callback cb: same name and, for a static function
        (title path:name, defined `static`), stored in its own file or in a header."""
        path, value = store
        if value != bare(cb):
            return False
        own = (sources or {}).get(cb) if ":" in cb else None
        return (own is None or own == path or path.endswith(".h") or
                not is_static(cb, own))

    unresolvable = set()  # members given something other than a function name
    all_stores = []
    for member, values in (stores or {}).items():
        for path, v in values:
            all_stores.append((path, v))
            if v not in names and v not in ("NULL", "0"):
                unresolvable.add(member)
    unnamed = [cb for cb in callbacks if not any(matches(cb, st) for st in all_stores)]

    def targets_of(label):
        members = call_members(label, direct) if stores is not None else None
        if members is None or members & unresolvable:
            return callbacks
        wanted = [st for member in members for st in stores.get(member, set())]
        return [cb for cb in callbacks if any(matches(cb, st) for st in wanted)] + unnamed

    memo, libs, errors = {}, set(), []

    def worst(fn, path, direct):
        if fn in memo:
            return memo[fn]
        if fn not in frames:
            libs.add(fn)
            return LIB_FRAME, [fn]
        best, best_path = 0, []
        path = path | {fn}
        direct = direct | {fn}
        for target, label in calls.get(fn, []):
            if target == "__indirect_call":
                for cb in targets_of(label):
                    if cb in path:
                        continue
                    d, p = worst(cb, path, frozenset())
                    if d > best:
                        best, best_path = d, ["(indirect)"] + p
                continue
            t = resolve(target)
            if t in direct:
                errors.append(f"recursion: {fn} -> {t}")
                continue
            if t in path:
                continue  # reached again only through an indirect call: not a real cycle
            d, p = worst(t, path, direct)
            if d > best:
                best, best_path = d, p
        result = (frames[fn] + best, [fn] + best_path)
        memo[fn] = result
        return result

    thread = {e: worst(resolve(e), frozenset(), frozenset())
              for e in entries if resolve(e) in frames}
    irq = {h: worst(resolve(h), frozenset(), frozenset()) for h in handlers if resolve(h) in frames}
    return thread, irq, sorted(libs), errors


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--root", required=True)
    ap.add_argument("--match", action="append", default=[])
    ap.add_argument("--limit", type=int, required=True)
    ap.add_argument("--entry", action="append", default=[])
    ap.add_argument("--handler", action="append", default=[])
    ap.add_argument("--map", help="link map: only functions the linker kept are analysed")
    ap.add_argument("--elf", help="linked image: indirect calls reach address-taken functions")
    ap.add_argument("--narrow", action="store_true",
                    help="resolve indirect calls by the ops member they go through")
    ap.add_argument("--json")
    ap.add_argument("--name", default="image")
    ap.add_argument("--min-free-percent", type=int, default=0,
                    help="fail unless this share of the reserve stays free at the worst case")
    a = ap.parse_args()
    entries = a.entry or ["Reset_Handler"]
    handlers = a.handler or ["HardFault_Handler", "Default_Handler", "SysTick_Handler",
                            "Uart_IRQHandler"]
    frames, calls, errors, sources = load(a.root, a.match)
    if not frames:
        print(f"stack_check: no .ci call-graph files under {a.root} matching {a.match}",
              file=sys.stderr)
        return 2
    if a.map:
        kept = linked_functions(a.map)
        frames = {f: v for f, v in frames.items() if is_linked(f, sources, kept)}
    taken = address_taken(a.elf) if a.elf else None
    stores = (image_stores({sources[f] for f in frames if f in sources}, frames)
              if a.narrow else None)
    callables = inline_functions(SOURCE_ROOT) if a.narrow else frozenset()
    thread, irq, libs, more = analyse(frames, calls, entries, handlers, taken, stores, sources,
                                      callables)
    errors += more
    t_worst = max((d for d, _ in thread.values()), default=0)
    i_worst = max((d for d, _ in irq.values()), default=0)
    total = t_worst + (i_worst + EXC_FRAME if irq else 0)
    print(f"stack_check {a.name}: worst case {total} bytes of {a.limit} reserved "
          f"(thread {t_worst}, deepest handler {i_worst} + {EXC_FRAME} exception frame)")
    for e, (d, p) in thread.items():
        print(f"  {e}: {d} bytes via " + " -> ".join(x.split(":")[-1] for x in p))
    for h, (d, p) in irq.items():
        print(f"  {h}: {d} bytes")
    if libs:
        print(f"  charged {LIB_FRAME} bytes each (no call graph): " + ", ".join(libs[:12]))
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"image": a.name, "stack_bytes_max": total, "limit": a.limit,
                       "thread": {k: v[0] for k, v in thread.items()},
                       "handlers": {k: v[0] for k, v in irq.items()}}, f, indent=1)
    for e in sorted(set(errors)):
        print(f"stack_check: {e}", file=sys.stderr)
    if errors:
        return 1
    if total > a.limit:
        print(f"stack_check: {a.name} needs up to {total} bytes of stack, the linker script "
              f"reserves {a.limit}", file=sys.stderr)
        return 1
    if (a.limit - total) * 100 < a.min_free_percent * a.limit:
        print(f"stack_check: {a.name} keeps {a.limit - total} of {a.limit} bytes of stack free "
              f"at the worst case, under the {a.min_free_percent} % margin: reserve more "
              f"(the linker script's STACK_SIZE) or make the deepest path shallower",
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
