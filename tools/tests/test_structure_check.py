#!/usr/bin/env python3
"""tools/structure_check.py can fail: a tree with one planted finding of each kind is
reported with each finding, and the same tree without them passes."""
import os
import subprocess
import sys
import tempfile

CHECK = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "structure_check.py")


def write(root, rel, text):
    path = os.path.join(root, rel)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)


def run(root):
    p = subprocess.run([sys.executable, CHECK, root], capture_output=True, text=True)
    return p.returncode, p.stdout


def clean_tree(root):
    write(root, "estimator/src/low.c", "/* The bottom. */\nint low(int x) { return x + 1; }\n")
    write(root, "estimator/src/high.c",
          "/* The top: calls down. */\nint low(int x);\nint high(int x) { return low(x); }\n")
    write(root, "tests/estimator/test_low.c", "/* A test of low(). */\nint t(void) { return 0; }\n")
    write(root, "tests/common/helper.c", "/* A helper every test may use. */\nint h(void);\n")
    write(root, "twin/models/model.c",
          "/* A model, handed its service by pointer. */\n"
          "struct svc { int (*now)(void); };\n"
          "int model_tick(const struct svc *s) { return s->now(); }\n")


def main():
    failures = []
    with tempfile.TemporaryDirectory() as root:
        clean_tree(root)
        rc, out = run(root)
        if rc != 0:
            failures.append(f"clean tree flagged:\n{out}")
        # each planted finding, in its own copy of the clean tree
        planted = {
            "first line": ("firmware/src/nohead.c", "#include <stdint.h>\nint f(void) { return 0; }\n",
                           "does not open with a comment"),
            "long file": ("drivers/x/long.c", "/* Long. */\n" +
                          "".join(f"int v{i};\n" for i in range(650)), "over 600"),
            "long function": ("sim/src/longfn.c", "/* Long function. */\nint g(void) {\n" +
                              "    int a = 0;\n" * 90 + "    return a;\n}\n",
                              "function g has"),
            "test folder by kind": ("tests/unit/test_x.c", "/* A test. */\nint x(void);\n",
                                    "not named after a component"),
            "history": ("estimator/src/told.c", "/* Added for issue 12. */\nint told(void);\n",
                        "narrates history"),
            "call loop": ("estimator/src/low.c",
                          "/* Calls back up. */\nint high(int x);\n"
                          "int low(int x) { return x > 0 ? high(x - 1) : 0; }\n",
                          "call loop between files"),
        }
        for name, (rel, text, expect) in planted.items():
            with tempfile.TemporaryDirectory() as case:
                clean_tree(case)
                write(case, rel, text)
                rc, out = run(case)
                if rc == 0 or expect not in out:
                    failures.append(f"{name}: expected '{expect}', got rc {rc}:\n{out}")
    for f in failures:
        print("FAIL", f)
    print(f"structure_check self-test: {len(planted) + 1 - len(failures)} of {len(planted) + 1} cases")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
