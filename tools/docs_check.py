#!/usr/bin/env python3
"""Checks the docs against the code: their shell blocks run, their options exist.

    tools/docs_check.py commands [--build-root DIR] [--keep]
    tools/docs_check.py help [--build-root DIR]

commands: every fenced ```sh block of docs/**/*.md and README.md runs with bash -e in a
scratch folder that sees the repository's build/, tools/ and traces/ (the blocks of one
page run in order in one folder, so a later block can use an earlier one's files). A block
right after a line `<!-- docs-check: skip REASON -->` is not run and the reason is printed;
so is a block that configures, builds or runs ctest or tools/test.sh (the suite this is
part of), and one that names a build product that is not there (which preset to build is
printed). A block running tools/demo.sh runs in the repository itself (it writes out/). Exit status 1 if a block fails (its output and the command are printed), 77 if
every block was skipped.

help: each tool's options and subcommands are taken from its own --help, and
- every command line in a code block or inline code span that starts with a known tool
  (`host_sim SUB`, `$H SUB`, `tof_twin`, `tools/NAME.py`, ...) may use only that tool's
  options;
- docs/reference/tools.md names, per tool section, exactly the options --help gives;
- its scenario list equals `host_sim scenario --help`'s, and host_sim's subcommands named
  anywhere exist;
- every command in docs/how-to/command-the-unit.md's command table is accepted by
  `tools/tof_telemetry.py --send`;
- every relative link points at a file that exists and, with a #fragment, at a heading.
A tool that is not built (tof_twin without the twin preset) is skipped with a line saying
so. Exit status 1 on any mismatch, each printed as file:line: what.
"""
import argparse
import glob
import os
import re
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PY = "/usr/bin/python3"
SKIP = re.compile(r"^<!-- docs-check: skip (.+) -->$")
OPT = re.compile(r"(?<![\w-])(--[a-z0-9][a-z0-9-]*)")


def markdown_files():
    files = sorted(glob.glob(os.path.join(ROOT, "docs", "**", "*.md"), recursive=True))
    return files + [os.path.join(ROOT, "README.md")]


def rel(path):
    return os.path.relpath(path, ROOT)


def fenced_blocks(path):
    """(first line number, language, text, skip reason or None) per fenced block."""
    with open(path) as f:
        lines = f.read().split("\n")
    out, i = [], 0
    while i < len(lines):
        m = re.match(r"^```(\w*)\s*$", lines[i])
        if not m:
            i += 1
            continue
        lang, start = m.group(1), i
        j = i + 1
        while j < len(lines) and not lines[j].startswith("```"):
            j += 1
        if j == len(lines):
            sys.exit("%s:%d: a code block that is never closed" % (rel(path), start + 1))
        reason = None
        k = start - 1
        while k >= 0 and not lines[k].strip():
            k -= 1
        if k >= 0:
            s = SKIP.match(lines[k].strip())
            if s:
                reason = s.group(1)
        out.append((start + 1, lang, "\n".join(lines[start + 1:j]), reason))
        i = j + 1
    return out


# ---------------------------------------------------------------------------- commands

BUILD_PATH = re.compile(r"(build/[A-Za-z0-9_./-]+)")


def missing_build_product(text, build_root):
    for m in BUILD_PATH.finditer(text):
        p = m.group(1).rstrip(".")
        parts = p.split("/")
        # only the build products a block runs (an executable or an input it reads)
        if len(parts) < 3 or "*" in p:
            continue
        full = os.path.join(build_root, *parts[1:])
        if not os.path.exists(full):
            return "%s is not built (cmake --build --preset %s)" % (p, parts[1])
    return None


def automatic_skip(text):
    """Why a block is not run without a marker: it would build, or recurse into the suite."""
    if re.search(r"(^|[\s;&|])tools/test\.sh", text):
        return "runs tools/test.sh, the whole suite this check is part of"
    if re.search(r"(^|[\s;&|(])(cmake|ctest) ", text):
        return "configures or builds a preset, or runs ctest (tools/test.sh does both)"
    return None


def cmd_commands(a):
    ran = skipped = failed = 0
    for path in markdown_files():
        blocks = [b for b in fenced_blocks(path) if b[1] in ("sh", "bash", "shell")]
        if not blocks:
            continue
        work = tempfile.mkdtemp(prefix="docs_check_")
        try:
            for name in ("tools", "traces"):
                os.symlink(os.path.join(ROOT, name), os.path.join(work, name))
            os.symlink(a.build_root, os.path.join(work, "build"))
            for line, _, text, reason in blocks:
                where = "%s:%d" % (rel(path), line)
                if reason is None:
                    reason = automatic_skip(text)
                demo = re.search(r"(^|[\s;&|])tools/demo\.sh", text) is not None
                if reason is None and demo and not os.access(os.path.join(
                        a.build_root, "host-release", "host_sim", "app", "host_sim"), os.X_OK):
                    reason = "tools/demo.sh builds host-release's host_sim, which is not built"
                if reason is None and demo and os.path.abspath(a.build_root) != os.path.join(
                        ROOT, "build"):
                    reason = "tools/demo.sh uses the repository's own build/"
                if reason is None:
                    reason = missing_build_product(text, a.build_root)
                if reason is not None:
                    print("SKIPPED %s: %s" % (where, reason))
                    skipped += 1
                    continue
                # tools/demo.sh works in the repository (its build/ and out/): only there
                r = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", text],
                                   cwd=ROOT if demo else work,
                                   capture_output=True, text=True, timeout=600)
                ran += 1
                if r.returncode != 0:
                    failed += 1
                    print("FAILED %s (exit %d):\n%s\n--- stdout:\n%s--- stderr:\n%s" % (
                        where, r.returncode, text, r.stdout[-3000:], r.stderr[-3000:]))
                else:
                    print("ran %s" % where)
        finally:
            if a.keep:
                print("kept %s" % work)
            else:
                shutil.rmtree(work)
    print("docs_check commands: %d block(s) ran, %d failed, %d skipped" % (ran, failed, skipped))
    if failed:
        return 1
    return 77 if ran == 0 else 0


# ---------------------------------------------------------------------------- help

class Tools:
    """Each tool's --help text, run once; None for a tool that is not built."""

    def __init__(self, build_root):
        self.build_root = build_root
        self.cache = {}
        self.host_sim = None
        for preset in ("host-release", "host"):
            p = os.path.join(build_root, preset, "host_sim", "app", "host_sim")
            if os.access(p, os.X_OK):
                self.host_sim = p
                break
        self.skipped = set()

    def find(self, presets, name):
        """A program in a preset's build tree, wherever its CMake folder puts it."""
        for preset in presets:
            tree = os.path.join(self.build_root, preset)
            for d, subdirs, files in os.walk(tree):
                subdirs[:] = [x for x in subdirs if x != "CMakeFiles"]
                if name in files and os.access(os.path.join(d, name), os.X_OK):
                    return os.path.join(d, name)
        return None

    def argv(self, tool):
        if tool.startswith("host_sim"):
            if self.host_sim is None:
                return None
            sub = tool.split()[1:] if " " in tool else []
            return [self.host_sim] + sub + ["--help"]
        if tool in ("tof_twin", "bench_estimator"):
            p = self.find(("twin",) if tool == "tof_twin" else ("host-release", "host"), tool)
            return [p, "--help"] if p else None
        return [PY, os.path.join(ROOT, "tools", tool), "--help"]

    def help(self, tool):
        if tool not in self.cache:
            argv = self.argv(tool)
            if argv is None:
                self.cache[tool] = None
            else:
                r = subprocess.run(argv, capture_output=True, text=True, timeout=60)
                if r.returncode != 0:
                    sys.exit("docs_check: %s exits %d on --help:\n%s" % (
                        " ".join(argv), r.returncode, r.stderr))
                self.cache[tool] = r.stdout
        if self.cache[tool] is None and tool not in self.skipped:
            self.skipped.add(tool)
            print("SKIPPED %s: not built, its options are not checked" % tool)
        return self.cache[tool]

    def options(self, tool):
        """The options the help offers: those of its usage lines and of its lines that
        begin with an option (not ones its prose mentions, e.g. another tool's)."""
        h = self.help(tool)
        if h is None:
            return None
        found, in_usage = set(), False
        for line in h.split("\n"):
            if re.match(r"^\s*usage:", line):
                in_usage = True
            elif in_usage and not re.match(r"^\s{2,}\S", line):
                in_usage = False
            if in_usage or re.match(r"^\s*(-\w, )?--", line):
                found.update(OPT.findall(line if in_usage else re.split(r"\s{2,}|: ", line.strip())[0]))
        return found - {"--help"}


# Tools whose --help lists their options (argparse or a hand-written usage text).
PY_TOOLS = ("tof_telemetry.py", "head_trace.py", "demo_seeds.py", "docs_figures.py",
            "docs_check.py", "stack_check.py", "twin_coverage.py", "bench_report.py")


def host_sim_subcommands(tools):
    h = tools.help("host_sim")
    if h is None:
        return None
    return set(re.findall(r"^\s*host_sim ([a-z]+) ", h, re.M)) - {"SUBCOMMAND"}


TOOL_AT = re.compile(
    r"(?:^|[\s`(])(?:\S*/)?(host_sim|\$H|tof_twin|bench_estimator|"
    + "|".join(re.escape(t) for t in PY_TOOLS) + r")(?=[\s`]|$)")


def command_uses(text):
    """(tool, options, offset) for every tool invocation in a command text."""
    out = []
    for m in TOOL_AT.finditer(text):
        tool = m.group(1)
        rest = text[m.end():]
        rest = re.split(r"\||&&|;|\s#|`|\)", rest, maxsplit=1)[0]
        if tool in ("host_sim", "$H"):
            w = rest.split()
            if not w or not re.match(r"^[a-z]+$", w[0]):
                continue
            tool = "host_sim " + w[0]
            rest = rest.split(w[0], 1)[1]
        opts = [o for o in OPT.findall(rest)]
        out.append((tool, opts, m.start()))
    return out


def doc_command_texts(path):
    """(line, text) of every command line: code blocks (with continuations joined) and
    inline code spans."""
    with open(path) as f:
        lines = f.read().split("\n")
    out, in_fence, indented = [], False, False
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("```"):
            in_fence = not in_fence
            i += 1
            continue
        if in_fence or line.startswith("    "):
            text, start = line, i
            while text.rstrip().endswith("\\") and i + 1 < len(lines):
                i += 1
                text = text.rstrip()[:-1] + " " + lines[i]
            out.append((start + 1, re.split(r"(^|\s)#\s", text, maxsplit=1)[0]))
        else:
            for m in re.finditer(r"`([^`]+)`", line):
                out.append((i + 1, m.group(1)))
        i += 1
    return out


def tools_md_sections(path):
    """{tool: (line, set of options in its tables' first column)} of docs/reference/tools.md."""
    with open(path) as f:
        lines = f.read().split("\n")
    sections, tool = {}, None
    for n, line in enumerate(lines, 1):
        h = re.match(r"^#{2,3} `([^`]+)`", line)
        if h:
            name = h.group(1)
            name = name.replace("tools/", "")
            tool = name if (name.startswith("host_sim ") or name in ("tof_twin",) + PY_TOOLS) \
                else None
            if tool:
                sections[tool] = (n, set())
            continue
        if line.startswith("#"):
            tool = None
        if tool and line.startswith("| `"):
            first = line.split("|")[1]
            sections[tool][1].update(OPT.findall(first))
    return sections


TELEMETRY_EXAMPLES = {
    "set-window": "set-window 50 sliding", "estimator": "estimator kalman", "start": "start",
    "stop": "stop", "status": "status", "raw": "raw on", "process-noise": "process-noise auto",
    "set-arm": "set-arm 30", "set-period": "set-period 20", "save": "save",
    "read-calibration": "read-calibration", "re-zero": "re-zero 100",
}


def check_telemetry_commands(problems):
    path = os.path.join(ROOT, "docs", "how-to", "command-the-unit.md")
    with open(path) as f:
        lines = f.read().split("\n")
    seen = 0
    for n, line in enumerate(lines, 1):
        m = re.match(r"^\| `([a-z-]+)[^|]*\|", line)
        if not m:
            continue
        verbs = re.findall(r"`([a-z][a-z-]*)[^`]*`", line.split("|")[1])
        for verb in verbs:
            if verb == "write-calibration":
                print("SKIPPED %s:%d: write-calibration takes a 168-digit record; --send-cal"
                      " is tested by unit.tof_calibration_py" % (rel(path), n))
                continue
            example = TELEMETRY_EXAMPLES.get(verb)
            if example is None:
                problems.append("%s:%d: command '%s' has no example in docs_check.py's"
                                " TELEMETRY_EXAMPLES (add one)" % (rel(path), n, verb))
                continue
            with tempfile.NamedTemporaryFile() as tmp:
                r = subprocess.run([PY, os.path.join(ROOT, "tools", "tof_telemetry.py"),
                                    "--write-commands", tmp.name, "--send", example],
                                   capture_output=True, text=True, timeout=60)
            seen += 1
            if r.returncode != 0:
                problems.append("%s:%d: tof_telemetry.py --send '%s' refused: %s" % (
                    rel(path), n, example, (r.stderr or r.stdout).strip()))
    if seen == 0:
        problems.append("%s: no command table found" % rel(path))


def anchor(heading):
    """GitHub's anchor of a Markdown heading."""
    h = heading.strip().lower()
    h = re.sub(r"[^\w\- ]", "", h)
    return h.replace(" ", "-")


def check_links(problems):
    """Every relative link of the docs points at a file that exists, and at a heading of it."""
    for path in markdown_files():
        with open(path) as f:
            text = f.read()
        for n, line in enumerate(text.split("\n"), 1):
            for m in re.finditer(r"\]\(([^)\s]+)\)", line):
                target = m.group(1)
                if re.match(r"^[a-z]+:", target):
                    continue
                file_part, _, frag = target.partition("#")
                full = os.path.normpath(os.path.join(os.path.dirname(path), file_part)) \
                    if file_part else path
                if not os.path.exists(full):
                    problems.append("%s:%d: link to %s: no such file" % (rel(path), n, target))
                    continue
                if frag and full.endswith(".md"):
                    with open(full) as g:
                        heads = {anchor(h) for h in re.findall(r"^#+ (.*)$", g.read(), re.M)}
                    if frag not in heads:
                        problems.append("%s:%d: link to %s: no heading '%s' there" % (
                            rel(path), n, target, frag))


def cmd_help(a):
    tools = Tools(a.build_root)
    problems = []
    check_links(problems)
    subs = host_sim_subcommands(tools)
    checked = 0
    for path in markdown_files():
        for line, text in doc_command_texts(path):
            for tool, opts, _ in command_uses(text):
                if tool.startswith("host_sim "):
                    if subs is None:
                        continue
                    if tool.split()[1] not in subs:
                        problems.append("%s:%d: host_sim has no subcommand '%s' (%s)" % (
                            rel(path), line, tool.split()[1], ", ".join(sorted(subs))))
                        continue
                known = tools.options(tool)
                if known is None:
                    continue
                for o in opts:
                    checked += 1
                    if o not in known:
                        problems.append("%s:%d: %s has no option %s (its --help: %s)" % (
                            rel(path), line, tool, o, " ".join(sorted(known))))
    ref = os.path.join(ROOT, "docs", "reference", "tools.md")
    for tool, (line, documented) in sorted(tools_md_sections(ref).items()):
        known = tools.options(tool)
        if known is None:
            continue
        for o in sorted(documented - known):
            problems.append("%s:%d: section %s names %s, which its --help does not give" % (
                rel(ref), line, tool, o))
        for o in sorted(known - documented):
            problems.append("%s:%d: section %s lacks %s, which its --help gives" % (
                rel(ref), line, tool, o))
        checked += 1
    h = tools.help("host_sim scenario")
    if h is not None:
        m = re.search(r"^scenarios: (.*)$", h, re.M)
        listed = set(m.group(1).split()) if m else set()
        with open(ref) as f:
            text = f.read()
        n = re.search(r"^Names: (.*?)\.$", text, re.M | re.S)
        documented = set(re.findall(r"`([a-z0-9-]+)`", n.group(1))) if n else set()
        if listed != documented:
            problems.append("%s: scenario names %s differ from host_sim scenario --help's %s"
                            % (rel(ref), sorted(documented), sorted(listed)))
    check_telemetry_commands(problems)
    for p in problems:
        print(p)
    print("docs_check help: %d option use(s) and sections checked, %d problem(s)" % (
        checked, len(problems)))
    return 1 if problems else 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("what", choices=("commands", "help"))
    ap.add_argument("--build-root", default=os.path.join(ROOT, "build"),
                    help="folder holding the presets' builds (default: build/)")
    ap.add_argument("--keep", action="store_true", help="commands: keep the scratch folders")
    a = ap.parse_args()
    a.build_root = os.path.abspath(a.build_root)
    sys.exit(cmd_commands(a) if a.what == "commands" else cmd_help(a))


if __name__ == "__main__":
    main()
