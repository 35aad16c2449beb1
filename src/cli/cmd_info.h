/*
 * slctl commands on the daemon's state: events and stats (help texts in slctl.c).
 */
#ifndef SLCTL_CMD_INFO_H
#define SLCTL_CMD_INFO_H

struct slctl;

/* slctl events [--follow] [--new] [--count N] [--timeout MS] */
int cmd_info_events(struct slctl *s, int argc, char **argv);

/* slctl stats [--json] [--all] */
int cmd_info_stats(struct slctl *s, int argc, char **argv);

#endif
