#!/usr/bin/env python3
"""Minimal reproduction: mosquitto re-sends as a new PUBLISH (DUP) a QoS 2 message whose PUBREL
it had already sent, after restoring a persistent session from its persistence file.

A raw MQTT 3.1.1 subscriber (clean session off, QoS 2) takes a message through PUBLISH ->
PUBREC -> PUBREL and withholds only the final PUBCOMP (as if it were lost when the broker
stopped). The receiver has then delivered the message and, per MQTT 3.1.1 4.3.3, may forget
its packet id. Case 1 reconnects to the same broker process; case 2 restarts the broker
(SIGTERM: persistence saved) first. MQTT 3.1.1 4.4 requires the broker to resend PUBREL.
Usage: mosquitto_qos2_restore.py [MAX_INFLIGHT_MESSAGES [MESSAGES]]   (default 20 1)
Not a test (it needs no sharedlink): the evidence behind the broker requirement in
sharedlink-mqtt(8). With mosquitto 2.0.11: 20, 1000 or 65534 -> PUBREL (right); 0 or 65535
("no maximum") -> PUBLISH dup=1 after the restart, a second delivery of every message whose
PUBREL had gone out. A plain reconnection to the same broker process gets PUBREL in every case:
the loss of state is in the restore from the persistence file.
"""
import os, socket, struct, subprocess, sys, tempfile, time

def enc_str(s):
    b = s.encode(); return struct.pack("!H", len(b)) + b

def packet(ptype, flags, body):
    n, rl = len(body), b""
    while True:
        d, n = n % 128, n // 128
        rl += bytes([d | (0x80 if n else 0)])
        if not n: break
    return bytes([(ptype << 4) | flags]) + rl + body

def recv_exact(s, n):
    data = b""
    while len(data) < n:
        part = s.recv(n - len(data))
        if not part: raise EOFError      # the broker closed the connection mid-packet
        data += part
    return data

def read_packet(s):
    h = recv_exact(s, 1)
    mult, n = 1, 0
    while True:
        d = recv_exact(s, 1)[0]; n += (d & 127) * mult; mult *= 128
        if not d & 128: break
    return h[0] >> 4, h[0] & 15, recv_exact(s, n)

NAMES = {3: "PUBLISH", 4: "PUBACK", 5: "PUBREC", 6: "PUBREL", 7: "PUBCOMP", 9: "SUBACK", 2: "CONNACK"}

def connect(port, cid):
    s = socket.create_connection(("127.0.0.1", port)); s.settimeout(2)
    s.sendall(packet(1, 0, enc_str("MQTT") + bytes([4, 0x00]) + struct.pack("!H", 60) + enc_str(cid)))
    t, _, b = read_packet(s); assert t == 2, t
    print(f"  CONNACK session_present={b[0]} rc={b[1]}")
    return s

def start_broker(d, port, inflight):
    conf = os.path.join(d, "m.conf")
    with open(conf, "w") as f:
        f.write(f"listener {port} 127.0.0.1\nallow_anonymous true\npersistence true\n"
                f"persistence_location {d}/\nmax_inflight_messages {inflight}\n"
                + ("user root\n" if os.geteuid() == 0 else ""))
    p = subprocess.Popen(["mosquitto", "-c", conf], stderr=subprocess.DEVNULL)
    for _ in range(100):
        try: socket.create_connection(("127.0.0.1", port)).close(); return p
        except OSError: time.sleep(0.05)
    raise RuntimeError("broker did not start")

def free_port():
    s = socket.socket(); s.bind(("127.0.0.1", 0)); p = s.getsockname()[1]; s.close(); return p

def run(restart, inflight, count):
    d, port = tempfile.mkdtemp(), free_port()
    b = start_broker(d, port, inflight)
    print(f"case: {'broker restart' if restart else 'reconnect, same broker'} "
          f"(max_inflight_messages {inflight}, {count} message(s))")
    sub = connect(port, "sub")
    sub.sendall(packet(8, 2, struct.pack("!H", 1) + enc_str("t") + bytes([2])))
    assert read_packet(sub)[0] == 9
    pub = connect(port, "pub")
    for k in range(1, count + 1):
        pub.sendall(packet(3, 2 << 1, enc_str("t") + struct.pack("!H", k) + f"event-{k}".encode()))
        assert read_packet(pub)[0] == 5
        pub.sendall(packet(6, 2, struct.pack("!H", k)))
        assert read_packet(pub)[0] == 7
    released = []
    try:
        while len(released) < count:
            t, fl, body = read_packet(sub)
            if t == 3:                      # PUBLISH: answer PUBREC
                sub.sendall(packet(5, 0, body[3:5]))
            elif t == 6:                    # PUBREL: delivered now; PUBCOMP withheld
                released.append(struct.unpack("!H", body[:2])[0])
    except socket.timeout:
        pass
    print(f"  PUBREL came for {len(released)} of {count} message(s) {released}: the subscriber "
          "delivered those and, withholding PUBCOMP, forgets their ids")
    sub.close(); pub.close()
    if restart:
        b.terminate(); b.wait()
        b = start_broker(d, port, inflight)
    time.sleep(0.2)
    sub = connect(port, "sub")
    try:
        while True:
            t, fl, body = read_packet(sub)
            dup = (fl >> 3) & 1
            print(f"  after reconnect: {NAMES.get(t, t)} dup={dup} mid {struct.unpack('!H', body[-2:] if t != 3 else body[3:5])[0]}"
                  + (f" payload {body[5:]!r}  <-- a second delivery" if t == 3 else ""))
    except (socket.timeout, EOFError):
        pass
    sub.close(); b.terminate(); b.wait()

inflight = int(sys.argv[1]) if len(sys.argv) > 1 else 20
count = int(sys.argv[2]) if len(sys.argv) > 2 else 1
run(False, inflight, count)
run(True, inflight, count)
