/*
 * Serial ports (see serial.h).
 */
#include "daemon/serial.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include "daemon/serial_speed.h"

/* Unix98 pty slaves (/dev/pts/N) use majors 136..143 (Documentation/admin-guide/devices.txt). */
#define SERIAL_PTY_SLAVE_MAJOR_FIRST    136
#define SERIAL_PTY_SLAVE_MAJOR_LAST     143
#define SERIAL_XON                      0x11
#define SERIAL_XOFF                     0x13
#define SERIAL_PERMILLE                 1000u

static const struct {
        uint32_t baud;
        speed_t code;
} serial_bauds[] = {
        { 1200, B1200 }, { 1800, B1800 }, { 2400, B2400 }, { 4800, B4800 },
        { 9600, B9600 }, { 19200, B19200 }, { 38400, B38400 }, { 57600, B57600 },
        { 115200, B115200 }, { 230400, B230400 }, { 460800, B460800 }, { 500000, B500000 },
        { 576000, B576000 }, { 921600, B921600 }, { 1000000, B1000000 },
        { 1152000, B1152000 }, { 1500000, B1500000 }, { 2000000, B2000000 },
        { 2500000, B2500000 }, { 3000000, B3000000 }, { 3500000, B3500000 },
        { 4000000, B4000000 },
};

void serial_config_default(struct serial_config *cfg)
{
        *cfg = (struct serial_config){
                .baud = 115200, .parity = SERIAL_PARITY_NONE, .data_bits = 8, .stop_bits = 1,
                .flow = SERIAL_FLOW_NONE,
        };
}

const char *serial_config_check(const struct serial_config *cfg)
{
        if (cfg->baud < SERIAL_BAUD_MIN || cfg->baud > SERIAL_BAUD_MAX)
                return "baud out of range 1200..4000000";
        if (cfg->parity != SERIAL_PARITY_NONE && cfg->parity != SERIAL_PARITY_EVEN &&
            cfg->parity != SERIAL_PARITY_ODD)
                return "parity must be none, even or odd";
        if (cfg->data_bits != 7 && cfg->data_bits != 8)
                return "data_bits must be 7 or 8";
        if (cfg->stop_bits != 1 && cfg->stop_bits != 2)
                return "stop_bits must be 1 or 2";
        if (cfg->flow != SERIAL_FLOW_NONE && cfg->flow != SERIAL_FLOW_RTSCTS &&
            cfg->flow != SERIAL_FLOW_XONXOFF)
                return "flow_control must be none, rtscts or xonxoff";
        return NULL;
}

static bool serial_baud_code(uint32_t baud, speed_t *ret_code)
{
        for (size_t i = 0; i < sizeof(serial_bauds) / sizeof(serial_bauds[0]); i++) {
                if (serial_bauds[i].baud == baud) {
                        *ret_code = serial_bauds[i].code;
                        return true;
                }
        }
        return false;
}

bool serial_baud_is_standard(uint32_t baud)
{
        speed_t code;

        return serial_baud_code(baud, &code);
}

static int serial_tcsetattr(int fd, const struct termios *t)
{
        int r;

        /* TCSANOW: TCSADRAIN would block on a stuck (flow-controlled) line, O_NONBLOCK or not. */
        do {
                r = tcsetattr(fd, TCSANOW, t);
        } while (r < 0 && errno == EINTR);
        return r < 0 ? -errno : 0;
}

static bool serial_fd_is_pty(int fd)
{
        struct stat st;

        if (fstat(fd, &st) < 0 || !S_ISCHR(st.st_mode))
                return false;
        return major(st.st_rdev) >= SERIAL_PTY_SLAVE_MAJOR_FIRST &&
               major(st.st_rdev) <= SERIAL_PTY_SLAVE_MAJOR_LAST;
}

/* Raw mode by hand: cfmakeraw() leaves CRTSCTS, CSTOPB, CLOCAL, CREAD, IXOFF, IXANY, VMIN and
 * VTIME alone, so everything a link depends on is set here explicitly. */
static void serial_make_raw(struct termios *t, const struct serial_config *cfg)
{
        t->c_iflag &= ~(tcflag_t)(IGNBRK | BRKINT | PARMRK | ISTRIP | INLCR | IGNCR | ICRNL |
                                  IXON | IXOFF | IXANY | IUCLC | IMAXBEL | INPCK | IGNPAR);
        t->c_oflag &= ~(tcflag_t)OPOST;
        t->c_lflag &= ~(tcflag_t)(ECHO | ECHOE | ECHOK | ECHONL | ICANON | ISIG | IEXTEN);
        /* CIBAUD cleared: the input speed follows the output speed. A CIBAUD left at BOTHER by
         * an earlier non-standard speed would otherwise keep the old input speed. */
        t->c_cflag &= ~(tcflag_t)(CSIZE | PARENB | PARODD | CMSPAR | CSTOPB | CRTSCTS | CIBAUD);
        t->c_cflag |= CLOCAL | CREAD | (cfg->data_bits == 7 ? CS7 : CS8);
        if (cfg->parity != SERIAL_PARITY_NONE) {
                /* INPCK without IGNPAR/PARMRK: a byte with a parity error reads as NUL, which no
                 * frame of our protocols contains, so the codec rejects that frame. */
                t->c_cflag |= PARENB | (cfg->parity == SERIAL_PARITY_ODD ? PARODD : 0);
                t->c_iflag |= INPCK;
        }
        if (cfg->stop_bits == 2)
                t->c_cflag |= CSTOPB;
        if (cfg->flow == SERIAL_FLOW_RTSCTS)
                t->c_cflag |= CRTSCTS;
        if (cfg->flow == SERIAL_FLOW_XONXOFF) {
                t->c_iflag |= IXON | IXOFF;
                t->c_cc[VSTART] = SERIAL_XON;
                t->c_cc[VSTOP] = SERIAL_XOFF;
        }
        /* VMIN=1, VTIME=0, never VMIN=0: with VMIN=VTIME=0 the Linux n_tty read() returns 0 when
         * no byte is there, even with O_NONBLOCK, and 0 must keep meaning "hung up". With
         * VMIN=1 an empty non-blocking read fails with EAGAIN. */
        t->c_cc[VMIN] = 1;
        t->c_cc[VTIME] = 0;
}

/* Compares what the kernel kept with what we asked for. */
static int serial_verify(int fd, const struct termios *want, uint32_t baud, char *err,
                         size_t errsz)
{
        const tcflag_t cflags = CSTOPB | CRTSCTS | CLOCAL | CREAD;
        const tcflag_t framing = CSIZE | PARENB | PARODD;
        const tcflag_t iflags = IXON | IXOFF | ICRNL | INLCR | IGNCR | ISTRIP | INPCK;
        const tcflag_t lflags = ICANON | ECHO | ISIG | IEXTEN;
        struct termios got;
        uint32_t ispeed, ospeed;
        uint64_t tolerance = (uint64_t)baud * SERIAL_BAUD_TOLERANCE_PERMILLE / SERIAL_PERMILLE;
        int r;

        if (tcgetattr(fd, &got) < 0) {
                r = -errno;
                snprintf(err, errsz, "tcgetattr: %s", strerror(-r));
                return r;
        }
        if ((got.c_cflag & cflags) != (want->c_cflag & cflags) ||
            (got.c_iflag & iflags) != (want->c_iflag & iflags) ||
            (got.c_lflag & lflags) != (want->c_lflag & lflags) ||
            (got.c_oflag & OPOST) != 0 || got.c_cc[VMIN] != want->c_cc[VMIN] ||
            got.c_cc[VTIME] != want->c_cc[VTIME]) {
                snprintf(err, errsz, "the tty did not keep raw mode or flow control settings");
                return -EINVAL;
        }
        /* Ptys force 8 bits and no parity (pty_set_termios): accepted there, on purpose. */
        if ((got.c_cflag & framing) != (want->c_cflag & framing) && !serial_fd_is_pty(fd)) {
                snprintf(err, errsz, "the device does not support this parity/data bits");
                return -EINVAL;
        }
        r = serial_speed_get(fd, &ispeed, &ospeed);
        if (r < 0) {
                snprintf(err, errsz, "TCGETS2: %s", strerror(-r));
                return r;
        }
        if ((uint64_t)ospeed + tolerance < baud || ospeed > baud + tolerance ||
            (uint64_t)ispeed + tolerance < baud || ispeed > baud + tolerance) {
                snprintf(err, errsz, "baud %u not supported by the device (got %u/%u)",
                           (unsigned)baud, (unsigned)ispeed, (unsigned)ospeed);
                return -EINVAL;
        }
        return 0;
}

int serial_apply(int fd, const struct serial_config *cfg, char *err, size_t errsz)
{
        const char *why = serial_config_check(cfg);
        struct termios t;
        speed_t code;
        bool standard;
        int r;

        if (why) {
                snprintf(err, errsz, "%s", why);
                return -EINVAL;
        }
        if (tcgetattr(fd, &t) < 0) {
                r = -errno;
                snprintf(err, errsz, "tcgetattr: %s", strerror(-r));
                return r;
        }
        serial_make_raw(&t, cfg);
        standard = serial_baud_code(cfg->baud, &code);
        if (standard) {
                cfsetispeed(&t, code);
                cfsetospeed(&t, code);
        }
        r = serial_tcsetattr(fd, &t);
        if (r < 0) {
                snprintf(err, errsz, "tcsetattr: %s", strerror(-r));
                return r;
        }
        if (!standard) {
                r = serial_speed_set(fd, cfg->baud);
                if (r < 0) {
                        snprintf(err, errsz, "TCSETS2 baud %u: %s", (unsigned)cfg->baud,
                                   strerror(-r));
                        return r;
                }
        }
        /* tcsetattr() succeeds when any one change was made: read everything back. */
        return serial_verify(fd, &t, cfg->baud, err, errsz);
}

int serial_open(const char *path, const struct serial_config *cfg, struct serial_port *ret_port,
                char *err, size_t errsz)
{
        struct serial_port port = { .fd = -1 };
        int r;

        port.fd = open(path, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
        if (port.fd < 0) {
                r = -errno;
                snprintf(err, errsz, "open %s: %s", path, strerror(-r));
                return r;
        }
        if (!isatty(port.fd)) {
                snprintf(err, errsz, "%s: not a tty", path);
                close(port.fd);
                return -ENOTTY;
        }
        port.is_pty = serial_fd_is_pty(port.fd);
        if (tcgetattr(port.fd, &port.orig) < 0 ||
            serial_speed_get(port.fd, &port.orig_ispeed, &port.orig_ospeed) < 0) {
                r = -errno;
                snprintf(err, errsz, "%s: reading settings: %s", path, strerror(-r));
                close(port.fd);
                return r;
        }
        port.have_orig = true;
        if (ioctl(port.fd, TIOCEXCL) < 0) {
                r = -errno;
                snprintf(err, errsz, "%s: TIOCEXCL: %s", path, strerror(-r));
                close(port.fd);
                return r;
        }
        r = serial_apply(port.fd, cfg, err, errsz);
        if (r < 0) {
                /* Prefix the device: serial_apply() does not know it. */
                if (err && errsz > 0) {
                        char tmp[SERIAL_ERR_MAX];

                        snprintf(tmp, sizeof(tmp), "%s", err);
                        snprintf(err, errsz, "%s: %s", path, tmp);
                }
                serial_close(&port);
                return r;
        }
        /* Bytes that arrived before we owned the port belong to nobody. */
        tcflush(port.fd, TCIOFLUSH);
        *ret_port = port;
        return 0;
}

void serial_close(struct serial_port *port)
{
        uint32_t ispeed, ospeed;

        if (!port || port->fd < 0)
                return;
        /* On a hung-up tty these fail with EIO; nothing is left to restore then. */
        if (port->have_orig && serial_tcsetattr(port->fd, &port->orig) == 0) {
                /* tcsetattr() cannot carry a non-standard speed: put it back with TCSETS2. */
                if (serial_speed_get(port->fd, &ispeed, &ospeed) == 0 &&
                    (ispeed != port->orig_ispeed || ospeed != port->orig_ospeed))
                        serial_speed_set(port->fd, port->orig_ospeed);
        }
        ioctl(port->fd, TIOCNXCL);
        close(port->fd);
        port->fd = -1;
        port->have_orig = false;
}
