/*
 * termios2 speeds (see serial_speed.h). This file must not include <termios.h>.
 */
#include "daemon/serial_speed.h"

#include <asm/termbits.h>
#include <errno.h>
#include <sys/ioctl.h>

int serial_speed_set(int fd, uint32_t baud)
{
        struct termios2 t;
        int r;

        if (baud == 0)
                return -EINVAL;         /* B0 would hang up the line */
        if (ioctl(fd, TCGETS2, &t) < 0)
                return -errno;
        /* Both directions explicitly: CIBAUD left at 0 would mean "same as output" on some
         * drivers but keep a stale input speed on others. */
        t.c_cflag &= ~(tcflag_t)(CBAUD | (CBAUD << IBSHIFT));
        t.c_cflag |= BOTHER | ((tcflag_t)BOTHER << IBSHIFT);
        t.c_ispeed = baud;
        t.c_ospeed = baud;
        do {
                r = ioctl(fd, TCSETS2, &t);
        } while (r < 0 && errno == EINTR);
        return r < 0 ? -errno : 0;
}

int serial_speed_get(int fd, uint32_t *ret_ispeed, uint32_t *ret_ospeed)
{
        struct termios2 t;

        if (ioctl(fd, TCGETS2, &t) < 0)
                return -errno;
        /* The kernel fills c_ispeed/c_ospeed for Bxxx codes too, not only for BOTHER. */
        *ret_ispeed = t.c_ispeed;
        *ret_ospeed = t.c_ospeed;
        return 0;
}
