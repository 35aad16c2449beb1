#!/usr/bin/env python3
"""A Kairos Pronto4 peer for tests: behaves like the public ROS clients (docs/pronto4.md).

Plays the host (node A, e.g. the ROS adapter) or the vehicle (node B, the Pronto4 controller) over
UDP, and is as demanding as those clients are:

- every datagram it receives must end with "]\\r\\n" (the C++ adapter aborts otherwise): a missing
  CR LF is reported and, unless --tolerate-missing-crlf, ends the peer with exit status 3;
- data frames must be one full-length "N0" list (a partial list or "N<k>" kills the ROS 2
  bridge's receiver): reported as an error;
- received checksums are checked (the ROS 2 bridge does not; we do, to catch a bad sender);
- values are checked against their declared type (T0 long, T2 double, T4 string);
- at start it sends L? and N? and waits for the typed answers: the script action "query", which
  a script that plays the C++ adapter puts first.

Roles:
  host     sends the connect sequence (ELink|D0, SetIP, <ip>:<port>, 4000 / outbound, on /
           inbound, on), its typed declarations N0 (what it sends) and L0 (what it wants),
           pings, values and E commands; takes the vehicle's R/D reply to its N0 declaration
           as an acknowledgement.
  vehicle  learns the host's declarations (its inbound list from the host's N0, its outbound
           list from the host's L0) unless --send/--recv give them, answers an N0 declaration
           with the R/D acknowledgement, sends its full N0 list every --period-ms, answers P0
           with G0 and reports E commands and MUI/MUO/ML/MW.
Both roles answer "L?" with "N0|T|Q..." (the list they send) and "N?" with "L0|T|Q..." (the list
they receive).

Output: one JSON object per line on stdout, one per event (see EVENTS below); nothing else. The
first line is always "ready", with the bound address ("local"): bind port 0 and read it.
Script: actions separated by ";" in --script, or one per line on stdin with --script -. Actions:
  connect                         host: the three ELink commands
  declare                         send the N0 and L0 declarations (typed, one frame each)
  query                           send L? and N?, wait for both typed answers (--timeout)
  ping                            send P0 and wait for G0
  set NAME VALUE                  set one of our outbound values and send the full N0 list
  send                            send the full N0 list now
  command MODULE TEXT...          send E<MODULE>|D<TEXT>
  raw FRAME                       send FRAME as is (for bad-input tests), CR LF added
  mu WHAT                         send MUI, MUO, ML or MW
  wait EVENT [KEY=VALUE...]       wait (--timeout) for an event whose fields match
  run                             serve (answer, send periodically) until --duration or killed
  quit                            stop now (the end of the script does too)
EVENTS: ready, sent, declaration, ack, list_answer, value, ping, pong, command, mu, query,
error, timeout, done. Every event has "event" and "t" (seconds since start).
Exit status: 0, 1 (a wait timed out or a script error), 2 (usage), 3 (aborted: missing CR LF).
"""

import argparse
import json
import math
import re
import select
import shlex
import socket
import sys
import time

TYPE_LONG, TYPE_DOUBLE, TYPE_STRING = "0", "2", "4"
ADDR = {"host": "A", "vehicle": "B"}
DATAGRAM_MAX = 8192
INT64_MIN, INT64_MAX = -(1 << 63), (1 << 63) - 1
LONG_RE = re.compile(r"[+-]?[0-9]+\Z")
DOUBLE_RE = re.compile(r"[+-]?([0-9]+(\.[0-9]*)?|\.[0-9]+)([eE][+-]?[0-9]+)?\Z")
VALUE_MAX = 63


class Aborted(Exception):
    """The peer stops the way the C++ adapter would."""


def checksum(body):
    """Sum mod 256 of the text from ':' through the 'C' (PROTOCOLS.md 1.3)."""
    return sum(body.encode("ascii")) & 0xFF


def frame(dst, src, fields, crlf=True):
    body = ":%s%s|%s|C" % (dst, src, "|".join(fields))
    return "[%s%02X]%s" % (body, checksum(body), "\r\n" if crlf else "")


def value_ok(vtype, value):
    if len(value) > VALUE_MAX:
        return False
    if vtype == TYPE_LONG:
        return bool(LONG_RE.match(value)) and INT64_MIN <= int(value) <= INT64_MAX
    if vtype == TYPE_DOUBLE:
        return bool(DOUBLE_RE.match(value)) and math.isfinite(float(value))
    return True


def parse_list_spec(spec):
    """"T0:veh_start,T2:joy_steer" -> [(name, type)]; a bare name is a double (as on the wire)."""
    out = []
    for item in filter(None, (s.strip() for s in spec.split(","))):
        if ":" in item:
            t, name = item.split(":", 1)
            if t not in ("T0", "T2", "T4"):
                raise ValueError("bad type %r in %r" % (t, item))
            out.append((name, t[1]))
        else:
            out.append((item, TYPE_DOUBLE))
    return out


def parse_endpoint(text):
    host, _, port = text.rpartition(":")
    return (host or "127.0.0.1", int(port))


class Peer:
    def __init__(self, args):
        self.args = args
        self.role = args.role
        self.me = ADDR[self.role]
        self.them = ADDR["vehicle" if self.role == "host" else "host"]
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(parse_endpoint(args.local))
        self.remote = parse_endpoint(args.remote) if args.remote else None
        self.start = time.monotonic()
        self.send_list = parse_list_spec(args.send)        # what we send: our N list
        self.recv_list = parse_list_spec(args.recv)        # what we receive: our L list
        self.values = {name: "0" for name, _ in self.send_list}
        self.received = {}
        self.counts = {}
        self.events = []                                   # for "wait"
        self.pending_answers = set()                       # "N", "L": answers a query awaits
        self.next_periodic = None

    # -- output -------------------------------------------------------------------------------

    def emit(self, event, **fields):
        rec = {"event": event, "t": round(time.monotonic() - self.start, 3)}
        rec.update(fields)
        self.events.append(rec)
        sys.stdout.write(json.dumps(rec, sort_keys=True) + "\n")
        sys.stdout.flush()
        return rec

    def error(self, what, **fields):
        self.counts[what] = self.counts.get(what, 0) + 1
        self.emit("error", what=what, **fields)

    # -- sending ------------------------------------------------------------------------------

    def send_fields(self, fields):
        if not self.remote:
            self.error("no_remote", fields="|".join(fields))
            return
        text = frame(self.them, self.me, fields)
        self.sock.sendto(text.encode("ascii"), self.remote)
        self.emit("sent", frame=text.rstrip("\r\n"))

    def send_declaration(self, head, entries):
        fields = ["%s0" % head]
        for name, vtype in entries:
            fields += ["T" + vtype, "Q" + name]
        self.send_fields(fields)

    def send_data(self):
        if self.send_list:
            self.send_fields(["N0"] + ["D" + self.values[name] for name, _ in self.send_list])

    # -- receiving ----------------------------------------------------------------------------

    def receive(self, timeout):
        ready, _, _ = select.select([self.sock], [], [], max(timeout, 0))
        if not ready:
            return
        data, src = self.sock.recvfrom(DATAGRAM_MAX)
        if self.role == "vehicle" and not self.args.remote:
            self.remote = src                              # answer whoever spoke
        self.on_datagram(data)

    def on_datagram(self, data):
        text = data.decode("ascii", "replace")
        if not text.endswith("]\r\n"):
            self.error("no_crlf", datagram=text)
            if not self.args.tolerate_missing_crlf:
                raise Aborted("datagram without ]\\r\\n: %r" % text)
            text = text.rstrip("\r\n")
        else:
            text = text[:-2]
        if not (text.startswith("[") and text.endswith("]")) or text.count("[") != 1:
            self.error("bad_frame", datagram=text)
            return
        inner = text[1:-1]
        cut = inner.rfind("|C")
        if cut < 0 or not re.fullmatch(r"[0-9A-Fa-f]{1,2}", inner[cut + 2:]):
            self.error("bad_checksum", frame=text)
            return
        if checksum(inner[:cut + 2]) != int(inner[cut + 2:], 16):
            self.error("bad_checksum", frame=text)
            return
        if not re.match(r":[A-P][A-P]\|", inner):
            self.error("bad_header", frame=text)
            return
        dst, src = inner[1], inner[2]
        if dst != self.me or src != self.them:
            self.error("not_for_us", frame=text)
            return
        fields = [f for f in inner[4:cut].split("|") if f]
        self.on_frame(text, fields)

    def on_frame(self, text, fields):
        head = fields[0] if fields else ""
        letters = {f[0] for f in fields}
        if head in ("N?", "L?"):
            self.emit("query", list=head[0])
            # L?: the list we send (N0 declaration); N?: the list we receive (L0 declaration).
            if head == "L?":
                self.send_declaration("N", self.send_list)
            else:
                self.send_declaration("L", self.recv_list)
        elif head == "P0":
            self.emit("ping")
            self.send_fields(["G0"])
        elif head == "G0":
            self.emit("pong")
        elif head.startswith("E"):
            text_field = fields[1][1:] if len(fields) > 1 and fields[1][0] == "D" else ""
            self.emit("command", module=head[1:], text=text_field)
        elif head in ("MUI", "MUO", "ML", "MW"):
            self.emit("mu", what=head)
        elif head in ("N0", "L0") and ("Q" in letters):
            self.on_declaration(head[0], fields[1:])
        elif head == "N0" and "R" in letters:
            self.on_ack(fields[1:])
        elif head.startswith("N"):
            self.on_data(text, head, fields[1:])
        else:
            self.error("unknown_frame", frame=text)

    def on_declaration(self, head, rest):
        entries, values, vtype = [], {}, TYPE_DOUBLE       # a name without T is a double
        for f in rest:
            if f[0] == "T":
                if f[1:] not in (TYPE_LONG, TYPE_DOUBLE, TYPE_STRING):
                    self.error("bad_type", field=f)
                vtype = f[1:]
            elif f[0] == "Q":
                entries.append((f[1:], vtype))
                vtype = TYPE_DOUBLE
            elif f[0] == "D" and entries:
                values[entries[-1][0]] = f[1:]             # self-describing: T, Q, D
        typed = [{"name": n, "type": t} for n, t in entries]
        if values:
            for name, value in values.items():
                self.on_value(name, dict(entries)[name], value)
            return
        if self.awaiting_answer(head):
            self.emit("list_answer", list=head, entries=typed)
        else:
            self.emit("declaration", list=head, entries=typed)
        if self.role != "vehicle":
            return
        if head == "N":
            # The host's N list is what we receive; acknowledge it with our current values.
            if not self.args.recv:
                self.recv_list = entries
            acks = []
            for name, _ in entries:
                acks += ["R" + name, "D" + self.received.get(name, "0")]
            self.send_fields(["N0"] + acks)
        elif not self.args.send:
            self.send_list = entries
            self.values = {name: self.values.get(name, "0") for name, _ in entries}

    def awaiting_answer(self, head):
        if head in self.pending_answers:
            self.pending_answers.discard(head)
            return True
        return False

    def on_ack(self, rest):
        pairs = []
        for i in range(0, len(rest) - 1, 2):
            if rest[i][0] != "R" or rest[i + 1][0] != "D":
                self.error("bad_ack", fields="|".join(rest))
                return
            pairs.append({"name": rest[i][1:], "value": rest[i + 1][1:]})
        self.emit("ack", entries=pairs)

    def on_data(self, text, head, rest):
        if head != "N0":
            self.error("partial_list", frame=text, reason="starts at %s" % head)
            return
        if not all(f[0] == "D" for f in rest):
            self.error("unknown_frame", frame=text)
            return
        if not self.recv_list:
            self.error("data_before_declaration", frame=text)
            return
        if len(rest) != len(self.recv_list):
            self.error("partial_list", frame=text,
                       reason="%d values for a list of %d" % (len(rest), len(self.recv_list)))
            return
        for (name, vtype), f in zip(self.recv_list, rest):
            if f[1:] != "":                                # empty D: unchanged
                self.on_value(name, vtype, f[1:])

    def on_value(self, name, vtype, value):
        if not value_ok(vtype, value):
            self.error("bad_value", name=name, type=vtype, value=value)
            return
        if self.received.get(name) != value:
            self.received[name] = value
            self.emit("value", name=name, type=vtype, value=value)

    # -- the script ---------------------------------------------------------------------------

    def serve(self, until):
        """Answers and sends periodically until the monotonic time `until`."""
        while True:
            now = time.monotonic()
            if now >= until:
                return
            deadline = until
            if self.role == "vehicle" and self.args.period_ms > 0:
                if self.next_periodic is None or now >= self.next_periodic:
                    if self.remote and self.send_list:
                        self.send_data()
                    self.next_periodic = now + self.args.period_ms / 1000.0
                deadline = min(deadline, self.next_periodic)
            self.receive(deadline - time.monotonic())

    def wait_for(self, event, want):
        def match(rec):
            return rec["event"] == event and all(str(rec.get(k)) == v for k, v in want.items())
        seen = len(self.events)
        if any(match(r) for r in self.events):
            return True
        deadline = time.monotonic() + self.args.timeout
        while time.monotonic() < deadline:
            self.serve(min(deadline, time.monotonic() + 0.05))
            if any(match(r) for r in self.events[seen:]):
                return True
        self.emit("timeout", waited=event, want=want)
        return False

    def act(self, words):
        cmd, rest = words[0], words[1:]
        if cmd == "connect":
            host, port = self.sock.getsockname()
            self.send_fields(["ELink", "D0, SetIP, %s:%d, 4000" % (host, port)])
            self.send_fields(["ELink", "D0, outbound, on"])
            self.send_fields(["ELink", "D0, inbound, on"])
        elif cmd == "declare":
            self.send_declaration("N", self.send_list)
            self.send_declaration("L", self.recv_list)
        elif cmd == "query":
            self.pending_answers = {"N", "L"}
            self.send_fields(["L?"])
            self.send_fields(["N?"])
            return (self.wait_for("list_answer", {"list": "N"}) and
                    self.wait_for("list_answer", {"list": "L"}))
        elif cmd == "ping":
            self.send_fields(["P0"])
            return self.wait_for("pong", {})
        elif cmd == "set" and len(rest) == 2:
            if rest[0] not in self.values:
                self.error("script", action=" ".join(words), reason="not in our outbound list")
                return False
            self.values[rest[0]] = rest[1]
            self.send_data()
        elif cmd == "send":
            self.send_data()
        elif cmd == "command" and len(rest) >= 2:
            self.send_fields(["E" + rest[0], "D" + " ".join(rest[1:])])
        elif cmd == "raw" and len(rest) == 1:
            self.sock.sendto((rest[0] + "\r\n").encode("ascii"), self.remote)
            self.emit("sent", frame=rest[0])
        elif cmd == "mu" and rest and rest[0] in ("MUI", "MUO", "ML", "MW"):
            self.send_fields([rest[0]])
        elif cmd == "wait" and rest:
            want = dict(w.split("=", 1) for w in rest[1:])
            return self.wait_for(rest[0], want)
        elif cmd == "run":
            self.serve(time.monotonic() + self.args.duration)
        elif cmd == "quit":
            raise StopIteration
        else:
            self.error("script", action=" ".join(words))
            return False
        return True

    def run(self, actions):
        host, port = self.sock.getsockname()
        self.emit("ready", role=self.role, node=self.me, local="%s:%d" % (host, port))
        ok = True
        try:
            for words in actions:
                self.serve(time.monotonic())               # take what arrived meanwhile
                if not self.act(words):
                    ok = False
                    break
        except StopIteration:
            pass
        self.emit("done", ok=ok, errors=self.counts)
        return 0 if ok else 1


def read_script(text):
    lines = sys.stdin.read().splitlines() if text == "-" else text.split(";")
    return [shlex.split(line) for line in lines if line.strip()]


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--role", choices=("host", "vehicle"), required=True)
    ap.add_argument("--local", default="127.0.0.1:0", help="HOST:PORT to bind (0: any port)")
    ap.add_argument("--remote", help="HOST:PORT to send to (vehicle: default the last sender)")
    ap.add_argument("--send", default="",
                    help="our outbound list, e.g. T0:veh_start,T2:x (bare name: double)")
    ap.add_argument("--recv", default="", help="our inbound list, same syntax")
    ap.add_argument("--period-ms", type=int, default=200, help="vehicle: full N0 every (0: no)")
    ap.add_argument("--timeout", type=float, default=10.0, help="seconds a wait may take")
    ap.add_argument("--duration", type=float, default=5.0, help="seconds of the run action")
    ap.add_argument("--script", default="run", help="actions separated by ';', or - for stdin")
    ap.add_argument("--tolerate-missing-crlf", action="store_true",
                    help="count a datagram without ]\\r\\n instead of aborting")
    args = ap.parse_args(argv)
    try:
        peer = Peer(args)
        actions = read_script(args.script)
    except (OSError, ValueError) as e:
        print(json.dumps({"event": "error", "what": "usage", "reason": str(e)}), flush=True)
        return 2
    try:
        return peer.run(actions)
    except Aborted as e:
        peer.emit("done", ok=False, aborted=str(e), errors=peer.counts)
        return 3


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
