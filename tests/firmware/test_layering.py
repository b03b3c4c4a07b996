#!/usr/bin/env python3
"""No include cycles between the firmware's modules (COMMON rules: no two files that
include each other; docs/explanation/architecture.md: includes point down the layers).

A module is a .c file and its header (firmware/src/app.c + firmware/include/firmware/app.h
is module "firmware/app"). Module X depends on Y when a file of X includes Y's header.
Any cycle (app <-> link, tlm_frame <-> tlm_messages, ...) fails, with the path printed.
Usage: test_layering.py [REPO_ROOT]
"""
import os
import re
import sys

INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)
# Component folders: (sources, public headers under an include dir).
COMPONENTS = ["firmware", "firmware/telemetry"]


def modules(root):
    """header path as included ("firmware/app.h") -> module name, and module -> files."""
    header_of, files = {}, {}
    for comp in COMPONENTS:
        inc = os.path.join(root, comp, "include")
        src = os.path.join(root, comp, "src")
        for d, _, names in os.walk(inc):
            for n in names:
                if n.endswith(".h"):
                    rel = os.path.relpath(os.path.join(d, n), inc)
                    mod = os.path.splitext(rel)[0]
                    header_of[rel] = mod
                    files.setdefault(mod, []).append(os.path.join(d, n))
        if os.path.isdir(src):
            for n in os.listdir(src):
                if n.endswith(".c"):
                    # the module whose header the .c file includes first as its own
                    path = os.path.join(src, n)
                    with open(path, encoding="utf-8") as f:
                        incs = INCLUDE.findall(f.read())
                    stem = os.path.splitext(n)[0]
                    mod = next((header_of.get(i) for i in incs
                                if os.path.splitext(os.path.basename(i))[0] == stem
                                and i in header_of), None)
                    files.setdefault(mod or ("src:" + stem), []).append(path)
    return header_of, files


def find_cycle(graph):
    state = {}
    for start in sorted(graph):
        stack = [(start, iter(sorted(graph[start])))]
        path = [start]
        state[start] = 1
        while stack:
            node, it = stack[-1]
            nxt = next(it, None)
            if nxt is None:
                stack.pop()
                path.pop()
                state[node] = 2
                continue
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if nxt not in state:
                state[nxt] = 1
                path.append(nxt)
                stack.append((nxt, iter(sorted(graph.get(nxt, ())))))
    return None


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "..")
    header_of, files = modules(root)
    graph = {}
    for mod, paths in files.items():
        deps = graph.setdefault(mod, set())
        for p in paths:
            with open(p, encoding="utf-8") as f:
                for inc in INCLUDE.findall(f.read()):
                    dep = header_of.get(inc)
                    if dep is not None and dep != mod:
                        deps.add(dep)
    if len(graph) < 5:
        print("layering: found only %d modules under %s: the check would prove nothing" %
              (len(graph), root))
        return 1
    cycle = find_cycle(graph)
    if cycle:
        print("layering: include cycle: " + " -> ".join(cycle))
        return 1
    print("layering: %d firmware modules, no include cycle" % len(graph))
    return 0


if __name__ == "__main__":
    sys.exit(main())
