#!/usr/bin/env python3
"""Self-test of the ROS 2 test peers (tests/ros2peer/README.md): peer_cyclone and peer_fastdds,
each with its own copy of the types on its own DDS library, exchange every type both ways over
loopback unicast, and each sample must arrive as the golden CDR bytes below, decoded to the value
written, with the writer's type name, QoS and USER_DATA type hash as a ROS 2 node announces them.
Both a ROS-default reader (RELIABLE, VOLATILE, KEEP_LAST 10) and a BEST_EFFORT one match the
RELIABLE/TRANSIENT_LOCAL writer, and a TRANSIENT_LOCAL late joiner gets the value written before
it existed. Since the peers are what proves sharedlink-ros2's wire format, a peer that accepted
anything would make those proofs worthless; this is the check on them.

Every step waits for a line the peers print (bounded by TIMEOUT_S), never for time to pass.
Run by `make check` when both peers are built (tests/run-tests.sh); prints cmocka's summary.
"""

import os
import queue
import subprocess
import sys
import threading
import unittest

import summary
import test_typehash

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
BIN_DIR = os.environ.get("ROS2PEER_DIR", os.path.join(ROOT, "build", "tests", "ros2peer"))
CONFIG = {"cyclone": os.path.join(HERE, "cyclonedds.xml"),
          "fastdds": os.path.join(HERE, "fastdds.xml")}
VENDORS = ("cyclone", "fastdds")
TIMEOUT_S = 60                  # bound on any one wait (a busy machine, not an expectation)
RETRY_S = 2                     # a best-effort reader: the value is written again this often
PEER_TIMEOUT_MS = str(TIMEOUT_S * 1000)
# A domain of this run's own (the port map allows 0..232; 200..231 here, clear of the ranges
# test_ros2 and bench_ros2 take), so concurrent runs rarely meet; the topics carry the pid too.
DOMAIN = str(200 + os.getpid() % 32)
EXIT_USAGE = 2

# ---- golden CDR: the 4-byte encapsulation header, then the members in plain CDR, little endian.
# RTPS pads every payload to 4 bytes. Cyclone counts that padding in the header's options
# (00 01 00 0N, XTypes 1.3 7.6.3.1.2); Fast DDS 2.9, like rmw_fastrtps over it, leaves the options
# 00 00 and the reader sees the pad bytes as trailing zeros. Nothing else may differ.
HEADER = {"cyclone": "000100%02x", "fastdds": "00010000"}


def encap(vendor, body_hex):
    pad = -(len(body_hex) // 2) % 4
    return (HEADER[vendor] % pad if vendor == "cyclone" else HEADER[vendor]) + body_hex + "00" * pad


def cdr_string(text_hex, chars):
    """A CDR string: uint32 length with the NUL, the bytes, the NUL (no padding after)."""
    return "%02x000000" % (chars + 1) + text_hex + "00"


GOLDEN = {
    # Int64 42: int64 data
    "Int64": ("42", "42", "2a00000000000000"),
    # Float64 2.5: float64 data (0x4004000000000000)
    "Float64": ("2.5", "2.5", "0000000000000440"),
    # String "hi": string data
    "String": ("hi", '"hi"', "03000000" "6869" "00"),
    # DiagnosticArray: header{stamp{sec 1, nanosec 2}, frame_id "frame"}, status[1]{level 2,
    # name "name", message "msg", hardware_id "hw", values[2]{"a"="1", "b"="2"}}
    "DiagnosticArray": (
        "1|2|frame|2|name|msg|hw|a=1,b=2",
        '{"stamp":{"sec":1,"nanosec":2},"frame_id":"frame","status":[{"level":2,"name":"name",'
        '"message":"msg","hardware_id":"hw","values":[{"key":"a","value":"1"},'
        '{"key":"b","value":"2"}]}]}',
        "01000000" "02000000" "06000000" "6672616d6500" "0000"      # stamp, frame_id, pad to 4
        "01000000"                                                  # status: 1 element
        "02" "000000" "05000000" "6e616d6500" "000000"              # level, pad, name, pad
        "04000000" "6d736700" "03000000" "687700" "00"              # message, hardware_id, pad
        "02000000"                                                  # values: 2 elements
        "02000000" "6100" "0000" "02000000" "3100" "0000"           # "a" = "1"
        "02000000" "6200" "0000" "02000000" "3200"),                # "b" = "2"
    # NavSatFix: header{stamp{10, 20}, frame_id "gps"}, status{status 0, service 1},
    # latitude 47.5, longitude 8.25, altitude 400.125, covariance diag(1,2,3), type 2
    "NavSatFix": (
        "10|20|gps|0|1|47.5|8.25|400.125|1,0,0,0,2,0,0,0,3|2",
        '{"stamp":{"sec":10,"nanosec":20},"frame_id":"gps","status":{"status":0,"service":1},'
        '"latitude":47.5,"longitude":8.25,"altitude":400.125,'
        '"position_covariance":[1,0,0,0,2,0,0,0,3],"position_covariance_type":2}',
        "0a000000" "14000000" "04000000" "67707300"                 # stamp, frame_id
        "00" "00" "0100"                                            # status int8, pad, service
        "00000000"                                                  # pad to 8
        "0000000000c04740" "0000000000802040" "0000000000027940"    # latitude, longitude, altitude
        "000000000000f03f" + "0000000000000000" * 3 +               # covariance row 1..
        "0000000000000040" + "0000000000000000" * 3 +
        "0000000000000840"                                          # ..to [8]
        "02"),                                                      # covariance type
}
ROS_NAME = {"Int64": "std_msgs/msg/Int64", "Float64": "std_msgs/msg/Float64",
            "String": "std_msgs/msg/String",
            "DiagnosticArray": "diagnostic_msgs/msg/DiagnosticArray",
            "NavSatFix": "sensor_msgs/msg/NavSatFix"}


def dds_name(t):
    pkg, _, name = ROS_NAME[t].split("/")
    return "%s::msg::dds_::%s_" % (pkg, name)


def fields(line):
    """'sample topic=.. type=.. cdr=.. value=<rest>' -> dict (value is the rest of the line)."""
    head, _, value = line.partition(" value=")
    out = dict(f.split("=", 1) for f in head.split()[1:])
    if value:
        out["value"] = value
    return out


class Peer:
    """One peer process; its stdout lines arrive on a queue (a thread reads them)."""

    def __init__(self, vendor, *args):
        argv = [os.path.join(BIN_DIR, "peer_" + vendor)] + list(args)
        argv += ["--config", CONFIG[vendor], "--domain", DOMAIN, "--timeout-ms", PEER_TIMEOUT_MS]
        self.p = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True)
        self.lines = queue.Queue()
        self.seen = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.p.stdout:
            self.lines.put(line.rstrip("\n"))
        self.lines.put(None)

    def wait(self, prefix, timeout=TIMEOUT_S):
        """The next line starting with prefix (earlier lines are kept in seen); queue.Empty
        when none came within timeout seconds."""
        while True:
            line = self.lines.get(timeout=timeout)
            if line is None:
                raise AssertionError("peer exited before '%s': %s" % (prefix, self.finish()))
            self.seen.append(line)
            if line.startswith(prefix):
                return line

    def go(self):
        self.p.stdin.write("go\n")
        self.p.stdin.flush()

    def finish(self):
        """Closes stdin, waits for the exit; returns (status, stderr)."""
        try:
            self.p.stdin.close()
        except BrokenPipeError:
            pass
        rc = self.p.wait(timeout=TIMEOUT_S)
        return rc, self.p.stderr.read()


class Interop(unittest.TestCase):
    n = 0

    def topic(self):
        Interop.n += 1
        return "rt/ros2peer_%d/t%d" % (os.getpid(), Interop.n)

    def exchange(self, writer, reader, t, sub_args=()):
        """writer publishes GOLDEN[t] to reader (both started here); returns the reader's
        writer and sample lines as dicts. Both readers here may lose what they are sent before
        their side of the match has settled, even though each side has reported the other: a
        best-effort one by its nature, and a reliable but volatile one (the ROS default) because
        it owes only what is written after it has the writer's first heartbeat (between a Fast
        DDS writer and a Cyclone reader, on a busy machine, the first sample sometimes is lost:
        2 of 11 runs at load 6). So the value is written again, RETRY_S apart, until one
        arrives; what is checked is the bytes that arrive, not the first write. (The late
        joiner's test checks that a transient-local reader gets the value written before it.)"""
        value, shown, body = GOLDEN[t]
        topic = self.topic()
        sub = Peer(reader, "sub", topic, t, *sub_args)
        sub.wait("ready")
        pub = Peer(writer, "pub", topic, t, value, "--wait-stdin")
        pub.wait("matched")
        w = fields(sub.wait("writer"))   # the reader has matched the writer too
        for attempt in range(TIMEOUT_S // RETRY_S):
            pub.go()
            try:
                s = fields(sub.wait("sample", RETRY_S))
                break
            except queue.Empty:
                continue
        else:
            raise AssertionError("no sample: %s" % (sub.finish(),))
        self.assertEqual(pub.finish(), (0, ""))      # end of input: acknowledged, exit 0
        self.assertEqual(sub.finish(), (0, ""))
        self.assertEqual(s, {"topic": topic, "type": dds_name(t), "cdr": encap(writer, body),
                             "value": shown})
        self.assertEqual(w["topic"], topic)
        self.assertEqual(w["type"], dds_name(t))
        self.assertEqual(w["user_data"],
                         "typehash=%s;" % test_typehash.PUBLISHED[ROS_NAME[t]][1])
        return w, s

    def test_every_type_both_ways_ros_default_reader(self):
        for t in GOLDEN:
            for writer in VENDORS:
                for reader in VENDORS:
                    with self.subTest(type=t, writer=writer, reader=reader):
                        w, _ = self.exchange(writer, reader, t)
                        self.assertEqual((w["reliability"], w["durability"]),
                                         ("reliable", "transient_local"))

    def test_every_type_both_ways_best_effort_reader(self):
        for t in GOLDEN:
            for writer, reader in (("cyclone", "fastdds"), ("fastdds", "cyclone")):
                with self.subTest(type=t, writer=writer, reader=reader):
                    self.exchange(writer, reader, t,
                                  ("--reliability", "best_effort", "--depth", "1"))

    def test_late_joiner_gets_the_last_value_both_ways(self):
        for writer, reader in (("cyclone", "fastdds"), ("fastdds", "cyclone")):
            with self.subTest(writer=writer, reader=reader):
                topic = self.topic()
                pub = Peer(writer, "pub", topic, "Int64", "42", "--readers", "0",
                           "--hold")
                pub.wait("acked")           # written and kept, with nobody listening yet
                sub = Peer(reader, "sub", topic, "Int64", "--durability", "transient_local")
                s = fields(sub.wait("sample"))
                self.assertEqual(sub.finish(), (0, ""))
                self.assertEqual(pub.finish(), (0, ""))
                self.assertEqual((s["cdr"], s["value"]),
                                 (encap(writer, GOLDEN["Int64"][2]), "42"))


class Refusals(unittest.TestCase):
    def test_no_network_configuration_is_refused(self):
        env = {k: v for k, v in os.environ.items()
               if k not in ("CYCLONEDDS_URI", "FASTRTPS_DEFAULT_PROFILES_FILE")}
        for vendor in VENDORS:
            with self.subTest(vendor):
                r = subprocess.run([os.path.join(BIN_DIR, "peer_" + vendor), "sub", "rt/x",
                                    "Int64"], env=env, capture_output=True, text=True,
                                   timeout=TIMEOUT_S)
                self.assertEqual(r.returncode, EXIT_USAGE)
                self.assertIn("no network configuration", r.stderr)

    def test_bad_values_and_arguments_are_refused(self):
        bad = [["pub", "rt/x", "Int64", "4x2"], ["pub", "rt/x", "Int64", "99999999999999999999"],
               ["pub", "rt/x", "Float64", "two"], ["pub", "rt/x", "NavSatFix", "1|2|gps"],
               ["pub", "rt/x", "DiagnosticArray", "1|2|f|300|n|m|h|"],
               ["sub", "rt/x", "Int32"], ["sub", "rt/x", "Int64", "--reliability", "maybe"]]
        for vendor in VENDORS:
            for argv in bad:
                with self.subTest(vendor=vendor, argv=argv):
                    r = subprocess.run([os.path.join(BIN_DIR, "peer_" + vendor)] + argv +
                                       ["--config", CONFIG[vendor], "--domain", DOMAIN],
                                       capture_output=True, text=True, timeout=TIMEOUT_S)
                    self.assertEqual(r.returncode, EXIT_USAGE, r.stderr)


if __name__ == "__main__":
    sys.exit(summary.run(__name__))
