/*
 * Link state and counters, and the daemon behind the tables.
 */
#include <errno.h>
#include <signal.h>
#include <stddef.h>
#include <string.h>

#include <sharedlink.h>

#include "lib/client.h"
#include "lib/export.h"
#include "shm/seqlock.h"

/* Extensible structs: the caller's size must cover at least the first version (sl_link_info's
 * ended with counters[]; state_text came after). */
#define SL_LINK_INFO_SIZE_V1    offsetof(struct sl_link_info, state_text)
#define SL_DAEMON_INFO_SIZE_V1  sizeof(struct sl_daemon_info)

_Static_assert(SL_COUNTERS_MAX == SHM_COUNTERS_MAX, "counter slots");
_Static_assert(SL_STATE_NAME_SIZE == SHM_STATE_NAME_SIZE && SL_PROTOCOL_SIZE == SHM_PROTOCOL_SIZE &&
               SL_STATE_TEXT_SIZE == SHM_LINK_TEXT_SIZE, "link sizes");

/* Named counters only: the spare slots have no name and are not reported. */
static unsigned counters_fill(struct sl_counter *out, const _Atomic uint64_t *words)
{
        unsigned n = 0;

        for (unsigned i = 0; i < SHM_COUNTER_COUNT; i++) {
                out[n].name = shm_layout_counter_name(i);
                out[n].value = atomic_load_explicit(&words[i], memory_order_relaxed);
                n++;
        }
        return n;
}

_Static_assert(SL_COUNTER_SHAREDLINK == SHM_SCOPE_SHAREDLINK && SL_COUNTER_CIRCE == SHM_SCOPE_CIRCE &&
               SL_COUNTER_DAEMON == SHM_SCOPE_DAEMON, "counter scopes");

SL_EXPORT unsigned sl_counter_scope(const char *name)
{
        return shm_layout_counter_scope(name);
}

SL_EXPORT const char *sl_counter_name(unsigned i)
{
        return shm_layout_counter_name(i);
}

SL_EXPORT int sl_link_count(struct sl_client *c)
{
        uint32_t n;

        if (!c)
                return -EINVAL;
        client_rdlock(c);
        n = atomic_load_explicit(&c->map->in->link_count, memory_order_acquire);
        client_unlock(c);
        return (int)(n < SHM_LINKS_MAX ? n : SHM_LINKS_MAX);
}

/*
 * Bounded seqlock copy of a link's state (see seqlock.h), with its whole text when the table has
 * link texts (text NULL: layout before 1.4, the 31-byte state name is all there is).
 */
static int link_state_read(const struct shm_link *l, const struct shm_link_text *text,
                           struct sl_link_info *info, uint64_t now)
{
        for (unsigned attempt = 0; attempt < SHM_SEQLOCK_TRIES; attempt++) {
                uint64_t words[SHM_STATE_NAME_WORDS], start = shm_seqlock_read_begin(&l->seq);
                uint64_t long_words[SHM_LINK_TEXT_WORDS];
                uint64_t state_ns;
                uint32_t state;

                if (shm_seqlock_odd(start)) {
                        shm_seqlock_relax();
                        continue;
                }
                state = atomic_load_explicit(&l->state, SHM_SEQLOCK_PAYLOAD_LOAD);
                state_ns = atomic_load_explicit(&l->state_ns, SHM_SEQLOCK_PAYLOAD_LOAD);
                for (unsigned i = 0; i < SHM_STATE_NAME_WORDS; i++)
                        words[i] = atomic_load_explicit(&l->state_name[i], SHM_SEQLOCK_PAYLOAD_LOAD);
                for (unsigned i = 0; text && i < SHM_LINK_TEXT_WORDS; i++)
                        long_words[i] = atomic_load_explicit(&text->text[i],
                                                             SHM_SEQLOCK_PAYLOAD_LOAD);
                if (shm_seqlock_read_retry(&l->seq, start))
                        continue;
                info->state = (int)state;
                info->state_age_ns = state_ns && now > state_ns ? now - state_ns : 0;
                client_copy_field(info->state_name, sizeof(info->state_name),
                                  (const char *)words, sizeof(words));
                if (text)
                        client_copy_field(info->state_text, sizeof(info->state_text),
                                          (const char *)long_words, sizeof(long_words));
                else
                        client_copy_field(info->state_text, sizeof(info->state_text),
                                          (const char *)words, sizeof(words));
                return 0;
        }
        return -EAGAIN;
}

SL_EXPORT int sl_link_info(struct sl_client *c, int link, struct sl_link_info *ret)
{
        const struct shm_link *l;
        struct sl_link_info info;
        uint32_t n;
        int r;

        if (!c || !ret || ret->size < SL_LINK_INFO_SIZE_V1)
                return -EINVAL;
        memset(&info, 0, sizeof(info));
        client_rdlock(c);
        n = atomic_load_explicit(&c->map->in->link_count, memory_order_acquire);
        if (link < 0 || (uint32_t)link >= n || (uint32_t)link >= SHM_LINKS_MAX) {
                client_unlock(c);
                return -ENOENT;
        }
        l = &c->map->links[link];
        client_copy_field(info.name, sizeof(info.name), l->name, sizeof(l->name));
        client_copy_field(info.protocol, sizeof(info.protocol), l->protocol, sizeof(l->protocol));
        r = link_state_read(l, c->map->link_texts ? &c->map->link_texts[link] : NULL, &info,
                            client_now(CLOCK_MONOTONIC));
        info.counter_count = counters_fill(info.counters, l->counters);
        client_unlock(c);
        if (r < 0)
                return r;
        client_struct_out(ret, &info, sizeof(info));
        return 0;
}

/*
 * The hot path (sl_read) judges liveness by the heartbeat alone; here a daemon without heartbeat
 * is also checked by pid (EPERM: it exists, owned by someone else).
 */
static int daemon_alive(const struct sl_client *c, uint64_t *ret_age)
{
        const struct shm_in_header *h = c->map->in;
        int alive = client_alive(c, client_now(CLOCK_MONOTONIC), ret_age);

        if (alive && h->heartbeat_interval_ms == 0 && h->daemon_pid > 0 &&
            kill(h->daemon_pid, 0) < 0 && errno == ESRCH)
                alive = 0;
        return alive;
}

SL_EXPORT int sl_daemon_info(struct sl_client *c, struct sl_daemon_info *ret)
{
        const struct shm_in_header *h;
        struct sl_daemon_info info;

        if (!c || !ret || ret->size < SL_DAEMON_INFO_SIZE_V1)
                return -EINVAL;
        memset(&info, 0, sizeof(info));
        client_rdlock(c);
        h = c->map->in;
        info.pid = h->daemon_pid;
        info.epoch = h->epoch;
        info.heartbeat_interval_ms = h->heartbeat_interval_ms;
        info.started_real_ns = h->created_real_ns;
        info.alive = daemon_alive(c, &info.heartbeat_age_ns);
        info.counter_count = counters_fill(info.counters, h->counters);
        client_unlock(c);
        client_struct_out(ret, &info, sizeof(info));
        return 0;
}

SL_EXPORT int sl_daemon_alive(struct sl_client *c)
{
        int alive;

        if (!c)
                return -EINVAL;
        client_rdlock(c);
        alive = daemon_alive(c, NULL);
        client_unlock(c);
        return alive;
}
