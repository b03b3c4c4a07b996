"""Unit tests of tools/tof_telemetry.py (run: /usr/bin/python3 -m unittest discover -s tools/tests).

The byte-exact examples are the ones in docs/telemetry.md and in
tests/telemetry/test_tlm_frame.c, so all three agree.
"""

import io
import os
import select
import struct
import subprocess
import sys
import tempfile
import time
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import tof_telemetry as t  # noqa: E402

START_SEQ0 = bytes.fromhex("a55a0083005782")
SET_WINDOW_100_SEQ1 = bytes.fromhex("a55a038101640000 6e79".replace(" ", ""))
ACK_SEQ9 = bytes.fromhex("a55a040409018100000be4")
ESTIMATE_SEQ42 = bytes.fromhex(
    "a55a1c012a204e0000c7000000000000 0f60e31600702ffcff00ca5b07f4ffffff2502".replace(" ", ""))


def frames_of(events):
    return [e for e in events if e[0] == "frame"]


class CrcTest(unittest.TestCase):
    def test_check_value(self):
        self.assertEqual(t.crc16(b"123456789"), 0x29B1)

    def test_empty_and_incremental(self):
        self.assertEqual(t.crc16(b""), 0xFFFF)
        data = bytes(range(200))
        self.assertEqual(t.crc16(data[77:], t.crc16(data[:77])), t.crc16(data))


class EncodeTest(unittest.TestCase):
    def test_documented_frames(self):
        self.assertEqual(t.encode_frame(t.T_START, 0, b""), START_SEQ0)
        self.assertEqual(t.encode_frame(t.T_SET_WINDOW, 1, struct.pack("<HB", 100, 0)),
                         SET_WINDOW_100_SEQ1)
        self.assertEqual(t.encode_frame(t.T_ACK, 9, bytes([1, 0x81, 0, 0])), ACK_SEQ9)
        payload = struct.pack("<IIBBBBiiii", 20000, 199, 0, 0, 0, 15, 1500000, -250000,
                              123456000, -12)
        self.assertEqual(t.encode_frame(t.T_ESTIMATE, 42, payload), ESTIMATE_SEQ42)

    def test_payload_limit(self):
        self.assertEqual(len(t.encode_frame(1, 0, bytes(192))), 199)
        with self.assertRaises(t.ProtocolError):
            t.encode_frame(1, 0, bytes(193))

    def test_commands_from_text(self):
        self.assertEqual(t.encode_commands(["start"]), START_SEQ0)
        self.assertEqual(t.encode_commands(["status", "set-window 100"], first_seq=0)[7:],
                         SET_WINDOW_100_SEQ1)
        self.assertEqual(t.command_payload("set-window 50 sliding"),
                         (t.T_SET_WINDOW, b"\x32\x00\x01"))
        self.assertEqual(t.command_payload("estimator consensus-paper"),
                         (t.T_SELECT_ESTIMATOR, b"\x01"))
        self.assertEqual(t.command_payload("raw off"), (t.T_RAW_STREAM, b"\x00"))
        self.assertEqual(t.command_payload("status"), (t.T_STATUS_REQUEST, b""))

    def test_bad_commands_name_the_problem(self):
        cases = {"set-window 1": "2..255", "set-window 256": "2..255",
                 "set-window x": "not an integer", "set-window 5 zigzag": "tumbling or sliding",
                 "estimator best": "one of", "raw 2": "on or off", "start now": "usage",
                 "fly": "unknown command", "": "empty"}
        for text, fragment in cases.items():
            with self.assertRaises(t.ProtocolError, msg=text) as ctx:
                t.command_payload(text)
            self.assertIn(fragment, str(ctx.exception))


class DecoderTest(unittest.TestCase):
    def test_single_frames(self):
        d = t.Decoder()
        events = d.feed(ESTIMATE_SEQ42 + START_SEQ0)
        self.assertEqual([(e[1], e[2]) for e in frames_of(events)], [(1, 42), (0x83, 0)])
        fields, result = t.parse(events[0][1], events[0][3])
        self.assertEqual(result, t.R_OK)
        self.assertEqual(fields["alpha_udeg"], 1500000)
        self.assertEqual(fields["beta_udeg"], -250000)
        self.assertEqual(fields["distance_um"], 123456000)
        self.assertEqual(d.counters["frames_ok"], 2)

    def test_byte_at_a_time_equals_whole(self):
        stream = b"junk\xa5" + ACK_SEQ9 + START_SEQ0[:4] + SET_WINDOW_100_SEQ1 + b"\xa5\x5a\xff"
        whole = t.Decoder()
        events_whole = whole.feed(stream) + whole.flush()
        single = t.Decoder()
        events_single = []
        for b in stream:
            events_single += single.feed(bytes([b]))
        events_single += single.flush()
        self.assertEqual(events_whole, events_single)
        self.assertEqual(whole.counters, single.counters)
        self.assertEqual(len(frames_of(events_whole)), 2)
        self.assertEqual(whole.counters["truncated"], 1)  # the cut start frame
        self.assertEqual(whole.counters["bad_length"], 1)  # length 0xff
        self.assertEqual(whole.counters["discarded_bytes"], 5 + 4 + 3)

    def test_bad_crc(self):
        bad = bytearray(ESTIMATE_SEQ42)
        bad[10] ^= 0x10
        d = t.Decoder()
        events = d.feed(bytes(bad) + ACK_SEQ9) + d.flush()
        self.assertEqual(len(frames_of(events)), 1)
        self.assertEqual(d.counters["bad_crc"], 1)
        self.assertEqual(d.counters["truncated"], 0)

    def test_rejections(self):
        d = t.Decoder(t.ACCEPT_COMMANDS)
        events = d.feed(ACK_SEQ9 + t.encode_frame(t.T_START, 3, b"\x00"))
        self.assertEqual(events, [("reject", t.T_ACK, 9, 4, t.R_UNKNOWN_TYPE),
                                  ("reject", t.T_START, 3, 1, t.R_BAD_LENGTH)])
        self.assertEqual(d.counters["unknown_type"], 1)
        self.assertEqual(d.counters["bad_length"], 1)

    def test_out_of_range_fields(self):
        self.assertEqual(t.parse(t.T_SET_WINDOW, b"\x01\x00\x00")[1], t.R_OUT_OF_RANGE)
        self.assertEqual(t.parse(t.T_SET_WINDOW, b"\x00\x01\x00")[1], t.R_OUT_OF_RANGE)
        self.assertEqual(t.parse(t.T_SELECT_ESTIMATOR, b"\x04")[1], t.R_OUT_OF_RANGE)
        self.assertEqual(t.parse(t.T_RAW_STREAM, b"\x02")[1], t.R_OUT_OF_RANGE)
        self.assertEqual(t.parse(t.T_START, b"\x00")[1], t.R_BAD_LENGTH)
        self.assertEqual(t.parse(0x42, b"")[1], t.R_UNKNOWN_TYPE)
        ok_with_reason = struct.pack("<IIBBBBiiii", 0, 0, 0, 0, 1, 15, 0, 0, 0, 0)
        self.assertEqual(t.parse(t.T_ESTIMATE, ok_with_reason)[1], t.R_OUT_OF_RANGE)


class FormatTest(unittest.TestCase):
    def test_fixed_point_text_is_exact(self):
        self.assertEqual(t.fixed(1500000, 6), "1.500000")
        self.assertEqual(t.fixed(-1, 6), "-0.000001")
        self.assertEqual(t.fixed(-2147483647, 6), "-2147.483647")
        self.assertEqual(t.fixed(123456000, 3), "123456.000")
        self.assertEqual(t.fixed(0, 3), "0.000")

    def test_file_output_and_csv(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "cap.bin")
            with open(path, "wb") as f:
                f.write(ESTIMATE_SEQ42 + ACK_SEQ9)
            out, err = io.StringIO(), io.StringIO()
            old = sys.stdout, sys.stderr
            sys.stdout, sys.stderr = out, err
            try:
                self.assertEqual(t.main(["--file", path]), 0)
            finally:
                sys.stdout, sys.stderr = old
            self.assertEqual(err.getvalue(), "# lost_frames=222 (sequence gaps)\n")
            lines = out.getvalue().splitlines()
            self.assertEqual(lines[0], (
                "seq=42 estimate t_ms=20000 window=199 estimator=consensus status=ok "
                "reason=none sensors=ABCD alpha_deg=1.500000 beta_deg=-0.250000 "
                "distance_mm=123456.000 flatness_um=-12"))
            self.assertEqual(lines[1], "seq=9 ack echo_seq=1 command=set-window result=ok error=0")
            self.assertTrue(lines[2].startswith("# frames_ok=2 bad_crc=0"))


class SerialPortTest(unittest.TestCase):
    """--port on a pseudo-terminal: commands go out, frames come in, idle flush works."""

    def test_send_and_receive_over_a_pty(self):
        try:
            import serial  # noqa: F401
        except ImportError:
            self.fail("python3-serial missing: run tools/setup.sh and use /usr/bin/python3")
        master, slave = os.openpty()
        script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..",
                              "tof_telemetry.py")
        proc = subprocess.Popen(
            [sys.executable, script, "--port", os.ttyname(slave), "--duration", "2.0",
             "--send", "set-window 50 sliding", "--send", "start"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        try:
            expected_cmds = t.encode_commands(["set-window 50 sliding", "start"])
            received = b""
            deadline = time.monotonic() + 5
            while len(received) < len(expected_cmds) and time.monotonic() < deadline:
                ready, _, _ = select.select([master], [], [], 0.1)
                if ready:
                    received += os.read(master, 1024)
            self.assertEqual(received, expected_cmds)
            # Answer: two acks, then a partial frame and silence (idle flush -> truncated).
            os.write(master, t.encode_frame(t.T_ACK, 0, bytes([0, t.T_SET_WINDOW, 0, 0]))
                     + t.encode_frame(t.T_ACK, 1, bytes([1, t.T_START, 0, 0])) + ACK_SEQ9[:6])
            out, err = proc.communicate(timeout=10)
        finally:
            if proc.poll() is None:
                proc.kill()
            os.close(master)
            os.close(slave)
        self.assertEqual(proc.returncode, 0, err.decode())
        lines = out.decode().splitlines()
        self.assertEqual(lines[0], "seq=0 ack echo_seq=0 command=set-window result=ok error=0")
        self.assertEqual(lines[1], "seq=1 ack echo_seq=1 command=start result=ok error=0")
        self.assertEqual(lines[-1], "# frames_ok=2 bad_crc=0 bad_length=0 unknown_type=0 "
                                    "truncated=1 out_of_range=0 discarded_bytes=6")


if __name__ == "__main__":
    unittest.main()
