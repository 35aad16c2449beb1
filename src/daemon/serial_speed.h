/*
 * Any serial speed, standard or not, through the Linux termios2 ioctls (TCGETS2/TCSETS2 with
 * BOTHER). Kept in its own file because <asm/termbits.h>, which defines struct termios2,
 * clashes with glibc's <termios.h> (both define struct termios and the flag macros): this
 * header includes neither, so serial.c can use <termios.h> and still call these.
 */
#ifndef SHAREDLINK_DAEMON_SERIAL_SPEED_H
#define SHAREDLINK_DAEMON_SERIAL_SPEED_H

#include <stdint.h>

/* Sets the input and output speed of tty fd to `baud` bits/s (BOTHER); 0 or -errno. The driver
 * may round to what its clock allows: read the result back with serial_speed_get(). */
int serial_speed_set(int fd, uint32_t baud);

/* Reads the input and output speeds in bits/s as the kernel holds them; 0 or -errno. */
int serial_speed_get(int fd, uint32_t *ret_ispeed, uint32_t *ret_ospeed);

#endif
