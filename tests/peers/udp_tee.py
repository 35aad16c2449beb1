#!/usr/bin/env python3
"""A UDP relay that prints what passes: `make demo` puts it between a Pronto4 host link and a
vehicle link of one sharedlinkd, so the frames they exchange are shown byte for byte.

    udp_tee.py A_LISTEN A_PEER B_LISTEN B_PEER LOG

A datagram received on A_LISTEN (from the host link, whose remote: it is) goes to B_PEER (the
vehicle link's local:) from B_LISTEN (the vehicle link's remote:), and the other way round, so
each link sees its peer at the address it is configured with. Each datagram is written to LOG
as one line, "A -> B " or "B -> A " then the bytes with CR and LF shown as <CR> <LF>. SIGUSR1
injects a real vehicle ping [:AB|P0|C78] toward the host and a host ping [:BA|P0|C78] toward
the vehicle (both logged as "tee -> A" / "tee -> B"), so the demo can show P0 answered by G0.
"ready" goes to stdout once both sockets are bound. Ends on SIGTERM or SIGINT.
"""
import select
import signal
import socket
import sys

DATAGRAM_MAX = 8192
PINGS = {"A": b"[:AB|P0|C78]\r\n", "B": b"[:BA|P0|C78]\r\n"}


def endpoint(text):
    host, _, port = text.rpartition(":")
    return (host, int(port))


def shown(data):
    return data.decode("ascii", "replace").replace("\r", "<CR>").replace("\n", "<LF>")


def main(argv):
    if len(argv) != 5:
        print(__doc__, file=sys.stderr)
        return 2
    a_listen, a_peer, b_listen, b_peer = (endpoint(x) for x in argv[:4])
    log = open(argv[4], "w", buffering=1)
    a = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    b = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    a.bind(a_listen)
    b.bind(b_listen)
    pending = []
    stop = []
    signal.signal(signal.SIGUSR1, lambda *_: pending.append(True))
    signal.signal(signal.SIGTERM, lambda *_: stop.append(True))
    signal.signal(signal.SIGINT, lambda *_: stop.append(True))
    print("ready", flush=True)
    while not stop:
        if pending:
            pending.clear()
            a.sendto(PINGS["A"], a_peer)
            log.write("tee -> A  %s\n" % shown(PINGS["A"]))
            b.sendto(PINGS["B"], b_peer)
            log.write("tee -> B  %s\n" % shown(PINGS["B"]))
        try:
            ready, _, _ = select.select([a, b], [], [], 0.5)
        except InterruptedError:
            continue
        for s in ready:
            try:
                data = s.recv(DATAGRAM_MAX)
            except ConnectionRefusedError:
                continue
            # A datagram from the host link (on a) is for the vehicle, and back.
            out, to, what = (b, b_peer, "A -> B") if s is a else (a, a_peer, "B -> A")
            log.write("%s  %s\n" % (what, shown(data)))
            try:
                out.sendto(data, to)
            except ConnectionRefusedError:
                pass
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
