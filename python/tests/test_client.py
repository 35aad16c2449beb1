"""The binding against the real sharedlinkd (python/tests/daemon.py): values through real shared
memory and a real pty both ways, wait(), events, query, the CIRCE commands seen by the emulator,
link and daemon state, and every failure as its typed exception with the errno and sl_strerror.

One daemon serves the whole module (starting an ASan daemon is the slow part); each test leaves
the tables as it found them or uses its own values. Waits are on changes (Client.wait), bounded
by WAIT_S so a broken daemon fails a test instead of hanging it; nothing asserts timing.
"""
import errno
import os
import subprocess
import sys
import time
import unittest

import sharedlink
from daemon import Daemon

WAIT_S = 15.0           # one awaited value or event: a hang guard, not a timing assertion


def until(c, name, pred, timeout=WAIT_S):
    """Waits (on changes, not a sleep loop) until pred(c[name]); returns that value."""
    deadline = time.monotonic() + timeout
    while True:
        value = c.get(name)
        if pred(value):
            return value
        left = deadline - time.monotonic()
        if left <= 0:
            raise AssertionError("%s never matched; last value %r" % (name, value))
        c.wait([name], timeout=left)


class DaemonCase(unittest.TestCase):
    daemon = None

    @classmethod
    def setUpClass(cls):
        cls.daemon = Daemon(cls.__name__.lower()).start()
        cls.c = sharedlink.Client(cls.daemon.instance, runtime_dir=cls.daemon.dir)
        # Both CIRCE sides up and the emulated display seen: the CIRCE tests start from there.
        until(cls.c, "agility.state", lambda v: v == "connected")
        until(cls.c, "agility.device.D15D15.online", lambda v: v == 1)

    @classmethod
    def tearDownClass(cls):
        cls.c.close()
        status = cls.daemon.stop()
        log = cls.daemon.log()
        cls.daemon.cleanup()
        if status != 0:
            raise AssertionError("sharedlinkd exit status %r; log:\n%s" % (status, log))

    def assertError(self, cls, err, call, *args, **kwargs):
        """call raises cls with this errno and sl_strerror's text; returns the exception."""
        with self.assertRaises(cls) as cm:
            call(*args, **kwargs)
        e = cm.exception
        self.assertIsInstance(e, sharedlink.SharedLinkError)
        self.assertEqual(e.errno, err, str(e))
        self.assertEqual(e.strerror, sharedlink.strerror(err))
        self.assertIn(e.strerror, str(e))
        return e


class TestValues(DaemonCase):
    def test_double_from_node_a_to_node_b(self):
        c = self.c
        c["a.AutoGpsLat"] = 40.12345678
        self.assertEqual(until(c, "b.AutoGpsLat", lambda v: v == 40.12345678), 40.12345678)
        text, meta = c.read("b.AutoGpsLat")
        self.assertEqual(text, "40.12345678")
        self.assertTrue(meta.valid)
        self.assertFalse(meta.outbound)
        self.assertGreater(meta.sequence, 0)
        self.assertGreater(meta.mono_ns, 0)
        self.assertEqual(c.read_double("b.AutoGpsLat"), 40.12345678)
        self.assertIsInstance(c["b.AutoGpsLat"], float)
        # An outbound variable reads as what was written to it.
        text, meta = c.read("a.AutoGpsLat")
        self.assertEqual(text, "40.12345678")
        self.assertTrue(meta.outbound)

    def test_long_from_node_b_to_node_a(self):
        c = self.c
        c.write("b.CmdThrottle", -42)
        self.assertEqual(until(c, "a.CmdThrottle", lambda v: v == -42), -42)
        self.assertEqual(c.read_long("a.CmdThrottle"), -42)
        self.assertIsInstance(c["a.CmdThrottle"], int)
        self.assertEqual(c.read("a.CmdThrottle")[0], "-42")

    def test_text_and_decimals(self):
        c = self.c
        c.write("a.Label", "hello world")
        self.assertEqual(until(c, "b.Label", lambda v: v == "hello world"), "hello world")
        c.write("a.AutoGpsLat", 1.0 / 3.0, decimals=3)
        until(c, "b.AutoGpsLat", lambda v: v == 0.333)
        self.assertEqual(c.read("b.AutoGpsLat")[0], "0.333")
        c.write("a.Label", b"bytes too")
        until(c, "b.Label", lambda v: v == "bytes too")

    def test_names_and_info(self):
        c = self.c
        names = c.names()
        for name in ("a.AutoGpsLat", "b.AutoGpsLat", "a.CmdThrottle", "b.CmdThrottle",
                     "agility.state", "agility.device.E1E1E1.signal"):
            self.assertIn(name, names)
            self.assertIn(name, c)
        self.assertNotIn("NoSuchName", c)
        info = c.info("b.AutoGpsLat")
        self.assertEqual((info.name, info.direction, info.type, info.peer, info.position),
                         ("b.AutoGpsLat", "in", "double", "A", 0))
        self.assertEqual(c.links()[info.link].name, "node_b")
        self.assertEqual(c.info("a.CmdThrottle").type, "long")
        self.assertEqual(c.info("b.CmdThrottle").direction, "out")
        self.assertEqual(c.find("b.AutoGpsLat"), info.id)
        self.assertEqual(c.info(info.id), info)
        self.assertTrue(c.info("agility.device.E1E1E1.signal").adhoc)
        self.assertEqual(c["agility.device.E1E1E1.signal"], 150)
        self.assertEqual(c.read("agility.device.E1E1E1.signal")[0], "150")
        self.assertEqual(c.read_long("agility.device.E1E1E1.signal"), 150)

    def test_wait(self):
        c = self.c
        c.wait(["b.CmdThrottle", "a.CmdThrottle"], timeout=0)      # the baseline
        # Nothing written: the wait times out with nothing changed.
        self.assertEqual(c.wait(["b.CmdThrottle"], timeout=0.05), [])
        c["b.CmdThrottle"] = c.read_long("b.CmdThrottle") + 1
        self.assertEqual(c.wait(["b.CmdThrottle"], timeout=WAIT_S), ["b.CmdThrottle"])
        # A change that happened between two waits is not lost.
        want = c.read_long("b.CmdThrottle")
        until(c, "a.CmdThrottle", lambda v: v == want)
        c.wait(["a.CmdThrottle"], timeout=0)
        c["b.CmdThrottle"] = want + 1
        until(c, "a.CmdThrottle", lambda v: v == want + 1)
        self.assertEqual(c.wait("a.CmdThrottle", timeout=0), [])   # until() already saw it
        c["b.CmdThrottle"] = want + 2
        changed = c.wait(None, timeout=WAIT_S)
        self.assertIn("b.CmdThrottle", changed + c.wait(None, timeout=WAIT_S))

    def test_wait_spin(self):
        c = self.c
        c.wait(["b.CmdThrottle"], timeout=0)
        self.assertEqual(c.wait(["b.CmdThrottle"], timeout=0.05, spin_us=200), [])
        c["b.CmdThrottle"] = c.read_long("b.CmdThrottle") + 1
        self.assertEqual(c.wait(["b.CmdThrottle"], timeout=WAIT_S, spin_us=1000),
                         ["b.CmdThrottle"])
        for bad in (-1, sharedlink._lib.SL_WAIT_SPIN_MAX_US + 1, 1.5):
            with self.assertRaises(sharedlink.InvalidValue) as e:
                c.wait(["b.CmdThrottle"], timeout=0, spin_us=bad)
            self.assertEqual(e.exception.errno, errno.EINVAL)


class TestLinks(DaemonCase):
    def test_links_and_daemon(self):
        links = {l.name: l for l in self.c.links()}
        self.assertEqual(set(links), {"node_a", "node_b", "arena", "agility", "p4veh", "p4host"})
        self.assertEqual(links["node_a"].protocol, "sharedlink")
        self.assertEqual(links["agility"].protocol, "circe")
        self.assertEqual(links["agility"].state_name, "connected")
        # 39 + 15 appended for Pronto4 + out_taken_over
        self.assertEqual(len(links["node_b"].counters), 55)
        self.c["a.AutoGpsLat"] = 1.5
        until(self.c, "b.AutoGpsLat", lambda v: v == 1.5)           # node_b has had frames
        self.assertGreater(self.c.link("node_b").counters["frames_in"], 0)
        d = self.c.daemon()
        self.assertEqual(d.pid, self.daemon.proc.pid)
        self.assertTrue(d.alive)
        self.assertTrue(self.c.alive)
        self.assertIn("out_accepted", d.counters)
        self.assertNotEqual(d.epoch, 0)

    def test_query(self):
        c = self.c
        c["a.AutoGpsLat"] = 12.5
        until(c, "b.AutoGpsLat", lambda v: v == 12.5)
        self.assertEqual(c.query("node_b", "A", "a.AutoGpsLat", timeout=WAIT_S), "12.5")

    def test_ping(self):
        c = self.c
        c.query("node_b", "A", "a.AutoGpsLat", timeout=WAIT_S)    # the link is up
        rtt = c.ping("node_b", "A", timeout=WAIT_S)
        self.assertIsInstance(rtt, float)
        self.assertGreater(rtt, 0.0)
        self.assertGreater(c.ping("node_a", "B", timeout=WAIT_S), 0.0)
        # Node C is configured but not on the wire: no pong.
        e = self.assertError(sharedlink.Timeout, errno.ETIMEDOUT, c.ping, "node_b", "C",
                             timeout=0.1)
        self.assertIn("no pong", str(e))
        self.assertError(sharedlink.InvalidValue, errno.EINVAL, c.ping, "node_b", "D")
        self.assertError(sharedlink.InvalidValue, errno.EINVAL, c.ping, "node_b", "Z")


class TestPronto4(DaemonCase):
    def test_command_is_an_event_of_the_vehicle(self):
        c = self.c
        follow = c.events(follow=True, new=True, timeout=WAIT_S)
        c.command("p4host", "ServoPod", "0,TELEOP START")
        for ev in follow:
            if ev.type == "command" and ev.link == "p4veh":
                break
        else:
            self.fail("no command event within %.0f s" % WAIT_S)
        self.assertEqual(ev.text, 'module=ServoPod text="0,TELEOP START"')
        self.assertEqual(ev.fields, {"module": "ServoPod", "text": "0,TELEOP START"})
        # An empty text: E<module>|D, an event with an empty text.
        c.command("p4host", "Physics")
        for ev in follow:
            if ev.type == "command" and ev.fields.get("module") == "Physics":
                break
        else:
            self.fail("no second command event within %.0f s" % WAIT_S)
        self.assertEqual(ev.fields["text"], "")

    def test_values_through_learned_lists(self):
        c = self.c
        c["veh_start"] = 7
        until(c, "p4veh.A.veh_start", lambda v: v == 7)
        self.assertEqual(c.info("p4veh.A.veh_start").type, "long")
        c["p4veh.A.VehicleName"] = "VEH_1"
        until(c, "VehicleName", lambda v: v == "VEH_1")


class TestCirce(DaemonCase):
    def test_emulated_action_is_an_event(self):
        c = self.c
        start = c.events(new=True)
        self.assertEqual(list(start), [])               # new=True: nothing retained
        follow = c.events(follow=True, new=True, timeout=WAIT_S)
        c.circe_emulate_action("arena", "E1E1E1", sensor_time_ms=5000)
        for ev in follow:
            if ev.type == "action" and ev.link == "agility":
                break
        else:
            self.fail("no action event within %.0f s" % WAIT_S)
        self.assertEqual(ev.fields, {"device": "E1E1E1", "sensor_time": "5000"})
        self.assertEqual(ev.text, "device=E1E1E1 sensor_time=5000")
        self.assertEqual(ev.lost, 0)
        self.assertGreater(ev.seq, 0)
        # The key press reaches the controller's variables too.
        c.circe_emulate_action("arena", "AAAAAA", keys=32768)
        until(c, "agility.device.AAAAAA.keys", lambda v: v == 32768)
        # Without follow, the generator ends once the retained events are read.
        seqs = [e.seq for e in c.events()]
        self.assertIn(ev.seq, seqs)
        self.assertEqual(seqs, sorted(seqs))

    def test_visualize_alert_network_setup(self):
        c = self.c
        c.circe_visualize("agility", "D15D15", current=12, next=13, start_timer=True)
        until(c, "arena.device.D15D15.current_competitor", lambda v: v == 12)
        self.assertEqual(c["arena.device.D15D15.next_competitor"], 13)
        c.circe_visualize("agility", ["D15D15"], primary_ms=31250, faults=1)
        until(c, "arena.device.D15D15.faults", lambda v: v == 1)
        alerts = c.get("arena.device.AAAAAA.alerts", 0)
        c.circe_alert("agility", "AAAAAA")
        until(c, "arena.device.AAAAAA.alerts", lambda v: v == alerts + 1)
        c.circe_network_setup("agility", "E1E1E1", join=True, roles=2)
        until(c, "agility.device.E1E1E1.roles", lambda v: v == 2)
        self.assertEqual(c["agility.device.E1E1E1.membership"], 1)

    def test_sync_clocks(self):
        self.assertEqual(self.c.circe_sync_clocks("agility"),
                         {"E1E1E1": True, "AAAAAA": True, "D15D15": True})

    def test_request_raw(self):
        reply, data = self.c.request("circe agility alert E1E1E1")
        self.assertEqual((reply, data), ("", []))


class TestErrors(DaemonCase):
    def test_write_inbound(self):
        e = self.assertError(sharedlink.PermissionDenied, errno.EPERM, self.c.write,
                             "b.AutoGpsLat", 1.0)
        self.assertIsInstance(e, PermissionError)
        self.assertIn("b.AutoGpsLat", str(e))

    def test_unknown_name(self):
        c = self.c
        e = self.assertError(sharedlink.NotFound, errno.ENOENT, c.read, "NoSuchName")
        self.assertIsInstance(e, KeyError)
        self.assertError(sharedlink.NotFound, errno.ENOENT, c.__getitem__, "NoSuchName")
        self.assertError(sharedlink.NotFound, errno.ENOENT, c.write, "NoSuchName", 1)
        self.assertIsNone(c.get("NoSuchName"))
        self.assertEqual(c.get("NoSuchName", 7), 7)

    def test_bad_values(self):
        c = self.c
        for bad in ("a|b", "[x]", "x" * 64, "caf\u00e9", "tab\there"):
            self.assertError(sharedlink.InvalidValue, errno.EINVAL, c.write, "a.Label", bad)
        # A NUL would cut the text short in C: refused before the call.
        e = self.assertError(sharedlink.InvalidValue, errno.EINVAL, c.write, "a.Label", "a\0b")
        self.assertIn("NUL", str(e))
        self.assertError(sharedlink.InvalidValue, errno.EINVAL, c.read, "a.Label\0x")
        self.assertError(sharedlink.InvalidValue, errno.ERANGE, c.write, "b.CmdThrottle", 2**63)
        self.assertRaises(TypeError, c.write, "b.CmdThrottle", True)
        self.assertRaises(TypeError, c.write, "b.CmdThrottle", [1])
        # Nothing of it reached the table.
        self.assertNotIn(c.read("a.Label")[0], ("a", "a|b"))

    def test_typed_write(self):
        # b.CmdThrottle is a long: text of another type is refused where it is written, with
        # the library's reason, and the variable keeps its value.
        c = self.c
        c.write("b.CmdThrottle", 5)
        e = self.assertError(sharedlink.InvalidValue, errno.EINVAL, c.write, "b.CmdThrottle",
                             "abc")
        self.assertIn('"abc" is not a long', str(e))
        self.assertIn("b.CmdThrottle", str(e))
        e = self.assertError(sharedlink.InvalidValue, errno.EINVAL, c.write, "b.CmdThrottle",
                             0.5)
        self.assertIn('"0.5" is not a long', str(e))
        self.assertEqual(c.read_long("b.CmdThrottle"), 5)

    def test_not_a_number(self):
        c = self.c
        e = self.assertError(sharedlink.InvalidValue, errno.EDOM, c.read_double, "agility.state")
        self.assertIsInstance(e, ValueError)
        self.assertError(sharedlink.InvalidValue, errno.EDOM, c.read_long, "agility.state")

    def test_no_data(self):
        c = self.c
        # The emulated gate never sent keys: an optional parameter never received is empty.
        self.assertEqual(c.read("agility.device.E1E1E1.keys")[0], "")
        self.assertError(sharedlink.NoData, errno.ENODATA, c.read_long,
                         "agility.device.E1E1E1.keys")

    def test_commands(self):
        c = self.c
        # A command for another role of the protocol, and for another protocol: EOPNOTSUPP both.
        e = self.assertError(sharedlink.NotSupported, errno.EOPNOTSUPP, c.circe_alert, "arena",
                             "E1E1E1")
        self.assertIn("mediator", e.detail)
        e = self.assertError(sharedlink.NotSupported, errno.EOPNOTSUPP, c.circe_alert, "node_a",
                             "E1E1E1")
        self.assertIn("speaks sharedlink", e.detail)
        self.assertError(sharedlink.NotSupported, errno.EOPNOTSUPP, c.circe_emulate_action,
                         "agility", "E1E1E1")
        e = self.assertError(sharedlink.NotFound, errno.ENOENT, c.circe_alert, "nolink",
                             "E1E1E1")
        self.assertTrue(e.detail)
        e = self.assertError(sharedlink.InvalidValue, errno.EINVAL, c.circe_alert, "agility",
                             "FFFFFF")
        self.assertIn("FFFFFF", e.detail)
        self.assertError(sharedlink.InvalidValue, errno.EINVAL, c.circe_visualize, "agility",
                         "D15D15", current=1000)
        self.assertError(sharedlink.InvalidValue, errno.EINVAL, c.circe_visualize, "agility",
                         "D15D15")
        self.assertError(sharedlink.InvalidValue, errno.EINVAL, c.query, "node_b", "Z", "x")
        e = self.assertError(sharedlink.InvalidValue, errno.EINVAL, c.query, "node_b", "D",
                             "a.AutoGpsLat")
        self.assertIn("not a peer", e.detail)
        # Node C is configured but not on the wire: nobody answers.
        self.assertError(sharedlink.Timeout, errno.ETIMEDOUT, c.query, "node_b", "C", "x",
                         timeout=0.1)
        # A synchronisation follows the devices for seconds: no reply within a millisecond.
        self.assertError(sharedlink.Timeout, errno.ETIMEDOUT, c.request,
                         "circe agility sync-clocks", timeout=0.001)

    def test_module_command(self):
        c = self.c
        # Refused by the library before anything is sent.
        for module, text in (("Servo Pod", "x"), ("", "x"), ("Servo|Pod", ""),
                             ("ServoPod", "0,TELEOP  START"), ("ServoPod", " 0"),
                             ("ServoPod", "0 "), ("ServoPod", "0|1"), ("ServoPod", "x" * 64),
                             ("ServoPod", "caf\u00e9")):
            self.assertError(sharedlink.InvalidValue, errno.EINVAL, c.command, "node_a", module,
                             text)
        self.assertError(sharedlink.InvalidValue, errno.EINVAL, c.command, "node_a",
                         "ServoPod", "0\0x")
        self.assertRaises(TypeError, c.command, "node_a", "ServoPod", 5)
        # Through the daemon: no such link; a SharedLink link without a pronto4 peer; a link of
        # another protocol (EOPNOTSUPP, as for circe_alert on a SharedLink link above). The round
        # trip to a pronto4 peer: tests/integration/test_pronto4.c.
        self.assertError(sharedlink.NotFound, errno.ENOENT, c.command, "nolink", "ServoPod",
                         "0,TELEOP START")
        self.assertError(sharedlink.NotSupported, errno.EOPNOTSUPP, c.command, "node_a",
                         "ServoPod", "0,TELEOP START")
        self.assertError(sharedlink.NotSupported, errno.EOPNOTSUPP, c.command, "agility",
                         "ServoPod", "0,TELEOP START")

    def test_no_instance(self):
        self.assertError(sharedlink.NotFound, errno.ENOENT, sharedlink.Client, "nosuchinstance")
        self.assertError(sharedlink.InvalidValue, errno.EINVAL, sharedlink.Client, "bad/name")

    def test_wrong_runtime_dir(self):
        with sharedlink.Client(self.daemon.instance, runtime_dir="/nonexistent") as c:
            self.assertEqual(c["agility.state"], "connected")     # reads need no socket
            e = self.assertError(sharedlink.NotRunning, errno.ECONNREFUSED, c.circe_alert,
                                 "agility", "E1E1E1")
            self.assertIsInstance(e, ConnectionError)

    @unittest.skipUnless(os.geteuid() == 0, "needs root to run a child as another user")
    def test_unprivileged_user(self):
        # A user outside the daemon's group reads, but may neither write nor send commands.
        script = (
            "import errno, sharedlink\n"
            "c = sharedlink.Client(%r, runtime_dir=%r)\n"
            "assert c['agility.state'] == 'connected'\n"
            "for call in (lambda: c.write('a.Label', 'x'),\n"
            "             lambda: c.circe_alert('agility', 'E1E1E1')):\n"
            "    try:\n"
            "        call()\n"
            "    except sharedlink.PermissionDenied as e:\n"
            "        assert e.errno == errno.EACCES, e\n"
            "        print(e.errno, e.strerror)\n"
            "    else:\n"
            "        raise AssertionError('not refused')\n"
            % (self.daemon.instance, self.daemon.dir))
        here = os.path.dirname(os.path.abspath(__file__))
        env = dict(os.environ, PYTHONPATH=os.path.dirname(here))
        r = subprocess.run(["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups",
                            sys.executable, "-c", script], env=env, capture_output=True,
                           text=True, timeout=60)
        self.assertEqual(r.returncode, 0, r.stderr)
        want = "%d %s\n" % (errno.EACCES, sharedlink.strerror(errno.EACCES))
        self.assertEqual(r.stdout, want * 2)

    def test_closed(self):
        c = sharedlink.Client(self.daemon.instance)
        c.close()
        c.close()
        self.assertRaises(ValueError, c.read, "agility.state")


class TestRestart(DaemonCase):
    def test_restart_is_transparent(self):
        # The same Client across a daemon restart: the library remaps the new tables, ids and
        # names keep working, and the event cursor says it restarted.
        c = self.c
        c["a.AutoGpsLat"] = 7.25
        until(c, "b.AutoGpsLat", lambda v: v == 7.25)
        epoch = c.daemon().epoch
        events = c.events(follow=True, new=True, timeout=WAIT_S)
        self.assertEqual(self.daemon.stop(), 0)
        self.assertFalse(c.alive)
        self.daemon.start()
        until(c, "agility.state", lambda v: v == "connected")
        self.assertNotEqual(c.daemon().epoch, epoch)
        self.assertEqual(c.daemon().pid, self.daemon.proc.pid)
        c["a.AutoGpsLat"] = 8.5
        self.assertEqual(until(c, "b.AutoGpsLat", lambda v: v == 8.5), 8.5)
        first = next(events)
        self.assertTrue(first.restarted)


def import_with(library):
    """A child Python that imports the package under test with SHAREDLINK_LIB=library."""
    here = os.path.dirname(os.path.abspath(__file__))
    path = [os.path.dirname(here)] + [p for p in os.environ.get("PYTHONPATH", "").split(":") if p]
    env = dict(os.environ, PYTHONPATH=":".join(path), SHAREDLINK_LIB=library)
    return subprocess.run([sys.executable, "-c", "import sharedlink"], env=env,
                          capture_output=True, text=True, timeout=60)


class TestLibrary(unittest.TestCase):
    def test_library_not_found(self):
        r = import_with("/nonexistent/libsharedlink.so.1")
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("ImportError: sharedlink: cannot load libsharedlink.so.1", r.stderr)
        self.assertIn("/nonexistent/libsharedlink.so.1", r.stderr)

    def test_not_the_library(self):
        # Some other shared object: its missing functions are named.
        r = import_with("libm.so.6")
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("not libsharedlink 1", r.stderr)

    def test_strerror(self):
        self.assertEqual(sharedlink.strerror(errno.EPERM), sharedlink.strerror(-errno.EPERM))
        self.assertIn("outbound", sharedlink.strerror(errno.EPERM))

    def test_event_fields(self):
        def fields(text):
            return sharedlink.Event(1, 0, 0, 0, "command", "v", 0, text).fields
        self.assertEqual(fields('module=ServoPod text="0,TELEOP START"'),
                         {"module": "ServoPod", "text": "0,TELEOP START"})
        self.assertEqual(fields(r'module=X text="say \"hi\" \\ back" n=1'),
                         {"module": "X", "text": 'say "hi" \\ back', "n": "1"})
        self.assertEqual(fields("device=E1E1E1 sensor_time=5000 stray"),
                         {"device": "E1E1E1", "sensor_time": "5000"})
        self.assertEqual(fields('text="cut short'), {"text": "cut short"})


if __name__ == "__main__":
    unittest.main()
