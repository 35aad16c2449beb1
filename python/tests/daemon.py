"""Starts the real sharedlinkd for the Python tests, the way tests/common/harness.c does: a private
temporary directory (config, control socket, pty symlinks), a unique instance name, and READY=1
awaited on our own NOTIFY_SOCKET (a datagram, not a sleep), every wait bounded.

The links are the demo's (conf/demo.yaml): SharedLink node A <-> node B over a pty (node B also
has a peer C that never answers), a CIRCE controller <-> the built-in mediator emulator, and a
Pronto4 host <-> vehicle pair over UDP on loopback.

$SHAREDLINK_BUILD names the build whose sharedlinkd and slctl run (default build/); the library
the binding loads is $SHAREDLINK_LIB (see python/tests/run.py).
"""
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
START_S = 30.0          # READY=1 from an ASan daemon on a busy machine: a hang guard only
STOP_S = 15.0
NOTIFY_MAX = 4096

CONFIG = """\
instance: {instance}
runtime_dir: {dir}
links:
  - name: node_a
    protocol: sharedlink
    transport: pty
    device: {dir}/node-a.tty
    address: A
    peers:
      - address: B
        period_ms: 100
        refresh_ms: 1000
        on_change: true
        outbound:
          - {{name: a.AutoGpsLat, type: double}}
          - {{name: a.Label, type: string}}
        inbound:
          - {{name: a.CmdThrottle, type: long}}
  - name: node_b
    protocol: sharedlink
    transport: serial
    device: {dir}/node-a.tty
    address: B
    peers:
      - address: A
        period_ms: 100
        refresh_ms: 1000
        on_change: true
        outbound:
          - {{name: b.CmdThrottle, type: long}}
        inbound:
          - {{name: b.AutoGpsLat, type: double}}
          - {{name: b.Label, type: string}}
      - address: C                  # never on the wire: a query to it times out
        period_ms: 1000
        outbound: [b.ForC]
  - name: arena
    protocol: circe
    role: mediator
    transport: pty
    device: {dir}/arena.tty
    version: "0.2.3"
    keepalive_ms: 750
    emulate:
      - {{address: E1E1E1, capabilities: 32, signal: 150, battery: 200}}
      - {{address: AAAAAA, capabilities: 31}}
      - {{address: D15D15, capabilities: 64}}
  - name: agility
    protocol: circe
    role: controller
    transport: serial
    device: {dir}/arena.tty
    expect_version: "0.2"
    login_timeout_ms: 1000
    idle_timeout_ms: 2000
  - name: p4veh                     # a Pronto4 vehicle side, learning the host's lists
    protocol: sharedlink
    transport: udp
    local: "127.0.0.1:{p4veh}"
    remote: "127.0.0.1:{p4host}"
    address: B
    peers:
      - address: A
        dialect: pronto4
        outbound: learn
        inbound: learn
  - name: p4host                    # its host
    protocol: sharedlink
    transport: udp
    local: "127.0.0.1:{p4host}"
    remote: "127.0.0.1:{p4veh}"
    address: A
    peers:
      - address: B
        dialect: pronto4
        outbound: [{{name: veh_start, type: long}}]
        inbound: [{{name: VehicleName, type: string}}]
"""


def free_udp_ports(n):
    """n loopback UDP ports free right now (all bound at once, so they differ)."""
    socks = [socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(n)]
    try:
        for s in socks:
            s.bind(("127.0.0.1", 0))
        return [s.getsockname()[1] for s in socks]
    finally:
        for s in socks:
            s.close()


def build_dir():
    return os.path.join(ROOT, os.environ.get("SHAREDLINK_BUILD", "build"))


class Daemon:
    """One sharedlinkd on CONFIG in a temporary directory; stop() (or the with block) ends it."""

    def __init__(self, tag="py"):
        self.dir = tempfile.mkdtemp(prefix="sharedlink-%s." % tag)
        self.instance = "t%d_%s" % (os.getpid(), tag)
        self.config = os.path.join(self.dir, "sharedlinkd.yaml")
        self.log_path = os.path.join(self.dir, "daemon.log")
        self.proc = None
        with open(self.config, "w") as f:
            p4veh, p4host = free_udp_ports(2)
            f.write(CONFIG.format(instance=self.instance, dir=self.dir, p4veh=p4veh,
                                  p4host=p4host))
        self.env = dict(os.environ, SHAREDLINK_RUNTIME_DIR=self.dir,
                        SHAREDLINK_INSTANCE=self.instance)

    def start(self):
        notify_path = os.path.join(self.dir, "notify")
        if os.path.exists(notify_path):
            os.unlink(notify_path)          # left by an earlier start(): a restart
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM | socket.SOCK_CLOEXEC)
        try:
            sock.bind(notify_path)
            env = dict(self.env, NOTIFY_SOCKET=notify_path)
            with open(self.log_path, "wb") as log:
                self.proc = subprocess.Popen(
                    [os.path.join(build_dir(), "sharedlinkd"), "-c", self.config],
                    env=env, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
            deadline = time.monotonic() + START_S
            while True:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise RuntimeError("sharedlinkd: no READY=1 in %.0f s; log:\n%s"
                                       % (START_S, self.log()))
                if self.proc.poll() is not None:
                    raise RuntimeError("sharedlinkd exited (%d) before READY=1; log:\n%s"
                                       % (self.proc.returncode, self.log()))
                # Short slices: a daemon that dies before READY=1 is noticed promptly.
                sock.settimeout(min(left, 0.2))
                try:
                    data = sock.recv(NOTIFY_MAX)
                except socket.timeout:
                    continue
                if b"READY=1" in data.split(b"\n"):
                    return self
        finally:
            sock.close()

    def log(self):
        try:
            with open(self.log_path, "rb") as f:
                return f.read().decode("utf-8", "replace")
        except OSError as e:
            return "(no log: %s)" % e

    def stop(self):
        """SIGTERM and wait (SIGKILL past STOP_S); returns the exit status (None if not run)."""
        status = None
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                status = self.proc.wait(STOP_S)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                status = self.proc.wait()
        elif self.proc:
            status = self.proc.returncode
        return status

    def cleanup(self):
        self.stop()
        shutil.rmtree(self.dir, ignore_errors=True)

    def slctl(self, *args, timeout=20.0):
        """Runs the build's slctl against this daemon; CompletedProcess with text output."""
        return subprocess.run([os.path.join(build_dir(), "slctl")] + list(args), env=self.env,
                              capture_output=True, text=True, timeout=timeout)

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.cleanup()
