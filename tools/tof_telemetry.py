#!/usr/bin/python3
"""Decode the ToF firmware's binary telemetry (docs/reference/telemetry-protocol.md).

Reads a serial port or a capture file, decodes every frame with the same
CRC-16/CCITT-FALSE and the same resynchronisation rule as the firmware's
decoder (firmware/telemetry/src/tlm_frame.c), prints one line per message (or
CSV), counts malformed frames, and optionally plots the estimates.

    tof_telemetry.py --file capture.bin [--csv [--type estimate|raw]] [--plot out.png]
    tof_telemetry.py --port /dev/ttyACM0 [--baud 115200] [--duration S] [--send CMD]...
    tof_telemetry.py --port /dev/ttyACM0 --live [--plot last.png]   (estimates with
                                                  +-2 sd bands, redrawn as frames arrive)
    tof_telemetry.py --write-commands cmds.bin --send CMD [--send CMD]...

--send sends its commands one at a time, in order: each waits for its ack or
nack (matched by the protocol's sequence number), a lost one is sent again with
the same sequence number (the firmware answers a repeat without applying it
twice), and a nack or no answer stops the tool with status 1 and a message that
names it (docs/reference/telemetry-protocol.md, "Commands from a host").

Commands for --send: "set-window N [tumbling|sliding]", "estimator NAME"
(consensus, consensus-paper, kalman, mean), "start", "stop", "status",
"raw on|off", "process-noise QD,QT|auto" (the Kalman filter's random-walk
intensities in mm^2/s, up to 6 decimals, as host_sim's --process-noise), "save"
(keep the settings in force across resets and power loss).

Run it with /usr/bin/python3 (Debian's, with python3-serial and
python3-matplotlib); the pyenv python3 on PATH has neither.
"""

import argparse
import os
import struct
import sys
import time

import tof_calibration

# --- protocol constants (docs/reference/telemetry-protocol.md; tlm_frame.h, tlm_messages.h) ----

SYNC0 = 0xA5
SYNC1 = 0x5A
HEADER_SIZE = 5
CRC_SIZE = 2
FRAME_OVERHEAD = HEADER_SIZE + CRC_SIZE
MAX_PAYLOAD = 192
PROTOCOL_VERSION = 7

ACCEPT_COMMANDS = 1
ACCEPT_TELEMETRY = 2
ACCEPT_ALL = 3

T_ESTIMATE = 0x01
T_RAW_SAMPLE = 0x02
T_HEALTH = 0x03
T_ACK = 0x04
T_STATUS = 0x05
T_SET_WINDOW = 0x81
T_SELECT_ESTIMATOR = 0x82
T_START = 0x83
T_STOP = 0x84
T_STATUS_REQUEST = 0x85
T_RAW_STREAM = 0x86
T_SET_PROCESS_NOISE = 0x87
T_SAVE = 0x88
T_SET_ARM = 0x89              # u32 arm_um: the head's arm a
T_SET_PERIOD = 0x8A           # u16 period_ms: the sample period
ARM_MIN_UM, ARM_MAX_UM = 1000, 1000000
PERIOD_MIN_MS, PERIOD_MAX_MS = 1, 10000
T_CALIBRATION = 0x10          # the answer to read-calibration
T_WRITE_CALIBRATION = 0x90    # record section 2, saved and put in force
T_READ_CALIBRATION = 0x91
T_REZERO = 0x92               # u16 samples: refit the offsets at the latched position
REZERO_MIN, REZERO_MAX = 10, 5000
CAL_SECTION_LEN = 118         # u8 id 2, u8 version 4, u16 114, the 114 bytes (tof_calibration.py)
# A temperature on the wire: u8 known (0, 1), i16 0.01 degC (0 when not known), -100..200 degC.
TEMP_MIN_CDEG, TEMP_MAX_CDEG = -10000, 20000

# type -> (name, direction, payload length)
TYPES = {
    T_ESTIMATE: ("estimate", ACCEPT_TELEMETRY, 50),
    T_RAW_SAMPLE: ("raw", ACCEPT_TELEMETRY, 17),
    T_HEALTH: ("health", ACCEPT_TELEMETRY, 148),
    T_ACK: ("ack", ACCEPT_TELEMETRY, 4),
    T_STATUS: ("status", ACCEPT_TELEMETRY, 30),
    T_SET_WINDOW: ("set-window", ACCEPT_COMMANDS, 3),
    T_SELECT_ESTIMATOR: ("select-estimator", ACCEPT_COMMANDS, 1),
    T_START: ("start", ACCEPT_COMMANDS, 0),
    T_STOP: ("stop", ACCEPT_COMMANDS, 0),
    T_STATUS_REQUEST: ("status-request", ACCEPT_COMMANDS, 0),
    T_RAW_STREAM: ("raw-stream", ACCEPT_COMMANDS, 1),
    T_SET_PROCESS_NOISE: ("set-process-noise", ACCEPT_COMMANDS, 9),
    T_SAVE: ("save", ACCEPT_COMMANDS, 0),
    T_SET_ARM: ("set-arm", ACCEPT_COMMANDS, 4),
    T_SET_PERIOD: ("set-period", ACCEPT_COMMANDS, 2),
    T_CALIBRATION: ("calibration", ACCEPT_TELEMETRY, 1 + CAL_SECTION_LEN),
    T_WRITE_CALIBRATION: ("write-calibration", ACCEPT_COMMANDS, CAL_SECTION_LEN),
    T_READ_CALIBRATION: ("read-calibration", ACCEPT_COMMANDS, 0),
    T_REZERO: ("re-zero", ACCEPT_COMMANDS, 2),
}

RESULTS = ["ok", "unknown-type", "bad-length", "out-of-range", "state", "other-head",
           "other-parts", "other-mode", "other-budget", "other-arm", "busy"]
R_OK, R_UNKNOWN_TYPE, R_BAD_LENGTH, R_OUT_OF_RANGE = 0, 1, 2, 3
ESTIMATORS = ["consensus", "consensus-paper", "kalman", "mean"]
STATUSES = ["ok", "degraded", "invalid"]
# The estimate's why set: the estimator's attitude_why_t bits, unchanged on the wire
# (estimator/integrity.h, estimator/attitude.h; named as attitude_why_format() names them).
WHY_PER_SENSOR = ["no-target", "range", "flagged", "missing", "rejected"]  # bit 4*g + k
WHY_WINDOW = ["parity", "motion", "drift"]                                 # bits 20..22
WHY_UNCALIBRATED_BIT = 23  # "uncalibrated": the head has no calibration
WHY_RECALIBRATE_BIT = 24  # "recalibrate": the drift shown exceeds the allowance
WHY_REASON_SHIFT = 32  # bit 32 + r for enum attitude_reason r (r = 0, "none", has no bit)
ATTITUDE_REASONS = [
    "none", "flagged-data", "sensor-missing", "kalman-restarted", "alpha-unobservable",
    "beta-unobservable", "unobservable", "disabled", "no-convergence", "paper-too-few-rows",
    "paper-nonpositive-variance", "paper-zero-covariance", "paper-zero-row-sum",
    "paper-negative-row-sum", "paper-overflow", "paper-diverged", "paper-no-convergence",
    "paper-outside-hull", "paper-inconsistent"]
HEALTH_STATES = ["healthy", "suspect", "lost", "recovering"]
MODES = ["tumbling", "sliding"]
# The status frame's record state: what the firmware found of its saved settings at boot
# (firmware/record.h enum tof_record_state).
RECORD_STATES = ["none", "loaded", "corrupt", "version", "rejected", "no-storage"]
# The status frame's calibration state: what the firmware found of the head's calibration
# at boot (firmware/calibration_record.h enum tof_cal_state); all but applied: uncalibrated.
CAL_STATES = ["none", "applied", "corrupt", "version", "other-head", "other-mode", "rejected",
              "no-storage", "other-parts", "other-budget", "other-arm"]
# the status frame's cal_age (protocol 6): how the calibration's age is known
CAL_AGE_STATES = ["none", "kept", "unknown", "failed"]
# What a refusal of the head's calibration means and what to do (a nack's result, or the
# status frame's calibration state).
CAUSES = {
    "other-head": "the calibration was made on another head (head_id differs): send this "
                  "head's HEAD.cal, or calibrate this head (docs/how-to/calibrate-a-head.md)",
    "other-parts": "the calibration was made with other parts (a part's NVM identity "
                   "differs: a sensor was replaced): calibrate the head again",
    "other-mode": "the calibration was made in another distance mode: calibrate in the "
                  "unit's mode, or give the file's distance_mode correctly",
    "other-budget": "the calibration was made at another timing budget (set-period changes "
                    "it): calibrate at the unit's period, or set-period back",
    "other-arm": "the calibration was made at another arm (arm_mm): set-arm back to the "
                 "calibration's arm, or calibrate at this arm",
    "busy": "a re-zero or a record write is in progress: wait for its answer (the "
            "calibration message, or the save's ack) and send again",
    "corrupt": "the section's values are out of range or do not add up",
    "version": "a section version this firmware does not read",
    "no-storage": "the board has no record storage",
    "rejected": "the estimator refused the values",
    "none": "no calibration stored: send one with --send-cal HEAD.cal",
}
SENSORS = "ABCD"
WINDOW_MIN, WINDOW_MAX = 2, 255
PROCESS_NOISE_AUTO = 0x01  # set-process-noise flags; every other bit is out of range
UM2_PER_MM2 = 1000000      # set-process-noise intensities travel in um^2/s (u32)
NO_VALUE = -(2 ** 31)  # INT32_MIN: "no value" in an int32 estimate field

COUNTER_NAMES = ["frames_ok", "bad_crc", "bad_length", "unknown_type", "truncated",
                 "out_of_range", "discarded_bytes"]


class ProtocolError(ValueError):
    """A message that cannot be encoded (a field out of range)."""


# --- CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, no xorout --

def _make_crc_table():
    table = []
    for byte in range(256):
        reg = byte << 8
        for _ in range(8):
            reg = ((reg << 1) ^ 0x1021) if reg & 0x8000 else (reg << 1)
        table.append(reg & 0xFFFF)
    return table


_CRC_TABLE = _make_crc_table()


def crc16(data, crc=0xFFFF):
    """CRC-16/CCITT-FALSE of `data`; crc16(b"123456789") == 0x29B1."""
    for byte in data:
        crc = ((crc << 8) & 0xFFFF) ^ _CRC_TABLE[((crc >> 8) ^ byte) & 0xFF]
    return crc


def encode_frame(ftype, seq, payload):
    """One frame: sync, length, type, seq, payload, CRC (little-endian)."""
    if len(payload) > MAX_PAYLOAD:
        raise ProtocolError("payload of %d bytes exceeds the maximum %d" % (len(payload), MAX_PAYLOAD))
    body = bytes([len(payload), ftype & 0xFF, seq & 0xFF]) + bytes(payload)
    return bytes([SYNC0, SYNC1]) + body + struct.pack("<H", crc16(body))


# --- streaming decoder: the same algorithm as tlm_frame.c -------------------

class Decoder:
    """Byte-stream to frames, resynchronising after garbage.

    feed() and flush() return a list of events: ("frame", type, seq, payload)
    for an accepted frame and ("reject", type, seq, length, result) for a
    CRC-valid frame refused for its type or length. Malformed input is
    counted in `counters` exactly as the firmware counts it.
    """

    def __init__(self, accept=ACCEPT_ALL):
        self.accept = accept
        self.window = bytearray()
        self.suspect_left = 0  # bytes of a CRC-failed frame's span still ahead
        self.counters = dict.fromkeys(COUNTER_NAMES, 0)

    def pending(self):
        return len(self.window)

    def _advance(self, count, discarded):
        del self.window[:count]
        if discarded:
            self.counters["discarded_bytes"] += count
        if self.suspect_left > 0:
            if count >= self.suspect_left:
                self.suspect_left = 0
                self.counters["bad_crc"] += 1
            else:
                self.suspect_left -= count

    def _examine(self, events):
        """Examine the candidate at the window start; False if it needs more bytes."""
        w = self.window
        if w[0] != SYNC0:
            self._advance(1, True)
            return True
        if len(w) < 2:
            return False
        if w[1] != SYNC1:
            self._advance(1, True)
            return True
        if len(w) < 3:
            return False
        length = w[2]
        if length > MAX_PAYLOAD:
            self.counters["bad_length"] += 1
            self._advance(1, True)
            return True
        size = length + FRAME_OVERHEAD
        if len(w) < size:
            return False
        crc_received = w[HEADER_SIZE + length] | (w[HEADER_SIZE + length + 1] << 8)
        if crc16(w[2:HEADER_SIZE + length]) != crc_received:
            # Corrupted, or cut short by the next frame: rescan its span to tell.
            self._advance(1, True)
            if self.suspect_left > 0:
                self.counters["bad_crc"] += 1
            self.suspect_left = size - 1
            return True
        if self.suspect_left > 0:
            # A genuine frame starts inside a CRC-failed one: that one was truncated.
            self.suspect_left = 0
            self.counters["truncated"] += 1
        ftype, seq = w[3], w[4]
        info = TYPES.get(ftype)
        if info is None or not (info[1] & self.accept):
            self.counters["unknown_type"] += 1
            events.append(("reject", ftype, seq, length, R_UNKNOWN_TYPE))
            self._advance(size, True)
            return True
        if info[2] != length:
            self.counters["bad_length"] += 1
            events.append(("reject", ftype, seq, length, R_BAD_LENGTH))
            self._advance(size, True)
            return True
        self.counters["frames_ok"] += 1
        events.append(("frame", ftype, seq, bytes(w[HEADER_SIZE:HEADER_SIZE + length])))
        self._advance(size, False)
        return True

    def _scan(self, events):
        while self.window and self._examine(events):
            pass

    def feed(self, data):
        events = []
        self.window.extend(data)
        self._scan(events)
        return events

    def flush(self):
        """End of stream or idle line: the pending partial frame was truncated."""
        events = []
        while self.window:
            if len(self.window) >= 2:
                self.counters["truncated"] += 1
            self._advance(1, True)
            self._scan(events)
        if self.suspect_left > 0:
            self.suspect_left = 0
            self.counters["bad_crc"] += 1
        return events


# --- message payloads: parse with the firmware's validation rules -----------

ESTIMATE_FORMAT = "<IIBBBiiiiiiiQBh"  # docs/reference/telemetry-protocol.md 5.1


def _temp_valid(known, cdeg):
    """A temperature's known byte is 0 or 1; known: within -100..200 degC; else 0."""
    return known in (0, 1) and (TEMP_MIN_CDEG <= cdeg <= TEMP_MAX_CDEG if known else cdeg == 0)


def _value_and_sd_agree(value, sd):
    """A value and its sd are present together; a present sd is >= 1, never 0."""
    return (value == NO_VALUE) == (sd == NO_VALUE) and (sd == NO_VALUE or sd >= 1)


def _estimate(p):
    (t_ms, window, estimator, status, sensors, alpha, beta, distance, flatness,
     alpha_sd, beta_sd, distance_sd, why, temp_known, temp_cdeg) = struct.unpack(ESTIMATE_FORMAT, p)
    ok = status == 0
    both = alpha != NO_VALUE and beta != NO_VALUE
    valid = (estimator < len(ESTIMATORS) and status < len(STATUSES) and not sensors & ~0x0F
             and _value_and_sd_agree(alpha, alpha_sd) and _value_and_sd_agree(beta, beta_sd)
             and _value_and_sd_agree(distance, distance_sd)
             and ok == (why == 0)
             and (not ok or (sensors == 0x0F and flatness != NO_VALUE and both
                             and distance != NO_VALUE))
             and (ok or (status == 2) == (not both))
             and _temp_valid(temp_known, temp_cdeg))
    return valid, {"t_ms": t_ms, "window": window, "estimator": estimator, "status": status,
                   "sensors": sensors, "alpha_udeg": alpha, "beta_udeg": beta,
                   "distance_um": distance, "flatness_um": flatness, "alpha_sd_udeg": alpha_sd,
                   "beta_sd_udeg": beta_sd, "distance_sd_um": distance_sd, "why": why,
                   "temp_known": temp_known, "temp_cdeg": temp_cdeg}


def _raw(p):
    fields = struct.unpack("<I4H4BB", p)
    t_ms, ranges, statuses, mask = fields[0], fields[1:5], fields[5:9], fields[9]
    valid = not mask & ~0x0F and all(
        mask & (1 << i) or (ranges[i] == 0 and statuses[i] == 0) for i in range(4))
    return valid, {"t_ms": t_ms, "range_mm": list(ranges), "range_status": list(statuses),
                   "present": mask}


HEALTH_FORMAT = "<I4B16I7I4I7II"


def _health(p):
    f = struct.unpack(HEALTH_FORMAT, p)
    msg = {"uptime_ms": f[0], "state": list(f[1:5])}
    per_sensor = f[5:21]
    for k, name in enumerate(["comm_errors", "timeouts", "flagged", "reinits"]):
        msg[name] = [per_sensor[4 * s + k] for s in range(4)]
    for name, value in zip(["bus_addr_nack", "bus_data_nack", "bus_busy", "bus_timeout",
                            "bus_stuck", "bus_other", "bus_recoveries", "watchdog_resets",
                            "loop_overruns", "loop_max_us", "tx_dropped"], f[21:32]):
        msg[name] = value
    for name, value in zip(COUNTER_NAMES, f[32:39]):
        msg["rx_" + name] = value
    msg["uart_overruns"] = f[39]  # protocol 3: received bytes the UART lost
    valid = all(s < len(HEALTH_STATES) for s in msg["state"])
    return valid, msg


def _ack(p):
    # error: the firmware's own negative code behind a nack, unchanged (an attitude_error
    # of estimator/attitude.h for set-window and select-estimator); 0 in an ack. Each
    # module's codes have a block of their own (docs/reference/errors.md: -1..-31 hal_err,
    # -64..-79 attitude_error), so the number alone says whose it is.
    echo_seq, command, result, error = struct.unpack("<BBBb", p)
    valid = result < len(RESULTS) and error <= 0 and (result != R_OK or error == 0)
    return valid, {"echo_seq": echo_seq, "command": command, "result": result, "error": error}


def _status(p):
    (major, minor, patch, protocol, uptime, window_n, mode, estimator, running, raw,
     period, record, cal, arm, cal_age_s, cal_age, temp_known,
     temp_cdeg) = struct.unpack("<BBBBIHBBBBHBBIIBBh", p)
    valid = (protocol == PROTOCOL_VERSION and WINDOW_MIN <= window_n <= WINDOW_MAX
             and mode < len(MODES) and estimator < len(ESTIMATORS) and running <= 1 and raw <= 1
             and record < len(RECORD_STATES) and cal < len(CAL_STATES)
             and ARM_MIN_UM <= arm <= ARM_MAX_UM and PERIOD_MIN_MS <= period <= PERIOD_MAX_MS
             and cal_age < len(CAL_AGE_STATES) and _temp_valid(temp_known, temp_cdeg))
    return valid, {"fw": (major, minor, patch), "protocol": protocol, "uptime_ms": uptime,
                   "window_n": window_n, "mode": mode, "estimator": estimator,
                   "running": running, "raw_stream": raw, "period_ms": period,
                   "record": record, "calibration": cal, "arm_um": arm,
                   "cal_age_s": cal_age_s, "cal_age": cal_age, "temp_known": temp_known,
                   "temp_cdeg": temp_cdeg}


def _set_window(p):
    window_n, mode = struct.unpack("<HB", p)
    return (WINDOW_MIN <= window_n <= WINDOW_MAX and mode < len(MODES),
            {"window_n": window_n, "mode": mode})


def _select_estimator(p):
    return p[0] < len(ESTIMATORS), {"estimator": p[0]}


def _raw_stream(p):
    return p[0] <= 1, {"enable": p[0]}


def _set_process_noise(p):
    qd, qt, flags = struct.unpack("<IIB", p)
    return (flags & ~PROCESS_NOISE_AUTO) == 0, {"qd_um2_per_s": qd, "qt_um2_per_s": qt,
                                                "auto": flags & PROCESS_NOISE_AUTO}


def _set_arm(p):
    arm = struct.unpack("<I", p)[0]
    return ARM_MIN_UM <= arm <= ARM_MAX_UM, {"arm_um": arm}


def _set_period(p):
    period = struct.unpack("<H", p)[0]
    return PERIOD_MIN_MS <= period <= PERIOD_MAX_MS, {"period_ms": period}


def _empty(_p):
    return True, {}


def _cal_section_valid(s, none_ok):
    """The protocol's check of a calibration section: its header (id 2, a version, length
    114), or all zero (none stored) where none_ok; the content is the firmware's to check."""
    if none_ok and not any(s):
        return True
    return s[0] == 2 and s[1] != 0 and struct.unpack_from("<H", s, 2)[0] == CAL_SECTION_LEN - 4


def _calibration(p):
    return (p[0] < len(CAL_STATES) and _cal_section_valid(p[1:], True),
            {"state": p[0], "section": bytes(p[1:])})


def _rezero(p):
    samples = struct.unpack("<H", p)[0]
    return REZERO_MIN <= samples <= REZERO_MAX, {"samples": samples}


def _write_calibration(p):
    return _cal_section_valid(p, False), {"section": bytes(p)}


PARSERS = {T_ESTIMATE: _estimate, T_RAW_SAMPLE: _raw, T_HEALTH: _health, T_ACK: _ack,
           T_STATUS: _status, T_SET_WINDOW: _set_window,
           T_SELECT_ESTIMATOR: _select_estimator, T_START: _empty, T_STOP: _empty,
           T_STATUS_REQUEST: _empty, T_RAW_STREAM: _raw_stream,
           T_SET_PROCESS_NOISE: _set_process_noise, T_SAVE: _empty,
           T_CALIBRATION: _calibration, T_WRITE_CALIBRATION: _write_calibration,
           T_READ_CALIBRATION: _empty, T_REZERO: _rezero, T_SET_ARM: _set_arm,
           T_SET_PERIOD: _set_period}


def parse(ftype, payload):
    """(fields dict or None, result): fields is None unless result is R_OK."""
    info = TYPES.get(ftype)
    if info is None:
        return None, R_UNKNOWN_TYPE
    if len(payload) != info[2]:
        return None, R_BAD_LENGTH
    valid, fields = PARSERS[ftype](payload)
    return (fields, R_OK) if valid else (None, R_OUT_OF_RANGE)


# --- text: the canonical line format (the C test helper prints the same) ----

def fixed(value, scale_digits):
    """Exact decimal text of value / 10**scale_digits ("-1.500000")."""
    sign = "-" if value < 0 else ""
    value = abs(value)
    unit = 10 ** scale_digits
    return "%s%d.%0*d" % (sign, value // unit, scale_digits, value % unit)


def opt(value, fmt):
    return "none" if value == NO_VALUE else fmt(value)


def temp_text(m, none="none"):
    """A message's temperature in degC with its two decimals ("-12.34"), or `none`."""
    return fixed(m["temp_cdeg"], 2) if m["temp_known"] else none


def why_names(why):
    """The reasons in a why set, in attitude_why_format()'s order: per-sensor names
    ("no-target:A"), then parity, motion, drift, then the estimator's reasons. A bit the
    estimator does not define is named "bit-N", never dropped."""
    names, known = [], 0
    for g, name in enumerate(WHY_PER_SENSOR):
        for k in range(4):
            bit = 1 << (4 * g + k)
            known |= bit
            if why & bit:
                names.append("%s:%s" % (name, SENSORS[k]))
    for b, name in enumerate(WHY_WINDOW):
        bit = 1 << (20 + b)
        known |= bit
        if why & bit:
            names.append(name)
    for bit_no, name in ((WHY_UNCALIBRATED_BIT, "uncalibrated"),
                         (WHY_RECALIBRATE_BIT, "recalibrate")):
        known |= 1 << bit_no
        if why & (1 << bit_no):
            names.append(name)
    for r in range(1, len(ATTITUDE_REASONS)):
        bit = 1 << (WHY_REASON_SHIFT + r)
        known |= bit
        if why & bit:
            names.append(ATTITUDE_REASONS[r])
    names += ["bit-%d" % b for b in range(64) if why & ~known & (1 << b)]
    return names


def why_text(why, empty="none"):
    return "+".join(why_names(why)) or empty


def sensors_text(mask):
    return "".join(SENSORS[i] for i in range(4) if mask & (1 << i)) or "none"


def command_name(ftype):
    info = TYPES.get(ftype)
    return info[0] if info and info[1] == ACCEPT_COMMANDS else "0x%02x" % ftype


def format_message(ftype, seq, m):
    name = TYPES[ftype][0]
    head = "seq=%d " % seq
    if ftype == T_ESTIMATE:
        return head + (
            "estimate t_ms=%d window=%d estimator=%s status=%s why=%s sensors=%s "
            "alpha_deg=%s beta_deg=%s distance_mm=%s alpha_sd_deg=%s beta_sd_deg=%s "
            "distance_sd_mm=%s flatness_um=%s" % (
                m["t_ms"], m["window"], ESTIMATORS[m["estimator"]], STATUSES[m["status"]],
                why_text(m["why"]), sensors_text(m["sensors"]),
                opt(m["alpha_udeg"], lambda v: fixed(v, 6)),
                opt(m["beta_udeg"], lambda v: fixed(v, 6)),
                opt(m["distance_um"], lambda v: fixed(v, 3)),
                opt(m["alpha_sd_udeg"], lambda v: fixed(v, 6)),
                opt(m["beta_sd_udeg"], lambda v: fixed(v, 6)),
                opt(m["distance_sd_um"], lambda v: fixed(v, 3)),
                opt(m["flatness_um"], str)) + " temp_c=" + temp_text(m))
    if ftype == T_RAW_SAMPLE:
        present = [m["present"] & (1 << i) for i in range(4)]
        ranges = " ".join("%s_mm=%s" % (SENSORS[i].lower(),
                                         m["range_mm"][i] if present[i] else "none")
                          for i in range(4))
        statuses = " ".join("%s_st=%s" % (SENSORS[i].lower(),
                                           m["range_status"][i] if present[i] else "none")
                            for i in range(4))
        return head + "raw t_ms=%d %s %s" % (m["t_ms"], ranges, statuses)
    if ftype == T_HEALTH:
        parts = ["health uptime_ms=%d" % m["uptime_ms"],
                 "state=" + ",".join(HEALTH_STATES[s] for s in m["state"])]
        for key in ["comm_errors", "timeouts", "flagged", "reinits"]:
            parts.append("%s=%s" % (key, ",".join(str(v) for v in m[key])))
        for key in ["bus_addr_nack", "bus_data_nack", "bus_busy", "bus_timeout", "bus_stuck",
                    "bus_other", "bus_recoveries", "watchdog_resets", "loop_overruns",
                    "loop_max_us", "tx_dropped"] + ["rx_" + c for c in COUNTER_NAMES] + [
                        "uart_overruns"]:
            parts.append("%s=%d" % (key, m[key]))
        return head + " ".join(parts)
    if ftype == T_ACK:
        return head + "%s echo_seq=%d command=%s result=%s error=%d" % (
            "ack" if m["result"] == 0 else "nack", m["echo_seq"], command_name(m["command"]),
            RESULTS[m["result"]], m["error"])
    if ftype == T_STATUS:
        return head + (
            "status fw=%d.%d.%d protocol=%d uptime_ms=%d window_n=%d mode=%s estimator=%s "
            "running=%s raw_stream=%s period_ms=%d record=%s calibration=%s arm_um=%d "
            "cal_age_s=%d cal_age=%s" % (
                m["fw"][0], m["fw"][1], m["fw"][2], m["protocol"], m["uptime_ms"],
                m["window_n"], MODES[m["mode"]], ESTIMATORS[m["estimator"]],
                "yes" if m["running"] else "no", "yes" if m["raw_stream"] else "no",
                m["period_ms"], RECORD_STATES[m["record"]], CAL_STATES[m["calibration"]],
                m["arm_um"], m["cal_age_s"], CAL_AGE_STATES[m["cal_age"]]) + " temp_c="
            + temp_text(m))
    if ftype == T_CALIBRATION:
        return head + "calibration state=%s section=%s" % (CAL_STATES[m["state"]],
                                                           m["section"].hex())
    if ftype == T_WRITE_CALIBRATION:
        return head + "write-calibration section=%s" % m["section"].hex()
    if ftype == T_REZERO:
        return head + "re-zero samples=%d" % m["samples"]
    if ftype == T_SET_ARM:
        return head + "set-arm arm_um=%d" % m["arm_um"]
    if ftype == T_SET_PERIOD:
        return head + "set-period period_ms=%d" % m["period_ms"]
    if ftype == T_SET_WINDOW:
        return head + "set-window window_n=%d mode=%s" % (m["window_n"], MODES[m["mode"]])
    if ftype == T_SELECT_ESTIMATOR:
        return head + "select-estimator estimator=%s" % ESTIMATORS[m["estimator"]]
    if ftype == T_RAW_STREAM:
        return head + "raw-stream enable=%s" % ("on" if m["enable"] else "off")
    if ftype == T_SET_PROCESS_NOISE:
        return head + "set-process-noise qd_mm2_per_s=%s qt_mm2_per_s=%s auto=%s" % (
            format_intensity(m["qd_um2_per_s"]), format_intensity(m["qt_um2_per_s"]),
            "yes" if m["auto"] else "no")
    return head + name


def format_reject(ftype, seq, length, result):
    return "seq=%d rejected type=0x%02x length=%d reason=%s" % (seq, ftype, length,
                                                              RESULTS[result])


def format_counters(counters):
    return "# " + " ".join("%s=%d" % (k, counters[k]) for k in COUNTER_NAMES)


def format_intensity(um2_per_s):
    """um^2/s as exact mm^2/s text with six decimals (no float rounding)."""
    return "%d.%06d" % divmod(um2_per_s, UM2_PER_MM2)


# --- commands from text (--send) ---------------------------------------------

def parse_fixed(text, places):
    """Decimal text as whole 10^-places units, or None: exact decimal, at most `places`
    places, at most 0xFFFFFFFF units (a u32 on the wire)."""
    whole, point, frac = text.partition(".")
    if not whole.isdigit() or (point and not frac.isdigit()) or not text.isascii():
        return None
    frac = frac.rstrip("0")
    if len(frac) > places:
        return None  # finer than one unit
    value = int(whole, 10) * 10 ** places + int((frac or "0").ljust(places, "0") or "0", 10)
    return value if value <= 0xFFFFFFFF else None


def parse_intensity(text):
    """mm^2/s text ("0.5", "12", "0.000001") as whole um^2/s, or None: at most six places,
    at most 4294.967295 (a u32 of um^2/s on the wire)."""
    return parse_fixed(text, 6)


def command_payload(text):
    """(type, payload) of a command line such as "set-window 50 sliding"."""
    words = text.split()
    if not words:
        raise ProtocolError("empty command")
    verb, args = words[0].lower(), words[1:]

    def expect(count_min, count_max, usage):
        if not count_min <= len(args) <= count_max:
            raise ProtocolError("'%s': usage: %s" % (text, usage))

    if verb == "set-window":
        expect(1, 2, "set-window N [tumbling|sliding]")
        try:
            window_n = int(args[0], 10)
        except ValueError:
            raise ProtocolError("'%s': window N '%s' is not an integer" % (text, args[0])) from None
        if not WINDOW_MIN <= window_n <= WINDOW_MAX:
            raise ProtocolError("'%s': window N must be %d..%d, got %d"
                                % (text, WINDOW_MIN, WINDOW_MAX, window_n))
        mode = args[1].lower() if len(args) > 1 else "tumbling"
        if mode not in MODES:
            raise ProtocolError("'%s': mode must be tumbling or sliding, got '%s'" % (text, mode))
        return T_SET_WINDOW, struct.pack("<HB", window_n, MODES.index(mode))
    if verb in ("estimator", "select-estimator"):
        expect(1, 1, "estimator consensus|consensus-paper|kalman|mean")
        name = args[0].lower()
        if name not in ESTIMATORS:
            raise ProtocolError("'%s': estimator must be one of %s, got '%s'"
                                % (text, ", ".join(ESTIMATORS), name))
        return T_SELECT_ESTIMATOR, bytes([ESTIMATORS.index(name)])
    if verb in ("start", "stop", "status", "status-request", "save", "read-calibration"):
        expect(0, 0, verb)
        plain = {"start": T_START, "stop": T_STOP, "save": T_SAVE,
                 "read-calibration": T_READ_CALIBRATION}
        return plain.get(verb, T_STATUS_REQUEST), b""
    if verb == "re-zero":
        expect(1, 1, "re-zero N (samples at the latched position, %d..%d)"
               % (REZERO_MIN, REZERO_MAX))
        try:
            samples = int(args[0], 10)
        except ValueError:
            samples = -1
        if not REZERO_MIN <= samples <= REZERO_MAX:
            raise ProtocolError("'%s': N must be an integer %d..%d, got '%s'"
                                % (text, REZERO_MIN, REZERO_MAX, args[0]))
        return T_REZERO, struct.pack("<H", samples)
    if verb == "write-calibration":
        expect(1, 1, "write-calibration HEX (record section 2, %d bytes; --send-cal makes it)"
               % CAL_SECTION_LEN)
        try:
            section = bytes.fromhex(args[0])
        except ValueError:
            section = b""
        if len(section) != CAL_SECTION_LEN or not _cal_section_valid(section, False):
            raise ProtocolError("'%s': not the %d bytes of a calibration section in hex"
                                % (text[:60], CAL_SECTION_LEN))
        return T_WRITE_CALIBRATION, section
    if verb in ("set-arm", "set-period"):
        arm = verb == "set-arm"
        expect(1, 1, "set-arm MM (1..1000, at most 3 decimals)" if arm
               else "set-period MS (whole ms, 1..10000)")
        value = parse_fixed(args[0], 3 if arm else 0)
        low, high = (ARM_MIN_UM, ARM_MAX_UM) if arm else (PERIOD_MIN_MS, PERIOD_MAX_MS)
        if value is None or not low <= value <= high:
            raise ProtocolError("'%s': %s" % (text, "the arm is 1..1000 mm, at most 3 decimals"
                                              if arm else "the period is 1..10000 whole ms"))
        return (T_SET_ARM, struct.pack("<I", value)) if arm else (T_SET_PERIOD,
                                                                   struct.pack("<H", value))
    if verb in ("raw", "raw-stream"):
        expect(1, 1, "raw on|off")
        if args[0].lower() not in ("on", "off"):
            raise ProtocolError("'%s': raw takes on or off, got '%s'" % (text, args[0]))
        return T_RAW_STREAM, bytes([1 if args[0].lower() == "on" else 0])
    if verb in ("process-noise", "set-process-noise"):
        expect(1, 1, "process-noise QD,QT|auto")
        if args[0].lower() == "auto":
            return T_SET_PROCESS_NOISE, struct.pack("<IIB", 0, 0, PROCESS_NOISE_AUTO)
        parts = args[0].split(",")
        values = [parse_intensity(v) for v in parts] if len(parts) == 2 else [None]
        if None in values:
            raise ProtocolError("'%s': expected QD,QT (mm^2/s, decimals up to 4294.967295, at "
                                "most 6 places) or auto, got '%s'" % (text, args[0]))
        return T_SET_PROCESS_NOISE, struct.pack("<IIB", values[0], values[1], 0)
    raise ProtocolError("unknown command '%s' (set-window, estimator, start, stop, status, raw, "
                        "process-noise, set-arm, set-period, save, write-calibration, "
                        "read-calibration, re-zero)" % verb)


# The firmware's own codes behind a nack (the ack's `error`): estimator/attitude.h's
# enum attitude_error (docs/reference/errors.md: -64..-79); tools/tests checks them against the header.
ATTITUDE_ERRORS = {
    -64: "ATTITUDE_ERR_ARM", -65: "ATTITUDE_ERR_WINDOW", -66: "ATTITUDE_ERR_MODE",
    -67: "ATTITUDE_ERR_ESTIMATORS", -68: "ATTITUDE_ERR_TOLERANCE",
    -69: "ATTITUDE_ERR_PAPER_ITERATIONS", -70: "ATTITUDE_ERR_KALMAN_PROCESS_NOISE",
    -71: "ATTITUDE_ERR_KALMAN_MEASUREMENT_NOISE", -72: "ATTITUDE_ERR_KALMAN_WARMUP",
    -73: "ATTITUDE_ERR_KALMAN_NOISE_SHIFT", -74: "ATTITUDE_ERR_NULL",
    -75: "ATTITUDE_ERR_INTEGRITY", -76: "ATTITUDE_ERR_BUFFER",
    -77: "ATTITUDE_ERR_CALIBRATION",
}

# An answer comes within 50 ms of a command's last byte (the firmware drains its receiver
# once per main-loop iteration, at least once per 20 ms sample period); a USB serial
# adapter adds a few ms each way. 0.25 s is five times that; four tries ride out a lost
# frame or two.
ACK_TIMEOUT_S = 0.25
COMMAND_TRIES = 4


class CommandFailed(Exception):
    """A command was refused (nack) or never answered."""


def nack_text(m):
    name = RESULTS[m["result"]] if m["result"] < len(RESULTS) else "result %d" % m["result"]
    text = "nack %s" % name
    if m["error"] != 0:
        text += ", error %d %s" % (m["error"], ATTITUDE_ERRORS.get(m["error"], "(unknown code)"))
    if name in CAUSES:
        text += ": " + CAUSES[name]
    return text


def send_command(port, text, seq, on_event, timeout=ACK_TIMEOUT_S, tries=COMMAND_TRIES,
                 clock=time.monotonic, decoder=None):
    """Send command `text` with sequence `seq` on `port` (write/read of a pyserial port) and
    wait for its answer; every decoded event also goes to on_event(event, counters). A
    missing answer is retried with the very same frame, so the firmware answers the repeat
    without applying the command twice. Returns (ack fields, tries used); raises
    CommandFailed naming the nack (result and error) or the timeout."""
    ftype, payload = command_payload(text)
    frame = encode_frame(ftype, seq, payload)
    decoder = decoder if decoder is not None else Decoder(ACCEPT_ALL)
    for attempt in range(1, tries + 1):
        port.write(frame)
        deadline = clock() + timeout
        while clock() < deadline:
            data = port.read(256)
            answer = None
            for event in decoder.feed(data) if data else []:
                on_event(event, decoder.counters)  # every event of the chunk, answer or not
                if event[0] != "frame" or event[1] != T_ACK or answer is not None:
                    continue
                valid, m = PARSERS[T_ACK](event[3])
                if valid and m["echo_seq"] == seq and m["command"] == ftype:
                    answer = m
            if answer is not None and answer["result"] != R_OK:
                raise CommandFailed("'%s' (seq %d): %s" % (text, seq, nack_text(answer)))
            if answer is not None:
                return answer, attempt
    raise CommandFailed("'%s' (seq %d): no answer within %.2f s, %d tries: timeout"
                        % (text, seq, timeout, tries))


def encode_commands(texts, first_seq=0):
    out = bytearray()
    for i, text in enumerate(texts):
        ftype, payload = command_payload(text)
        out += encode_frame(ftype, (first_seq + i) & 0xFF, payload)
    return bytes(out)


# --- output sinks -------------------------------------------------------------

# EST.csv's columns first (docs/reference/tools.md; temp_c, the window's temperature, empty
# when the unit had none), then what only telemetry has.
ESTIMATE_CSV = ["t_ms", "alpha_deg", "beta_deg", "distance_mm", "status", "alpha_sd_deg",
                "beta_sd_deg", "distance_sd_mm", "why", "temp_c", "estimator", "window",
                "sensors", "flatness_um", "seq"]
RAW_CSV = ["t_ms", "a_mm", "b_mm", "c_mm", "d_mm", "a_st", "b_st", "c_st", "d_st", "seq"]


class Printer:
    """Turns decoder events into output lines and collects estimates to plot."""

    def __init__(self, out, csv_type=None, on_estimate=None):
        self.out = out
        self.csv_type = csv_type
        self.on_estimate = on_estimate  # called with each valid estimate (the live plot)
        self.estimates = []
        self.last_seq = None
        self.lost_frames = 0
        self.reboots = 0
        self.latest_ms = None  # the unit's latest time seen (uptime, t_ms): a restart goes back
        if csv_type == "estimate":
            out.write(",".join(ESTIMATE_CSV) + "\n")
        elif csv_type == "raw":
            out.write(",".join(RAW_CSV) + "\n")

    def _track_sequence(self, seq):
        if self.last_seq is not None:
            self.lost_frames += (seq - self.last_seq - 1) % 256
        self.last_seq = seq

    def handle(self, event, counters):
        if event[0] == "reject":
            _, ftype, seq, length, result = event
            if self.csv_type is None:
                self.out.write(format_reject(ftype, seq, length, result) + "\n")
            return
        _, ftype, seq, payload = event
        fields, result = parse(ftype, payload)
        # The boot's status frame is sequence 0 with an uptime below what was seen: the unit
        # restarted (its numbering starts again), not 255 frames lost.
        now_ms = None if fields is None else fields.get("uptime_ms", fields.get("t_ms"))
        if (ftype == T_STATUS and seq == 0 and fields is not None and self.latest_ms is not None
                and now_ms < self.latest_ms):
            self.reboots += 1
            self.last_seq = None
            if self.csv_type is None:
                self.out.write("# the unit restarted (boot status, uptime %d ms)\n" % now_ms)
            self.latest_ms = now_ms
        elif now_ms is not None:
            self.latest_ms = now_ms if self.latest_ms is None else max(self.latest_ms, now_ms)
        self._track_sequence(seq)
        if result != R_OK:
            counters["out_of_range"] += result == R_OUT_OF_RANGE
            if self.csv_type is None:
                self.out.write(format_reject(ftype, seq, len(payload), result) + "\n")
            return
        if ftype == T_ESTIMATE:
            self.estimates.append(fields)
            if self.on_estimate is not None:
                self.on_estimate(fields)
        if self.csv_type is None:
            self.out.write(format_message(ftype, seq, fields) + "\n")
        elif self.csv_type == "estimate" and ftype == T_ESTIMATE:
            m = fields
            cell = lambda key, digits: opt(m[key], lambda v: fixed(v, digits)).replace("none", "")
            row = [str(m["t_ms"]), cell("alpha_udeg", 6), cell("beta_udeg", 6),
                   cell("distance_um", 3), STATUSES[m["status"]], cell("alpha_sd_udeg", 6),
                   cell("beta_sd_udeg", 6), cell("distance_sd_um", 3), why_text(m["why"], ""),
                   temp_text(m, ""), ESTIMATORS[m["estimator"]], str(m["window"]), sensors_text(m["sensors"]),
                   "" if m["flatness_um"] == NO_VALUE else str(m["flatness_um"]), str(seq)]
            self.out.write(",".join(row) + "\n")
        elif self.csv_type == "raw" and ftype == T_RAW_SAMPLE:
            m = fields
            present = [m["present"] & (1 << i) for i in range(4)]
            row = ([str(m["t_ms"])]
                   + [str(m["range_mm"][i]) if present[i] else "" for i in range(4)]
                   + [str(m["range_status"][i]) if present[i] else "" for i in range(4)]
                   + [str(seq)])
            self.out.write(",".join(row) + "\n")


def _series(estimates, est_id, value_key, sd_key):
    """(t [s], value, sd) of one estimator's estimates where the value was estimated."""
    rows = [e for e in estimates if e["estimator"] == est_id and e[value_key] != NO_VALUE]
    return ([e["t_ms"] / 1000.0 for e in rows], [e[value_key] / 1e6 for e in rows],
            [e[sd_key] / 1e6 for e in rows])


def draw_estimates(axes, estimates, title=None):
    """Alpha and beta of each estimator with a +-2 sd band around each line, degraded
    estimates marked, invalid ones as grey lines. axes = (ax_alpha, ax_beta)."""
    colours = ["C0", "C1", "C2", "C3"]
    for ax in axes:
        ax.clear()
    for est_id, name in enumerate(ESTIMATORS):
        for ax, key in zip(axes, ("alpha", "beta")):
            t, v, sd = _series(estimates, est_id, key + "_udeg", key + "_sd_udeg")
            if not t:
                continue
            ax.plot(t, v, ".-", markersize=3, color=colours[est_id], label=name)
            ax.fill_between(t, [x - 2 * s for x, s in zip(v, sd)],
                            [x + 2 * s for x, s in zip(v, sd)], color=colours[est_id],
                            alpha=0.2, linewidth=0, label="%s +-2 sd" % name)
            deg = [(e["t_ms"] / 1000.0, e[key + "_udeg"] / 1e6) for e in estimates
                   if e["estimator"] == est_id and e["status"] == 1]
            if deg:
                ax.plot([d[0] for d in deg], [d[1] for d in deg], "x", color="red",
                        markersize=4)
    invalid = [e["t_ms"] / 1000.0 for e in estimates if e["status"] == 2]
    for ax in axes:
        for t in invalid:
            ax.axvline(t, color="grey", alpha=0.3, linewidth=0.8)
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("alpha [deg]")
    axes[1].set_ylabel("beta [deg]")
    axes[1].set_xlabel("t [s]")
    axes[0].set_title(title or "Estimates (%d; %d invalid as grey lines, degraded as red x); "
                      "bands +-2 sd" % (len(estimates), len(invalid)))
    if estimates:
        axes[0].legend(fontsize="x-small", ncol=2)


def plot_estimates(estimates, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(10, 6))
    draw_estimates(axes, estimates)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


class LivePlot:
    """--live: a window with the estimates and their +-2 sd bands, redrawn as frames arrive
    (at most every `interval` seconds). With a non-interactive backend (Agg: tests, no
    display) it draws into the figure all the same; save() writes it out."""

    def __init__(self, interval=0.25, last=None, clock=time.monotonic):
        import matplotlib
        import matplotlib.pyplot as plt
        self.plt = plt
        self.interactive = matplotlib.get_backend().lower() not in ("agg", "pdf", "svg", "ps")
        if self.interactive:
            plt.ion()
        self.fig, self.axes = plt.subplots(2, 1, sharex=True, figsize=(10, 6))
        self.interval = interval
        self.last = last  # keep only the newest `last` estimates on screen (None: all)
        self.clock = clock
        self.estimates = []
        self.pending = 0
        self.redraws = 0
        self.drawn_at = None

    def add(self, estimate):
        self.estimates.append(estimate)
        if self.last is not None and len(self.estimates) > self.last:
            del self.estimates[:len(self.estimates) - self.last]
        self.pending += 1

    def tick(self, force=False):
        """Redraw if there is something new and the interval has passed (or forced)."""
        now = self.clock()
        if not self.pending or (not force and self.drawn_at is not None
                                and now - self.drawn_at < self.interval):
            return False
        draw_estimates(self.axes, self.estimates)
        self.fig.canvas.draw()
        if self.interactive:
            self.plt.pause(0.001)
        self.pending = 0
        self.drawn_at = now
        self.redraws += 1
        return True

    def closed(self):
        return self.interactive and not self.plt.fignum_exists(self.fig.number)

    def save(self, path):
        self.tick(force=True)
        self.fig.savefig(path, dpi=110)


# --- sources --------------------------------------------------------------------

def run_stream(chunks, decoder, printer, idle_flush=None, live=None):
    """Decode chunks (bytes; b"" means the line was idle) until exhausted; a live plot
    is redrawn between chunks, and the stream ends if its window is closed."""
    for chunk in chunks:
        if chunk:
            events = decoder.feed(chunk)
        elif idle_flush and decoder.pending():
            events = decoder.flush()
        else:
            events = []
        for event in events:
            printer.handle(event, decoder.counters)
        if live is not None:
            live.tick()
            if live.closed():
                break
    for event in decoder.flush():
        printer.handle(event, decoder.counters)
    if live is not None:
        live.tick(force=True)


def stream_chunks(f, size=4096, idle_s=0.2, duration=None, clock=time.monotonic):
    """Chunks from a file-like object as they arrive (a pty, a pipe, a growing capture):
    b"" after an idle gap, the end at EOF or after `duration` seconds."""
    deadline = None if duration is None else clock() + duration
    while deadline is None or clock() < deadline:
        data = f.read(size)
        if data is None:  # non-blocking and nothing yet
            time.sleep(idle_s / 4)
            yield b""
            continue
        if not data:
            return
        yield data


def file_chunks(path, size=65536):
    with open(path, "rb") as f:
        while True:
            chunk = f.read(size)
            if not chunk:
                return
            yield chunk


def serial_chunks(port, duration, idle_s=0.2):
    """Read until `duration` seconds pass (None: until Ctrl-C); b"" after an idle gap."""
    deadline = None if duration is None else time.monotonic() + duration
    last_data = time.monotonic()
    while deadline is None or time.monotonic() < deadline:
        data = port.read(4096)
        now = time.monotonic()
        if data:
            last_data = now
            yield data
        elif now - last_data >= idle_s:
            last_data = now
            yield b""


# --- the head's calibration: send, read back, record fixture stations ----------

def _collect(chunks, decoder, want, count, on_event=None):
    """Up to `count` valid messages of type `want` from `chunks` (every event also to
    on_event)."""
    out = []
    for data in chunks:
        for event in decoder.feed(data) if data else []:
            if on_event is not None:
                on_event(event, decoder.counters)
            if event[0] == "frame" and event[1] == want:
                fields, result = parse(want, event[3])
                if result == R_OK:
                    out.append(fields)
        if len(out) >= count:
            break
    return out


class _Tap:
    """An on_event that keeps the messages of one type and passes every event on."""

    def __init__(self, want, then):
        self.want, self.then, self.got = want, then, []

    def __call__(self, event, counters):
        if event[0] == "frame" and event[1] == self.want:
            fields, result = parse(self.want, event[3])
            if result == R_OK:
                self.got.append(fields)
        self.then(event, counters)


def _read_back(port, seq, printer, decoder, timeout=1.0):
    """read-calibration on `port`: the calibration message (fields) or None."""
    tap = _Tap(T_CALIBRATION, printer.handle)
    send_command(port, "read-calibration", seq, tap, decoder=decoder)
    if not tap.got:
        tap.got = _collect(serial_chunks(port, timeout), decoder, T_CALIBRATION, 1,
                           printer.handle)
    return tap.got[-1] if tap.got else None


def _unit_status(port, seq, printer, decoder, timeout=1.0):
    """status-request on `port`: the status message (fields) or None."""
    tap = _Tap(T_STATUS, printer.handle)
    send_command(port, "status", seq, tap, decoder=decoder)
    if not tap.got:
        tap.got = _collect(serial_chunks(port, timeout), decoder, T_STATUS, 1, printer.handle)
    return tap.got[-1] if tap.got else None


def _check_arm(path, text, status):
    """A HEAD.cal whose arm_mm is not the unit's arm would not calibrate it (other-arm): the
    message naming both, or None."""
    keys, where = tof_calibration.read_head_cal(text, path)
    if "arm_mm" not in keys:
        return None
    try:
        arm_um = int(decimal_units(keys["arm_mm"], 3))
    except (TypeError, ValueError):
        return "%s: arm_mm: not a plain decimal, got '%s'" % (where["arm_mm"], keys["arm_mm"])
    if arm_um != status["arm_um"]:
        return ("%s: arm_mm=%s, but the unit's arm is %s mm (other-arm): %s"
                % (where["arm_mm"], keys["arm_mm"], fixed(status["arm_um"], 3),
                   CAUSES["other-arm"]))
    return None


def decimal_units(text, decimals):
    """text as an integer count of 10^-decimals, or None (tof_calibration's rounding)."""
    return tof_calibration._units(text, decimals)


def write_head_cal(path, message, source, arm_um=None):
    """The calibration message's section as HEAD.cal at path; its state on stdout. Raises
    CalibrationError when the unit holds none."""
    state = CAL_STATES[message["state"]]
    if not any(message["section"]):
        raise tof_calibration.CalibrationError(
            "the unit holds no calibration (state=%s): nothing written to %s; send one with "
            "--send-cal HEAD.cal (docs/how-to/calibrate-a-head.md)" % (state, path))
    text = tof_calibration.section_to_head_cal(message["section"], source, arm_um)
    with open(path, "w") as f:
        f.write(text)
    return "calibration state=%s written to %s" % (CAL_STATES[message["state"]], path)


def calibration_main(args, ap):
    """--send-cal, --read-cal, --record-station. Returns the exit status."""
    section = None
    if args.send_cal and args.file:
        ap.exit(1, "tof_telemetry: --send-cal %s: a capture file (--file %s) cannot be sent "
                   "to; give the unit's --port, or --write-commands FILE for the frames\n"
                % (args.send_cal, args.file))
    if args.send_cal:
        try:
            text = tof_calibration.read_text_file(args.send_cal)
            section = tof_calibration.head_cal_to_section(
                text, args.send_cal, args.cal_mode, args.cal_budget_ms)
        except (OSError, tof_calibration.CalibrationError) as e:
            ap.exit(1, "tof_telemetry: --send-cal %s\n" % e)
        if args.write_commands:
            with open(args.write_commands, "wb") as f:
                f.write(encode_commands(["write-calibration " + section.hex(),
                                         "read-calibration"], args.first_seq or 0))
            return 0
    decoder = Decoder(ACCEPT_ALL)
    printer = Printer(sys.stdout)
    if args.file:  # a capture: what it holds
        chunks = file_chunks(args.file)
        if args.read_cal:
            got = _collect(chunks, decoder, T_CALIBRATION, 1 << 30)
            if not got:
                ap.exit(1, "tof_telemetry: %s: no calibration message\n" % args.file)
            try:
                print(write_head_cal(args.read_cal, got[-1], args.file))
            except tof_calibration.CalibrationError as e:
                ap.exit(1, "tof_telemetry: --read-cal: %s\n" % e)
        if args.record_station:
            raw = _collect(chunks, decoder, T_RAW_SAMPLE, args.readings)
            return _append_station(args, ap, raw[:args.readings])
        return 0
    try:
        import serial
        port = serial.Serial(args.port, args.baud, timeout=0.05)
    except (ImportError, OSError) as e:
        ap.exit(1, "tof_telemetry: --port %s: %s\n" % (args.port, e))
    seq = (args.first_seq if args.first_seq is not None else int(time.time() * 1000)) & 0xFF
    with port:
        try:
            if section is not None:
                status = _unit_status(port, seq, printer, decoder)
                seq = (seq + 1) & 0xFF
                why = None if status is None else _check_arm(args.send_cal, text, status)
                if status is None:
                    ap.exit(1, "tof_telemetry: --send-cal: no status from the unit\n")
                if why is not None:
                    ap.exit(1, "tof_telemetry: --send-cal %s\n" % why)
                send_command(port, "write-calibration " + section.hex(), seq, printer.handle,
                             decoder=decoder)
                back = _read_back(port, (seq + 1) & 0xFF, printer, decoder)
                if back is None or back["section"] != section:
                    ap.exit(1, "tof_telemetry: --send-cal: the calibration read back differs\n")
                print("calibration written, saved and read back: state=%s"
                      % CAL_STATES[back["state"]])
                keys = tof_calibration.read_head_cal(text, args.send_cal)[0]
                if "head_id" not in keys and not any(k.startswith("part_id_") for k in keys):
                    sys.stdout.flush()
                    sys.stderr.write(
                        "tof_telemetry: note: %s names no head (head_id) and no parts "
                        "(part_id_A..D): the unit binds it to the parts it runs, and cannot tell "
                        "it from another head's; check the estimates are ok at a known "
                        "station\n" % args.send_cal)
                seq = (seq + 2) & 0xFF
            if args.read_cal:
                status = _unit_status(port, seq, printer, decoder)
                seq = (seq + 1) & 0xFF
                back = _read_back(port, seq, printer, decoder)
                if back is None:
                    ap.exit(1, "tof_telemetry: --read-cal: no calibration message\n")
                try:
                    # the arm it is bound to: the unit's while it is applied (other-arm: not)
                    arm = (status["arm_um"] if status is not None
                           and CAL_STATES[back["state"]] == "applied" else None)
                    print(write_head_cal(args.read_cal, back, args.port, arm))
                except tof_calibration.CalibrationError as e:
                    ap.exit(1, "tof_telemetry: --read-cal: %s\n" % e)
                seq = (seq + 1) & 0xFF
            if args.record_station:
                send_command(port, "raw on", seq, printer.handle, decoder=decoder)
                wait = args.readings * 0.1 + 2.0  # at 20 ms a sample: far more than needed
                raw = _collect(serial_chunks(port, wait), decoder, T_RAW_SAMPLE, args.readings)
                send_command(port, "raw off", (seq + 1) & 0xFF, printer.handle, decoder=decoder)
                return _append_station(args, ap, raw[:args.readings])
        except CommandFailed as e:
            ap.exit(1, "tof_telemetry: %s\n" % e)
    return 0


def _append_station(args, ap, raw):
    if len(raw) < args.readings:
        ap.exit(1, "tof_telemetry: --record-station: %d raw samples, %d asked for\n"
                % (len(raw), args.readings))
    try:
        alpha, beta, distance = args.station.split(",")
        n = tof_calibration.append_station(
            args.record_station, raw, alpha, beta, distance, args.arm_mm, args.period_ms,
            args.cal_mode or "short",
            args.cal_budget_ms if args.cal_budget_ms is not None else 15)
    except (ValueError, AttributeError, tof_calibration.CalibrationError) as e:
        ap.exit(1, "tof_telemetry: --station ALPHA,BETA,DISTANCE: %s\n" % e)
    print("station alpha=%s beta=%s distance_mm=%s: %d rows appended to %s"
          % (alpha, beta, distance, n, args.record_station))
    return 0


def main(argv=None):
    ap = argparse.ArgumentParser(
        description="Decode the ToF firmware's binary telemetry (docs/reference/telemetry-protocol.md).")
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--port", help="serial device, e.g. /dev/ttyACM0")
    src.add_argument("--file", help="capture file of raw telemetry bytes")
    src.add_argument("--write-commands", metavar="FILE",
                     help="write the --send commands as frames to FILE and exit")
    ap.add_argument("--baud", type=int, default=115200, help="serial baud rate (115200)")
    ap.add_argument("--duration", type=float, help="seconds to read from --port (default: until Ctrl-C)")
    ap.add_argument("--send", action="append", default=[], metavar="CMD",
                    help='command to send first, e.g. "set-window 50 sliding" (repeatable; '
                         'each waits for its ack, exit status 1 on a nack or timeout)')
    ap.add_argument("--first-seq", type=int, metavar="N",
                    help="sequence number of the first --send command, 0..255 (default: "
                         "from the clock, so a new run's command is never taken for a "
                         "repeat of the last one)")
    ap.add_argument("--csv", action="store_true", help="CSV instead of one line per message")
    ap.add_argument("--type", choices=["estimate", "raw"], default="estimate",
                    help="message type written as CSV (estimate)")
    ap.add_argument("--plot", metavar="PNG", help="plot the estimates over time into PNG "
                    "(with --live: the last picture)")
    ap.add_argument("--live", action="store_true",
                    help="plot the estimates with +-2 sd bands in a window as frames arrive "
                         "(python3-matplotlib; MPLBACKEND=Agg draws without a display)")
    ap.add_argument("--live-last", type=int, metavar="N",
                    help="with --live: keep only the newest N estimates on screen")
    ap.add_argument("--strict", action="store_true",
                    help="exit with status 1 if any malformed frame was seen")
    cal = ap.add_argument_group("the head's calibration (docs/how-to/calibrate-a-head.md)")
    cal.add_argument("--send-cal", metavar="HEAD.cal",
                     help="send HEAD.cal as the calibration (write-calibration: saved and in "
                          "force), then read it back and compare")
    cal.add_argument("--read-cal", metavar="OUT.cal",
                     help="read the unit's calibration (or a capture's last calibration "
                          "message) into a HEAD.cal")
    cal.add_argument("--cal-mode", choices=["short", "long"],
                     help="distance mode the HEAD.cal was made in, if it has no "
                          "distance_mode key, and the mode --record-station states in a new "
                          "calibration trace (default short, the flight image's)")
    cal.add_argument("--cal-budget-ms", type=int,
                     help="timing budget the HEAD.cal was made with, if it has no "
                          "timing_budget_ms key, and the budget --record-station states "
                          "(default 15, the flight image's)")
    cal.add_argument("--record-station", metavar="CAL_TRACE.csv",
                     help="append a fixture station's raw readings (raw on, N samples, raw "
                          "off) with --station's reference to a calibration trace")
    cal.add_argument("--station", metavar="ALPHA,BETA,DISTANCE",
                     help="the station's stated reference: degrees, degrees, mm (x-bar)")
    cal.add_argument("--readings", type=int, default=500,
                     help="raw samples per station (default 500)")
    cal.add_argument("--arm-mm", default="30", help="arm_mm of a new calibration trace (30)")
    cal.add_argument("--period-ms", type=int, default=20,
                     help="period_ms of a new calibration trace (20)")
    argv = list(sys.argv[1:] if argv is None else argv)
    for i in range(len(argv) - 1):
        if argv[i] == "--station" and argv[i + 1].startswith("-"):
            # a station at a negative alpha ("-5,5,165") is its value, not an option
            argv[i:i + 2] = ["--station=" + argv[i + 1], ""]
    args = ap.parse_args([a for a in argv if a != ""])
    if args.cal_budget_ms is not None and not 1 <= args.cal_budget_ms <= 65535:
        ap.exit(2, "tof_telemetry: --cal-budget-ms %d: a timing budget is 1..65535 ms\n"
                % args.cal_budget_ms)
    if args.period_ms is not None and not PERIOD_MIN_MS <= args.period_ms <= PERIOD_MAX_MS:
        ap.exit(2, "tof_telemetry: --period-ms %d: a period is %d..%d ms\n"
                % (args.period_ms, PERIOD_MIN_MS, PERIOD_MAX_MS))
    if args.readings is not None and not 1 <= args.readings <= 100000:
        ap.exit(2, "tof_telemetry: --readings %d: 1..100000 raw samples\n" % args.readings)
    if args.send_cal or args.read_cal or args.record_station:
        if args.record_station and not args.station:
            ap.exit(1, "tof_telemetry: --record-station needs --station ALPHA,BETA,DISTANCE\n")
        if not (args.port or args.file or (args.send_cal and args.write_commands)):
            ap.exit(1, "tof_telemetry: --send-cal/--read-cal/--record-station need --port "
                       "(or --file, or --write-commands for --send-cal)\n")
        return calibration_main(args, ap)

    try:
        commands = encode_commands(args.send)
    except ProtocolError as e:
        ap.exit(1, "tof_telemetry: --send %s\n" % e)
    if args.write_commands:
        if not args.send:
            ap.exit(1, "tof_telemetry: --write-commands needs at least one --send\n")
        with open(args.write_commands, "wb") as f:
            f.write(commands)
        return 0
    if args.send and not args.port:
        ap.exit(1, "tof_telemetry: --send needs --port (or --write-commands)\n")

    live = None
    if args.live:
        try:
            live = LivePlot(last=args.live_last)
        except ImportError:
            ap.exit(1, "tof_telemetry: --live needs python3-matplotlib; run with /usr/bin/python3\n")
    decoder = Decoder(ACCEPT_ALL)
    printer = Printer(sys.stdout, "estimate" if args.csv and args.type == "estimate"
                      else "raw" if args.csv else None,
                      on_estimate=live.add if live is not None else None)
    try:
        if args.file:
            if not os.path.isfile(args.file):
                ap.exit(1, "tof_telemetry: %s: no such file\n" % args.file)
            run_stream(file_chunks(args.file), decoder, printer, live=live)
        else:
            try:
                import serial
            except ImportError:
                ap.exit(1, "tof_telemetry: --port needs python3-serial (tools/setup.sh); "
                           "run with /usr/bin/python3\n")
            try:
                port = serial.Serial(args.port, args.baud, timeout=0.05)
            except serial.SerialException as e:
                ap.exit(1, "tof_telemetry: %s: %s\n" % (args.port, e))
            with port:
                if args.send:
                    seq = (args.first_seq if args.first_seq is not None
                           else int(time.time() * 1000)) & 0xFF
                    for text in args.send:
                        tap = _Tap(T_STATUS, printer.handle)
                        try:
                            send_command(port, text, seq, tap, decoder=decoder)
                        except CommandFailed as e:
                            sys.stdout.flush()
                            ap.exit(1, "tof_telemetry: --send %s\n" % e)
                        seq = (seq + 1) & 0xFF
                        if text.split()[:1] in (["set-arm"], ["set-period"]):
                            # the status frame after its ack: does the calibration still hold?
                            got = tap.got or _collect(serial_chunks(port, 1.0), decoder,
                                                      T_STATUS, 1, printer.handle)
                            state = CAL_STATES[got[-1]["calibration"]] if got else None
                            if state in CAUSES and state != "none":
                                sys.stdout.flush()
                                sys.stderr.write(
                                    "tof_telemetry: note: '%s' acknowledged; the unit's "
                                    "calibration no longer holds (calibration=%s): %s\n"
                                    % (text, state, CAUSES[state]))
                try:
                    run_stream(serial_chunks(port, args.duration), decoder, printer,
                               idle_flush=True, live=live)
                except KeyboardInterrupt:
                    for event in decoder.flush():
                        printer.handle(event, decoder.counters)
    except BrokenPipeError:
        return 0
    summary = format_counters(decoder.counters)
    (sys.stderr if args.csv else sys.stdout).write(summary + "\n")
    sys.stdout.flush()
    if printer.lost_frames:
        sys.stderr.write("# lost_frames=%d (sequence gaps)\n" % printer.lost_frames)
    if printer.reboots:
        sys.stderr.write("# reboots=%d (the unit restarted; its sequence numbers start again)\n"
                         % printer.reboots)
    if args.plot and live is not None:
        live.save(args.plot)
    elif args.plot:
        try:
            plot_estimates(printer.estimates, args.plot)
        except ImportError:
            ap.exit(1, "tof_telemetry: --plot needs python3-matplotlib; run with /usr/bin/python3\n")
    malformed = sum(decoder.counters[k] for k in COUNTER_NAMES
                    if k not in ("frames_ok", "discarded_bytes"))
    return 1 if args.strict and malformed else 0


if __name__ == "__main__":
    sys.exit(main())
