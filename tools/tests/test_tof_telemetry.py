"""Unit tests of tools/tof_telemetry.py (run: /usr/bin/python3 -m unittest discover -s tools/tests).

The byte-exact examples are the ones in docs/reference/telemetry-protocol.md and in
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
# the C encoder's bytes (tests/telemetry/test_tlm_messages.c): a window at -12.34 degC
ESTIMATE_SEQ42 = bytes.fromhex(
    "a55a32012a204e0000c700000000000f60e31600702ffcff00ca5b"
    "07f4ffffffb01e040088130000dc0500000000000000000000012efb984f")


def estimate_payload(t_ms=20000, window=199, estimator=0, status=0, sensors=15, alpha=1500000,
                     beta=-250000, distance=123456000, flatness=-12, alpha_sd=270000,
                     beta_sd=5000, distance_sd=1500, why=0, temp_known=1, temp_cdeg=-1234):
    return struct.pack(t.ESTIMATE_FORMAT, t_ms, window, estimator, status, sensors, alpha, beta,
                       distance, flatness, alpha_sd, beta_sd, distance_sd, why, temp_known,
                       temp_cdeg)


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
        payload = struct.pack("<IIBBBiiiiiiiQBh", 20000, 199, 0, 0, 15, 1500000, -250000,
                              123456000, -12, 270000, 5000, 1500, 0, 1, -1234)
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
        # QD 0.5 mm^2/s = 500000 um^2/s, QT 4294.967295 (the u32 maximum), flags 0
        self.assertEqual(t.command_payload("process-noise 0.5,4294.967295"),
                         (t.T_SET_PROCESS_NOISE,
                          b"\x20\xa1\x07\x00\xff\xff\xff\xff\x00"))
        self.assertEqual(t.command_payload("set-process-noise 2,0.000001"),
                         (t.T_SET_PROCESS_NOISE, struct.pack("<IIB", 2000000, 1, 0)))
        self.assertEqual(t.command_payload("process-noise auto"),
                         (t.T_SET_PROCESS_NOISE, bytes(8) + b"\x01"))
        ftype, payload = t.command_payload("process-noise 1.25,0.0100")
        fields, result = t.parse(ftype, payload)
        self.assertEqual(result, t.R_OK)
        self.assertEqual(t.format_message(ftype, 4, fields),
                         "seq=4 set-process-noise qd_mm2_per_s=1.250000 "
                         "qt_mm2_per_s=0.010000 auto=no")
        # set-arm in mm (3 decimals) as u32 um; set-period in whole ms as u16
        self.assertEqual(t.command_payload("set-arm 45.25"), (t.T_SET_ARM, struct.pack("<I", 45250)))
        self.assertEqual(t.command_payload("set-period 33"), (t.T_SET_PERIOD, b"\x21\x00"))
        ftype, payload = t.command_payload("set-arm 1000")
        fields, result = t.parse(ftype, payload)
        self.assertEqual(result, t.R_OK)
        self.assertEqual(t.format_message(ftype, 2, fields), "seq=2 set-arm arm_um=1000000")

    def test_bad_commands_name_the_problem(self):
        cases = {"set-window 1": "2..255", "set-window 256": "2..255",
                 "set-window x": "not an integer", "set-window 5 zigzag": "tumbling or sliding",
                 "estimator best": "one of", "raw 2": "on or off", "start now": "usage",
                 "fly": "unknown command", "": "empty",
                 "process-noise 1": "QD,QT", "process-noise 1,2,3": "QD,QT",
                 "process-noise 0.0000001,1": "QD,QT", "process-noise 4294.967296,0": "QD,QT",
                 "process-noise -1,0": "QD,QT", "process-noise 1e3,0": "QD,QT",
                 "process-noise ,1": "QD,QT", "process-noise": "usage",
                 "set-arm 0.999": "1..1000 mm", "set-arm 1000.001": "1..1000 mm",
                 "set-arm 30.0001": "1..1000 mm", "set-arm": "usage",
                 "set-period 0": "1..10000", "set-period 10001": "1..10000",
                 "set-period 20.5": "1..10000", "set-period 20 30": "usage"}
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
        for flags in (0x02, 0x80, 0xFF):
            self.assertEqual(t.parse(t.T_SET_PROCESS_NOISE, bytes(8) + bytes([flags]))[1],
                             t.R_OUT_OF_RANGE)
        self.assertEqual(t.parse(t.T_SET_PROCESS_NOISE, bytes(8))[1], t.R_BAD_LENGTH)
        self.assertEqual(t.parse(t.T_START, b"\x00")[1], t.R_BAD_LENGTH)
        self.assertEqual(t.parse(0x42, b"")[1], t.R_UNKNOWN_TYPE)
        ok_with_reason = estimate_payload(why=1)
        self.assertEqual(t.parse(t.T_ESTIMATE, ok_with_reason)[1], t.R_OUT_OF_RANGE)

    def test_estimate_sd_rules(self):
        self.assertEqual(t.parse(t.T_ESTIMATE, estimate_payload())[1], t.R_OK)
        # an sd is never a claimed 0, and comes with its value (and only with it)
        self.assertEqual(t.parse(t.T_ESTIMATE, estimate_payload(alpha_sd=0))[1],
                         t.R_OUT_OF_RANGE)
        self.assertEqual(t.parse(t.T_ESTIMATE, estimate_payload(beta_sd=t.NO_VALUE))[1],
                         t.R_OUT_OF_RANGE)
        self.assertEqual(t.parse(t.T_ESTIMATE, estimate_payload(
            status=2, why=1 << 38, alpha=t.NO_VALUE))[1], t.R_OUT_OF_RANGE)
        fields, result = t.parse(t.T_ESTIMATE, estimate_payload(
            status=2, why=1 << 38, alpha=t.NO_VALUE, alpha_sd=t.NO_VALUE))
        self.assertEqual(result, t.R_OK)
        self.assertEqual(t.why_text(fields["why"]), "unobservable")
        # degraded needs both angles; invalid needs one missing
        self.assertEqual(t.parse(t.T_ESTIMATE, estimate_payload(status=1, why=1))[1], t.R_OK)
        self.assertEqual(t.parse(t.T_ESTIMATE, estimate_payload(status=2, why=1))[1],
                         t.R_OUT_OF_RANGE)

    def test_temperature_rules(self):
        # known 0 or 1; known: -100..200 degC; not known: 0 (the C encoder's rules)
        for known, cdeg, result in [(1, -10000, t.R_OK), (1, 20000, t.R_OK), (0, 0, t.R_OK),
                                    (1, -10001, t.R_OUT_OF_RANGE), (1, 20001, t.R_OUT_OF_RANGE),
                                    (0, 5, t.R_OUT_OF_RANGE), (2, 0, t.R_OUT_OF_RANGE)]:
            fields, got = t.parse(t.T_ESTIMATE, estimate_payload(temp_known=known,
                                                                 temp_cdeg=cdeg))
            self.assertEqual(got, result, (known, cdeg))
        fields, _ = t.parse(t.T_ESTIMATE, estimate_payload(temp_known=0, temp_cdeg=0))
        self.assertIn(" temp_c=none", t.format_message(t.T_ESTIMATE, 1, fields))
        status = struct.pack("<BBBBIHBBBBHBBIIBBh", 0, 1, 0, t.PROTOCOL_VERSION, 5000, 100, 0,
                             0, 1, 0, 20, 0, 1, 30000, 0, 0, 1, -5)
        fields, result = t.parse(t.T_STATUS, status)
        self.assertEqual(result, t.R_OK)
        self.assertTrue(t.format_message(t.T_STATUS, 0, fields).endswith(" temp_c=-0.05"))
        self.assertEqual(t.parse(t.T_STATUS, status[:-3] + b"\x00\xfb\xff")[1],
                         t.R_OUT_OF_RANGE)  # not known, with a value
        self.assertEqual(t.parse(t.T_STATUS, status[:-3])[1], t.R_BAD_LENGTH)  # protocol 6

    def test_why_names_follow_the_estimator(self):
        why = (1 << 1) | (1 << 6) | (1 << 8) | (1 << 15) | (1 << 17) | (7 << 20) | (1 << 35)
        self.assertEqual(t.why_text(why), "no-target:B+range:C+flagged:A+missing:D+rejected:B"
                                          "+parity+motion+drift+kalman-restarted")
        self.assertEqual(t.why_text(0), "none")
        self.assertEqual(t.why_text(0, ""), "")
        # a bit the estimator does not define is named, never dropped
        self.assertEqual(t.why_text((1 << 63) | (1 << 20)), "parity+bit-63")


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
                "why=none sensors=ABCD alpha_deg=1.500000 beta_deg=-0.250000 "
                "distance_mm=123456.000 alpha_sd_deg=0.270000 beta_sd_deg=0.005000 "
                "distance_sd_mm=1.500 flatness_um=-12 temp_c=-12.34"))
            self.assertEqual(lines[1], "seq=9 ack echo_seq=1 command=set-window result=ok error=0")
            self.assertTrue(lines[2].startswith("# frames_ok=2 bad_crc=0"))


class FakeFirmwarePort:
    """A serial port with the firmware's command handling behind it (firmware/src/link.c):
    each whole command frame is applied unless it repeats the last one answered (same
    sequence, type and payload), and answered; `lose_answers` answers are dropped on the
    way back, `answer` says what to answer (result, error)."""

    def __init__(self, lose_answers=0, answer=(0, 0), silent=False):
        self.decoder = t.Decoder(t.ACCEPT_COMMANDS)
        self.lose_answers = lose_answers
        self.answer = answer
        self.silent = silent
        self.applied = []
        self.writes = []
        self.last = None
        self.out = b""

    def write(self, data):
        self.writes.append(bytes(data))
        for event in self.decoder.feed(data):
            self.assertion = event[0] == "frame"
            _, ftype, seq, payload = event
            if (seq, ftype, payload) != self.last:
                self.applied.append((ftype, payload))
                self.last = (seq, ftype, payload)
            if self.silent:
                continue
            if self.lose_answers > 0:
                self.lose_answers -= 1
                continue
            self.out += t.encode_frame(t.T_ACK, 7, bytes([seq, ftype, self.answer[0],
                                                         self.answer[1] & 0xFF]))
        return len(data)

    def read(self, n):
        data, self.out = self.out[:n], self.out[n:]
        if not data:
            time.sleep(0.001)  # a port's read timeout
        return data


class SendCommandTest(unittest.TestCase):
    """--send: one command, its answer matched by sequence number, a lost one retried."""

    def setUp(self):
        self.events = []

    def send(self, port, text="set-window 50 sliding", seq=200):
        return t.send_command(port, text, seq, lambda e, c: self.events.append(e),
                              timeout=0.05, tries=4)

    def test_an_ack_ends_the_wait(self):
        port = FakeFirmwarePort()
        m, tries = self.send(port)
        self.assertEqual((m["echo_seq"], m["command"], m["result"], tries),
                         (200, t.T_SET_WINDOW, 0, 1))
        self.assertEqual(len(port.applied), 1)

    def test_a_lost_ack_is_retried_with_the_same_frame_and_applied_once(self):
        port = FakeFirmwarePort(lose_answers=2)
        m, tries = self.send(port)
        self.assertEqual((m["result"], tries), (0, 3))
        self.assertEqual(len(port.writes), 3)
        self.assertEqual(set(port.writes), {t.encode_commands(["set-window 50 sliding"], 200)})
        self.assertEqual(port.applied, [(t.T_SET_WINDOW, bytes([50, 0, 1]))])

    def test_a_nack_is_named_with_its_error(self):
        port = FakeFirmwarePort(answer=(4, -67))  # state, ATTITUDE_ERR_ESTIMATORS
        with self.assertRaises(t.CommandFailed) as ctx:
            self.send(port, "estimator mean", seq=3)
        self.assertEqual(str(ctx.exception), "'estimator mean' (seq 3): nack state, error -67 "
                                             "ATTITUDE_ERR_ESTIMATORS")
        self.assertEqual(len(port.writes), 1)  # a nack is an answer: not retried

    def test_no_answer_is_a_timeout_after_every_try(self):
        port = FakeFirmwarePort(silent=True)
        with self.assertRaises(t.CommandFailed) as ctx:
            self.send(port, "start", seq=9)
        self.assertIn("'start' (seq 9): no answer within 0.05 s, 4 tries: timeout",
                      str(ctx.exception))
        self.assertEqual(len(port.writes), 4)
        self.assertEqual(len(port.applied), 1)  # the retries were the same command

    def test_an_answer_to_another_command_is_not_taken(self):
        port = FakeFirmwarePort(silent=True)
        port.out = t.encode_frame(t.T_ACK, 1, bytes([199, t.T_SET_WINDOW, 0, 0]))
        with self.assertRaises(t.CommandFailed):
            self.send(port)

    def test_error_names_match_the_header(self):
        header = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..",
                              "estimator", "include", "estimator", "attitude.h")
        import re
        with open(header) as f:
            found = dict((int(v), k) for k, v in
                         re.findall(r"(ATTITUDE_ERR_[A-Z_]+) = (-\d+)", f.read()))
        self.assertEqual(found, t.ATTITUDE_ERRORS)

    def test_the_tool_exits_1_naming_a_nack(self):
        try:
            import serial  # noqa: F401
        except ImportError:
            self.fail("python3-serial missing: run tools/setup.sh and use /usr/bin/python3")
        master, slave = os.openpty()
        script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..",
                              "tof_telemetry.py")
        proc = subprocess.Popen(
            [sys.executable, script, "--port", os.ttyname(slave), "--duration", "1.0",
             "--first-seq", "5", "--send", "estimator mean"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        try:
            expected = t.encode_commands(["estimator mean"], first_seq=5)
            received = b""
            deadline = time.monotonic() + 5
            while len(received) < len(expected) and time.monotonic() < deadline:
                ready, _, _ = select.select([master], [], [], 0.1)
                if ready:
                    received += os.read(master, 1024)
            self.assertEqual(received, expected)
            os.write(master, t.encode_frame(t.T_ACK, 0, bytes([5, t.T_SELECT_ESTIMATOR, 4,
                                                               (-67) & 0xFF])))
            out, err = proc.communicate(timeout=10)
        finally:
            if proc.poll() is None:
                proc.kill()
            os.close(master)
            os.close(slave)
        self.assertEqual(proc.returncode, 1)
        self.assertIn("'estimator mean' (seq 5): nack state, error -67 ATTITUDE_ERR_ESTIMATORS",
                      err.decode())


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
             "--first-seq", "0", "--send", "set-window 50 sliding", "--send", "start"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        try:
            # One command at a time: the second goes out once the first is answered.
            for seq, text, ftype in ((0, "set-window 50 sliding", t.T_SET_WINDOW),
                                     (1, "start", t.T_START)):
                expected = t.encode_commands([text], first_seq=seq)
                received = b""
                deadline = time.monotonic() + 5
                while len(received) < len(expected) and time.monotonic() < deadline:
                    ready, _, _ = select.select([master], [], [], 0.1)
                    if ready:
                        received += os.read(master, 1024)
                self.assertEqual(received, expected)
                os.write(master, t.encode_frame(t.T_ACK, seq, bytes([seq, ftype, 0, 0])))
            # Then a partial frame and silence (idle flush -> truncated).
            os.write(master, ACK_SEQ9[:6])
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


def live_capture(n=12):
    """A capture of n estimate windows (consensus and kalman, one degraded, one invalid)."""
    out = bytearray(b"boot banner\r\n")
    seq = 0
    for k in range(n):
        for est in (0, 2):
            status, why, alpha, alpha_sd = 0, 0, 1000000 + 10000 * k, 200000 + est * 1000
            if k == 5 and est == 2:
                status, why = 1, 1 << 21  # motion
            if k == 7 and est == 0:
                status, why, alpha, alpha_sd = 2, 1 << 36, t.NO_VALUE, t.NO_VALUE
            out += t.encode_frame(t.T_ESTIMATE, seq & 0xFF, estimate_payload(
                t_ms=2000 * (k + 1), window=k, estimator=est, status=status, why=why,
                alpha=alpha, alpha_sd=alpha_sd))
            seq += 1
    return bytes(out)


class LiveTest(unittest.TestCase):
    """--live: estimates with +-2 sd bands redrawn as frames arrive (Agg: no display)."""

    def setUp(self):
        os.environ["MPLBACKEND"] = "Agg"
        try:
            import matplotlib  # noqa: F401
        except ImportError:
            self.fail("python3-matplotlib missing: run tools/setup.sh and use /usr/bin/python3")

    def test_bands_from_a_file_like_stream(self):
        clock = [0.0]
        live = t.LivePlot(interval=0.25, clock=lambda: clock[0])
        printer = t.Printer(io.StringIO(), on_estimate=live.add)

        class Trickle(io.RawIOBase):
            """A serial-port-like reader: a few bytes per read, time moving on."""
            def __init__(self, data):
                self.data, self.at = data, 0

            def readable(self):
                return True

            def read(self, size=-1):
                clock[0] += 0.1
                chunk = self.data[self.at:self.at + 37]
                self.at += len(chunk)
                return chunk

        stream = Trickle(live_capture())
        t.run_stream(t.stream_chunks(stream, clock=lambda: clock[0]), t.Decoder(t.ACCEPT_ALL),
                     printer, live=live)
        self.assertEqual(len(live.estimates), 24)
        self.assertGreater(live.redraws, 3)  # redrawn while the frames came in, not once
        ax_alpha = live.axes[0]
        bands = [c for c in ax_alpha.collections if c.get_label().endswith("+-2 sd")]
        self.assertEqual(sorted(b.get_label() for b in bands),
                         ["consensus +-2 sd", "kalman +-2 sd"])
        # the consensus band is alpha +- 2 sd exactly, and skips the invalid window
        verts = bands[[b.get_label() for b in bands].index("consensus +-2 sd")].get_paths()[0]
        ys = verts.vertices[:, 1]
        self.assertAlmostEqual(ys.max(), (1000000 + 10000 * 11 + 2 * 200000) / 1e6, places=6)
        self.assertAlmostEqual(ys.min(), (1000000 - 2 * 200000) / 1e6, places=6)
        line = [ln for ln in ax_alpha.get_lines() if ln.get_label() == "consensus"][0]
        self.assertEqual(len(line.get_xdata()), 11)  # 12 windows, one invalid
        # only the newest N on screen when asked
        short = t.LivePlot(last=5, clock=lambda: 0.0)
        for e in live.estimates:
            short.add(e)
        self.assertEqual(len(short.estimates), 5)

    def test_live_over_a_pty_saves_the_last_picture(self):
        try:
            import serial  # noqa: F401
        except ImportError:
            self.fail("python3-serial missing: run tools/setup.sh and use /usr/bin/python3")
        master, slave = os.openpty()
        script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..",
                              "tof_telemetry.py")
        with tempfile.TemporaryDirectory() as tmp:
            png = os.path.join(tmp, "live.png")
            env = dict(os.environ, MPLBACKEND="Agg")
            proc = subprocess.Popen(
                [sys.executable, script, "--port", os.ttyname(slave), "--duration", "3.0",
                 "--live", "--plot", png, "--first-seq", "0", "--send", "status"],
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE, env=env)
            try:
                # the status request shows the port is open (opening it drops older input)
                expected = t.encode_commands(["status"])
                received = b""
                deadline = time.monotonic() + 10
                while len(received) < len(expected) and time.monotonic() < deadline:
                    ready, _, _ = select.select([master], [], [], 0.1)
                    if ready:
                        received += os.read(master, 1024)
                self.assertEqual(received, expected)
                os.write(master, t.encode_frame(t.T_ACK, 0, bytes([0, t.T_STATUS_REQUEST, 0, 0])))
                data = live_capture(6)
                for i in range(0, len(data), 64):  # frames arrive over time
                    os.write(master, data[i:i + 64])
                    time.sleep(0.05)
                out, err = proc.communicate(timeout=20)
            finally:
                if proc.poll() is None:
                    proc.kill()
                os.close(master)
                os.close(slave)
            self.assertEqual(proc.returncode, 0, err.decode())
            lines = out.decode().splitlines()
            self.assertEqual(sum(1 for ln in lines if " estimate " in ln), 12)
            with open(png, "rb") as f:
                self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")


if __name__ == "__main__":
    unittest.main()
