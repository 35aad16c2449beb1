/*
 * Outbound routing: a client's write to the .out table wakes the loop (the table's wake thread
 * signals an eventfd), a scan hands each changed slot to the engine of the variable's link
 * (link_ops.outbound), and the path is timed in stages for `stats`.
 */
#ifndef SHAREDLINK_DAEMON_DAEMON_OUT_H
#define SHAREDLINK_DAEMON_DAEMON_OUT_H

struct daemon;

/* The stages of daemon.out_stages, as `stats` names them. */
#define DAEMON_OUT_STAGES       3
extern const char *const daemon_out_stage_names[DAEMON_OUT_STAGES];

/* Empties the stage figures and the rate limit; not on the loop yet. */
void daemon_out_init(struct daemon *d);

/* Puts the table's wake fd on the loop and scans once. 0 or -errno (logged). */
int daemon_out_start(struct daemon *d);

/*
 * Scans every slot of the .out table once and hands the changes to the links (a wake-up scans
 * only the slots marked touched: layout 1.6). The scan also checks the object (recreated when
 * truncated or scribbled), repairs slots of dead writers and finds writes whose mark was lost.
 */
void daemon_out_scan(struct daemon *d);

/* Takes the wake fd off the loop (the table owns and closes it). */
void daemon_out_stop(struct daemon *d);

#endif
