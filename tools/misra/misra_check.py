#!/usr/bin/python3
"""MISRA C:2012 gate of the `analyze` target (cmake/TofAnalyze.cmake).

cppcheck's MISRA addon writes its findings one per line as
    <file>:<line>:<column>:<id>        (--template='{file}:{line}:{column}:{id}')
This script reads that file, applies the project's documented deviations
(tools/misra/deviations.txt; reasons in docs/explanation/reliability.md, "MISRA C:2012")
and fails, naming file, line, column and rule, on every finding no deviation
covers. It also fails when cppcheck reported a non-MISRA error (for example a
syntax error or a crashed addon), since then the MISRA results are incomplete.

A deviation covers a finding when its rule matches, the file matches its glob
(relative to the source root) and the flagged source line matches its regular
expression ('*' = any line). Deviations that cover nothing are reported, so the
list stays short and true.

    misra_check.py --root SRC --deviations FILE --findings FILE
"""
import argparse
import fnmatch
import os
import re
import sys


def load_deviations(path):
    """Rows of (id, rule, file glob, compiled line regex or None) from the deviations file."""
    rows = []
    with open(path, encoding="utf-8") as f:
        for number, raw in enumerate(f, 1):
            line = raw.strip()
            if not line or line.startswith("#"):
                continue
            parts = [p.strip() for p in line.split("|", 3)]  # the regex may hold "|"
            if len(parts) != 4:
                sys.exit(f"{path}:{number}:1: expected 'id | rule | file glob | line regex', "
                         f"got {len(parts)} fields")
            dev_id, rule, glob, regex = parts
            if not re.fullmatch(r"\d+\.\d+", rule):
                sys.exit(f"{path}:{number}:1: rule '{rule}' is not a MISRA C:2012 rule number")
            try:
                compiled = None if regex == "*" else re.compile(regex)
            except re.error as err:
                sys.exit(f"{path}:{number}:1: bad regular expression '{regex}': {err}")
            rows.append((dev_id, rule, glob, compiled))
    return rows


def source_line(root, rel, number, cache):
    if rel not in cache:
        try:
            with open(os.path.join(root, rel), encoding="utf-8", errors="replace") as f:
                cache[rel] = f.read().split("\n")
        except OSError:
            cache[rel] = []
    lines = cache[rel]
    return lines[number - 1] if 0 < number <= len(lines) else ""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", required=True, help="source root the file names are relative to")
    ap.add_argument("--deviations", required=True)
    ap.add_argument("--findings", required=True, help="cppcheck output, one finding per line")
    args = ap.parse_args()

    root = os.path.realpath(args.root)
    deviations = load_deviations(args.deviations)
    used = {d[0]: 0 for d in deviations}
    cache = {}
    finding_re = re.compile(r"^(?P<file>.+?):(?P<line>\d+):(?P<col>\d+):\s*(?P<id>[\w.-]+)$")
    violations = []
    other = []
    total = 0
    if not os.path.exists(args.findings):
        sys.exit(f"misra: {args.findings} missing: did cppcheck run?")
    with open(args.findings, encoding="utf-8", errors="replace") as f:
        for raw in f:
            text = raw.rstrip("\n")
            if not text.strip():
                continue
            m = finding_re.match(text)
            if not m:
                other.append(text)
                continue
            path = os.path.realpath(m.group("file"))
            rel = os.path.relpath(path, root)
            number = int(m.group("line"))
            ident = m.group("id")
            if not ident.startswith("misra-c2012-"):
                other.append(f"{rel}:{number}:{m.group('col')}: {ident}")
                continue
            total += 1
            rule = ident[len("misra-c2012-"):]
            code = source_line(root, rel, number, cache)
            for dev_id, dev_rule, glob, regex in deviations:
                if dev_rule == rule and fnmatch.fnmatch(rel, glob) and (
                        regex is None or regex.search(code)):
                    used[dev_id] += 1
                    break
            else:
                violations.append(f"{rel}:{number}:{m.group('col')}: MISRA C:2012 rule {rule} "
                                  f"(no deviation applies): {code.strip()}")

    for v in sorted(set(violations)):
        print(v)
    for o in other:
        print(f"cppcheck: {o}")
    summary = ", ".join(f"{k}: {v}" for k, v in used.items())
    print(f"misra: {total} findings, {len(set(violations))} not covered; covered by deviation: "
          f"{summary}")
    unused = [k for k, v in used.items() if v == 0]
    if unused:
        print(f"misra: note: deviations covering nothing now: {', '.join(unused)}")
    return 1 if violations or other else 0


if __name__ == "__main__":
    sys.exit(main())
