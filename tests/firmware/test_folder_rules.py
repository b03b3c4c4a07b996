#!/usr/bin/env python3
"""Each top-level folder keeps its rule (docs/explanation/architecture.md, README "Layout").

For every C/C++ file of the folders below: which of our folders its #includes reach, and whether floating point (`float`, `double`, a floating literal) appears once
comments, strings and character literals are stripped. Floating point is allowed only
in pose/ (the camera pose pipeline), hostlib/, host_sim/, twin/ and tests/; pose/ includes
nothing of ours but itself, and only host_sim/camera/ and tests/ include pose/.
Every violation is printed as file:line: what; any violation fails.
Usage: test_folder_rules.py [REPO_ROOT]
"""
import os
import re
import sys

# Folder (or sub-folder: the longest prefix wins) -> our folders it may include besides
# its own. tests/ may include anything; it is not listed.
MAY_INCLUDE = {
    "hal": set(),
    "estimator": set(),
    "pose": set(),
    "drivers": {"hal"},
    "sim": {"hal"},
    "trace": set(),
    "firmware": {"hal", "drivers", "estimator"},
    "boards": {"hal", "drivers", "estimator", "firmware", "sim", "trace"},
    "hostlib": {"hal", "drivers", "estimator", "firmware", "sim", "trace"},
    "host_sim": {"hal", "drivers", "estimator", "firmware", "sim", "trace", "hostlib"},
    "host_sim/camera": {"hal", "drivers", "estimator", "firmware", "sim", "trace", "hostlib",
                        "pose"},
    "twin": {"hal", "drivers", "estimator", "firmware", "sim", "trace", "hostlib"},
}
FLOAT_ALLOWED = {"pose", "hostlib", "host_sim", "twin", "tests"}
SOURCE_EXT = (".c", ".h", ".cpp", ".hpp", ".cc")

INCLUDE = re.compile(r'^[ \t]*#[ \t]*include[ \t]*(?:"([^"]+)"|<([^>]+)>)', re.M)
FLOAT_WORD = re.compile(r"\b(float|double)\b")
# A decimal floating constant (1.5, .5f, 2e3, 1.f) or a hexadecimal one (0x1p-3);
# not part of an identifier or a pp-number like a version 1.2.3 inside #if.
FLOAT_LITERAL = re.compile(
    r"(?<![\w.])(?:\d+\.\d*(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?|\d+[eE][+-]?\d+"
    r"|0[xX][0-9a-fA-F]*\.?[0-9a-fA-F]*[pP][+-]?\d+)[fFlL]?(?![\w.])")


def strip(text):
    """The text with comments, string and character literals blanked (newlines kept,
    so line numbers hold). Returns (code, code_with_strings): the second keeps string
    literals, for the #include lines."""
    out, keep = [], []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            keep.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            blank = re.sub(r"[^\n]", " ", text[i:j])
            out.append(blank)
            keep.append(blank)
            i = j
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(c + re.sub(r"[^\n]", " ", text[i + 1:j - 1]) + c)
            keep.append(text[i:j])
            i = j
        else:
            out.append(c)
            keep.append(c)
            i += 1
    return "".join(out), "".join(keep)


def top(rel):
    return rel.split("/", 1)[0]


def rule_key(rel):
    """The MAY_INCLUDE key governing a file: its longest folder prefix listed."""
    parts = rel.split("/")
    for k in range(len(parts) - 1, 0, -1):
        key = "/".join(parts[:k])
        if key in MAY_INCLUDE:
            return key
    return None


def source_files(root):
    folders = set(MAY_INCLUDE) | FLOAT_ALLOWED
    for folder in sorted({top(f) for f in folders}):
        for d, dirs, names in os.walk(os.path.join(root, folder)):
            dirs[:] = sorted(x for x in dirs if not x.startswith("build"))
            for name in sorted(names):
                if name.endswith(SOURCE_EXT):
                    yield os.path.relpath(os.path.join(d, name), root).replace(os.sep, "/")


def header_index(root, files):
    """include spelling -> set of files it may name: paths below every include/ dir,
    and every header by its base name (sources in src/ folders include siblings and
    board headers by name through their include paths)."""
    by_inc, by_base = {}, {}
    for rel in files:
        if not rel.endswith((".h", ".hpp")):
            continue
        parts = rel.split("/")
        for k, p in enumerate(parts[:-1]):
            if p == "include":
                by_inc.setdefault("/".join(parts[k + 1:]), set()).add(rel)
        by_base.setdefault(parts[-1], set()).add(rel)
    return by_inc, by_base


def resolve(rel, inc, by_inc, by_base, files):
    """Our file(s) an #include "inc" in file rel names, or an empty set (a system or
    generated header)."""
    local = os.path.normpath(os.path.join(os.path.dirname(rel), inc)).replace(os.sep, "/")
    if local in files:
        return {local}
    if inc in by_inc:
        return by_inc[inc]
    if "/" not in inc:
        return by_base.get(inc, set())
    return set()


def check(root):
    files = list(source_files(root))
    fileset = set(files)
    by_inc, by_base = header_index(root, files)
    bad = []
    for rel in files:
        with open(os.path.join(root, rel), encoding="utf-8", errors="replace") as f:
            code, with_strings = strip(f.read())
        folder = top(rel)
        key = rule_key(rel)
        if key is not None:
            allowed = MAY_INCLUDE[key] | {folder}
            for m in INCLUDE.finditer(with_strings):
                if m.group(1) is not None:
                    targets = resolve(rel, m.group(1), by_inc, by_base, fileset)
                else:  # <...>: ours only if it names a header below one of our include/ dirs
                    targets = by_inc.get(m.group(2), set())
                inc = m.group(1) or m.group(2)
                # a name several folders define is ours if one of them is allowed
                if targets and not any(top(t) in allowed for t in targets):
                    line = with_strings.count("\n", 0, m.start()) + 1
                    owners = ", ".join(sorted({top(t) + "/" for t in targets}))
                    bad.append("%s:%d: includes \"%s\" of %s; %s/ may include %s" % (
                        rel, line, inc, owners, key,
                        ", ".join(sorted(a + "/" for a in allowed))))
        if folder not in FLOAT_ALLOWED:
            for no, text in enumerate(code.split("\n"), 1):
                if text.lstrip().startswith("#") and not re.search(r"#\s*define", text):
                    continue  # #if/#include/#line: no floating point can live there
                m = FLOAT_WORD.search(text) or FLOAT_LITERAL.search(text)
                if m:
                    bad.append("%s:%d: floating point ('%s') in %s/, which is fixed point"
                               % (rel, no, m.group(0), folder))
    return files, bad


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "..")
    files, bad = check(os.path.abspath(root))
    if len(files) < 50:
        print("folder rules: found only %d source files under %s: the check would prove nothing"
              % (len(files), root))
        return 1
    for b in bad:
        print(b)
    if bad:
        print("folder rules: %d violation(s) (docs/explanation/architecture.md; README, Layout)" % len(bad))
        return 1
    print("folder rules: %d files, includes point down, floating point only in %s"
          % (len(files), ", ".join(sorted(f + "/" for f in FLOAT_ALLOWED))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
