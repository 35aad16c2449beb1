/*
 * Transports: one interface over the three kinds of link, each a non-blocking fd that the link
 * engine reads and writes through transport_read()/transport_write().
 *
 * - TRANSPORT_SERIAL: a tty (serial.h). devices[] lists one or more paths, tried in turn.
 * - TRANSPORT_PTY: the daemon makes a pty pair, keeps the master as the link's fd and puts a
 *   symlink to the slave at devices[0] (made under a temporary name, then renamed over the
 *   path; a path that exists and is not a symlink is never replaced; the link is removed on
 *   close if it still points to our slave). The slave is set raw with the link's settings.
 *   The daemon keeps its own slave fd open for the life of the transport, so the master never
 *   sees a hang-up: a peer may open and close the slave any number of times and the link stays
 *   up. The price: bytes written while no peer has the slave open wait in the pty (a few KiB),
 *   then writes would block and the channel's queue drops frames; a peer that opens the slave
 *   later first reads those stale bytes (the codecs resynchronise on the next frame start).
 * - TRANSPORT_REPLAY: devices[0] is a recording (replay.h) played as if it came from the wire:
 *   one recorded "<" chunk per read at the recorded pace, writes counted and dropped. Its end is
 *   a read error, -ENODATA, that is final: transport_reopens() is false for this kind. With
 *   replay_datagram set (a recording of a UDP link), each chunk is one datagram, as on UDP.
 * - TRANSPORT_UDP: local and/or remote "host:port" ("[v6]:port" for IPv6), numeric addresses or
 *   "localhost" only (no DNS lookups in the event loop). One datagram per frame both ways.
 *   With a remote, the socket is connected (the kernel drops datagrams from anyone else); with
 *   only a local address, replies go to the sender of the last datagram received.
 */
#ifndef SHAREDLINK_DAEMON_TRANSPORT_H
#define SHAREDLINK_DAEMON_TRANSPORT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#include "daemon/serial.h"

#define TRANSPORT_DEVICES_MAX   8       /* serial: paths scanned in turn */
#define TRANSPORT_PATH_MAX      256     /* a device or symlink path, NUL included */
#define TRANSPORT_ADDR_MAX      96      /* "host:port", NUL included */
#define TRANSPORT_DATAGRAM_MAX  8192    /* largest UDP datagram taken in or sent */
/* A serial error, or a replay's "FILE:LINE: message" (a path and a recording parse error). */
#define TRANSPORT_ERR_MAX       (TRANSPORT_PATH_MAX + 128)

enum transport_kind {
        TRANSPORT_SERIAL,
        TRANSPORT_PTY,
        TRANSPORT_UDP,
        TRANSPORT_REPLAY,               /* plays a recording: replay.h */
};

/* Plain data, copied by value; main.c fills it from the configuration. */
struct transport_params {
        enum transport_kind kind;
        char devices[TRANSPORT_DEVICES_MAX][TRANSPORT_PATH_MAX];
        unsigned n_devices;
        struct serial_config serial;    /* serial and pty (the slave's settings) */
        char local[TRANSPORT_ADDR_MAX]; /* udp; "" for none */
        char remote[TRANSPORT_ADDR_MAX];
        double replay_speed;            /* replay: devices[0] is the file; 0 = "max" */
        bool replay_loop;
        bool replay_datagram;           /* replay: chunks are datagrams (the recording's head
                                         * said udp when the link was set up) */
};

struct transport;

/* Clears params and sets the kind and serial defaults (115200 8N1, no flow control). */
void transport_params_init(struct transport_params *params, enum transport_kind kind);

/* Appends a device path; 0, -ENAMETOOLONG or -ENOSPC (TRANSPORT_DEVICES_MAX). */
int transport_params_add_device(struct transport_params *params, const char *path);

/* Sets a UDP address ("" clears it); 0 or -ENAMETOOLONG. Syntax is checked by _check(). */
int transport_params_set_udp(struct transport_params *params, const char *local,
                             const char *remote);

/* NULL when the params can be opened as far as syntax goes, else a short reason. */
const char *transport_params_check(const struct transport_params *params);

/* Whether a transport opened with params reads and writes whole datagrams: udp, or a replay
 * with replay_datagram. */
bool transport_params_datagram(const struct transport_params *params);

/* Opens device `device_index` of params (serial), the pty, or the UDP socket. 0 or -errno with
 * a one-line reason in err ("open /dev/ttyUSB0: No such file or directory"; NULL if errsz 0). */
int transport_open(const struct transport_params *params, unsigned device_index,
                   struct transport **ret_transport, char *err, size_t errsz);

/* Closes the fd, restores a serial port's settings, removes a pty's symlink; returns NULL. */
struct transport *transport_close(struct transport *transport);

/* The non-blocking fd to poll. */
int transport_fd(const struct transport *transport);

/* Whether reads and writes are whole datagrams (udp, a replay of udp) rather than a byte
 * stream. */
bool transport_is_datagram(const struct transport *transport);

/* What is open: the device path, the pty symlink path, or "udp <local> -> <remote>". */
const char *transport_name(const struct transport *transport);

/* The pty kind's slave device (/dev/pts/N); NULL for other kinds. */
const char *transport_pty_slave(const struct transport *transport);

/* Reads bytes (stream) or one datagram. Returns the length (0 only for an empty datagram),
 * -EAGAIN when nothing is there, -EPIPE when a tty hung up (read returned 0), -EMSGSIZE for a
 * datagram larger than size (dropped), -ENODATA at the end of a replay, or another -errno. */
ssize_t transport_read(struct transport *transport, void *buf, size_t size);

/* Writes bytes (may be partial) or one whole datagram. Returns the length written, -EAGAIN,
 * -EDESTADDRREQ (udp: no peer known yet), or another -errno. */
ssize_t transport_write(struct transport *transport, const void *buf, size_t len);

/* Whether a transport of this kind that went down is opened again (false for a replay: its end
 * or a broken recording is final until the link is restarted). */
bool transport_reopens(enum transport_kind kind);

/* For err (negative) from transport_read: the reason when it is the normal end of a transport
 * that ends ("end of recording": a replay's -ENODATA), which is no I/O error; else NULL. Only a
 * replay ends: the same errno from a device is an error like any other. */
const char *transport_end_reason(const struct transport *transport, int err);

/* Whether err (negative) from transport_read/write means the transport is broken and must be
 * reopened; false for per-datagram errors (ICMP unreachable, too large, no peer yet). */
bool transport_error_fatal(const struct transport *transport, int err);

#endif
