#!/usr/bin/env python3
"""The flight ELF's temperature path in the twin, strict: the trace's temp_c (a 20 -> 40 °C ramp
over the demo trace) reaches the firmware through the STM32L476 ADC model (twin_adc.c: only
the documented sequence converts), the firmware reads it every sample, and ST's temperature
update reruns on each part at each 8 °C as host_sim's does from the exact values: two per
part. The twin's EST.csv temp_c (the estimate frame's, the unit's reading) is the trace's
temperature of each window's last row within the ADC's quantisation: the two 12-bit
conversions' rounding at VDDA 3.3 V, at most 0.22 °C (tests/boards/test_stm32_adc_temp.c),
taken as 0.25 °C. The estimate rows equal host_sim's but in the windows of the reruns, where the
ADC-quantised temperature (one LSB ~0.26 °C) may cross 8 °C some rows from where the exact
one does: those windows must be the same in both and name the missing parts.

usage: check_twin_temperature.py TOF_TWIN HOST_SIM ELF DEMO_TRACE WORK_DIR
"""
import csv
import json
import os
import subprocess
import sys

twin, host_sim, elf, demo, work = sys.argv[1:6]
os.makedirs(work, exist_ok=True)
if not os.path.exists(elf):
    sys.exit("%s missing: build the m4 preset first" % elf)

lines = open(demo, encoding="utf-8").read().splitlines()
out, k, header_done = [], 0, False
temp_at_t = {}
for line in lines:
    if line.startswith("#"):
        out.append(line)
    elif not header_done:
        out.append(line + ",temp_c")
        header_done = True
    else:
        out.append(line + ",%.2f" % (20.0 + 0.004 * k))
        temp_at_t[line.split(",")[0]] = round(20.0 + 0.004 * k, 2)
        k += 1
trace = os.path.join(work, "ramp.csv")
with open(trace, "w", encoding="utf-8") as f:
    f.write("\n".join(out) + "\n")


def run(cmd):
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    if res.returncode != 0:
        sys.exit("%s failed (%d): %s" % (cmd[0], res.returncode, res.stderr[-2000:]))


def rows(path):
    with open(path, encoding="utf-8") as f:
        return list(csv.DictReader(f))


run([twin, elf, trace, "--strict", "--out", os.path.join(work, "twin.est.csv"),
     "--report", os.path.join(work, "twin.json")])
run([host_sim, "replay", trace, "--quiet", "--out", os.path.join(work, "host.est.csv"),
     "--report", os.path.join(work, "host.json")])
tw = json.load(open(os.path.join(work, "twin.json"), encoding="utf-8"))
hs = json.load(open(os.path.join(work, "host.json"), encoding="utf-8"))
failures = []
if not tw["finished"]:
    failures.append("the twin stopped: %s" % tw["stop"])
if abs(tw["adc_sensor_conversions"] - k) > 20 or tw["adc_temp_unknown"] > 20:
    failures.append("%d sensor conversions with a temperature, %d without, for %d rows"
                    % (tw["adc_sensor_conversions"], tw["adc_temp_unknown"], k))
if (tw["adc_first_temp_c"], tw["adc_last_temp_c"]) != (20.0, 40.0):
    failures.append("the ADC converted %.2f .. %.2f C, the trace runs 20 .. 40"
                    % (tw["adc_first_temp_c"], tw["adc_last_temp_c"]))
if tw["part_temp_updates"] != [2, 2, 2, 2] or hs["temperature"]["part_updates"] != [2, 2, 2, 2]:
    failures.append("temperature updates: twin %s, host_sim %s, expected two a part"
                    % (tw["part_temp_updates"], hs["temperature"]["part_updates"]))
cols = ["t_ms", "alpha_deg", "beta_deg", "distance_mm", "status", "alpha_sd_deg", "beta_sd_deg",
        "distance_sd_mm", "why"]
t_rows, h_rows = rows(os.path.join(work, "twin.est.csv")), rows(os.path.join(work, "host.est.csv"))
if len(t_rows) != len(h_rows):
    failures.append("%d twin rows, %d host_sim rows" % (len(t_rows), len(h_rows)))
differ = 0
for i, (a, b) in enumerate(zip(t_rows, h_rows)):
    a_missing = "missing:" in a["why"]
    if a_missing != ("missing:" in b["why"]):
        failures.append("window %d: missing readings in one tool only" % i)
    elif not a_missing and [a[c] for c in cols] != [b[c] for c in cols]:
        failures.append("window %d: twin %s, host_sim %s" % (i, a, b))
    differ += [a[c] for c in cols] != [b[c] for c in cols]
worst = 0.0
for a in t_rows:
    if a["temp_c"] == "":
        failures.append("t_ms %s: the twin's estimate has no temperature" % a["t_ms"])
        continue
    err = abs(float(a["temp_c"]) - temp_at_t[a["t_ms"]])
    worst = max(worst, err)
    if err > 0.25:
        failures.append("t_ms %s: the unit read %s C, the trace's row has %.2f"
                        % (a["t_ms"], a["temp_c"], temp_at_t[a["t_ms"]]))
print("twin temp_c against the trace: worst %.2f C over %d windows" % (worst, len(t_rows)))
if failures:
    sys.exit("\n".join(failures))
print("twin temperature: %d sensor conversions (%.2f .. %.2f C), updates %s as host_sim's; "
      "%d of %d windows differ, each a rerun's" % (tw["adc_sensor_conversions"],
                                                  tw["adc_first_temp_c"], tw["adc_last_temp_c"],
                                                  tw["part_temp_updates"], differ, len(t_rows)))
