"""Unit tests of tools/tof_calibration.py and tof_telemetry.py's calibration options
(run: /usr/bin/python3 -m unittest discover -s tools/tests -p "test_tof_calibration.py").

The section bytes are the firmware's own (tof_cal_encode() of the same head, dumped once);
the decimal conversions are the C trace reader's test values (tests/scene/test_trace_v1_cal.c).
"""

import io
import os
import struct
import sys
import tempfile
import unittest
from contextlib import redirect_stdout

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import tof_calibration as c  # noqa: E402
import tof_telemetry as t  # noqa: E402

HEAD_CAL = """# tof-head-cal v1
# offset_mm=-3.105,7.882,0.516,-12.340
# offset_sd_mm=0.028,0.029,0.028,0.030
# gain=1.00410,0.99187,1.01202,0.99655
# gain_sd=0.00019,0.00020,0.00019,0.00021
# offset_gain_corr=-0.93,-0.93,-0.93,-0.93
# head_id=7
# fit=offsets+gains
"""
# firmware/src/calibration_record.c's tof_cal_encode() of this head, head 7, short, 15 ms:
# section 2 version 4 (118 bytes), the thermal fields 0 without the thermal keys
FIRMWARE_SECTION = bytes.fromhex(
    "020472000700000001010f00dff3ffff041000001c000000be000000f688ca1e00003ee0ffff1d000000"
    "c8000000f68804020000f42e00001c000000be000000f688cccfffff86f2ffff1e000000d2000000f688"
    "00000000000000000000000000000000000000000000000000000000000000000000")
# The same head measured across temperatures: calibrated at 21.5 C, coefficients 0.021,
# -0.008, 0, -1 mm/C with sd 0.0015, 0.0009, 0.002, 1 mm/C (tof_cal_encode() likewise)
THERMAL_KEYS = """# cal_temp_c=21.5
# temp_coeff_mm_per_c=0.021,-0.008,0,-1
# temp_coeff_sd_mm_per_c=0.0015,0.0009,0.002,1
"""
FIRMWARE_THERMAL_SECTION = bytes.fromhex(
    "020472000700000001030f00dff3ffff041000001c000000be000000f688ca1e00003ee0ffff1d000000"
    "c8000000f68804020000f42e00001c000000be000000f688cccfffff86f2ffff1e000000d2000000f688"
    "660808520000dc050000c0e0ffff8403000000000000d0070000c0bdf0ff40420f00")
# The version-1 section a unit before the thermal fields sent (84 bytes): the same head
FIRMWARE_V1_SECTION = bytes.fromhex(
    "020150000700000001010f00dff3ffff041000001c000000be000000f688ca1e00003ee0ffff1d000000"
    "c8000000f68804020000f42e00001c000000be000000f688cccfffff86f2ffff1e000000d2000000f688")


def sensor(section, i):
    return struct.unpack_from("<iiIIh", section, 12 + 18 * i)


class SectionTest(unittest.TestCase):
    def test_the_firmware_bytes(self):
        self.assertEqual(c.head_cal_to_section(HEAD_CAL), FIRMWARE_SECTION)

    def test_exact_decimals_as_the_trace_reader(self):
        text = ("# tof-head-cal v1\n# offset_mm=-3.105,7.882,0.5165,-12.3404\n"
                "# offset_sd_mm=0.028,0.029,0.0285,0\n"
                "# gain=1.00410,0.99187,1.0000005,0.9999995\n"
                "# gain_sd=0.00019,0.0002,1e-4,0.0000215\n"
                "# offset_gain_corr=-0.93,1,-1,0.5\n")
        s = c.head_cal_to_section(text)
        self.assertEqual([sensor(s, i) for i in range(4)],
                         [(-3105, 4100, 28, 190, -30474), (7882, -8130, 29, 200, 32767),
                          (517, 1, 29, 100, -32768), (-12340, -1, 0, 22, 16384)])

    def test_round_trip(self):
        text = c.section_to_head_cal(FIRMWARE_SECTION)
        self.assertIn("# head_id=7", text)
        self.assertIn("# distance_mode=short", text)
        self.assertEqual(c.head_cal_to_section(text), FIRMWARE_SECTION)

    def test_the_thermal_keys_as_the_firmware_stores_them(self):
        s = c.head_cal_to_section(HEAD_CAL + THERMAL_KEYS)
        self.assertEqual(s, FIRMWARE_THERMAL_SECTION)
        self.assertEqual(struct.unpack_from("<h", s, 84)[0], 2150)
        self.assertEqual([struct.unpack_from("<iI", s, 86 + 8 * i) for i in range(4)],
                         [(21000, 1500), (-8000, 900), (0, 2000), (-1000000, 1000000)])
        back = c.section_to_head_cal(s)
        self.assertIn("# cal_temp_c=21.50\n", back)
        self.assertIn("# temp_coeff_mm_per_c=0.021000,-0.008000,0.000000,-1.000000\n", back)
        self.assertIn("# temp_coeff_sd_mm_per_c=0.001500,0.000900,0.002000,1.000000\n", back)
        self.assertEqual(c.head_cal_to_section(back), s)
        # rounded as the trace reader rounds: half away from zero, to 0.01 C and 1 nm/C
        s = c.head_cal_to_section(HEAD_CAL + "# cal_temp_c=-12.345\n"
                                  "# temp_coeff_mm_per_c=0.0000005,-0.0000005,0.0000004,0\n"
                                  "# temp_coeff_sd_mm_per_c=0,0,0,0.0000015\n")
        self.assertEqual(struct.unpack_from("<h", s, 84)[0], -1235)
        self.assertEqual([struct.unpack_from("<iI", s, 86 + 8 * i) for i in range(4)],
                         [(1, 0), (-1, 0), (0, 0), (0, 2)])

    def test_the_version_before_the_thermal_fields_reads_without_them(self):
        text = c.section_to_head_cal(FIRMWARE_V1_SECTION)
        self.assertNotIn("cal_temp_c", text)
        self.assertNotIn("temp_coeff", text)
        self.assertEqual(c.head_cal_to_section(text), FIRMWARE_SECTION)
        # its reserved flag bit 1 is not the thermal flag
        bad = bytearray(FIRMWARE_V1_SECTION)
        bad[9] |= 0x02
        with self.assertRaisesRegex(c.CalibrationError, "flags 0x03: reserved bits"):
            c.section_to_head_cal(bytes(bad))

    def test_thermal_refusals_name_the_field(self):
        bad = [(THERMAL_KEYS.replace("# cal_temp_c=21.5\n", ""),
                "HEAD.cal:9: temp_coeff_mm_per_c without all of cal_temp_c"),
               (THERMAL_KEYS.replace("21.5", "200.01"),
                "HEAD.cal:9: cal_temp_c: a temperature within -100..200 C, got '200.01'"),
               (THERMAL_KEYS.replace("21.5", "-100.005"), "cal_temp_c: a temperature within"),
               (THERMAL_KEYS.replace("21.5", "21,22"), "cal_temp_c: one value"),
               (THERMAL_KEYS.replace("21.5", "warm"), "cal_temp_c: not a plain decimal"),
               (THERMAL_KEYS.replace("0.021,", "1.0000005,"),
                "HEAD.cal:10: temp_coeff_mm_per_c: a coefficient within -1..1 mm/C"),
               (THERMAL_KEYS.replace("0.0015,", "-0.0015,"),
                "HEAD.cal:11: temp_coeff_sd_mm_per_c: an sd within 0..1 mm/C"),
               (THERMAL_KEYS.replace(",-1\n", "\n"), "temp_coeff_mm_per_c: four values")]
        for keys, what in bad:
            with self.assertRaises(c.CalibrationError) as e:
                c.head_cal_to_section(HEAD_CAL + keys)
            self.assertIn(what, str(e.exception))
        # a section whose thermal fields are out of the firmware's bounds, or set without the
        # thermal flag, names the field and sensor
        def patched(base, at, fmt, value):
            s = bytearray(base)
            struct.pack_into(fmt, s, at, value)
            return bytes(s)
        cases = [(patched(FIRMWARE_THERMAL_SECTION, 84, "<h", 20001), "cal_temp_cdeg 20001"),
                 (patched(FIRMWARE_THERMAL_SECTION, 86 + 8, "<i", 1000001),
                  "temp_coeff_nm_per_c of sensor B is 1000001"),
                 (patched(FIRMWARE_THERMAL_SECTION, 90 + 16, "<I", 1000001),
                  "temp_coeff_sd_nm_per_c of sensor C is 1000001"),
                 (patched(FIRMWARE_SECTION, 84, "<h", 1), "cal_temp_cdeg 1 without the thermal"),
                 (patched(FIRMWARE_SECTION, 86 + 24, "<i", -5),
                  "temp_coeff_nm_per_c of sensor D is -5 without the thermal flag"),
                 (patched(FIRMWARE_SECTION, 9, "<B", 0x05), "flags 0x05: reserved bits")]
        for section, what in cases:
            with self.assertRaises(c.CalibrationError) as e:
                c.section_to_head_cal(section)
            self.assertIn(what, str(e.exception))

    def test_offsets_only(self):
        s = c.head_cal_to_section("# tof-head-cal v1\n# offset_mm=1,2,3,4\n"
                                  "# offset_sd_mm=0,0,0,0\n", mode="long", budget_ms=33)
        self.assertEqual(struct.unpack_from("<IBBH", s, 4), (0, 2, 0, 33))
        self.assertEqual(sensor(s, 3), (4000, 0, 0, 0, 0))
        back = c.section_to_head_cal(s)
        self.assertNotIn("gain", back)
        self.assertEqual(c.head_cal_to_section(back), s)

    def test_bad_files_say_where(self):
        bad = [("# tof-trace v1\n", "first line"),
               ("# tof-head-cal v1\n# offset_mm=1,2,3\n# offset_sd_mm=0,0,0,0\n",
                "HEAD.cal:2: offset_mm: four values"),
               ("# tof-head-cal v1\n# offset_mm=1,2,3,nan\n# offset_sd_mm=0,0,0,0\n",
                "not a plain decimal"),
               ("# tof-head-cal v1\n# offset_mm=1,2,3,4\n# offset_sd_mm=0,0,0,0\n"
                "# gain=1,1,1.2,1\n# gain_sd=0,0,0,0\n", "HEAD.cal:4: gain: a gain within"),
               ("# tof-head-cal v1\n# offset_mm=1,2,3,4\n# offset_sd_mm=0,0,0,0\n# gain=1,1,1,1\n",
                "together"),
               ("# tof-head-cal v1\n# offset_sd_mm=0,0,0,0\n", "no offset_mm")]
        for text, what in bad:
            with self.assertRaises(c.CalibrationError) as e:
                c.head_cal_to_section(text)
            self.assertIn(what, str(e.exception))
        with self.assertRaises(c.CalibrationError):
            c.section_to_head_cal(bytes(118))  # none stored


class TelemetryTest(unittest.TestCase):
    def test_messages(self):
        ftype, payload = t.command_payload("write-calibration " + FIRMWARE_SECTION.hex())
        self.assertEqual((ftype, payload), (t.T_WRITE_CALIBRATION, FIRMWARE_SECTION))
        self.assertEqual(t.command_payload("read-calibration"), (t.T_READ_CALIBRATION, b""))
        self.assertEqual(t.command_payload("re-zero 500"), (t.T_REZERO, b"\xf4\x01"))
        for bad in ("re-zero 9", "re-zero 5001", "re-zero x"):
            with self.assertRaises(t.ProtocolError):
                t.command_payload(bad)
        with self.assertRaises(t.ProtocolError):
            t.command_payload("write-calibration 0201")
        fields, result = t.parse(t.T_CALIBRATION, bytes([1]) + FIRMWARE_SECTION)
        self.assertEqual((result, fields["state"]), (t.R_OK, 1))
        self.assertEqual(t.parse(t.T_CALIBRATION, bytes([0]) + bytes(118))[1], t.R_OK)
        self.assertEqual(t.parse(t.T_CALIBRATION, bytes([8]) + bytes(118))[1], t.R_OK)  # other-parts
        self.assertEqual(t.parse(t.T_CALIBRATION, bytes([len(t.CAL_STATES)]) + bytes(118))[1], t.R_OUT_OF_RANGE)
        self.assertEqual(t.parse(t.T_WRITE_CALIBRATION, bytes(118))[1], t.R_OUT_OF_RANGE)
        # the previous protocol's 84-byte section is not this version's length
        self.assertEqual(t.parse(t.T_WRITE_CALIBRATION, FIRMWARE_V1_SECTION)[1], t.R_BAD_LENGTH)
        fields, result = t.parse(t.T_CALIBRATION, bytes([1]) + FIRMWARE_THERMAL_SECTION)
        self.assertEqual((result, fields["section"]), (t.R_OK, FIRMWARE_THERMAL_SECTION))
        status, result = t.parse(t.T_STATUS, bytes([0, 1, 0, t.PROTOCOL_VERSION]) + struct.pack(
            "<IHBBBBHBBIIBBh", 1000, 100, 0, 0, 1, 0, 20, 0, 5, 30000, 7200, 1, 0, 0))
        self.assertEqual((result, t.CAL_STATES[status["calibration"]]), (t.R_OK, "other-mode"))

    def run_main(self, argv):
        out = io.StringIO()
        with redirect_stdout(out):
            rc = t.main(argv)
        return rc, out.getvalue()

    def test_read_cal_from_a_capture(self):
        for section in (FIRMWARE_SECTION, FIRMWARE_THERMAL_SECTION):
            with tempfile.TemporaryDirectory() as d:
                cap, out = os.path.join(d, "cap.bin"), os.path.join(d, "out.cal")
                with open(cap, "wb") as f:
                    f.write(t.encode_frame(t.T_CALIBRATION, 3, bytes([1]) + section))
                rc, text = self.run_main(["--file", cap, "--read-cal", out])
                self.assertEqual(rc, 0)
                self.assertIn("state=applied", text)
                with open(out) as f:
                    self.assertEqual(c.head_cal_to_section(f.read()), section)

    def test_send_cal_commands(self):
        with tempfile.TemporaryDirectory() as d:
            cal, cmds = os.path.join(d, "head.cal"), os.path.join(d, "cmds.bin")
            with open(cal, "w") as f:
                f.write(HEAD_CAL)
            self.assertEqual(self.run_main(["--write-commands", cmds, "--send-cal", cal,
                                            "--first-seq", "0"])[0], 0)
            with open(cmds, "rb") as f:
                data = f.read()
            self.assertEqual(data, t.encode_frame(t.T_WRITE_CALIBRATION, 0, FIRMWARE_SECTION)
                             + t.encode_frame(t.T_READ_CALIBRATION, 1, b""))
            with open(cal, "w") as f:
                f.write(c.with_checksum(HEAD_CAL + THERMAL_KEYS))
            self.assertEqual(self.run_main(["--write-commands", cmds, "--send-cal", cal,
                                            "--first-seq", "0"])[0], 0)
            with open(cmds, "rb") as f:
                self.assertEqual(f.read()[:125], t.encode_frame(t.T_WRITE_CALIBRATION, 0,
                                                                FIRMWARE_THERMAL_SECTION))

    def test_record_stations_into_a_calibration_trace(self):
        with tempfile.TemporaryDirectory() as d:
            cap, trace = os.path.join(d, "cap.bin"), os.path.join(d, "cal.csv")
            with open(cap, "wb") as f:
                for k in range(5):
                    f.write(t.encode_frame(t.T_RAW_SAMPLE, k, struct.pack(
                        "<I4H4BB", 20 * k, 100 + k, 101, 102, 0, 0, 0, 4, 0, 0x07)))
            for station in ("5,0,60", "-5.5,2,200.25"):
                # --station=... : a negative angle would read as an option otherwise
                rc, _ = self.run_main(["--file", cap, "--record-station", trace,
                                       "--station=" + station, "--readings", "3"])
                self.assertEqual(rc, 0)
            with open(trace) as f:
                lines = f.read().splitlines()
            # the parts' mode and budget stated, for host_sim calibrate's binding
            self.assertEqual(lines[:6], ["# tof-trace v1", "# arm_mm=30", "# period_ms=20",
                                         "# distance_mode=short", "# timing_budget_ms=15",
                                         c.TRACE_HEADER])
            self.assertEqual(lines[6], "0,100,101,102,0,0,0,4,255,5,0,60")
            # the second station's capture restarts at t_ms 0: it continues the trace's time
            self.assertEqual(lines[-1], "100,102,101,102,0,0,0,4,255,-5.5,2,200.25")
            self.assertEqual(len(lines), 6 + 6)


if __name__ == "__main__":
    unittest.main()


class ChecksumTest(unittest.TestCase):
    """HEAD.cal's last line: the CRC-32 of the content before it (docs/reference/calibration-file.md)."""

    def test_written_files_read_back_without_warning(self):
        text = c.section_to_head_cal(FIRMWARE_SECTION, "unit")
        self.assertRegex(text.splitlines()[-1], r"^# checksum=crc32:[0-9a-f]{8}$")
        warn = io.StringIO()
        c.check_checksum(text, "back.cal", warn)
        self.assertEqual(warn.getvalue(), "")
        self.assertEqual(c.head_cal_to_section(text, "back.cal"), FIRMWARE_SECTION)

    def test_the_crc_is_zlibs_and_head_cal_cs(self):
        # CRC-32/IEEE check value, as head_cal.c's crc32_of() computes it
        self.assertEqual(c.with_checksum("123456789")[9:], "# checksum=crc32:cbf43926\n")

    def test_cut_or_edited_is_an_error_naming_the_line(self):
        text = c.section_to_head_cal(FIRMWARE_SECTION, "unit")
        with self.assertRaisesRegex(c.CalibrationError, r"^cut.cal:\d+: the last line has no "
                                                        r"line end: the file was cut"):
            c.check_checksum(text[:-3], "cut.cal")
        cut_line = text[:text.rindex("# checksum")]  # the whole checksum line gone: a v1 file
        with self.assertRaisesRegex(c.CalibrationError, r"edited.cal:11: checksum crc32:\w+ "
                                                        r"does not match"):
            c.check_checksum(text.replace("head_id=7", "head_id=8"), "edited.cal")
        with self.assertRaisesRegex(c.CalibrationError, r"joined.cal:12: content after the "
                                                        r"checksum line"):
            c.check_checksum(text + "# gain=1,1,1,1\n", "joined.cal")
        warn = io.StringIO()
        c.check_checksum(cut_line, "v1.cal", warn)
        self.assertIn("v1.cal: no checksum line", warn.getvalue())

    def test_binary_file_is_refused_naming_the_line(self):
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "bin.cal")
            with open(path, "wb") as f:
                f.write(b"# tof-head-cal v1\n# x\x00y\n")
            with self.assertRaisesRegex(c.CalibrationError, r"bin.cal:2: NUL byte"):
                c.read_text_file(path)


class RefusalTest(unittest.TestCase):
    def test_nacks_name_cause_and_remedy(self):
        for result in range(5, len(t.RESULTS)):
            text = t.nack_text({"result": result, "error": 0})
            self.assertIn(t.RESULTS[result] + ": ", text)
            self.assertIn(t.CAUSES[t.RESULTS[result]], text)

    def test_a_restart_is_not_counted_as_lost_frames(self):
        out = io.StringIO()
        p = t.Printer(out)
        status = struct.pack("<BBBBIHBBBBHBBIIBBh", 0, 1, 0, t.PROTOCOL_VERSION, 5000, 100, 0,
                             0, 1, 0, 20, 0, 1, 30000, 0, 0, 1, 2250)
        p.handle(("frame", t.T_STATUS, 0, status), {})
        p.handle(("frame", t.T_STATUS, 7, status), {})
        boot = status[:4] + struct.pack("<I", 130) + status[8:]
        p.handle(("frame", t.T_STATUS, 0, boot), {})
        self.assertEqual((p.lost_frames, p.reboots), (6, 1))
        self.assertIn("the unit restarted (boot status, uptime 130 ms)", out.getvalue())
