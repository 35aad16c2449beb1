/*
 * The event ring in .in: a single producer (the daemon) and any number of readers, each with its
 * own cursor. Record n (numbered from 1) lives at index (n - 1) % capacity; its seq word is 2n+1
 * while written and 2n+2 once complete (layout.h), so a reader tells a torn record from one
 * overwritten by a later lap, and learns how many records it lost.
 */
#ifndef SHM_EVENTS_H
#define SHM_EVENTS_H

#include <stdint.h>

#include "shm/layout.h"

/* A private, consistent copy of one event record. */
struct shm_event_copy {
        uint64_t number;                /* record number, >= 1 */
        uint64_t lost;                  /* records overwritten before the reader got to them */
        uint64_t mono_ns;
        uint64_t real_ns;
        uint32_t type;
        uint32_t link;
        uint32_t flags;
        uint32_t length;
        char text[SHM_EVENT_TEXT_SIZE]; /* always NUL-terminated */
};

/*
 * Producer: appends one record (text cut to SHM_EVENT_TEXT_SIZE - 1 bytes, flagged truncated) and
 * advances *head. ring has `capacity` records (a power of two). Returns the record number.
 */
uint64_t shm_events_write(struct shm_event *ring, uint32_t capacity, _Atomic uint64_t *head,
                          uint32_t type, uint32_t link, const char *text,
                          uint64_t mono_ns, uint64_t real_ns);

/*
 * Reader: reads the record after *cursor (the number of the last record read; 0 to start with the
 * oldest one retained). Returns 1 and advances *cursor (records skipped because they were
 * overwritten are counted in ret_event->lost), 0 when there is nothing new, -EAGAIN when the producer
 * kept the record busy for every bounded attempt.
 */
int shm_events_read(const struct shm_event *ring, uint32_t capacity, const _Atomic uint64_t *head,
                    uint64_t *cursor, struct shm_event_copy *ret_event);

#endif
