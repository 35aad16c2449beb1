/*
 * slctl commands on variables: list, get, set, watch (help texts in slctl.c).
 */
#ifndef SLCTL_CMD_VARS_H
#define SLCTL_CMD_VARS_H

struct slctl;

/* slctl list [--json] */
int cmd_vars_list(struct slctl *s, int argc, char **argv);

/* slctl get [--strict] NAME... */
int cmd_vars_get(struct slctl *s, int argc, char **argv);

/* slctl set NAME VALUE */
int cmd_vars_set(struct slctl *s, int argc, char **argv);

/* slctl watch [--count N] [--timeout MS] [NAME...] */
int cmd_vars_watch(struct slctl *s, int argc, char **argv);

#endif
