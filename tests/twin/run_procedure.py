#!/usr/bin/python3
"""The head's calibration procedure (docs/how-to/calibrate-a-head.md) run through the tools, with the twin
on a pseudo-terminal standing in for the board (tof_twin --pty):

1. a fixture trace (host_sim scenario fixture): a head whose parts have offsets and gains;
2. each station: the unit powered with the fixture at that station (the twin on that
   station's rows, its storage carried by --flash-in/--flash-out), and
   `tof_telemetry.py --port PTY --record-station CAL.csv --station A,B,D`;
3. `host_sim calibrate CAL.csv --out HEAD.cal`;
4. `tof_telemetry.py --port PTY --send-cal HEAD.cal`, then `--send save`;
5. a reset (the twin restarted on its flash image): `--read-cal BACK.cal` holds what was sent,
   `--send status` says calibration=applied;
6. the unit's rows on a recording seen through that head (tools/head_trace.py) equal host_sim
   replay's with --calibration HEAD.cal, byte for byte, and some are `ok`.
Every command over the line is acknowledged within 50 ms of simulated time.

    run_procedure.py TOF_TWIN FIRMWARE.elf HOST_SIM REPO WORKDIR
"""

import csv
import json
import os
import shutil
import signal
import subprocess
import sys

READINGS = 100
STATIONS = 6  # the fixture's first six: distances 95..200 mm, attitudes up to 10 degrees
ACK_LIMIT_US = 50000
PY = "/usr/bin/python3"


def fail(msg):
    sys.exit("run_procedure: FAIL: " + msg)


def run(cmd, expect_rc=0, what=None):
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired:
        fail("%s: no end within 120 s" % (what or " ".join(cmd)))
    if p.returncode != expect_rc:
        fail("%s: exit %d (expected %d)\n%s%s" % (what or " ".join(cmd), p.returncode,
                                                  expect_rc, p.stdout, p.stderr))
    return p


class Unit:
    """The twin on a pseudo-terminal: started, its PATH read, stopped by SIGTERM."""

    def __init__(self, twin, elf, trace, work, name, flash_in=None):
        self.report = os.path.join(work, name + ".json")
        self.flash_out = os.path.join(work, name + ".flash")
        self.err_path = os.path.join(work, name + ".err")
        cmd = [twin, elf, trace, "--pty", "--report", self.report, "--flash-out",
               self.flash_out]
        if flash_in:
            cmd += ["--flash-in", flash_in]
        self.err = open(self.err_path, "w")
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=self.err, text=True)
        first = self.proc.stdout.readline().split()
        if len(first) != 2 or first[0] != "pty":
            self.proc.kill()
            fail("%s: first line on stdout is %r, not 'pty PATH'" % (name, first))
        self.path = first[1]
        self.name = name

    def tool(self, *args, expect_rc=0):
        return run([PY, TOOL, "--port", self.path] + list(args), expect_rc,
                   "%s: tof_telemetry.py %s" % (self.name, " ".join(args)))

    def stop(self):
        self.proc.send_signal(signal.SIGTERM)
        rc = self.proc.wait(timeout=60)
        self.err.close()
        with open(self.err_path) as f:
            err = f.read()
        if rc != 0:
            fail("%s: tof_twin exit %d after SIGTERM\n%s" % (self.name, rc, err))
        with open(self.report) as f:
            rep = json.load(f)
        if rep["pty_answered"] != rep["pty_commands"] or rep["pty_commands"] == 0:
            fail("%s: %d commands over the line, %d answered" % (self.name, rep["pty_commands"],
                                                                  rep["pty_answered"]))
        if rep["pty_ack_latency_max_us"] > ACK_LIMIT_US:
            fail("%s: an answer %d us after its command (limit %d)"
                 % (self.name, rep["pty_ack_latency_max_us"], ACK_LIMIT_US))
        if rep["hardfaults"] or rep["watchdog_resets"]:
            fail("%s: %d HardFaults, %d watchdog resets" % (self.name, rep["hardfaults"],
                                                            rep["watchdog_resets"]))
        print("%s: %d commands, ack latency max %d us, mean %d us, %.2f s slept"
              % (self.name, rep["pty_commands"], rep["pty_ack_latency_max_us"],
                 rep["pty_ack_latency_mean_us"], rep["pty_slept_s"]))
        return rep


def stations_of(path):
    """The fixture trace's metadata lines, header, and its stations (runs of rows with the
    same truth) as (alpha, beta, distance, rows)."""
    meta, header, out = [], None, []
    with open(path) as f:
        for line in f:
            if line.startswith("#"):
                meta.append(line)
            elif header is None:
                header = line
            else:
                truth = tuple(line.rstrip("\n").split(",")[9:12])
                if not truth[0]:
                    continue  # moving between stations
                if out and out[-1][0] == truth:
                    out[-1][1].append(line)
                else:
                    out.append((truth, [line]))
    return meta, header, out


def main():
    global TOOL
    twin, elf, host_sim, repo, work = sys.argv[1:6]
    TOOL = os.path.join(repo, "tools", "tof_telemetry.py")
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    fixture = os.path.join(work, "fixture.csv")
    run([host_sim, "scenario", "fixture", "--seed", "3", "--trace-out", fixture])
    meta, header, stations = stations_of(fixture)
    cal_trace = os.path.join(work, "cal.csv")
    flash = None
    for k, ((alpha, beta, dist), rows) in enumerate(stations[:STATIONS]):
        trace = os.path.join(work, "station%d.csv" % k)
        with open(trace, "w") as f:
            f.writelines(meta + [header] + rows)
        unit = Unit(twin, elf, trace, work, "station%d" % k, flash)
        p = unit.tool("--record-station", cal_trace, "--station",
                      "%s,%s,%s" % (alpha, beta, dist), "--readings", str(READINGS),
                      "--arm-mm", "30", "--period-ms", "20")
        if "%d rows appended" % READINGS not in p.stdout:
            fail("station %d: %s" % (k, p.stdout))
        unit.stop()
        flash = unit.flash_out
    head_cal = os.path.join(work, "HEAD.cal")
    p = run([host_sim, "calibrate", cal_trace, "--out", head_cal])
    print(p.stderr.strip())

    unit = Unit(twin, elf, trace, work, "send", flash)
    p = unit.tool("--send-cal", head_cal)
    if "read back: state=applied" not in p.stdout:
        fail("--send-cal: %s" % p.stdout)
    unit.tool("--send", "save", "--duration", "0.2")
    unit.stop()

    unit = Unit(twin, elf, trace, work, "reset", unit.flash_out)
    back = os.path.join(work, "BACK.cal")
    p = unit.tool("--read-cal", back)
    if "calibration state=applied" not in p.stdout:
        fail("--read-cal after the reset: %s" % p.stdout)
    p = unit.tool("--send", "status", "--duration", "0.2")
    if "calibration=applied" not in p.stdout:
        fail("status after the reset: %s" % p.stdout)
    rep = unit.stop()
    if rep["calibration_state"] != 1:
        fail("the boot's status frame: calibration state %d, not applied (1)"
             % rep["calibration_state"])
    sys.path.insert(0, os.path.join(repo, "tools"))
    import tof_calibration
    with open(head_cal) as f:
        sent = tof_calibration.head_cal_to_section(f.read(), head_cal)
    with open(back) as f:
        got = tof_calibration.head_cal_to_section(f.read(), back)
    if sent != got:
        fail("the calibration read back after the reset differs from HEAD.cal:\n%s\n%s"
             % (sent.hex(), got.hex()))

    seen = os.path.join(work, "seen.csv")
    run([PY, os.path.join(repo, "tools", "head_trace.py"), fixture,
         os.path.join(repo, "traces", "demo", "realnoise_demo.csv"), seen])
    twin_est = os.path.join(work, "twin_est.csv")
    host_est = os.path.join(work, "host_est.csv")
    run([twin, elf, seen, "--flash-in", unit.flash_out, "--out", twin_est, "--report",
         os.path.join(work, "rows.json")])
    run([host_sim, "replay", seen, "--estimator", "consensus", "--calibration", head_cal,
         "--out", host_est])
    # The unit keeps the calibration's age across resets (firmware/cal_age.h) and adds the
    # off allowance at each boot, so its sd carries more walk than host_sim's (whose head was
    # calibrated at its start); the estimates, statuses and reasons are host_sim's exactly.
    with open(twin_est) as a, open(host_est) as b:
        rows_a, rows_b = list(csv.DictReader(a)), list(csv.DictReader(b))
    same = ("t_ms", "alpha_deg", "beta_deg", "distance_mm", "status", "why")
    sds = ("alpha_sd_deg", "beta_sd_deg", "distance_sd_mm")
    if len(rows_a) != len(rows_b) or any(
            ra[k] != rb[k] for ra, rb in zip(rows_a, rows_b) for k in same) or any(
            float(ra[k] or 0) < float(rb[k] or 0) for ra, rb in zip(rows_a, rows_b) for k in sds):
        fail("the unit's rows differ from host_sim's with HEAD.cal (%s, %s)"
             % (twin_est, host_est))
    ok = sum(1 for row in rows_a if row["status"] == "ok")
    rows = len(rows_a)
    if ok == 0 or rows == 0:
        fail("%d rows, %d ok: the calibration did not take" % (rows, ok))
    print("procedure: %d stations, HEAD.cal sent, saved, read back equal after a reset, "
          "status applied; %d rows equal host_sim's, %d ok" % (STATIONS, rows, ok))


if __name__ == "__main__":
    main()
