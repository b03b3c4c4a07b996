#!/usr/bin/python3
"""The misuse a user of the calibration procedure commits, each answered by one line naming
its cause and a non-zero exit status (or, where the action is legitimate, a note saying what
it means), never a traceback, never a silent acceptance. The unit is the twin on a
pseudo-terminal (tof_twin --pty), as in run_procedure.py.

    run_misuse.py TOF_TWIN FIRMWARE.elf HOST_SIM REPO WORKDIR

Each case prints `ok NAME`; the first that fails stops the run with the command's output.
"""

import os
import re
import shutil
import signal
import subprocess
import sys
import time

PY = "/usr/bin/python3"
OFFSETS = "# offset_mm=1.5,-0.8,-1.2,0.6\n# offset_sd_mm=0.03,0.03,0.03,0.03\n"


def fail(msg):
    sys.exit("run_misuse: FAIL: " + msg)


def check(name, cmd, rc, pattern, where="stderr", absent=None):
    """Run cmd: exit status rc, `pattern` (a regex) in its stderr or stdout, no traceback."""
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired:
        fail("%s: no end within 120 s: %s" % (name, " ".join(cmd)))
    text = p.stderr if where == "stderr" else p.stdout
    why = []
    if p.returncode != rc:
        why.append("exit %d, expected %d" % (p.returncode, rc))
    if "Traceback" in p.stderr + p.stdout:
        why.append("a traceback")
    if pattern is not None and not re.search(pattern, text):
        why.append("no /%s/ in its %s" % (pattern, where))
    if absent is not None and re.search(absent, p.stderr + p.stdout):
        why.append("/%s/ should not appear" % absent)
    if why:
        fail("%s: %s\n$ %s\n--- stdout\n%s--- stderr\n%s" % (name, "; ".join(why),
                                                              " ".join(cmd), p.stdout, p.stderr))
    print("ok %s" % name)
    return p


def head_cal(path, extra="", checksum=True):
    sys.path.insert(0, os.path.join(REPO, "tools"))
    import tof_calibration
    text = "# tof-head-cal v1\n" + OFFSETS + extra
    with open(path, "w") as f:
        f.write(tof_calibration.with_checksum(text) if checksum else text)
    return path


def section_hex(path):
    import tof_calibration
    with open(path) as f:
        return tof_calibration.head_cal_to_section(f.read(), path).hex()


class Unit:
    def __init__(self, trace, name, flash_in=None):
        cmd = [TWIN, ELF, trace, "--pty", "--flash-out", os.path.join(WORK, name + ".flash")]
        if flash_in:
            cmd += ["--flash-in", flash_in]
        self.err = open(os.path.join(WORK, name + ".err"), "w")
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=self.err, text=True)
        first = self.proc.stdout.readline().split()
        if len(first) != 2 or first[0] != "pty":
            self.proc.kill()
            fail("%s: no 'pty PATH' line" % name)
        self.path = first[1]

    def tool(self, *args):
        return [PY, TOOL, "--port", self.path] + list(args)

    def stop(self):
        self.proc.send_signal(signal.SIGTERM)
        rc = self.proc.wait(timeout=60)
        self.err.close()
        if rc != 0:
            fail("tof_twin exit %d after SIGTERM" % rc)


def main():
    global TWIN, ELF, REPO, WORK, TOOL
    TWIN, ELF, host_sim, REPO, WORK = sys.argv[1:6]
    TOOL = os.path.join(REPO, "tools", "tof_telemetry.py")
    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK)
    w = lambda name: os.path.join(WORK, name)
    good = head_cal(w("good.cal"), "# arm_mm=30\n")

    # --- HEAD.cal files that cannot be half-read: every tool refuses them alike ---------
    with open(good) as f:
        text = f.read()
    with open(w("cut.cal"), "w") as f:
        f.write(text[:-7])  # cut inside its last line
    with open(w("edited.cal"), "w") as f:
        f.write(text.replace("offset_mm=1.5", "offset_mm=2.5"))
    with open(w("binary.cal"), "wb") as f:
        f.write(b"# tof-head-cal v1\n\x00\x01\x02\xff")
    # the demo recording's first 150 rows (its calibration keys kept): short twin runs
    with open(os.path.join(REPO, "traces", "demo", "realnoise_demo.csv")) as f:
        rows = f.readlines()
    head = [x for x in rows if x.startswith("#")]
    demo = w("demo_short.csv")
    with open(demo, "w") as f:
        f.writelines(head + rows[len(head):len(head) + 151])
    for bad, pattern in (("cut.cal", r"cut.cal:\d+: the last line has no line end: the file "
                                     r"was cut"),
                         ("edited.cal", r"edited.cal:\d+(:\d+)?: checksum crc32:\w+ does not "
                                        r"match the content before it"),
                         ("binary.cal", r"binary.cal:2(:\d+)?: NUL byte")):
        check("send_cal_" + bad, [PY, TOOL, "--write-commands", w("x.bin"), "--send-cal",
                                  w(bad)], 1, pattern)
        check("host_sim_" + bad, [host_sim, "replay", demo, "--calibration", w(bad), "--out",
                                  w("x.csv")], 1, pattern)
        check("twin_" + bad, [TWIN, ELF, demo, "--calibration", w(bad), "--out", w("x.csv")], 1,
              pattern)
    v1 = head_cal(w("v1.cal"), checksum=False)
    check("v1_without_checksum_warns", [PY, TOOL, "--write-commands", w("x.bin"), "--send-cal",
                                        v1], 0, r"v1.cal: no checksum line .*read as it stands")

    # --- options the tool must not take silently --------------------------------------
    check("file_with_send_cal", [PY, TOOL, "--file", w("x.bin"), "--send-cal", good], 1,
          r"a capture file \(--file .*\) cannot be sent to")
    check("cal_budget_0", [PY, TOOL, "--write-commands", w("x.bin"), "--send-cal", good,
                           "--cal-budget-ms", "0"], 2,
          r"--cal-budget-ms 0: a timing budget is 1\.\.65535 ms")
    short = head_cal(w("short.cal"), "# distance_mode=short\n# timing_budget_ms=15\n")
    check("cal_mode_against_file", [PY, TOOL, "--write-commands", w("x.bin"), "--send-cal",
                                    short, "--cal-mode", "long"], 1,
          r"short.cal:4: distance_mode=short, but --cal-mode long")
    check("cal_budget_against_file", [PY, TOOL, "--write-commands", w("x.bin"), "--send-cal",
                                      short, "--cal-budget-ms", "33"], 1,
          r"short.cal:5: timing_budget_ms=15, but --cal-budget-ms 33")
    big = head_cal(w("big.cal"), "# timing_budget_ms=70000\n")
    check("range_names_value_and_range", [PY, TOOL, "--write-commands", w("x.bin"),
                                          "--send-cal", big], 1,
          r"big.cal:4: timing_budget_ms 70000 is outside 1\.\.65535")

    # --- a capture holding a reboot: a restart, not 255 lost frames ---------------------
    run = subprocess.run([TWIN, ELF, demo, "--out", w("x.csv"), "--uart-out", w("cap.bin")],
                         capture_output=True)
    if run.returncode != 0:
        fail("capture run: %s" % run.stderr.decode())
    with open(w("cap.bin"), "rb") as f:
        cap = f.read()
    with open(w("cap2.bin"), "wb") as f:
        f.write(cap + cap)  # the unit restarted after its first 3 s
    check("reboot_in_capture", [PY, TOOL, "--file", w("cap2.bin")], 0,
          r"# reboots=1 \(the unit restarted", absent=r"lost_frames")

    # --- calibrate: a fit whose scatter says the geometry is wrong ----------------------
    fixture = w("fixture.csv")
    subprocess.run([host_sim, "scenario", "fixture", "--seed", "3", "--trace-out", fixture],
                   check=True, capture_output=True)
    with open(fixture) as f:
        wrong = f.read().replace("# arm_mm=30\n", "# arm_mm=40\n")
    with open(w("wrong_arm.csv"), "w") as f:
        f.write(wrong)
    check("calibrate_wrong_arm", [host_sim, "calibrate", w("wrong_arm.csv"), "--out",
                                  w("wrong.cal")], 1,
          r"sensor A: scatter ratio \d+\.\d over \d+ dof; its station means fit an arm of "
          r"(29|30)\.\d+ mm \(\d+\.\d sd from the trace's arm_mm 40")
    if os.path.exists(w("wrong.cal")):
        fail("calibrate_wrong_arm: wrote %s" % w("wrong.cal"))

    # --- the twin's --calibration and storage -------------------------------------------
    for cal, state in (("head_long.cal", "other-mode"), ("head_other_parts.cal", "other-parts")):
        check("twin_calibration_refused_" + state,
              [TWIN, ELF, demo, "--calibration", os.path.join(REPO, "tests", "twin", cal),
               "--out", w("x.csv")], 0,
              r"warning: .*%s: not applied by the flight image's boot \(calibration=%s\)"
              % (cal, state))
    blank = w("blank.flash")
    with open(blank, "wb") as f:
        f.write(b"\xff" * 8192)  # erased record and age pages (TWIN_RECORDS_SIZE)
    check("twin_trace_keys_kept_off_storage",
          [TWIN, ELF, demo, "--flash-in", blank, "--out", w("x.csv")], 0,
          r"the trace's calibration keys are not written over the unit's storage")
    check("twin_calibration_written_says_so",
          [TWIN, ELF, demo, "--flash-in", blank, "--calibration", good, "--out", w("x.csv")],
          0, r"--calibration .*good.cal written into the unit's storage")

    # --- the unit over its serial line ----------------------------------------------------
    with open(fixture) as f:
        lines = f.readlines()
    meta = [x for x in lines if x.startswith("#")]
    body = [x for x in lines if not x.startswith("#")]
    station = w("station.csv")
    with open(station, "w") as f:
        f.writelines(meta + body[:1] + body[1:750])  # the header and the first station
    unit = Unit(station, "unit")
    check("read_cal_none", unit.tool("--read-cal", w("back.cal")), 1,
          r"--read-cal: the unit holds no calibration \(state=none\): nothing written")
    for key, result in (("# head_id=17\n", "other-head"),
                        ("# distance_mode=long\n", "other-mode"),
                        ("# timing_budget_ms=33\n", "other-budget")):
        cal = head_cal(w(result + ".cal"), key)
        check("send_cal_" + result, unit.tool("--send-cal", cal), 1,
              r"nack %s(, error -?\d+ \S+)?: the calibration was made " % result)
    hexed = bytearray.fromhex(section_hex(good))
    hexed[8] = 3  # distance mode byte 3: no mode
    check("send_cal_mode_byte_3", unit.tool("--send", "write-calibration " + hexed.hex()), 1,
          r"nack out-of-range")
    arm40 = head_cal(w("arm40.cal"), "# arm_mm=40\n")
    check("send_cal_other_arm", unit.tool("--send-cal", arm40), 1,
          r"arm40.cal:4: arm_mm=40, but the unit's arm is 30\.000 mm \(other-arm\)")
    p = check("send_cal_good", unit.tool("--send-cal", good), 0,
              r"read back: state=applied", where="stdout")
    if "names no head (head_id) and no parts" not in p.stderr:
        fail("send_cal_good: no note that a HEAD.cal naming no head cannot be told from "
             "another head's:\n" + p.stderr)
    check("write_during_rezero_busy",
          unit.tool("--send", "re-zero 100", "--send", "write-calibration " + section_hex(good)),
          1, r"nack busy: a re-zero or a record write is in progress")
    time.sleep(3.0)  # the re-zero's 100 samples at 20 ms
    check("set_arm_says_other_arm", unit.tool("--send", "set-arm 40", "--duration", "0.3"), 0,
          r"'set-arm 40' acknowledged; the unit's calibration no longer holds "
          r"\(calibration=other-arm\)")
    check("status_other_arm", unit.tool("--send", "status", "--duration", "0.3"), 0,
          r"calibration=other-arm", where="stdout")
    check("set_arm_back_applied", unit.tool("--send", "set-arm 30", "--send", "status",
                                            "--duration", "0.3"), 0,
          r"calibration=applied", where="stdout", absent=r"no longer holds")
    # a thermal calibration: saved by the flight image, read back byte for byte (--send-cal
    # compares), its keys back in the HEAD.cal --read-cal writes; a coefficient beyond
    # 1 mm/C refused by the unit's decoder; the status line says the unit's temperature
    thermal = head_cal(w("thermal.cal"), "# cal_temp_c=21.5\n"
                                         "# temp_coeff_mm_per_c=0.021,-0.008,0,-1\n"
                                         "# temp_coeff_sd_mm_per_c=0.0015,0.0009,0.002,1\n")
    check("send_cal_thermal", unit.tool("--send-cal", thermal), 0, r"read back: state=applied",
          where="stdout")
    check("read_cal_thermal", unit.tool("--read-cal", w("thermal_back.cal")), 0,
          r"calibration state=applied", where="stdout")
    with open(w("thermal_back.cal")) as f:
        back = f.read()
    if ("# cal_temp_c=21.50\n" not in back
            or "# temp_coeff_mm_per_c=0.021000,-0.008000,0.000000,-1.000000\n" not in back
            or section_hex(w("thermal_back.cal")) != section_hex(thermal)):
        fail("read_cal_thermal: the HEAD.cal read back is not the one sent:\n" + back)
    hexed = bytearray.fromhex(section_hex(thermal))
    hexed[4 + 82 + 8:4 + 82 + 12] = (1000001).to_bytes(4, "little")  # sensor B: 1.000001 mm/C
    check("send_cal_thermal_coeff_beyond", unit.tool("--send", "write-calibration " + hexed.hex()),
          1, r"nack out-of-range")
    check("status_says_the_temperature", unit.tool("--send", "status", "--duration", "0.3"), 0,
          r"status .* temp_c=(none|-?\d+\.\d\d)\n", where="stdout")
    unit.stop()

    # --- every tool's --help: complete, exit status 0 ------------------------------------
    with open(os.path.join(REPO, "twin", "tool", "tof_twin_args.c")) as f:
        options = set(re.findall(r'"(--[a-z0-9-]+)"', f.read()))
    p = check("tof_twin_help", [TWIN, "--help"], 0, r"usage: tof_twin", where="stdout")
    missing = sorted(o for o in options if o not in p.stdout)
    if missing:
        fail("tof_twin --help does not list %s" % ", ".join(missing))
    p = check("host_sim_help", [host_sim, "--help"], 0, None, where="stdout")
    for o in ("--calibration", "--distance-mode", "--command"):
        if o not in p.stdout + p.stderr:
            fail("host_sim --help does not list replay's %s" % o)
    print("misuse: every case answered with its cause and exit status")


if __name__ == "__main__":
    main()
