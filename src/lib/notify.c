/*
 * Waiting for changes (futex on the .in change word) and reading the event ring.
 */
#define _GNU_SOURCE     /* sched_getaffinity, CPU_COUNT */
#include <errno.h>
#include <limits.h>
#include <sched.h>
#include <string.h>

#include <sharedlink.h>

#include "lib/client.h"
#include "lib/export.h"
#include "shm/events.h"
#include "shm/futex.h"
#include "shm/seqlock.h"

static_assert(SL_EVENT_TEXT_SIZE == SHM_EVENT_TEXT_SIZE,
              "sl_event.text copies the shm event text whole");

#define NS_PER_MS               1000000ull
/* Longest single futex sleep: in between, sl_wait checks whether the table was replaced behind
 * its back (normally the replacing daemon wakes it at once; this covers a removed object). */
#define NOTIFY_SLICE_MS         1000
/* Event cursors carry 16 bits of the epoch above a 48-bit event number, so a cursor from another
 * daemon run is recognised instead of silently skipping or repeating events. */
#define NOTIFY_CURSOR_SHIFT     48
#define NOTIFY_CURSOR_MASK      ((UINT64_C(1) << NOTIFY_CURSOR_SHIFT) - 1u)
#define SL_EVENT_SIZE_V1        sizeof(struct sl_event)

static uint32_t change_word(const struct client_map *m)
{
        return atomic_load_explicit(&m->in->change, memory_order_acquire);
}

/* Extensible struct: the caller's size must cover at least the first version. */
#define SL_WAIT_OPTS_SIZE_V1    sizeof(struct sl_wait_opts)
#define NS_PER_US               1000ull
/* Spinning reads the clock once per this many polls of the change word (a pause each): often
 * enough for a budget of microseconds, rare enough that the clock is not what it spins on. */
#define NOTIFY_SPIN_CHECK       32u
/* The longest a spinner holds its CPU before sched_yield() hands it to whatever else is runnable
 * there. The threads that bring the change (the tty's flip-buffer worker, the daemon, the program
 * writing the frame) need a CPU: on a machine of few cores the scheduler may queue one of them
 * behind the spinner for a whole time slice (milliseconds), which made a spin slower than a plain
 * sleep in the futex. A yield with nothing else runnable returns at once. */
#define NOTIFY_SPIN_YIELD_NS    10000u

/*
 * The spin of SL_WAIT_SPIN: polls the change word until it differs from cursor (1) or until
 * spin_end (0). Reads only the word's cache line, which stays local until the daemon writes it.
 */
static int wait_spin(const struct client_map *m, uint32_t cursor, uint64_t spin_end)
{
        uint64_t yield_at = client_now(CLOCK_MONOTONIC) + NOTIFY_SPIN_YIELD_NS;

        for (unsigned i = 1;; i++) {
                uint64_t now;

                if (change_word(m) != cursor)
                        return 1;
                shm_seqlock_relax();
                if (i % NOTIFY_SPIN_CHECK != 0)
                        continue;
                now = client_now(CLOCK_MONOTONIC);
                if (now >= spin_end)
                        return 0;
                if (now >= yield_at) {
                        sched_yield();
                        yield_at = now + NOTIFY_SPIN_YIELD_NS;
                }
        }
}

/* Whether this thread may run on more than one CPU. On one, a spin only keeps the CPU from the
 * daemon and the tty it waits for: SL_WAIT_SPIN then blocks at once. */
static int spin_can_help(void)
{
        cpu_set_t set;

        if (sched_getaffinity(0, sizeof(set), &set) < 0)
                return 1;
        return CPU_COUNT(&set) > 1;
}

/* Spin budget in ns of opts (NULL: none); -EINVAL for a struct or a budget we do not take. */
static int64_t wait_spin_ns(const struct sl_wait_opts *opts)
{
        if (!opts)
                return 0;
        if (opts->size < SL_WAIT_OPTS_SIZE_V1 || (opts->flags & ~SL_WAIT_SPIN) ||
            opts->spin_us > SL_WAIT_SPIN_MAX_US)
                return -EINVAL;
        return (opts->flags & SL_WAIT_SPIN) ? (int64_t)opts->spin_us * (int64_t)NS_PER_US : 0;
}

SL_EXPORT int sl_wait_with(struct sl_client *c, uint32_t *cursor, int timeout_ms,
                           const struct sl_wait_opts *opts)
{
        uint64_t deadline = 0, now = 0;
        struct client_map *m;
        int64_t spin_ns = wait_spin_ns(opts);
        uint32_t seen;
        int r, changed = 0;

        if (!c || !cursor || spin_ns < 0)
                return -EINVAL;
        if (timeout_ms > 0 || spin_ns > 0) {
                now = client_now(CLOCK_MONOTONIC);
                deadline = now + (uint64_t)(timeout_ms > 0 ? timeout_ms : 0) * NS_PER_MS;
        }
        client_rdlock(c);
        m = client_map_get(c);
        client_unlock(c);

        /* Spin first, never past the deadline; timeout 0 only checks, as without a spin. The
         * affinity syscall is paid only when there is nothing to take yet. */
        if (spin_ns > 0 && timeout_ms != 0 && change_word(m) == *cursor && spin_can_help()) {
                uint64_t spin_end = now + (uint64_t)spin_ns;

                if (timeout_ms > 0 && spin_end > deadline)
                        spin_end = deadline;
                changed = wait_spin(m, *cursor, spin_end);
        }
        while (!changed) {
                int slice = NOTIFY_SLICE_MS;

                /* A daemon that shuts down or replaces this table bumps the word too. A closed
                 * table without a successor does not count as a change on every call (that would
                 * spin the caller): it is waited on slice by slice until a new one appears. */
                seen = change_word(m);
                if (seen != *cursor) {
                        changed = 1;
                        break;
                }
                if (timeout_ms == 0)
                        break;
                if (timeout_ms > 0) {
                        now = client_now(CLOCK_MONOTONIC);
                        if (now >= deadline)
                                break;
                        if ((deadline - now) / NS_PER_MS < (uint64_t)slice)
                                slice = (int)((deadline - now + NS_PER_MS - 1u) / NS_PER_MS);
                }
                r = shm_futex_wait(&m->in->change, seen, slice);
                if (r == -ETIMEDOUT && client_map_replaced(c, m)) {
                        changed = 1;
                        break;
                }
                if (r < 0 && r != -ETIMEDOUT && r != -EAGAIN && r != -EINTR) {
                        client_map_put(m);
                        return r;
                }
        }
        client_map_put(m);
        if (!changed)
                return 0;
        /* Follow a restart now, so that the cursor belongs to the table that will be waited on. */
        client_rdlock(c);
        *cursor = change_word(c->map);
        client_unlock(c);
        return 1;
}

SL_EXPORT int sl_wait(struct sl_client *c, uint32_t *cursor, int timeout_ms)
{
        return sl_wait_with(c, cursor, timeout_ms, NULL);
}

static uint64_t cursor_tag(const struct client_map *m)
{
        uint64_t tag = m->epoch >> NOTIFY_CURSOR_SHIFT;

        return tag ? tag : 1u;  /* never 0: cursor 0 means "from the start" */
}

static void event_fill(const struct sl_client *c, const struct shm_event_copy *e, uint32_t flags,
                       struct sl_event *ret)
{
        const struct client_map *m = c->map;
        uint32_t links = atomic_load_explicit(&m->in->link_count, memory_order_acquire);
        struct sl_event ev;

        memset(&ev, 0, sizeof(ev));
        ev.seq = e->number;
        ev.lost = e->lost;
        ev.mono_ns = e->mono_ns;
        ev.real_ns = e->real_ns;
        ev.type = (int)e->type;
        client_copy_field(ev.type_name, sizeof(ev.type_name), shm_layout_event_name(e->type),
                          sizeof(ev.type_name));
        ev.link = -1;
        if (e->link < links && e->link < SHM_LINKS_MAX) {
                ev.link = (int)e->link;
                client_copy_field(ev.link_name, sizeof(ev.link_name), m->links[e->link].name,
                                  sizeof(m->links[e->link].name));
        }
        ev.flags = flags | ((e->flags & SHM_EVENT_TRUNCATED) ? SL_EVENT_TRUNCATED : 0u);
        /* The public and the shm text sizes are the same by construction (asserted below). */
        memcpy(ev.text, e->text, sizeof(ev.text));
        client_struct_out(ret, &ev, sizeof(ev));
}

SL_EXPORT int sl_events_read(struct sl_client *c, uint64_t *cursor, struct sl_event *ret,
                             size_t ret_size)
{
        const struct client_map *m;
        size_t stride, got = 0;
        uint64_t number, tag;
        uint32_t flags = 0;
        int r = 0;

        if (!c || !cursor || !ret || ret_size == 0 || ret[0].size < SL_EVENT_SIZE_V1)
                return -EINVAL;
        stride = ret[0].size;   /* the caller's sizeof: elements are that far apart */
        client_rdlock(c);
        m = c->map;
        tag = cursor_tag(m);
        number = *cursor & NOTIFY_CURSOR_MASK;
        if (*cursor != 0 && (*cursor >> NOTIFY_CURSOR_SHIFT) != tag) {
                number = 0;     /* a cursor of an earlier daemon run: start over, and say so */
                flags = SL_EVENT_RESTARTED;
        }
        while (got < ret_size) {
                struct sl_event *out = (struct sl_event *)(void *)((char *)ret + got * stride);
                struct shm_event_copy e;

                if (out->size != stride) {
                        r = -EINVAL;
                        break;
                }
                r = shm_events_read(m->events, m->event_capacity, &m->in->event_head, &number, &e);
                if (r == -ESTALE) {     /* a cursor ahead of the ring: not from this run either */
                        number = 0;
                        flags = SL_EVENT_RESTARTED;
                        continue;
                }
                if (r <= 0)
                        break;
                event_fill(c, &e, flags, out);
                flags = 0;
                got++;
        }
        /* A restart seen but no event handed out to carry its flag: the cursor stays as it was,
         * so the next call sees the restart again and flags the first event it does hand out
         * (rewriting it with this run's tag would lose the flag for good). */
        if (got > 0 || !(flags & SL_EVENT_RESTARTED))
                *cursor = (tag << NOTIFY_CURSOR_SHIFT) | (number & NOTIFY_CURSOR_MASK);
        client_unlock(c);
        if (got == 0 && r < 0)
                return r;
        return (int)got;
}

SL_EXPORT int sl_events_now(struct sl_client *c, uint64_t *ret_cursor)
{
        uint64_t head;

        if (!c || !ret_cursor)
                return -EINVAL;
        client_rdlock(c);
        head = atomic_load_explicit(&c->map->in->event_head, memory_order_acquire);
        *ret_cursor = (cursor_tag(c->map) << NOTIFY_CURSOR_SHIFT) | (head & NOTIFY_CURSOR_MASK);
        client_unlock(c);
        return 0;
}
