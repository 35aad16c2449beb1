/*
 * Event ring (see events.h). The seqlock fences are those of seqlock.h; the record's own seq word
 * doubles as its number.
 */
#include "shm/events.h"

#include <errno.h>
#include <string.h>

#include "shm/seqlock.h"

#define EVENTS_READ_LAPS        8u      /* times a reader may be lapped during one read call */

uint64_t shm_events_write(struct shm_event *ring, uint32_t capacity, _Atomic uint64_t *head,
                          uint32_t type, uint32_t link, const char *text,
                          uint64_t mono_ns, uint64_t real_ns)
{
        uint64_t n = atomic_load_explicit(head, memory_order_relaxed) + 1u;
        struct shm_event *e = &ring[(n - 1u) & (capacity - 1u)];
        uint64_t words[SHM_EVENT_TEXT_WORDS];
        size_t len = text ? strlen(text) : 0;
        uint32_t flags = 0;

        if (len > SHM_EVENT_TEXT_SIZE - 1u) {
                len = SHM_EVENT_TEXT_SIZE - 1u;
                flags |= SHM_EVENT_TRUNCATED;
        }
        memset(words, 0, sizeof(words));
        if (len)
                memcpy(words, text, len);

        /* Same ordering as shm_seqlock_write_begin/end, with the value 2n+1 / 2n+2 chosen here. */
        atomic_store_explicit(&e->seq, 2u * n + 1u, memory_order_relaxed);
        shm_seqlock_fence_release();
        atomic_store_explicit(&e->mono_ns, mono_ns, SHM_SEQLOCK_PAYLOAD_STORE);
        atomic_store_explicit(&e->real_ns, real_ns, SHM_SEQLOCK_PAYLOAD_STORE);
        atomic_store_explicit(&e->type, type, SHM_SEQLOCK_PAYLOAD_STORE);
        atomic_store_explicit(&e->link, link, SHM_SEQLOCK_PAYLOAD_STORE);
        atomic_store_explicit(&e->length, (uint32_t)len, SHM_SEQLOCK_PAYLOAD_STORE);
        atomic_store_explicit(&e->flags, flags, SHM_SEQLOCK_PAYLOAD_STORE);
        for (unsigned i = 0; i < SHM_EVENT_TEXT_WORDS; i++)
                atomic_store_explicit(&e->text[i], words[i], SHM_SEQLOCK_PAYLOAD_STORE);
        atomic_store_explicit(&e->seq, 2u * n + 2u, memory_order_release);
        /* Head after the record: a reader that sees head >= n finds record n complete (or newer). */
        atomic_store_explicit(head, n, memory_order_release);
        return n;
}

static void events_copy(const struct shm_event *e, struct shm_event_copy *c)
{
        uint64_t words[SHM_EVENT_TEXT_WORDS];

        c->mono_ns = atomic_load_explicit(&e->mono_ns, SHM_SEQLOCK_PAYLOAD_LOAD);
        c->real_ns = atomic_load_explicit(&e->real_ns, SHM_SEQLOCK_PAYLOAD_LOAD);
        c->type = atomic_load_explicit(&e->type, SHM_SEQLOCK_PAYLOAD_LOAD);
        c->link = atomic_load_explicit(&e->link, SHM_SEQLOCK_PAYLOAD_LOAD);
        c->length = atomic_load_explicit(&e->length, SHM_SEQLOCK_PAYLOAD_LOAD);
        c->flags = atomic_load_explicit(&e->flags, SHM_SEQLOCK_PAYLOAD_LOAD);
        for (unsigned i = 0; i < SHM_EVENT_TEXT_WORDS; i++)
                words[i] = atomic_load_explicit(&e->text[i], SHM_SEQLOCK_PAYLOAD_LOAD);
        memcpy(c->text, words, sizeof(words));
}

int shm_events_read(const struct shm_event *ring, uint32_t capacity, const _Atomic uint64_t *head,
                    uint64_t *cursor, struct shm_event_copy *ret_event)
{
        uint64_t next = *cursor + 1u;
        uint64_t lost = 0;

        for (unsigned lap = 0; lap < EVENTS_READ_LAPS; lap++) {
                uint64_t h = atomic_load_explicit(head, memory_order_acquire);
                struct shm_event_copy c;
                const struct shm_event *e;
                int busy = 1;

                if (next > h) {
                        if (*cursor > h)        /* a cursor from the future: not our ring */
                                return -ESTALE;
                        return 0;
                }
                if (h - next >= capacity) {     /* overrun: the oldest retained is h - cap + 1 */
                        lost += h - capacity + 1u - next;
                        next = h - capacity + 1u;
                }
                e = &ring[(next - 1u) & (capacity - 1u)];
                for (unsigned attempt = 0; attempt < SHM_SEQLOCK_TRIES; attempt++) {
                        uint64_t start = shm_seqlock_read_begin(&e->seq);

                        if (start > 2u * next + 2u) {
                                /* Overwritten by record `newer`: everything before
                                 * newer - capacity + 1 is gone too. */
                                uint64_t newer = (start - 1u) / 2u;

                                lost += newer - capacity + 1u - next;
                                next = newer - capacity + 1u;
                                busy = 0;
                                break;
                        }
                        if (start != 2u * next + 2u) {  /* being written (cannot be older) */
                                shm_seqlock_relax();
                                continue;
                        }
                        events_copy(e, &c);
                        if (shm_seqlock_read_retry(&e->seq, start))
                                continue;
                        if (c.length > SHM_EVENT_TEXT_SIZE - 1u)
                                c.length = SHM_EVENT_TEXT_SIZE - 1u;
                        c.text[c.length] = '\0';
                        c.number = next;
                        c.lost = lost;
                        *ret_event = c;
                        *cursor = next;
                        return 1;
                }
                if (busy)
                        return -EAGAIN;
                /* Lapped while reading: go round again from the oldest record retained. */
        }
        return -EAGAIN;
}
