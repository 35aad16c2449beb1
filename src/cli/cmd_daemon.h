/*
 * slctl commands that go through the daemon's control socket: query, ping, command and circe (help texts in
 * slctl.c).
 */
#ifndef SLCTL_CMD_DAEMON_H
#define SLCTL_CMD_DAEMON_H

struct slctl;

/* slctl query [--timeout MS] [--wait MS] LINK PEER NAME */
int cmd_daemon_query(struct slctl *s, int argc, char **argv);

/* slctl ping [--timeout MS] [--wait MS] LINK PEER */
int cmd_daemon_ping(struct slctl *s, int argc, char **argv);

/* slctl command [--wait MS] LINK MODULE [TEXT...] */
int cmd_daemon_command(struct slctl *s, int argc, char **argv);

/* slctl circe LINK OPERATION ... */
int cmd_daemon_circe(struct slctl *s, int argc, char **argv);

#endif
