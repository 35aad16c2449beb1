#!/usr/bin/env python3
"""Self-test of tests/peers/pronto4_peer.py: two instances (host and vehicle) on loopback UDP,
and one instance against literal datagrams, so that the peer the daemon's tests rely on is
itself checked: a peer that accepted anything would make those tests worthless.

Run by `make check` (tests/run-tests.sh); prints cmocka's summary lines so the total counts each
case. Needs only Python 3.9+ and its standard library; it fails, never skips, without them.
"""

import json
import os
import socket
import subprocess
import sys
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
PEER = os.path.join(HERE, "pronto4_peer.py")
PROC_TIMEOUT = 60       # seconds one peer process may run (each wait inside has --timeout)

HOST_SEND = "T0:veh_start,T2:joy_steer,T0:veh_brake"
HOST_RECV = "T2:AutoGpsLat,T0:AutoGpsQuality,T4:VehicleName"


def spawn(role, *args):
    """Starts a peer with unbuffered pipes (see read_ready)."""
    return subprocess.Popen([sys.executable, PEER, "--role", role] + list(args),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, bufsize=0)


def read_ready(p):
    """Its "ready" event (which names its port), the first line of its output. The pipe is
    unbuffered so that readline takes that line alone: a buffered reader would take whatever
    else the peer had written by then, which communicate() (it reads the descriptor, not the
    reader) would never see; how much that is depends on how soon this process runs."""
    ready = json.loads(p.stdout.readline())
    assert ready["event"] == "ready", ready
    return ready


def start(role, *args):
    """Starts a peer; returns the process and its "ready" event."""
    p = spawn(role, *args)
    return p, read_ready(p)


def finish(p):
    """Waits for a peer; returns its exit status and its events."""
    out, err = p.communicate(timeout=PROC_TIMEOUT)
    out, err = out.decode("utf-8"), err.decode("utf-8")
    events = [json.loads(line) for line in out.splitlines()]
    if err.strip():
        raise AssertionError("peer wrote to stderr: " + err)
    return p.returncode, events


def port_of(ready):
    return int(ready["local"].rsplit(":", 1)[1])


def of(events, kind, **want):
    return [e for e in events if e["event"] == kind and
            all(e.get(k) == v for k, v in want.items())]


class Raw:
    """A bare UDP socket that plays the other end byte for byte."""

    def __init__(self):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(10)

    @property
    def endpoint(self):
        return "127.0.0.1:%d" % self.sock.getsockname()[1]

    def send(self, port, data):
        self.sock.sendto(data, ("127.0.0.1", port))

    def recv(self):
        return self.sock.recvfrom(8192)[0]

    def close(self):
        self.sock.close()


class Harness(unittest.TestCase):
    """This file's own helpers."""

    def test_events_written_before_ready_is_read_are_kept(self):
        # The peer writes all it will write before its ready line is read (it has exited):
        # every event after that line must still reach finish().
        raw = Raw()
        try:
            p = spawn("host", "--remote", raw.endpoint, "--send", HOST_SEND, "--recv",
                      HOST_RECV, "--script", "connect; declare")
            p.wait(timeout=PROC_TIMEOUT)
            read_ready(p)
            rc, ev = finish(p)
        finally:
            raw.close()
        self.assertEqual(rc, 0)
        self.assertEqual(len(of(ev, "sent")), 5)
        self.assertTrue(of(ev, "done", ok=True))


class HostAndVehicle(unittest.TestCase):
    def test_full_exchange(self):
        vehicle, vready = start(
            "vehicle", "--period-ms", "100", "--script",
            "wait declaration list=L; set AutoGpsLat 40.5; set VehicleName VEH_1;"
            "wait command module=ServoPod; wait value name=veh_start value=1; wait mu what=MUO")
        host, _ = start(
            "host", "--remote", "127.0.0.1:%d" % port_of(vready), "--send", HOST_SEND,
            "--recv", HOST_RECV, "--script",
            "connect; declare; wait ack; query; ping; set veh_start 1;"
            "command ServoPod 0,TELEOP START; mu MUO;"
            "wait value name=AutoGpsLat value=40.5; wait value name=VehicleName value=VEH_1")
        hrc, hev = finish(host)
        vrc, vev = finish(vehicle)
        self.assertEqual((hrc, vrc), (0, 0), (hev[-3:], vev[-3:]))
        # The connect sequence, as the vehicle saw it.
        links = [e["text"] for e in of(vev, "command", module="Link")]
        self.assertEqual(len(links), 3)
        self.assertRegex(links[0], r"^0, SetIP, 127\.0\.0\.1:\d+, 4000$")
        self.assertEqual(links[1:], ["0, outbound, on", "0, inbound, on"])
        # The typed declarations, learned by the vehicle.
        n = of(vev, "declaration", list="N")[0]["entries"]
        self.assertEqual(n, [{"name": "veh_start", "type": "0"},
                             {"name": "joy_steer", "type": "2"},
                             {"name": "veh_brake", "type": "0"}])
        self.assertEqual(len(of(vev, "declaration", list="L")[0]["entries"]), 3)
        # The vehicle's R/D reply is an acknowledgement at the host, not values.
        ack = of(hev, "ack")[0]["entries"]
        self.assertEqual([a["name"] for a in ack], ["veh_start", "joy_steer", "veh_brake"])
        self.assertFalse(of(hev, "value", name="veh_start"))
        # L? and N? answered with one typed frame each: the vehicle's N0 (what it sends) and
        # L0 (what it receives).
        self.assertIn("[:AB|N0|T2|QAutoGpsLat|T0|QAutoGpsQuality|T4|QVehicleName|C",
                      " ".join(e["frame"] for e in of(vev, "sent")))
        answers = {e["list"]: e["entries"] for e in of(hev, "list_answer")}
        self.assertEqual(sorted(answers), ["L", "N"])
        self.assertEqual(answers["L"][0], {"name": "veh_start", "type": "0"})
        self.assertTrue(of(vev, "ping"))
        self.assertTrue(of(hev, "pong"))
        self.assertTrue(of(vev, "command", module="ServoPod", text="0,TELEOP START"))
        self.assertTrue(of(vev, "mu", what="MUO"))
        self.assertTrue(of(vev, "value", name="veh_start", value="1", type="0"))
        # Nothing was wrong on either side.
        self.assertEqual(of(hev, "error") + of(vev, "error"), [])
        self.assertEqual(of(hev, "done")[0]["errors"], {})


class Demanding(unittest.TestCase):
    """The peer is as strict as the clients it stands for."""

    def setUp(self):
        self.raw = Raw()

    def tearDown(self):
        self.raw.close()

    def vehicle(self, *args):
        p, ready = start("vehicle", "--period-ms", "0", *args)
        return p, port_of(ready)

    def test_missing_crlf_aborts(self):
        p, port = self.vehicle("--script", "run", "--duration", "30")
        self.raw.send(port, b"[:BA|P0|C78]")
        rc, ev = finish(p)
        self.assertEqual(rc, 3)
        self.assertEqual(of(ev, "error")[0]["what"], "no_crlf")
        self.assertIn("aborted", of(ev, "done")[0])

    def test_missing_crlf_counted_when_tolerated(self):
        p, port = self.vehicle("--tolerate-missing-crlf", "--script", "wait ping; wait ping")
        self.raw.send(port, b"[:BA|P0|C78]")
        self.assertEqual(self.raw.recv(), b"[:AB|G0|C6F]\r\n")
        self.raw.send(port, b"[:BA|P0|C78]\n\r")              # LF CR is not CR LF either
        self.assertEqual(self.raw.recv(), b"[:AB|G0|C6F]\r\n")
        rc, ev = finish(p)
        self.assertEqual(rc, 0)
        self.assertEqual(of(ev, "done")[0]["errors"], {"no_crlf": 2})

    def test_checksums(self):
        p, port = self.vehicle("--script", "wait command module=ServoPod; wait ping")
        self.raw.send(port, b"[:BA|P0|C79]\r\n")                # wrong
        self.raw.send(port, b"[:BA|EServoPod|D0,TELEOP START|C2]\r\n")   # unpadded: fine
        self.raw.send(port, b"[:BA|P0|c78]\r\n")                # lowercase letter: no checksum
        self.raw.send(port, b"[:BA|P0|C78]\r\n")
        self.assertEqual(self.raw.recv(), b"[:AB|G0|C6F]\r\n")
        rc, ev = finish(p)
        self.assertEqual(rc, 0)
        self.assertEqual(of(ev, "done")[0]["errors"], {"bad_checksum": 2})

    def test_partial_lists_and_bad_values(self):
        p, port = self.vehicle("--recv", "T0:a,T2:b,T4:c", "--script",
                               "wait value name=c value=ok")
        for frame in (b"[:BA|N0|D1|D2|C59]", b"[:BA|N1|D2|D3|C5C]", b"[:BA|N0|Dx|D2|Dz|CDA]",
                      b"[:BA|N0|D1|Dinf|Dz|C9E]", b"[:BA|N0||D7|D|Dok|C43]"):
            self.raw.send(port, frame + b"\r\n")
        rc, ev = finish(p)
        self.assertEqual(rc, 0, ev[-2:])
        errors = of(ev, "error")
        self.assertEqual([e["what"] for e in errors],
                         ["partial_list", "partial_list", "bad_value", "bad_value"])
        self.assertEqual(errors[2]["name"], "a")
        self.assertEqual(errors[3]["name"], "b")
        # N0||D7|D|Dok: the empty field skipped, an empty D leaves b alone.
        self.assertTrue(of(ev, "value", name="a", value="7"))
        self.assertEqual([e["value"] for e in of(ev, "value", name="b")], ["2"])

    def test_declaration_q_is_an_entry_and_triples_set_values(self):
        p, port = self.vehicle("--script", "wait value name=VehicleName value=VEH_1")
        # Qsvp_enb_eng without T: a double entry of the declaration, never a query.
        self.raw.send(port, b"[:BA|N0|T0|Qthrottle|Qsvp_enb_eng|T0|Qserialpck|C97]\r\n")
        self.assertEqual(self.raw.recv(),
                         b"[:AB|N0|Rthrottle|D0|Rsvp_enb_eng|D0|Rserialpck|D0|C6A]\r\n")
        self.raw.send(port, b"[:BA|N0|T4|QVehicleName|DVEH_1|T2|QAutoGpsLat|D0|C5E]\r\n")
        rc, ev = finish(p)
        self.assertEqual(rc, 0, ev[-2:])
        decl = of(ev, "declaration", list="N")[0]["entries"]
        self.assertEqual(decl[1], {"name": "svp_enb_eng", "type": "2"})
        self.assertTrue(of(ev, "value", name="AutoGpsLat", value="0", type="2"))

    def test_query_times_out_against_nobody(self):
        p, _ = start("host", "--remote", self.raw.endpoint, "--timeout", "0.5", "--script",
                     "query")
        self.assertEqual(self.raw.recv(), b"[:BA|L?|C83]\r\n")
        self.assertEqual(self.raw.recv(), b"[:BA|N?|C85]\r\n")
        rc, ev = finish(p)
        self.assertEqual(rc, 1)
        self.assertEqual(of(ev, "timeout")[0]["waited"], "list_answer")

    def test_not_for_us(self):
        p, port = self.vehicle("--script", "wait ping")
        self.raw.send(port, b"[:AB|P0|C78]\r\n")                # to A from B: not the vehicle's
        self.raw.send(port, b"[:BA|P0|C78]\r\n")
        self.assertEqual(self.raw.recv(), b"[:AB|G0|C6F]\r\n")
        rc, ev = finish(p)
        self.assertEqual((rc, of(ev, "done")[0]["errors"]), (0, {"not_for_us": 1}))


def main():
    suite = unittest.defaultTestLoader.loadTestsFromModule(sys.modules[__name__])
    result = unittest.TextTestRunner(verbosity=2, stream=sys.stdout).run(suite)
    bad = len(result.failures) + len(result.errors)
    print("[  PASSED  ] %d test(s)." % (result.testsRun - bad))
    if bad:
        print("[  FAILED  ] %d test(s)" % bad)
    return 0 if result.wasSuccessful() and result.testsRun > 0 else 1


if __name__ == "__main__":
    sys.exit(main())
