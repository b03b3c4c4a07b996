#!/usr/bin/env python3
"""The code's shape, checked (the developers' guide, "Style"):

- every .c file opens with a one-line comment saying what it is;
- in code that ships in a firmware image (FIRMWARE_DIRS), no file over 600 lines and no
  function over 80 lines (from the line of its name to its closing brace);
- no call loop between files (A calls a function defined in B and B, directly or through
  others, calls one defined in A) in LOOP_FREE_DIRS: calls point down the layers;
- tests are sorted by component only: every folder directly under tests/ is named after a
  component (a top-level code folder, or a sub-folder of one with its own CMakeLists.txt,
  like hostlib/scene or firmware/telemetry), tests/tools (the project's tools and the
  docs checked against the code) or tests/common (helpers every test may use). Unit, fuzz, reference and bench are ctest labels, not folders.

A light C reader, not a compiler: comments, strings and preprocessor lines are blanked,
functions are the brace blocks at file scope whose head ends in a parameter list, and a
call is an identifier followed by '(' inside a body that names a non-static function
defined in another .c file (a static function of the calling file shadows it). Calls
through pointers (ops structs) are not calls here, by design: that is how a lower layer
is handed a service without naming the file above it.

Usage: structure_check.py [REPO_ROOT]   (exit status 1 and file:line on every finding)
"""
import os
import re
import sys

FIRMWARE_DIRS = ["estimator", "drivers", "hal", "firmware", "boards", "sim", "trace"]
LOOP_FREE_DIRS = ["estimator", "drivers", "hal", "firmware", "boards", "sim", "trace", "pose",
                  "twin", "hostlib", "host_sim"]
CODE_DIRS = LOOP_FREE_DIRS + ["tests", "tools"]
MAX_FILE_LINES = 600
MAX_FUNCTION_LINES = 80

KEYWORDS = {"if", "for", "while", "switch", "return", "sizeof", "_Static_assert", "do",
            "else", "case", "defined", "_Alignof", "alignof", "__attribute__", "typeof",
            "__typeof__", "static_assert", "_Generic", "asm", "__asm__"}
IDENT_CALL = re.compile(r"\b([A-Za-z_]\w*)\s*\(")


def blank(text):
    """Comments, string and character literals and preprocessor lines replaced by spaces,
    newlines kept, so offsets and line numbers stay those of the file."""
    out = list(text)
    i, n = 0, len(text)
    at_line_start = True
    while i < n:
        c = text[i]
        if at_line_start and c == "#":
            # a directive, with its continuation lines
            j = i
            while j < n and not (text[j] == "\n" and text[j - 1] != "\\"):
                j += 1
            for k in range(i, j):
                if out[k] != "\n":
                    out[k] = " "
            i = j
            continue
        if c == "\n":
            at_line_start = True
            i += 1
            continue
        if not c.isspace():
            at_line_start = False
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            for k in range(i, j):
                out[k] = " "
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            for k in range(i, j):
                if out[k] != "\n":
                    out[k] = " "
            i = j
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            for k in range(i, min(j + 1, n)):
                if out[k] != "\n":
                    out[k] = " "
            i = j + 1
        else:
            i += 1
    return "".join(out)


def functions(code):
    """(name, is_static, first_line, last_line, body) of every function defined at file
    scope in blanked code."""
    found = []
    depth = 0
    stmt_start = 0
    i, n = 0, len(code)
    while i < n:
        c = code[i]
        if c == "{":
            if depth == 0:
                head = code[stmt_start:i]
                m = re.search(r"([A-Za-z_]\w*)\s*\(([^()]|\([^()]*\))*\)\s*$", head)
                j = i
                d = 0
                while j < n:
                    if code[j] == "{":
                        d += 1
                    elif code[j] == "}":
                        d -= 1
                        if d == 0:
                            break
                    j += 1
                if m and m.group(1) not in KEYWORDS and "=" not in head[: m.start()]:
                    name = m.group(1)
                    first = code.count("\n", 0, stmt_start + m.start(1)) + 1
                    last = code.count("\n", 0, j) + 1
                    is_static = re.search(r"\bstatic\b", head[: m.start()]) is not None
                    found.append((name, is_static, first, last, code[i:j + 1]))
                i = j + 1
                stmt_start = i
                continue
            depth += 1
        elif c == "}":
            depth -= 1
        elif c == ";" and depth == 0:
            stmt_start = i + 1
        i += 1
    return found


def c_files(root, dirs):
    for top in dirs:
        base = os.path.join(root, top)
        for d, subdirs, names in os.walk(base):
            subdirs[:] = sorted(s for s in subdirs if s not in ("build", "corpus"))
            for name in sorted(names):
                if name.endswith((".c", ".h")):
                    yield os.path.relpath(os.path.join(d, name), root)


def first_line_is_comment(text):
    head = text.lstrip("\ufeff")
    return head.startswith("/*") or head.startswith("//")


def loops(graph):
    """Strongly connected components of more than one file (Tarjan, iterative)."""
    index, low, on_stack, stack, comps = {}, {}, set(), [], []
    counter = [0]
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, it = work[-1]
            nxt = next(it, None)
            if nxt is not None:
                if nxt not in index:
                    index[nxt] = low[nxt] = counter[0]
                    counter[0] += 1
                    stack.append(nxt)
                    on_stack.add(nxt)
                    work.append((nxt, iter(sorted(graph.get(nxt, ())))))
                elif nxt in on_stack:
                    low[node] = min(low[node], index[nxt])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                comp = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp.append(w)
                    if w == node:
                        break
                if len(comp) > 1:
                    comps.append(sorted(comp))
    return comps


def component_names(root):
    """Top-level code folders and their sub-folders that have a CMakeLists.txt."""
    names = set()
    for top in LOOP_FREE_DIRS:
        base = os.path.join(root, top)
        if not os.path.isdir(base):
            continue
        names.add(top)
        for sub in os.listdir(base):
            if os.path.isfile(os.path.join(base, sub, "CMakeLists.txt")):
                names.add(sub)
    return names


HISTORY = re.compile(r"\b(?:[Ii]ssues?|[Ss]essions?|[Rr]ounds?) #?\d+|\bsession\b")
HISTORY_EXT = (".c", ".h", ".cpp", ".py", ".sh", ".cmake", ".txt", ".md")


def history_findings(root):
    found = []
    for top in CODE_DIRS + ["docs", "cmake", "traces", "boards"]:
        base = os.path.join(root, top)
        for d, subdirs, names in os.walk(base):
            subdirs[:] = sorted(s for s in subdirs if s not in ("build", "corpus"))
            for name in sorted(names):
                if not name.endswith(HISTORY_EXT) and name != "CMakeLists.txt":
                    continue
                path = os.path.join(d, name)
                rel = os.path.relpath(path, root)
                if rel in (os.path.join("tools", "structure_check.py"),
                           os.path.join("tools", "docs_figures.py"),
                           os.path.join("tools", "tests", "test_structure_check.py")):
                    continue  # the checkers name the pattern they look for
                with open(path, encoding="utf-8", errors="replace") as f:
                    for no, line in enumerate(f, 1):
                        if HISTORY.search(line):
                            found.append(f"{rel}:{no}: narrates history: {line.strip()[:80]}")
    readme = os.path.join(root, "README.md")
    if os.path.isfile(readme):
        with open(readme, encoding="utf-8") as f:
            for no, line in enumerate(f, 1):
                if HISTORY.search(line):
                    found.append(f"README.md:{no}: narrates history: {line.strip()[:80]}")
    return found


def test_folder_findings(root):
    tests = os.path.join(root, "tests")
    if not os.path.isdir(tests):
        return []
    allowed = component_names(root) | {"common", "tools"}
    return [f"tests/{d}:1: a test folder not named after a component (tests/<component>/; "
            "kinds of test are ctest labels)"
            for d in sorted(os.listdir(tests))
            if os.path.isdir(os.path.join(tests, d)) and d not in allowed]


def main():
    if any(a in ("--help", "-h") for a in sys.argv[1:]):
        print(__doc__.strip())
        return 0
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else
                           os.path.join(os.path.dirname(__file__), ".."))
    findings = test_folder_findings(root) + history_findings(root)
    parsed = {}
    for rel in c_files(root, CODE_DIRS):
        with open(os.path.join(root, rel), encoding="utf-8") as f:
            text = f.read()
        top = rel.split(os.sep)[0]
        if rel.endswith(".c") and not first_line_is_comment(text):
            findings.append(f"{rel}:1: does not open with a comment saying what the file is")
        if top in FIRMWARE_DIRS:
            lines = text.count("\n")
            if lines > MAX_FILE_LINES:
                findings.append(f"{rel}:{lines}: {lines} lines, over {MAX_FILE_LINES} "
                                "(firmware code: split it by idea)")
        if rel.endswith(".c") and top in LOOP_FREE_DIRS:
            fns = functions(blank(text))
            parsed[rel] = fns
            if top in FIRMWARE_DIRS:
                for name, _, first, last, _ in fns:
                    length = last - first + 1
                    if length > MAX_FUNCTION_LINES:
                        findings.append(f"{rel}:{first}: function {name} has {length} lines, "
                                        f"over {MAX_FUNCTION_LINES}")
    # Which file defines each non-static function. A name defined in two files (two
    # images' implementations of one interface, e.g. boards/) is ambiguous: not an edge.
    defined_in = {}
    for rel, fns in parsed.items():
        for name, is_static, *_ in fns:
            if not is_static:
                defined_in.setdefault(name, set()).add(rel)
    graph = {rel: set() for rel in parsed}
    for rel, fns in parsed.items():
        local = {name for name, *_ in fns}
        for *_, body in fns:
            for call in IDENT_CALL.findall(body):
                if call in local or call in KEYWORDS:
                    continue
                owners = defined_in.get(call, ())
                if len(owners) == 1:
                    (owner,) = owners
                    if owner.split(os.sep)[0] == rel.split(os.sep)[0]:
                        graph[rel].add(owner)
    for comp in loops(graph):
        edges = [f"{a} -> {b}" for a in comp for b in sorted(graph[a]) if b in comp]
        findings.append(f"{comp[0]}:1: call loop between files: " + "; ".join(edges))
    for f in findings:
        print(f)
    if findings:
        print(f"structure_check: {len(findings)} finding(s)", file=sys.stderr)
        return 1
    print(f"structure_check: {len(parsed)} files, no finding")
    return 0


if __name__ == "__main__":
    sys.exit(main())
