#!/usr/bin/python3
"""tools/stack_check.py's indirect-call narrowing on a synthetic call graph.

A driver calls `t->ops->now_us(...)`; the sources store `clock_now` into `.now_us` and
`deep_callback` (a 1000-byte frame) into `.on_sample`. Narrowed, the time call reaches
only clock_now; every way the narrowing could be unsound must fall back to "any
address-taken function" and reach deep_callback.
"""
import os
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tools"))
import stack_check  # noqa: E402

DRIVER = "uint32_t now(const struct t *t) {\n    return t->ops->now_us(t->ctx);\n}\n"
# the same call site, its statement going on to a second indirect call
DRIVER_TWO_LINES = ("uint32_t now(const struct t *t) {\n    return t->ops->now_us(t->ctx,\n"
                    "        t->out->on_sample(t->ctx));\n}\n")
# ... or to a call through a function-pointer variable
DRIVER_VARIABLE = ("uint32_t now(const struct t *t, hook_fn hook) {\n"
                   "    return t->ops->now_us(hook(t->ctx));\n}\n")


# ... or to a call through a dereferenced pointer
DRIVER_DEREF = ("uint32_t now(const struct t *t, hook_fn *hook) {\n"
                "    return t->ops->now_us((*hook)(t->ctx));\n}\n")


def run(table_source, narrow=True, driver_text=DRIVER, static_deep=False, titled_deep=False):
    with tempfile.TemporaryDirectory() as d:
        driver = os.path.join(d, "driver.c")
        table = os.path.join(d, "table.c")
        with open(driver, "w") as f:
            f.write(driver_text)
            if static_deep:
                f.write("static void deep_callback(void) {\n}\n")
            elif titled_deep:
                f.write("void deep_callback(void) {\n}\n")
        with open(table, "w") as f:
            f.write(table_source)
        # static_deep: deep_callback is a static function of driver.c (title path:name),
        # so table.c's `.on_sample = deep_callback` names another function; titled_deep: a
        # global function of driver.c titled path:name (as an LTO build titles every one)
        deep = f"{driver}:deep_callback" if static_deep or titled_deep else "deep_callback"
        frames = {"main": 16, f"{driver}:now": 8, "clock_now": 4, deep: 1000}
        calls = {"main": [(f"{driver}:now", f"{driver}:1:1")],
                 f"{driver}:now": [("__indirect_call", f"{driver}:2:12")]}
        sources = {f"{driver}:now": driver, "clock_now": table,
                   deep: driver if static_deep or titled_deep else table}
        stores = stack_check.member_stores(set(sources.values())) if narrow else None
        thread, _, _, errors = stack_check.analyse(
            frames, calls, ["main"], [], taken={"clock_now", "deep_callback"}, stores=stores,
            sources=sources)
        assert not errors, errors
        return thread["main"][0]


MAP = """Linker script and memory map

 .text.flash_read
                0x08000eac       0xb8 boards/x/CMakeFiles/fw.dir/__/stm32/stm32_flash.c.obj
 .text.window_end  0x08001000   0x40 estimator/libestimator_cortex-m4f.a(attitude.c.obj)
"""


def map_filter():
    """Two static functions of one name (the flight flash driver's and the simulated one's):
    only the one the map names the file of is in the image; a global name stays."""
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "image.map")
        with open(path, "w") as f:
            f.write(MAP)
        kept = stack_check.linked_functions(path)
        sources = {"/s/boards/stm32/stm32_flash.c:flash_read": "/s/boards/stm32/stm32_flash.c",
                   "/s/sim/src/sim_flash.c:flash_read": "/s/sim/src/sim_flash.c",
                   "window_end": "/s/estimator/src/attitude.c"}
        return sorted(f for f in sources if stack_check.is_linked(f, sources, kept))


def main():
    named = ("static const struct time_ops ops = {.now_us = clock_now};\n"
             "static const struct out_ops out = {.on_sample = deep_callback};\n")
    cases = [
        ("narrowed to the stored function", run(named), 16 + 8 + 4),
        ("not narrowed without --narrow", run(named, narrow=False), 16 + 8 + 1000),
        ("member also given an expression",
         run(named + "void f(struct x *x, struct y *y) { x->now_us = y->fn; }\n"), 16 + 8 + 1000),
        ("address-taken function stored under no name",
         run("static const struct time_ops ops = {.now_us = clock_now};\n"
             "void f(void) { attach(deep_callback); }\n"), 16 + 8 + 1000),
        ("statement going on to another member call",
         run(named, driver_text=DRIVER_TWO_LINES), 16 + 8 + 1000),
        ("statement calling through a variable", run(named, driver_text=DRIVER_VARIABLE),
         16 + 8 + 1000),
        ("statement calling through a dereferenced pointer",
         run(named, driver_text=DRIVER_DEREF), 16 + 8 + 1000),
        ("static function stored only under its name in another file",
         run(named, static_deep=True), 16 + 8 + 1000),
        ("global function titled path:name, stored in another file's table",
         run(named, titled_deep=True), 16 + 8 + 4),
    ]
    cases.append(("the map tells same-named static functions apart", map_filter(),
                  ["/s/boards/stm32/stm32_flash.c:flash_read", "window_end"]))
    failed = 0
    for name, got, want in cases:
        ok = got == want
        failed += not ok
        print(f"{'ok' if ok else 'FAIL'}: {name}: worst {got} bytes (expected {want})")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
