#!/usr/bin/python3
"""tools/image_budget.py charges a map's sections to the right parts, and
tools/stack_check.py --min-free-percent fails an image whose stack margin is too small."""
import os
import subprocess
import sys
import tempfile

TOOLS = os.path.join(os.path.dirname(__file__), "..", "..", "tools")
sys.path.insert(0, TOOLS)
import image_budget  # noqa: E402

# .text: 0x40 estimator + 0x10 board + 0x4 libgcc + 0x2 fill + a string section listed at
# 0x10 that the linker merged to 0xc (the output section says 0x62 in all);
# .data: 8 firmware bytes (flash and RAM); .bss: 0x20 firmware; .stack 0x800.
MAP = """Discarded input sections

 .text.unused   0x00000000       0x99 estimator/libestimator_cortex-m4f.a(attitude.c.obj)

Linker script and memory map

.text           0x08000000       0x62
 .text.window_end  0x08000000   0x40 estimator/libestimator_cortex-m4f.a(attitude.c.obj)
 .text.flash_read
                0x08000040       0x10 boards/x/CMakeFiles/fw.dir/__/stm32/stm32_flash.c.obj
 .text          0x08000050        0x4 /usr/lib/gcc/arm-none-eabi/12.2.1/thumb/libgcc.a(_dvmd_tls.o)
 *fill*         0x08000054        0x2 
 .rodata.main.str1.1
                0x08000056       0x10 firmware/libfirmware_cortex-m4f.a(app.c.obj)

.stack          0x20000000      0x800
 *fill*         0x20000000      0x800 

.data           0x20000800        0x8 load address 0x0800006c
 .data.x        0x20000800        0x8 firmware/libfirmware_cortex-m4f.a(link.c.obj)

.bss            0x20000808       0x20
 .bss.app       0x20000808       0x20 firmware/libfirmware_cortex-m4f.a(app.c.obj)
"""

CI = ('graph: { title: "/s/main.c"\n'
      'node: { title: "Reset_Handler" label: "Reset_Handler\\n/s/main.c:1:1\\n{n} bytes (static)" }\n'
      '}\n')


def budget():
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "fw.map")
        with open(path, "w") as f:
            f.write(MAP)
        by = {}
        for (part, _), (flash, ram) in image_budget.parse(path).items():
            by[part] = (by.get(part, (0, 0))[0] + flash, by.get(part, (0, 0))[1] + ram)
        return by


def stack_margin(frame, limit, percent):
    with tempfile.TemporaryDirectory() as d:
        with open(os.path.join(d, "main.c.ci"), "w") as f:
            f.write(CI.replace("{n}", str(frame)))
        return subprocess.run(
            [sys.executable, os.path.join(TOOLS, "stack_check.py"), "--root", d, "--limit",
             str(limit), "--min-free-percent", str(percent), "--entry", "Reset_Handler",
             "--handler", "none"], capture_output=True, text=True).returncode


def main():
    by = budget()
    cases = [
        ("estimator code", by.get("estimator"), (0x40, 0)),
        ("a board object", by.get("boards"), (0x10, 0)),
        ("libgcc", by.get("libgcc"), (4, 0)),
        ("firmware: strings, .data in flash and RAM, .bss", by.get("firmware"),
         (0x10 + 8, 8 + 0x20)),
        ("the merge settled against the output section", by.get("merged strings"), (-4, 0)),
        ("the reserved stack", by.get("stack (reserved)"), (0, 0x800)),
        ("discarded sections not counted",
         sum(v[0] for v in by.values()), 0x62 + 8),
        ("75 % used of the stack passes a 25 % margin", stack_margin(768, 1024, 25), 0),
        ("76 % used fails it", stack_margin(776, 1024, 25), 1),
        ("within the reserve but no margin asked passes", stack_margin(1000, 1024, 0), 0),
    ]
    failed = 0
    for name, got, want in cases:
        ok = got == want
        failed += not ok
        print(f"{'ok' if ok else 'FAIL'}: {name}: {got} (expected {want})")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
