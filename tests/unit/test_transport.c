/*
 * transport + serial: parameter checks; the serial kind on real ptys (the test owns the pair,
 * the transport opens the slave) at standard and non-standard speeds with the settings read
 * back and the original settings restored; the pty kind's symlink; UDP on loopback with
 * datagram boundaries; a replay of a UDP recording as datagrams. Reconnection lives in
 * test_channel.c.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <cmocka.h>

#include "common/harness.h"
#include "daemon/serial.h"
#include "daemon/serial_speed.h"
#include "daemon/replay.h"
#include "daemon/transport.h"
#include "proto/recording.h"

#define WAIT_MS         5000

struct fixture {
        char dir[HARNESS_PATH_MAX];
};

static int setup(void **state)
{
        static struct fixture f;

        snprintf(f.dir, sizeof(f.dir), "/tmp/sltransport.XXXXXX");
        if (!mkdtemp(f.dir))
                return -1;
        *state = &f;
        return 0;
}

static int teardown(void **state)
{
        struct fixture *f = *state;
        char cmd[HARNESS_PATH_MAX + 32];

        snprintf(cmd, sizeof(cmd), "rm -rf '%s'", f->dir);
        return system(cmd) == 0 ? 0 : -1;
}

static void path_in(const struct fixture *f, const char *name, char *out)
{
        int n = snprintf(out, TRANSPORT_PATH_MAX, "%s/%s", f->dir, name);

        assert_true(n > 0 && n < TRANSPORT_PATH_MAX);
}

/* Waits for fd to be readable; a test failure after WAIT_MS. */
static void wait_readable(int fd)
{
        struct pollfd p = { .fd = fd, .events = POLLIN };

        assert_int_equal(poll(&p, 1, WAIT_MS), 1);
}

/* Reads exactly len bytes from a non-blocking transport, waiting on its fd. */
static void transport_read_exact(struct transport *t, char *buf, size_t len)
{
        size_t got = 0;

        while (got < len) {
                ssize_t n;

                wait_readable(transport_fd(t));
                n = transport_read(t, buf + got, len - got);
                if (n == -EAGAIN)
                        continue;
                assert_true(n > 0);
                got += (size_t)n;
        }
}

/* ---------------------------------------------------------------------------------------------
 * Parameters */

static void test_params_check(void **state)
{
        static const struct {
                const char *local, *remote;
                bool ok;
        } udp[] = {
                { "127.0.0.1:4220", "127.0.0.1:4000", true },
                { "0.0.0.0:4220", "", true },
                { "", "[::1]:4000", true },
                { "[::]:0", "", true },                 /* local port 0: any */
                { "localhost:1", "localhost:2", true },
                { "", "", false },
                { "::1:4000", "", false },              /* v6 without brackets */
                { "[::1]4000", "", false },
                { "127.0.0.1", "", false },
                { ":4000", "", false },
                { "", "127.0.0.1:0", false },           /* remote port 0 */
                { "127.0.0.1:65536", "", false },
                { "127.0.0.1:12a", "", false },
                { "127.0.0.1:-1", "", false },
                { "127.0.0.1:", "", false },
        };
        static const struct {
                uint32_t baud;
                unsigned data, stop;
                int parity, flow;
                bool ok;
        } ser[] = {
                { 1200, 8, 1, SERIAL_PARITY_NONE, SERIAL_FLOW_NONE, true },
                { 4000000, 7, 2, SERIAL_PARITY_ODD, SERIAL_FLOW_XONXOFF, true },
                { 250000, 8, 1, SERIAL_PARITY_EVEN, SERIAL_FLOW_RTSCTS, true },
                { 1199, 8, 1, SERIAL_PARITY_NONE, SERIAL_FLOW_NONE, false },
                { 4000001, 8, 1, SERIAL_PARITY_NONE, SERIAL_FLOW_NONE, false },
                { 9600, 6, 1, SERIAL_PARITY_NONE, SERIAL_FLOW_NONE, false },
                { 9600, 8, 3, SERIAL_PARITY_NONE, SERIAL_FLOW_NONE, false },
                { 9600, 8, 1, 7, SERIAL_FLOW_NONE, false },
                { 9600, 8, 1, SERIAL_PARITY_NONE, 9, false },
        };
        struct transport_params p;
        char longpath[TRANSPORT_PATH_MAX + 1];

        (void)state;
        for (size_t i = 0; i < sizeof(udp) / sizeof(udp[0]); i++) {
                transport_params_init(&p, TRANSPORT_UDP);
                assert_int_equal(transport_params_set_udp(&p, udp[i].local, udp[i].remote), 0);
                if (udp[i].ok)
                        assert_null(transport_params_check(&p));
                else
                        assert_non_null(transport_params_check(&p));
        }
        for (size_t i = 0; i < sizeof(ser) / sizeof(ser[0]); i++) {
                transport_params_init(&p, TRANSPORT_SERIAL);
                assert_int_equal(transport_params_add_device(&p, "/dev/ttyS0"), 0);
                p.serial.baud = ser[i].baud;
                p.serial.data_bits = ser[i].data;
                p.serial.stop_bits = ser[i].stop;
                p.serial.parity = (enum serial_parity)ser[i].parity;
                p.serial.flow = (enum serial_flow)ser[i].flow;
                if (ser[i].ok)
                        assert_null(transport_params_check(&p));
                else
                        assert_non_null(transport_params_check(&p));
        }

        transport_params_init(&p, TRANSPORT_SERIAL);
        assert_non_null(transport_params_check(&p));            /* no device */
        for (int i = 0; i < TRANSPORT_DEVICES_MAX; i++)
                assert_int_equal(transport_params_add_device(&p, "/dev/ttyUSB0"), 0);
        assert_int_equal(transport_params_add_device(&p, "/dev/ttyUSB0"), -ENOSPC);
        assert_null(transport_params_check(&p));
        memset(longpath, 'a', sizeof(longpath) - 1);
        longpath[sizeof(longpath) - 1] = '\0';
        transport_params_init(&p, TRANSPORT_PTY);
        assert_int_equal(transport_params_add_device(&p, longpath), -ENAMETOOLONG);
        assert_non_null(transport_params_check(&p));            /* pty: one path needed */
        assert_int_equal(transport_params_add_device(&p, "/run/x.tty"), 0);
        assert_null(transport_params_check(&p));
        assert_int_equal(transport_params_add_device(&p, "/run/y.tty"), 0);
        assert_non_null(transport_params_check(&p));
        assert_int_equal(transport_params_set_udp(&p, longpath, NULL), -ENAMETOOLONG);
        p.kind = (enum transport_kind)42;
        assert_non_null(transport_params_check(&p));
}

/* ---------------------------------------------------------------------------------------------
 * Serial on a pty pair */

struct pty_pair {
        int master, slave;              /* the test's ends */
        char path[HARNESS_PATH_MAX];
};

static void pty_open(struct pty_pair *pp)
{
        assert_int_equal(harness_openpty(&pp->master, &pp->slave, pp->path), 0);
}

static void pty_close(struct pty_pair *pp)
{
        if (pp->master >= 0)
                close(pp->master);
        if (pp->slave >= 0)
                close(pp->slave);
        pp->master = pp->slave = -1;
}

/* A recognisable "original" state: cooked, echo, 9600 (or a given non-standard speed). */
static void set_original(int fd, uint32_t nonstandard, struct termios *ret)
{
        struct termios t;

        assert_int_equal(tcgetattr(fd, &t), 0);
        t.c_lflag |= ICANON | ECHO | ISIG;
        t.c_iflag |= ICRNL;
        t.c_oflag |= OPOST;
        t.c_cc[VMIN] = 4;
        t.c_cc[VTIME] = 7;
        cfsetispeed(&t, B9600);
        cfsetospeed(&t, B9600);
        assert_int_equal(tcsetattr(fd, TCSANOW, &t), 0);
        if (nonstandard)
                assert_int_equal(serial_speed_set(fd, nonstandard), 0);
        assert_int_equal(tcgetattr(fd, ret), 0);
}

static void assert_speed(int fd, uint32_t baud)
{
        uint32_t is, os;

        assert_int_equal(serial_speed_get(fd, &is, &os), 0);
        assert_int_equal(is, baud);
        assert_int_equal(os, baud);
}

static int excl_state(int fd)
{
        int excl = -1;

        assert_int_equal(ioctl(fd, TIOCGEXCL, &excl), 0);
        return excl;
}

static void test_serial_settings_table(void **state)
{
        static const struct {
                uint32_t baud;
                unsigned data, stop;
                enum serial_parity parity;
                enum serial_flow flow;
                speed_t code;           /* 0: non-standard */
                uint32_t orig_nonstd;   /* original speed set before open (0: 9600) */
        } table[] = {
                { 1200, 8, 1, SERIAL_PARITY_NONE, SERIAL_FLOW_NONE, B1200, 0 },
                { 9600, 7, 1, SERIAL_PARITY_EVEN, SERIAL_FLOW_NONE, B9600, 0 },
                { 115200, 8, 2, SERIAL_PARITY_ODD, SERIAL_FLOW_RTSCTS, B115200, 250000 },
                { 250000, 8, 1, SERIAL_PARITY_NONE, SERIAL_FLOW_XONXOFF, 0, 0 },
                { 31250, 8, 1, SERIAL_PARITY_NONE, SERIAL_FLOW_NONE, 0, 100000 },
                { 921600, 8, 1, SERIAL_PARITY_NONE, SERIAL_FLOW_NONE, B921600, 0 },
                { 3000000, 8, 2, SERIAL_PARITY_NONE, SERIAL_FLOW_RTSCTS, B3000000, 0 },
                { 4000000, 8, 1, SERIAL_PARITY_NONE, SERIAL_FLOW_NONE, B4000000, 0 },
        };

        (void)state;
        for (size_t i = 0; i < sizeof(table) / sizeof(table[0]); i++) {
                struct transport_params p;
                struct transport *t;
                struct pty_pair pp;
                struct termios orig, got;
                char err[TRANSPORT_ERR_MAX], buf[16];

                pty_open(&pp);
                set_original(pp.slave, table[i].orig_nonstd, &orig);

                transport_params_init(&p, TRANSPORT_SERIAL);
                assert_int_equal(transport_params_add_device(&p, pp.path), 0);
                p.serial.baud = table[i].baud;
                p.serial.data_bits = table[i].data;
                p.serial.stop_bits = table[i].stop;
                p.serial.parity = table[i].parity;
                p.serial.flow = table[i].flow;
                assert_int_equal(transport_open(&p, 0, &t, err, sizeof(err)), 0);
                assert_false(transport_is_datagram(t));
                assert_string_equal(transport_name(t), pp.path);
                assert_null(transport_pty_slave(t));

                /* Read back through the test's own fd on the same tty. */
                assert_int_equal(tcgetattr(pp.slave, &got), 0);
                assert_int_equal(got.c_lflag & (ICANON | ECHO | ISIG | IEXTEN), 0);
                assert_int_equal(got.c_oflag & OPOST, 0);
                assert_int_equal(got.c_iflag & (ICRNL | INLCR | IGNCR | ISTRIP), 0);
                assert_int_equal(got.c_cc[VMIN], 1);
                assert_int_equal(got.c_cc[VTIME], 0);
                assert_int_equal(got.c_cflag & (CLOCAL | CREAD), CLOCAL | CREAD);
                assert_int_equal(!!(got.c_cflag & CSTOPB), table[i].stop == 2);
                assert_int_equal(!!(got.c_cflag & CRTSCTS), table[i].flow == SERIAL_FLOW_RTSCTS);
                assert_int_equal(got.c_iflag & (IXON | IXOFF),
                                 table[i].flow == SERIAL_FLOW_XONXOFF ? (IXON | IXOFF) : 0);
                /* Parity asks for input checking; the pty forces CS8 and no PARENB. */
                assert_int_equal(!!(got.c_iflag & INPCK), table[i].parity != SERIAL_PARITY_NONE);
                assert_int_equal(got.c_cflag & CSIZE, CS8);
                if (table[i].code)
                        assert_int_equal(cfgetospeed(&got), table[i].code);
                assert_speed(pp.slave, table[i].baud);
                assert_int_equal(excl_state(pp.slave), 1);

                /* Empty: EAGAIN, not 0 (which would read as a hang-up). */
                assert_int_equal(transport_read(t, buf, sizeof(buf)), -EAGAIN);
                /* Both ways, bytes untouched (no CR/LF mapping, no echo), except that with
                 * XON/XOFF the tty itself takes 0x11 (XON) as flow control. */
                assert_int_equal(harness_write_all(pp.master, "ab\r\n\x11z", 6, WAIT_MS), 0);
                if (table[i].flow == SERIAL_FLOW_XONXOFF) {
                        transport_read_exact(t, buf, 5);
                        assert_memory_equal(buf, "ab\r\nz", 5);
                } else {
                        transport_read_exact(t, buf, 6);
                        assert_memory_equal(buf, "ab\r\n\x11z", 6);
                }
                assert_int_equal(transport_write(t, "[x]\n", 4), 4);
                assert_int_equal(harness_read_until(pp.master, buf, sizeof(buf), '\n', WAIT_MS), 4);
                assert_string_equal(buf, "[x]\n");

                transport_close(t);
                /* Restored: flags, control characters and speed, standard or not. */
                assert_int_equal(tcgetattr(pp.slave, &got), 0);
                assert_int_equal(got.c_lflag, orig.c_lflag);
                assert_int_equal(got.c_iflag, orig.c_iflag);
                assert_int_equal(got.c_oflag, orig.c_oflag);
                assert_int_equal(got.c_cc[VMIN], 4);
                assert_int_equal(got.c_cc[VTIME], 7);
                assert_speed(pp.slave, table[i].orig_nonstd ? table[i].orig_nonstd : 9600);
                assert_int_equal(excl_state(pp.slave), 0);
                pty_close(&pp);
        }
}

/* Opening at one non-standard speed, then a standard one, leaves no stale input speed. */
static void test_serial_speed_change_both_directions(void **state)
{
        struct transport_params p;
        struct transport *t;
        struct pty_pair pp;

        (void)state;
        pty_open(&pp);
        transport_params_init(&p, TRANSPORT_SERIAL);
        assert_int_equal(transport_params_add_device(&p, pp.path), 0);
        p.serial.baud = 250000;
        assert_int_equal(transport_open(&p, 0, &t, NULL, 0), 0);
        assert_speed(pp.slave, 250000);
        /* Without restore in between: apply a standard speed over a BOTHER one. */
        p.serial.baud = 57600;
        assert_int_equal(serial_apply(transport_fd(t), &p.serial, NULL, 0), 0);
        assert_speed(pp.slave, 57600);
        transport_close(t);
        pty_close(&pp);
}

static void test_serial_open_errors(void **state)
{
        struct fixture *f = *state;
        struct transport_params p;
        struct transport *t = NULL;
        char err[TRANSPORT_ERR_MAX], path[TRANSPORT_PATH_MAX];

        path_in(f, "missing-tty", path);
        transport_params_init(&p, TRANSPORT_SERIAL);
        assert_int_equal(transport_params_add_device(&p, path), 0);
        assert_int_equal(transport_open(&p, 0, &t, err, sizeof(err)), -ENOENT);
        assert_null(t);
        assert_non_null(strstr(err, path));
        assert_non_null(strstr(err, strerror(ENOENT)));
        assert_int_equal(transport_open(&p, 1, &t, err, sizeof(err)), -EINVAL);

        transport_params_init(&p, TRANSPORT_SERIAL);
        assert_int_equal(transport_params_add_device(&p, "/dev/null"), 0);
        assert_int_equal(transport_open(&p, 0, &t, err, sizeof(err)), -ENOTTY);
        assert_non_null(strstr(err, "not a tty"));

        p.serial.baud = 50;
        assert_int_equal(transport_open(&p, 0, &t, err, sizeof(err)), -EINVAL);
        assert_non_null(strstr(err, "baud"));
        assert_null(transport_close(NULL));
}

/* ---------------------------------------------------------------------------------------------
 * Pty kind */

static void test_pty_symlink(void **state)
{
        struct fixture *f = *state;
        struct transport_params p;
        struct transport *t;
        char link[TRANSPORT_PATH_MAX], target[TRANSPORT_PATH_MAX], buf[32];
        struct termios tio;
        struct pollfd pfd;
        struct stat st;
        ssize_t n;
        int peer;

        path_in(f, "arena.tty", link);
        transport_params_init(&p, TRANSPORT_PTY);
        assert_int_equal(transport_params_add_device(&p, link), 0);
        p.serial.baud = 115200;
        assert_int_equal(transport_open(&p, 0, &t, NULL, 0), 0);
        assert_string_equal(transport_name(t), link);
        assert_non_null(transport_pty_slave(t));
        n = readlink(link, target, sizeof(target) - 1);
        assert_true(n > 0);
        target[n] = '\0';
        assert_string_equal(target, transport_pty_slave(t));

        /* A peer opens the link: raw already, data both ways. */
        for (int round = 0; round < 2; round++) {
                peer = open(link, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
                assert_true(peer >= 0);
                assert_int_equal(tcgetattr(peer, &tio), 0);
                assert_int_equal(tio.c_lflag & (ICANON | ECHO), 0);
                assert_int_equal(harness_write_all(peer, "[:AB|P0|C78]\r\n", 14, WAIT_MS), 0);
                transport_read_exact(t, buf, 14);
                assert_memory_equal(buf, "[:AB|P0|C78]\r\n", 14);
                assert_int_equal(transport_write(t, "pong\n", 5), 5);
                assert_int_equal(harness_read_until(peer, buf, sizeof(buf), '\n', WAIT_MS), 5);
                assert_string_equal(buf, "pong\n");
                /* The peer leaves: the master sees no hang-up (the daemon holds the slave). */
                close(peer);
                pfd = (struct pollfd){ .fd = transport_fd(t), .events = POLLIN };
                assert_int_equal(poll(&pfd, 1, 0), 0);
                assert_int_equal(transport_read(t, buf, sizeof(buf)), -EAGAIN);
        }

        transport_close(t);
        assert_int_equal(lstat(link, &st), -1);
        assert_int_equal(errno, ENOENT);
}

static void test_pty_symlink_rules(void **state)
{
        struct fixture *f = *state;
        struct transport_params p;
        struct transport *t;
        char link[TRANSPORT_PATH_MAX], target[TRANSPORT_PATH_MAX], err[TRANSPORT_ERR_MAX];
        struct stat st;
        ssize_t n;
        int fd;

        path_in(f, "plain-file", link);
        fd = open(link, O_WRONLY | O_CREAT | O_CLOEXEC, 0600);
        assert_true(fd >= 0);
        assert_int_equal(write(fd, "keep", 4), 4);
        close(fd);
        transport_params_init(&p, TRANSPORT_PTY);
        assert_int_equal(transport_params_add_device(&p, link), 0);
        assert_int_equal(transport_open(&p, 0, &t, err, sizeof(err)), -EEXIST);
        assert_non_null(strstr(err, "not a symlink"));
        assert_int_equal(lstat(link, &st), 0);
        assert_true(S_ISREG(st.st_mode));
        assert_int_equal(st.st_size, 4);

        /* A stale symlink (a crashed daemon's) is replaced. */
        path_in(f, "stale.tty", link);
        assert_int_equal(symlink("/dev/pts/nonexistent", link), 0);
        transport_params_init(&p, TRANSPORT_PTY);
        assert_int_equal(transport_params_add_device(&p, link), 0);
        assert_int_equal(transport_open(&p, 0, &t, err, sizeof(err)), 0);
        n = readlink(link, target, sizeof(target) - 1);
        assert_true(n > 0);
        target[n] = '\0';
        assert_string_equal(target, transport_pty_slave(t));

        /* Someone re-pointed it meanwhile: close leaves their link alone. */
        assert_int_equal(unlink(link), 0);
        assert_int_equal(symlink("/elsewhere", link), 0);
        transport_close(t);
        n = readlink(link, target, sizeof(target) - 1);
        assert_int_equal(n, (ssize_t)strlen("/elsewhere"));

        /* A directory that does not exist: a clear error. */
        path_in(f, "no-such-dir/x.tty", link);
        transport_params_init(&p, TRANSPORT_PTY);
        assert_int_equal(transport_params_add_device(&p, link), 0);
        assert_int_equal(transport_open(&p, 0, &t, err, sizeof(err)), -ENOENT);
        assert_non_null(strstr(err, "symlink"));
}

/* ---------------------------------------------------------------------------------------------
 * UDP */

/* A port that was free a moment ago on the loopback of `family`; 0 if the family is absent. */
static unsigned free_port(int family)
{
        struct sockaddr_storage ss = { .ss_family = (sa_family_t)family };
        socklen_t len = family == AF_INET ? sizeof(struct sockaddr_in) :
                        sizeof(struct sockaddr_in6);
        unsigned port;
        int fd = socket(family, SOCK_DGRAM | SOCK_CLOEXEC, 0);

        if (fd < 0)
                return 0;
        if (family == AF_INET)
                ((struct sockaddr_in *)&ss)->sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        else
                ((struct sockaddr_in6 *)&ss)->sin6_addr = in6addr_loopback;
        if (bind(fd, (struct sockaddr *)&ss, len) < 0 ||
            getsockname(fd, (struct sockaddr *)&ss, &len) < 0) {
                close(fd);
                return 0;
        }
        port = ntohs(family == AF_INET ? ((struct sockaddr_in *)&ss)->sin_port :
                     ((struct sockaddr_in6 *)&ss)->sin6_port);
        close(fd);
        return port;
}

static void udp_pair(int family)
{
        struct transport_params pa, pb;
        struct transport *a, *b;
        char remote[TRANSPORT_ADDR_MAX], local[TRANSPORT_ADDR_MAX], buf[64];
        unsigned port = free_port(family);
        static const char *const frames[] = { "[:BA|N0|D1|C00]", "", "[:BA|N0|D2|C00]" };

        if (port == 0) {
                print_message("family %d unavailable: skipped\n", family);
                return;
        }
        snprintf(local, sizeof(local), "%s:%u", family == AF_INET ? "127.0.0.1" : "[::1]", port);
        snprintf(remote, sizeof(remote), "%s", local);
        /* b listens only; a is connected to b. */
        transport_params_init(&pb, TRANSPORT_UDP);
        assert_int_equal(transport_params_set_udp(&pb, local, NULL), 0);
        assert_int_equal(transport_open(&pb, 0, &b, NULL, 0), 0);
        assert_true(transport_is_datagram(b));
        assert_int_equal(transport_write(b, "x", 1), -EDESTADDRREQ);  /* no peer yet */
        assert_false(transport_error_fatal(b, -EDESTADDRREQ));
        transport_params_init(&pa, TRANSPORT_UDP);
        assert_int_equal(transport_params_set_udp(&pa, NULL, remote), 0);
        assert_int_equal(transport_open(&pa, 0, &a, NULL, 0), 0);

        /* Three datagrams (one empty) arrive as three reads with their boundaries. */
        for (size_t i = 0; i < 3; i++)
                assert_int_equal(transport_write(a, frames[i], strlen(frames[i])),
                                 (ssize_t)strlen(frames[i]));
        for (size_t i = 0; i < 3; i++) {
                ssize_t n;

                wait_readable(transport_fd(b));
                n = transport_read(b, buf, sizeof(buf));
                assert_int_equal(n, (ssize_t)strlen(frames[i]));
                assert_memory_equal(buf, frames[i], (size_t)n);
        }
        assert_int_equal(transport_read(b, buf, sizeof(buf)), -EAGAIN);

        /* b answers the last sender. */
        assert_int_equal(transport_write(b, "[:AB|G0|C00]", 12), 12);
        wait_readable(transport_fd(a));
        assert_int_equal(transport_read(a, buf, sizeof(buf)), 12);
        assert_memory_equal(buf, "[:AB|G0|C00]", 12);

        /* A datagram larger than the buffer: dropped whole, not cut, and not fatal. */
        assert_int_equal(transport_write(a, "0123456789", 10), 10);
        wait_readable(transport_fd(b));
        assert_int_equal(transport_read(b, buf, 4), -EMSGSIZE);
        assert_false(transport_error_fatal(b, -EMSGSIZE));
        assert_int_equal(transport_read(b, buf, sizeof(buf)), -EAGAIN);

        /* b gone: a's datagrams bounce (ICMP), which is per-datagram, not fatal. */
        transport_close(b);
        assert_int_equal(transport_write(a, "ping", 4), 4);
        {
                struct pollfd p = { .fd = transport_fd(a), .events = POLLIN };
                ssize_t n;

                assert_int_equal(poll(&p, 1, WAIT_MS), 1);
                n = transport_read(a, buf, sizeof(buf));
                assert_int_equal(n, -ECONNREFUSED);
                assert_false(transport_error_fatal(a, (int)n));
        }
        assert_true(transport_error_fatal(a, -EBADF));
        transport_close(a);
}

static void test_udp_ipv4(void **state)
{
        (void)state;
        udp_pair(AF_INET);
}

static void test_udp_ipv6(void **state)
{
        (void)state;
        udp_pair(AF_INET6);
}

static void test_udp_localhost_and_errors(void **state)
{
        struct transport_params p;
        struct transport *a, *b;
        char addr[TRANSPORT_ADDR_MAX], err[TRANSPORT_ERR_MAX], buf[8];
        unsigned port = free_port(AF_INET);

        (void)state;
        assert_true(port > 0);
        /* A numeric local address decides the family; "localhost" follows it. */
        snprintf(addr, sizeof(addr), "127.0.0.1:%u", port);
        transport_params_init(&p, TRANSPORT_UDP);
        assert_int_equal(transport_params_set_udp(&p, addr, NULL), 0);
        assert_int_equal(transport_open(&p, 0, &b, err, sizeof(err)), 0);
        snprintf(addr, sizeof(addr), "localhost:%u", port);
        transport_params_init(&p, TRANSPORT_UDP);
        assert_int_equal(transport_params_set_udp(&p, "127.0.0.1:0", addr), 0);
        assert_int_equal(transport_open(&p, 0, &a, err, sizeof(err)), 0);
        assert_int_equal(transport_write(a, "hi", 2), 2);
        wait_readable(transport_fd(b));
        assert_int_equal(transport_read(b, buf, sizeof(buf)), 2);
        assert_null(transport_end_reason(b, -ENODATA));

        /* The same port again: bind fails with a reason naming the address. */
        snprintf(addr, sizeof(addr), "127.0.0.1:%u", port);
        transport_params_init(&p, TRANSPORT_UDP);
        assert_int_equal(transport_params_set_udp(&p, addr, NULL), 0);
        {
                struct transport *c;

                assert_int_equal(transport_open(&p, 0, &c, err, sizeof(err)), -EADDRINUSE);
                assert_non_null(strstr(err, addr));
        }
        transport_close(a);
        transport_close(b);

        /* Names are not looked up (no DNS in the event loop). */
        transport_params_init(&p, TRANSPORT_UDP);
        assert_int_equal(transport_params_set_udp(&p, NULL, "example.invalid:4000"), 0);
        assert_int_equal(transport_open(&p, 0, &a, err, sizeof(err)), -EADDRNOTAVAIL);
        assert_non_null(strstr(err, "example.invalid"));
        /* Families that cannot meet. */
        transport_params_init(&p, TRANSPORT_UDP);
        assert_int_equal(transport_params_set_udp(&p, "127.0.0.1:0", "[::1]:4000"), 0);
        assert_int_equal(transport_open(&p, 0, &a, err, sizeof(err)), -EADDRNOTAVAIL);
}

/* Writes text to <dir>/name; its path in out (TRANSPORT_PATH_MAX). */
static void write_in(const struct fixture *f, const char *name, const char *text, char *out)
{
        FILE *fp;

        path_in(f, name, out);
        fp = fopen(out, "w");
        assert_non_null(fp);
        assert_int_equal(fputs(text, fp) >= 0, 1);
        assert_int_equal(fclose(fp), 0);
}

/* A recording that says "# transport: udp" before its first chunk is played as datagrams, if
 * the link was set up so (replay_datagram); one that does not, as a byte stream; a recording
 * that changed kind since the link was set up is refused rather than decoded the wrong way. */
static void test_replay_datagram(void **state)
{
        const struct fixture *f = *state;
        char udp[TRANSPORT_PATH_MAX], tty[TRANSPORT_PATH_MAX], late[TRANSPORT_PATH_MAX];
        char err[TRANSPORT_ERR_MAX], buf[16];
        struct transport_params p;
        struct transport *t;

        write_in(f, "udp.rec", REC_HEADER "\n# link: p4\n# transport: udp\n0.000001 < AB\n"
                 "0.000002 < C\n", udp);
        write_in(f, "tty.rec", REC_HEADER "\n# transport: serial\n0.000001 < AB\n", tty);
        write_in(f, "late.rec", REC_HEADER "\n0.000001 < AB\n# transport: udp\n", late);
        assert_true(replay_file_datagram(udp));
        assert_false(replay_file_datagram(tty));
        assert_false(replay_file_datagram(late));       /* after the first chunk: not metadata */
        path_in(f, "missing.rec", late);
        assert_false(replay_file_datagram(late));       /* unreadable: the open says why */

        transport_params_init(&p, TRANSPORT_REPLAY);
        assert_int_equal(transport_params_add_device(&p, udp), 0);
        p.replay_datagram = true;
        assert_true(transport_params_datagram(&p));
        assert_int_equal(transport_open(&p, 0, &t, err, sizeof(err)), 0);
        assert_true(transport_is_datagram(t));
        /* Its end is the end of a replay, not an I/O error; the same errno elsewhere is one. */
        assert_string_equal(transport_end_reason(t, -ENODATA), "end of recording");
        assert_null(transport_end_reason(t, -EIO));
        wait_readable(transport_fd(t));
        assert_int_equal(transport_read(t, buf, sizeof(buf)), 2);
        wait_readable(transport_fd(t));
        assert_int_equal(transport_read(t, buf, sizeof(buf)), 1);
        transport_close(t);

        /* Set up as a stream, but the file says udp: refused. */
        p.replay_datagram = false;
        assert_false(transport_params_datagram(&p));
        assert_int_equal(transport_open(&p, 0, &t, err, sizeof(err)), -ESTALE);
        assert_non_null(strstr(err, "transport changed"));

        transport_params_init(&p, TRANSPORT_REPLAY);
        assert_int_equal(transport_params_add_device(&p, tty), 0);
        assert_int_equal(transport_open(&p, 0, &t, err, sizeof(err)), 0);
        assert_false(transport_is_datagram(t));
        transport_close(t);

        /* A head of comments longer than REPLAY_HEAD_MAX before "# transport: udp": the set-up
         * and the load judge the same bytes, so it is a stream for both, never refused as
         * changed. */
        {
                static char text[REPLAY_HEAD_MAX + 256];
                size_t n = (size_t)snprintf(text, sizeof(text), "%s\n", REC_HEADER);

                while (n < REPLAY_HEAD_MAX)
                        n += (size_t)snprintf(text + n, sizeof(text) - n, "# %060u\n", 0u);
                snprintf(text + n, sizeof(text) - n, "# transport: udp\n0.000001 < AB\n");
                write_in(f, "long.rec", text, late);
        }
        assert_false(replay_file_datagram(late));
        transport_params_init(&p, TRANSPORT_REPLAY);
        assert_int_equal(transport_params_add_device(&p, late), 0);
        assert_int_equal(transport_open(&p, 0, &t, err, sizeof(err)), 0);
        assert_false(transport_is_datagram(t));
        transport_close(t);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_params_check),
                cmocka_unit_test(test_serial_settings_table),
                cmocka_unit_test(test_serial_speed_change_both_directions),
                cmocka_unit_test_setup_teardown(test_serial_open_errors, setup, teardown),
                cmocka_unit_test_setup_teardown(test_pty_symlink, setup, teardown),
                cmocka_unit_test_setup_teardown(test_pty_symlink_rules, setup, teardown),
                cmocka_unit_test_setup_teardown(test_replay_datagram, setup, teardown),
                cmocka_unit_test(test_udp_ipv4),
                cmocka_unit_test(test_udp_ipv6),
                cmocka_unit_test(test_udp_localhost_and_errors),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
