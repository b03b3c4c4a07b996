#!/usr/bin/python3
"""The head's calibration between its two forms (docs/how-to/calibrate-a-head.md).

- HEAD.cal text (docs/reference/calibration-file.md) <-> the flight unit's record section 2 version 4
  (firmware/calibration_record.h), the form the telemetry's write-calibration command and
  calibration message carry (docs/reference/telemetry-protocol.md); a version-1 section (84 bytes,
  before the thermal fields) is still read, as a calibration without them. The decimal
  conversion is the trace reader's (trace/src/trace_v1_cal.c), exactly: offsets and their sd
  to 1 um, gains read to 1e-9 then to 1 ppm of (gain - 1), gain sd to 1 ppm, the
  offset-gain correlation to Q15, the calibration temperature (cal_temp_c) to 0.01 degC, the
  offsets' temperature coefficients and their sd (temp_coeff_mm_per_c, temp_coeff_sd_mm_per_c)
  to 1 nm/degC, each rounded half away from zero; a section read back and written again as
  HEAD.cal gives the same bytes.
- a fixture station recorder: raw readings (the firmware's raw-sample messages) with the
  station's stated reference (alpha, beta, x-bar) appended as rows of a calibration trace
  (trace v1 with the truth columns, docs/how-to/calibrate-a-head.md "The calibration trace").

Used by tof_telemetry.py (--send-cal, --read-cal, --record-station).
"""

import decimal
import os
import struct
import sys
import zlib

SECTION_ID = 2
SECTION_VERSION = 4              # the first with the thermal fields: what the commands carry
SECTION_LEN = 114                # the section's bytes after its 4-byte header
V1_LEN = 80                      # version 1: the same bytes 0..79, no thermal fields
FLAG_GAINS = 0x01
FLAG_THERMAL = 0x02              # version 4: the thermal fields (bytes 80..113) were measured
OFFSET_MAX_UM = 100000           # estimator/calibration.h CALIBRATION_OFFSET_MAX_UM
GAIN_MAX_PPM = 100000            # CALIBRATION_GAIN_MAX_PPM
TEMP_COEFF_MAX_NM_PER_C = 1000000  # CALIBRATION_TEMP_COEFF_MAX_NM_PER_C
TEMP_MIN_CDEG, TEMP_MAX_CDEG = -10000, 20000  # CALIBRATION_TEMP_MIN_CDEG, _MAX_CDEG
THERMAL_KEYS = ("cal_temp_c", "temp_coeff_mm_per_c", "temp_coeff_sd_mm_per_c")
UNCAL_GAIN_SD_PPM = 17321        # CALIBRATION_UNCAL_GAIN_SD_PPM
MODES = {"short": 1, "long": 2}  # enum vl53_distance_mode
# The flight image's configuration (firmware/src/config.c): what a HEAD.cal without
# distance_mode / timing_budget_ms keys is taken to have been made in.
DEFAULT_MODE = "short"
DEFAULT_BUDGET_MS = 15
SENSORS = "ABCD"

_CTX = decimal.Context(prec=60, rounding=decimal.ROUND_HALF_UP)  # half away from zero


class CalibrationError(Exception):
    """A HEAD.cal or a section that cannot be converted: the message names what and where."""


def _units(text, decimals):
    """A plain decimal in units of 10^-decimals, rounded half away from zero (None: not one)."""
    t = text.strip()
    if not t or any(c not in "0123456789+-.eE" for c in t):
        return None
    try:
        d = decimal.Decimal(t)
    except decimal.InvalidOperation:
        return None
    if not d.is_finite():
        return None
    return int(d.scaleb(decimals, _CTX).quantize(decimal.Decimal(1), context=_CTX))


def _div_round(num, den):
    """Half away from zero of num / den, den > 0 (trace_v1_cal.c's div_round)."""
    q, r = divmod(abs(num), den)
    q += 2 * r >= den
    return q if num >= 0 else -q


# key -> (decimals, largest |units|, non-negative, what the message says)
_KEYS = {
    "offset_mm": (3, OFFSET_MAX_UM, False, "an offset within -100..100 mm"),
    "offset_sd_mm": (3, OFFSET_MAX_UM, True, "an sd within 0..100 mm"),
    "gain": (9, 1100000000, True, "a gain within 0.9..1.1"),
    "gain_sd": (6, GAIN_MAX_PPM, True, "an sd within 0..0.1"),
    "offset_gain_corr": (9, 1000000000, False, "a correlation within -1..1"),
    "temp_coeff_mm_per_c": (6, TEMP_COEFF_MAX_NM_PER_C, False, "a coefficient within -1..1 mm/C"),
    "temp_coeff_sd_mm_per_c": (6, TEMP_COEFF_MAX_NM_PER_C, True, "an sd within 0..1 mm/C"),
}


def _values(key, text, where):
    decimals, limit, non_negative, what = _KEYS[key]
    parts = text.split(",")
    if len(parts) != 4:
        raise CalibrationError("%s: %s: four values (sensors A, B, C, D), got %d"
                               % (where, key, len(parts)))
    out = []
    for part in parts:
        v = _units(part, decimals)
        if v is None:
            raise CalibrationError("%s: %s: not a plain decimal, got '%s'" % (where, key, part))
        if abs(v) > limit or (non_negative and v < 0):
            raise CalibrationError("%s: %s: %s, got '%s'" % (where, key, what, part))
        if key == "gain":
            v = _div_round(v - 1000000000, 1000)  # (gain - 1) in ppm
            if abs(v) > GAIN_MAX_PPM:
                raise CalibrationError("%s: gain: %s, got '%s'" % (where, what, part))
        elif key == "offset_gain_corr":
            v = min(_div_round(v * 32768, 1000000000), 32767)
        out.append(v)
    return out


def _cal_temp(text, where):
    """cal_temp_c: the head's one value in 0.01 degC, -100..200 degC."""
    if "," in text:
        raise CalibrationError("%s: cal_temp_c: one value (the head's), not a list, got '%s'"
                               % (where, text))
    v = _units(text, 2)
    if v is None:
        raise CalibrationError("%s: cal_temp_c: not a plain decimal, got '%s'" % (where, text))
    if not TEMP_MIN_CDEG <= v <= TEMP_MAX_CDEG:
        raise CalibrationError("%s: cal_temp_c: a temperature within -100..200 C, got '%s'"
                               % (where, text))
    return v


def read_text_file(path):
    """A HEAD.cal's text: UTF-8 without NUL bytes (a binary file is refused, naming the
    line of its first NUL or undecodable byte, as host_sim's reader does)."""
    with open(path, "rb") as f:
        data = f.read()
    at = data.find(b"\0")
    if at >= 0:
        raise CalibrationError("%s:%d: NUL byte: not a text file" % (path, data.count(b"\n", 0, at) + 1))
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise CalibrationError("%s:%d: not UTF-8 text (byte 0x%02x)"
                               % (path, data.count(b"\n", 0, e.start) + 1, data[e.start])) from None


CHECKSUM_PREFIX = "# checksum=crc32:"


def with_checksum(text):
    """HEAD.cal text with its last line: the CRC-32 (zlib's) of every byte before it."""
    return text + CHECKSUM_PREFIX + "%08x\n" % zlib.crc32(text.encode("utf-8"))


def check_checksum(text, name="HEAD.cal", warn=sys.stderr):
    """A cut or edited HEAD.cal is an error naming file and line (head_cal.c's rules); one
    without a checksum line (written before checksums) is read with a warning on `warn`."""
    if text and not text.endswith("\n"):
        raise CalibrationError("%s:%d: the last line has no line end: the file was cut"
                               % (name, text.count("\n") + 1))
    lines = text.split("\n")
    at = [i for i, line in enumerate(lines) if line.startswith(CHECKSUM_PREFIX)]
    if not at:
        if warn is not None:
            warn.write("warning: %s: no checksum line (a file written before checksums): read "
                       "as it stands; a cut or edited file cannot be told from it\n" % name)
        return
    if len(at) > 1:
        raise CalibrationError("%s:%d: a second checksum line (the first on line %d)"
                               % (name, at[1] + 1, at[0] + 1))
    later = [i for i in range(at[0] + 1, len(lines)) if lines[i].strip()]
    if later:
        raise CalibrationError("%s:%d: content after the checksum line (line %d): the file "
                               "was edited or joined" % (name, later[0] + 1, at[0] + 1))
    body = "\n".join(lines[:at[0]]) + "\n"
    got = lines[at[0]][len(CHECKSUM_PREFIX):].rstrip("\r")
    want = "%08x" % zlib.crc32(body.encode("utf-8"))
    if got != want:
        raise CalibrationError("%s:%d: checksum crc32:%s does not match the content before it "
                               "(crc32:%s): the file was cut or edited"
                               % (name, at[0] + 1, got[:16], want))


def read_head_cal(text, name="HEAD.cal"):
    """The keys of a HEAD.cal text: {key: value string} and {key: line}; checks the
    version line, the checksum line and the line syntax (the full rules are head_cal.c's)."""
    check_checksum(text, name)
    lines = text.lstrip("\ufeff").splitlines()
    if not lines or lines[0].strip() != "# tof-head-cal v1":
        raise CalibrationError("%s:1: the first line must be '# tof-head-cal v1'" % name)
    keys, where = {}, {}
    for n, line in enumerate(lines[1:], start=2):
        if not line.strip() or line.startswith(CHECKSUM_PREFIX):
            continue
        if not line.startswith("#"):
            raise CalibrationError("%s:%d: not a '# key=value' line" % (name, n))
        body = line[1:].strip()
        if "=" not in body:
            continue  # a comment
        key, value = body.split("=", 1)
        key = key.strip()
        if key in keys:
            raise CalibrationError("%s:%d: %s given twice" % (name, n, key))
        keys[key], where[key] = value.strip(), "%s:%d" % (name, n)
    return keys, where


def _integer(keys, where, key, default, lo, hi, name):
    """keys[key] (else default) as an integer lo..hi; the error names the value, the range
    and where it came from."""
    text = keys.get(key, str(default))
    at = where.get(key, "%s: (default or option)" % name)
    try:
        v = int(text)
    except ValueError:
        raise CalibrationError("%s: %s: not an integer, got '%s'" % (at, key, text)) from None
    if not lo <= v <= hi:
        raise CalibrationError("%s: %s %d is outside %d..%d" % (at, key, v, lo, hi))
    return v


def head_cal_to_section(text, name="HEAD.cal", mode=None, budget_ms=None, head_id=None):
    """The 118 bytes of record section 2 version 4 (header included) of a HEAD.cal: the
    thermal keys give its thermal fields (all three or none: else 0). Its binding: the
    keys head_id, distance_mode and timing_budget_ms when the file has them, else the
    arguments, else head 0 and the flight image's configuration (short, 15 ms)."""
    keys, where = read_head_cal(text, name)
    for need in ("offset_mm", "offset_sd_mm"):
        if need not in keys:
            raise CalibrationError("%s: no %s" % (name, need))
    if ("gain" in keys) != ("gain_sd" in keys):
        raise CalibrationError("%s: gain and gain_sd come together or not at all" % name)
    has_gain = "gain" in keys
    if "offset_gain_corr" in keys and not has_gain:
        raise CalibrationError("%s: offset_gain_corr without gain and gain_sd" % name)
    given = [k for k in THERMAL_KEYS if k in keys]
    if given and len(given) != len(THERMAL_KEYS):
        raise CalibrationError("%s: %s without all of %s (they come together or not at all)"
                               % (where[given[0]], given[0], ", ".join(THERMAL_KEYS)))
    thermal = bool(given)
    vals = {k: _values(k, keys[k], where[k]) for k in _KEYS if k in keys}
    cal_temp = _cal_temp(keys["cal_temp_c"], where["cal_temp_c"]) if thermal else 0
    zeros = [0, 0, 0, 0]
    if mode is not None and "distance_mode" in keys and keys["distance_mode"] != mode:
        raise CalibrationError("%s: distance_mode=%s, but --cal-mode %s: the file says the "
                               "mode it was made in; drop --cal-mode or correct the file"
                               % (where["distance_mode"], keys["distance_mode"], mode))
    if (budget_ms is not None and "timing_budget_ms" in keys
            and keys["timing_budget_ms"] != str(budget_ms)):
        raise CalibrationError("%s: timing_budget_ms=%s, but --cal-budget-ms %d: the file "
                               "says the budget it was made with; drop --cal-budget-ms or "
                               "correct the file"
                               % (where["timing_budget_ms"], keys["timing_budget_ms"], budget_ms))
    head = _integer(keys, where, "head_id", head_id if head_id is not None else 0, 0,
                    2 ** 32 - 1, name)
    mode_name = keys.get("distance_mode", mode or DEFAULT_MODE)
    if mode_name not in MODES:
        raise CalibrationError("%s: distance_mode must be short or long, got '%s'"
                               % (where.get("distance_mode", name), mode_name))
    budget = _integer(keys, where, "timing_budget_ms",
                      budget_ms if budget_ms is not None else DEFAULT_BUDGET_MS, 1, 65535, name)
    out = struct.pack("<BBH", SECTION_ID, SECTION_VERSION, SECTION_LEN)
    flags = (FLAG_GAINS if has_gain else 0) | (FLAG_THERMAL if thermal else 0)
    out += struct.pack("<IBBH", head, MODES[mode_name], flags, budget)
    for i in range(4):
        out += struct.pack("<iiIIh", vals["offset_mm"][i],
                           vals.get("gain", zeros)[i], vals["offset_sd_mm"][i],
                           vals.get("gain_sd", zeros)[i], vals.get("offset_gain_corr", zeros)[i])
    out += struct.pack("<h", cal_temp)
    for i in range(4):
        out += struct.pack("<iI", vals.get("temp_coeff_mm_per_c", zeros)[i],
                           vals.get("temp_coeff_sd_mm_per_c", zeros)[i])
    return out


def _exact(units, decimals):
    """units * 10^-decimals as an exact decimal text."""
    return format(decimal.Decimal(units).scaleb(-decimals), "f")


def _thermal_fields(section, thermal):
    """(cal_temp_cdeg, [(coeff_nm_per_c, sd_nm_per_c)] * 4) of a version-4 section, checked as
    the firmware checks them (calibration_record.c): the error names the field and sensor."""
    cal_temp = struct.unpack_from("<h", section, 4 + V1_LEN)[0]
    coeffs = [struct.unpack_from("<iI", section, 4 + V1_LEN + 2 + 8 * i) for i in range(4)]
    if not thermal:
        if cal_temp != 0:
            raise CalibrationError("section: cal_temp_cdeg %d without the thermal flag"
                                   % cal_temp)
        for i, (k, sd) in enumerate(coeffs):
            if k != 0 or sd != 0:
                raise CalibrationError(
                    "section: %s of sensor %s is %d without the thermal flag"
                    % ("temp_coeff_nm_per_c" if k != 0 else "temp_coeff_sd_nm_per_c",
                       SENSORS[i], k if k != 0 else sd))
        return cal_temp, coeffs
    if not TEMP_MIN_CDEG <= cal_temp <= TEMP_MAX_CDEG:
        raise CalibrationError("section: cal_temp_cdeg %d is outside %d..%d (-100..200 C)"
                               % (cal_temp, TEMP_MIN_CDEG, TEMP_MAX_CDEG))
    for i, (k, sd) in enumerate(coeffs):
        if abs(k) > TEMP_COEFF_MAX_NM_PER_C:
            raise CalibrationError("section: temp_coeff_nm_per_c of sensor %s is %d, beyond "
                                   "+-%d (1 mm/C)" % (SENSORS[i], k, TEMP_COEFF_MAX_NM_PER_C))
        if sd > TEMP_COEFF_MAX_NM_PER_C:
            raise CalibrationError("section: temp_coeff_sd_nm_per_c of sensor %s is %d, beyond "
                                   "%d (1 mm/C)" % (SENSORS[i], sd, TEMP_COEFF_MAX_NM_PER_C))
    return cal_temp, coeffs


def section_to_head_cal(section, source="the flight unit", arm_um=None):
    """HEAD.cal text of record section 2: version 4 (118 bytes, what the unit sends), or
    version 1 (84 bytes, before the thermal fields: a calibration without them). Raises
    CalibrationError for a section that is not one (all zero: none stored), naming the
    field that is wrong."""
    if len(section) not in (4 + SECTION_LEN, 4 + V1_LEN) or not any(section):
        raise CalibrationError("no calibration stored")
    sid, version, length = struct.unpack_from("<BBH", section, 0)
    if (sid != SECTION_ID or (version, length) not in ((SECTION_VERSION, SECTION_LEN), (1, V1_LEN))
            or length + 4 != len(section)):
        raise CalibrationError("section id %d version %d length %d: not a calibration this "
                               "tool reads (id 2, version 4 length 114 or version 1 length 80)"
                               % (sid, version, length))
    head, mode, flags, budget = struct.unpack_from("<IBBH", section, 4)
    allowed = FLAG_GAINS | (FLAG_THERMAL if version == SECTION_VERSION else 0)
    if flags & ~allowed:
        raise CalibrationError("section: flags 0x%02x: reserved bits set (version %d takes "
                               "0x%02x)" % (flags, version, allowed))
    thermal = bool(flags & FLAG_THERMAL)
    cal_temp, coeffs = (_thermal_fields(section, thermal) if version == SECTION_VERSION
                        else (0, []))
    sensors = [struct.unpack_from("<iiIIh", section, 12 + 18 * i) for i in range(4)]
    mode_name = {v: k for k, v in MODES.items()}.get(mode, str(mode))
    col = lambda k: [s[k] for s in sensors]
    lines = ["# tof-head-cal v1",
             "# offset_mm=" + ",".join(_exact(v, 3) for v in col(0)),
             "# offset_sd_mm=" + ",".join(_exact(v, 3) for v in col(2))]
    if flags & FLAG_GAINS:
        lines += ["# gain=" + ",".join(_exact(1000000 + v, 6) for v in col(1)),
                  "# gain_sd=" + ",".join(_exact(v, 6) for v in col(3)),
                  "# offset_gain_corr=" + ",".join(
                      format(decimal.Decimal(v) / 32768, "f") for v in col(4))]
    if thermal:
        lines += ["# cal_temp_c=" + _exact(cal_temp, 2),
                  "# temp_coeff_mm_per_c=" + ",".join(_exact(k, 6) for k, _ in coeffs),
                  "# temp_coeff_sd_mm_per_c=" + ",".join(_exact(sd, 6) for _, sd in coeffs)]
    lines += ["# head_id=%d" % head, "# distance_mode=%s" % mode_name,
              "# timing_budget_ms=%d" % budget]
    if arm_um is not None:
        lines.append("# arm_mm=" + _exact(arm_um, 3))
    lines.append("# source=%s" % source)
    return with_checksum("\n".join(lines) + "\n")


# --- the fixture station recorder ---------------------------------------------

TRACE_HEADER = "t_ms,a_mm,b_mm,c_mm,d_mm,a_st,b_st,c_st,d_st,alpha_deg,beta_deg,distance_mm"


def station_rows(raw_samples, alpha_deg, beta_deg, distance_mm):
    """Rows of a calibration trace: each raw sample (dicts of tof_telemetry's raw message)
    with the station's stated reference. An absent reading is status 255 (no reading)."""
    ref = "%s,%s,%s" % (alpha_deg, beta_deg, distance_mm)
    for s in raw_samples:
        ranges = [s["range_mm"][i] if s["present"] & (1 << i) else 0 for i in range(4)]
        status = [s["range_status"][i] if s["present"] & (1 << i) else 255 for i in range(4)]
        yield "%d,%s,%s,%s" % (s["t_ms"], ",".join(map(str, ranges)),
                               ",".join(map(str, status)), ref)


def append_station(path, raw_samples, alpha_deg, beta_deg, distance_mm, arm_mm=30.0,
                   period_ms=20, distance_mode="short", timing_budget_ms=15):
    """Append a station's rows to the calibration trace at path (created with its header
    when new, stating the parts' distance mode and timing budget, which host_sim calibrate
    binds the HEAD.cal to). The reference values are checked as numbers. Returns the rows
    written."""
    if distance_mode not in ("short", "long"):
        raise CalibrationError("distance mode '%s' is not short or long" % distance_mode)
    if not isinstance(timing_budget_ms, int) or not 1 <= timing_budget_ms <= 65535:
        raise CalibrationError("timing budget '%s' ms is not an integer 1..65535"
                               % timing_budget_ms)
    for v in (alpha_deg, beta_deg, distance_mm):
        if _units(str(v), 6) is None:
            raise CalibrationError("station reference '%s' is not a plain decimal" % v)
    new = not os.path.exists(path) or os.path.getsize(path) == 0
    shift = 0
    if not new and raw_samples:
        # t_ms must not go back (trace v1): a station recorded after a restart of the unit
        # (or from another capture) continues one period after the trace's last row
        with open(path) as f:
            last = [line for line in f.read().splitlines() if line[:1].isdigit()]
        last_t = int(last[-1].split(",", 1)[0]) if last else -period_ms
        if raw_samples[0]["t_ms"] <= last_t:
            shift = last_t + period_ms - raw_samples[0]["t_ms"]
    samples = [dict(s, t_ms=s["t_ms"] + shift) for s in raw_samples]
    rows = list(station_rows(samples, alpha_deg, beta_deg, distance_mm))
    with open(path, "a") as f:
        if new:
            f.write("# tof-trace v1\n# arm_mm=%s\n# period_ms=%d\n# distance_mode=%s\n"
                    "# timing_budget_ms=%d\n%s\n"
                    % (arm_mm, period_ms, distance_mode, timing_budget_ms, TRACE_HEADER))
        for row in rows:
            f.write(row + "\n")
    return len(rows)
