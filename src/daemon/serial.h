/*
 * Serial ports: open a tty for a link, put it in raw mode at the link's framing and speed,
 * give it back as it was found.
 *
 * serial_open(): O_RDWR|O_NOCTTY|O_NONBLOCK|O_CLOEXEC (O_NONBLOCK also keeps open() from
 * waiting for carrier before CLOCAL is set), TIOCEXCL (further opens fail with EBUSY, except
 * for CAP_SYS_ADMIN: a root peer still gets in), the original termios saved, raw settings
 * applied and read back, both queues flushed. serial_close() restores the original settings
 * (speed included), clears TIOCEXCL and closes.
 *
 * Speeds 1200..4000000 bit/s: the standard ones through cfsetospeed(), any other through
 * termios2/BOTHER (serial_speed.h). Ptys accept any speed and ignore it; they also force CS8 and
 * clear PARENB (Linux pty_set_termios()), so on a pty slave 7 data bits or parity are accepted
 * without being in effect; on a real port a setting that does not stick is an error.
 */
#ifndef SHAREDLINK_DAEMON_SERIAL_H
#define SHAREDLINK_DAEMON_SERIAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <termios.h>

#define SERIAL_BAUD_MIN                 1200
#define SERIAL_BAUD_MAX                 4000000
#define SERIAL_BAUD_TOLERANCE_PERMILLE  20      /* a UART frame survives about 2 % error */
#define SERIAL_ERR_MAX                  160     /* err buffers: one line of text */

enum serial_parity {
        SERIAL_PARITY_NONE,
        SERIAL_PARITY_EVEN,
        SERIAL_PARITY_ODD,
};

enum serial_flow {
        SERIAL_FLOW_NONE,
        SERIAL_FLOW_RTSCTS,
        SERIAL_FLOW_XONXOFF,
};

struct serial_config {
        uint32_t baud;                  /* SERIAL_BAUD_MIN..SERIAL_BAUD_MAX */
        enum serial_parity parity;
        unsigned data_bits;             /* 7 or 8 */
        unsigned stop_bits;             /* 1 or 2 */
        enum serial_flow flow;
};

/* An open port; fields are read-only for users except fd, which they read and write. */
struct serial_port {
        int fd;
        bool is_pty;                    /* a pty slave: framing bits are not enforced */
        bool have_orig;
        struct termios orig;            /* as found at open, restored at close */
        uint32_t orig_ispeed, orig_ospeed;
};

/* Fills in 115200 8N1, no flow control. */
void serial_config_default(struct serial_config *cfg);

/* NULL when cfg is usable, else a short reason ("baud out of range 1200..4000000"). */
const char *serial_config_check(const struct serial_config *cfg);

/* Whether `baud` has a Bxxx constant (else it needs BOTHER). */
bool serial_baud_is_standard(uint32_t baud);

/* Opens and configures the tty at path; 0 or -errno with a reason in err (NULL if errsz is 0). */
int serial_open(const char *path, const struct serial_config *cfg, struct serial_port *ret_port,
                char *err, size_t errsz);

/* Puts an open tty in raw mode with cfg's framing, speed and flow control, then reads the
 * settings back; 0 or -errno (-EINVAL: a setting did not stick) with a reason in err. */
int serial_apply(int fd, const struct serial_config *cfg, char *err, size_t errsz);

/* Restores the original settings, drops TIOCEXCL and closes; a NULL or closed port is fine.
 * Never blocks: pending output is discarded with the settings change (TCSANOW). */
void serial_close(struct serial_port *port);

#endif
