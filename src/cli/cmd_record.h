/*
 * slctl record: the traffic of a link into a recording file (help text in slctl.c, format in
 * docs/recording.md).
 */
#ifndef SLCTL_CMD_RECORD_H
#define SLCTL_CMD_RECORD_H

struct slctl;

/* slctl record [--duration S] [--count N] LINK FILE */
int cmd_record(struct slctl *s, int argc, char **argv);

#endif
