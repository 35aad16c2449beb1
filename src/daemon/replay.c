/*
 * Replay transport (see replay.h): a recording loaded whole, played from a timerfd.
 */
#include "daemon/replay.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/timerfd.h>
#include <time.h>
#include <unistd.h>

#include "svc/log.h"
#include "proto/recording.h"

#define REPLAY_NS_PER_US        1000ull
#define REPLAY_NS_PER_S         1000000000ull
#define REPLAY_US_PER_S         1e6
#define REPLAY_SPEED_TEXT       24      /* "%g" of a speed, or "max" */
#define REPLAY_CHUNKS_MIN       64      /* first allocation of the chunk table */

/* One "<" chunk: its time and where its bytes are in the blob. */
struct replay_chunk {
        uint64_t t_us;
        uint32_t off, len;
};

struct replay {
        char path[REC_WHY_MAX + 256];
        int fd;                         /* timerfd, CLOCK_MONOTONIC */
        double speed;                   /* 0: max */
        bool loop;

        struct replay_chunk *chunks;    /* the "<" chunks, in order */
        size_t n_chunks, cap_chunks;
        uint8_t *blob;                  /* their bytes */
        size_t blob_len;
        uint64_t end_t_us;              /* the time of the last chunk, either direction */
        uint64_t ref_out_bytes;         /* what the recording says the daemon sent */
        uint64_t ref_out_chunks;
        uint64_t dropped;               /* chunks the recorder could not keep */
        bool datagram;                  /* recorded on udp: each "<" chunk was a datagram */

        uint64_t start_ns;              /* when this pass began */
        size_t next;                    /* index of the next chunk to hand out */
        uint64_t in_bytes;              /* handed out this pass */
        uint64_t engine_bytes;          /* written by the engine this pass */
        unsigned passes;
};

static uint64_t replay_now_ns(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (uint64_t)ts.tv_sec * REPLAY_NS_PER_S + (uint64_t)ts.tv_nsec;
}

/* ---------------------------------------------------------------------------------------------
 * Loading */

/* Reads the whole file into a new buffer (NUL after it); 0 or -errno with the reason. */
static int replay_read_file(const char *path, char **ret_text, size_t *ret_len, char *err,
                            size_t errsz)
{
        struct stat st;
        size_t len = 0;
        char *text;
        int fd, r;

        fd = open(path, O_RDONLY | O_CLOEXEC | O_NOCTTY);
        if (fd < 0) {
                r = -errno;
                snprintf(err, errsz, "%s: %s", path, strerror(-r));
                return r;
        }
        if (fstat(fd, &st) < 0 || !S_ISREG(st.st_mode)) {
                r = S_ISREG(st.st_mode) ? -errno : -EINVAL;
                snprintf(err, errsz, "%s: %s", path,
                         r == -EINVAL ? "not a regular file" : strerror(-r));
                close(fd);
                return r;
        }
        if ((uint64_t)st.st_size > REPLAY_FILE_MAX) {
                snprintf(err, errsz, "%s: larger than %u MiB, the most a replay reads", path,
                         REPLAY_FILE_MAX >> 20);
                close(fd);
                return -EFBIG;
        }
        text = malloc((size_t)st.st_size + 1);
        if (!text) {
                snprintf(err, errsz, "%s: out of memory", path);
                close(fd);
                return -ENOMEM;
        }
        /* The size may change under us: read what is there, up to the bound. */
        while (len < (size_t)st.st_size) {
                ssize_t n = read(fd, text + len, (size_t)st.st_size - len);

                if (n < 0 && errno == EINTR)
                        continue;
                if (n < 0) {
                        r = -errno;
                        snprintf(err, errsz, "%s: %s", path, strerror(-r));
                        free(text);
                        close(fd);
                        return r;
                }
                if (n == 0)
                        break;
                len += (size_t)n;
        }
        close(fd);
        text[len] = '\0';
        *ret_text = text;
        *ret_len = len;
        return 0;
}

/* rec_parse_text() callback: keeps "<" chunks, counts ">" ones. */
static int replay_take(void *arg, const struct rec_reader *r)
{
        struct replay *rp = arg;
        struct replay_chunk *c;

        rp->end_t_us = r->last_t_us;
        if (r->dir == REC_DIR_OUT) {
                rp->ref_out_bytes += r->len;
                rp->ref_out_chunks++;
                return 0;
        }
        if (!rp->blob)
                return 0;               /* checking only */
        if (rp->n_chunks == rp->cap_chunks) {
                size_t cap = rp->cap_chunks ? rp->cap_chunks * 2 : REPLAY_CHUNKS_MIN;
                struct replay_chunk *p = realloc(rp->chunks, cap * sizeof(*p));

                if (!p)
                        return -ENOMEM;
                rp->chunks = p;
                rp->cap_chunks = cap;
        }
        c = &rp->chunks[rp->n_chunks++];
        c->t_us = r->last_t_us;
        /* The blob has the file's size: the bytes of a chunk never take more than its lines. */
        c->off = (uint32_t)rp->blob_len;
        c->len = (uint32_t)r->len;
        memcpy(rp->blob + rp->blob_len, r->chunk, r->len);
        rp->blob_len += r->len;
        return 0;
}

/* Whether the metadata of a recording's head (its first REPLAY_HEAD_MAX bytes, whole lines up
 * to the first chunk) says udp. The one rule for the link's set-up (replay_file_datagram) and
 * the load (replay_load), so the two never disagree about a file that did not change. */
static bool head_datagram(const char *head, size_t len)
{
        struct rec_reader *reader = malloc(sizeof(*reader));
        bool datagram;
        size_t pos = 0;

        if (!reader)
                return false;
        if (len > REPLAY_HEAD_MAX)
                len = REPLAY_HEAD_MAX;
        rec_reader_init(reader);
        while (pos < len && !reader->chunk_seen) {
                const char *nl = memchr(head + pos, '\n', len - pos);

                if (!nl || rec_reader_line(reader, head + pos, (size_t)(nl - (head + pos))) < 0)
                        break;
                pos = (size_t)(nl - head) + 1;
        }
        datagram = rec_reader_datagram(reader);
        free(reader);
        return datagram;
}

/* Parses the file into rp (rp->blob NULL: only checks). 0 or -errno with the reason in err. */
static int replay_load(struct replay *rp, const char *path, bool keep, char *err, size_t errsz)
{
        struct rec_reader *reader = malloc(sizeof(*reader));
        char *text = NULL;
        size_t len = 0;
        int r;

        if (!reader) {
                snprintf(err, errsz, "%s: out of memory", path);
                return -ENOMEM;
        }
        r = replay_read_file(path, &text, &len, err, errsz);
        if (r < 0)
                goto out;
        if (keep && !(rp->blob = malloc(len ? len : 1))) {
                snprintf(err, errsz, "%s: out of memory", path);
                r = -ENOMEM;
                goto out;
        }
        rec_reader_init(reader);
        r = rec_parse_text(reader, text, len, replay_take, rp);
        if (r == -ENOMEM) {
                snprintf(err, errsz, "%s: out of memory", path);
        } else if (r < 0) {
                snprintf(err, errsz, "%s:%u: %s", path, reader->line_no, reader->why);
                r = -EBADMSG;
        } else {
                rp->dropped = reader->dropped;
                rp->datagram = head_datagram(text, len);
        }
out:
        free(text);
        free(reader);
        return r;
}

bool replay_file_datagram(const char *path)
{
        char *head = malloc(REPLAY_HEAD_MAX);
        bool datagram = false;
        size_t len = 0;
        int fd = open(path, O_RDONLY | O_CLOEXEC | O_NOCTTY | O_NONBLOCK);

        if (fd < 0 || !head)
                goto out;
        while (len < REPLAY_HEAD_MAX) {
                ssize_t n = read(fd, head + len, REPLAY_HEAD_MAX - len);

                if (n < 0 && errno == EINTR)
                        continue;
                if (n <= 0)
                        break;
                len += (size_t)n;
        }
        datagram = head_datagram(head, len);
out:
        if (fd >= 0)
                close(fd);
        free(head);
        return datagram;
}

int replay_check_file(const char *path, char *err, size_t errsz)
{
        struct replay rp;

        memset(&rp, 0, sizeof(rp));
        return replay_load(&rp, path, false, err, errsz);
}

/* ---------------------------------------------------------------------------------------------
 * Playing */

/* When chunk i is due in this pass (ns, monotonic). */
static uint64_t replay_due_ns(const struct replay *rp, uint64_t t_us)
{
        if (rp->speed <= 0)
                return rp->start_ns;
        return rp->start_ns + (uint64_t)((double)t_us * REPLAY_NS_PER_US / rp->speed);
}

/* Arms the timerfd at an absolute time (one already past makes it readable at once). */
static void replay_arm(struct replay *rp, uint64_t at_ns)
{
        struct itimerspec its = { { 0, 0 }, { 0, 0 } };

        if (at_ns == 0)
                at_ns = 1;              /* 0 would disarm it */
        its.it_value.tv_sec = (time_t)(at_ns / REPLAY_NS_PER_S);
        its.it_value.tv_nsec = (long)(at_ns % REPLAY_NS_PER_S);
        /* Fails only for a bad fd or value: neither can happen here. */
        (void)timerfd_settime(rp->fd, TFD_TIMER_ABSTIME, &its, NULL);
}

static void replay_begin(struct replay *rp)
{
        rp->start_ns = replay_now_ns();
        rp->next = 0;
        rp->in_bytes = 0;
        rp->engine_bytes = 0;
        rp->passes++;
        replay_arm(rp, rp->start_ns);
}

int replay_open(const char *path, double speed, bool loop, struct replay **ret_replay, char *err,
                size_t errsz)
{
        struct replay *rp = calloc(1, sizeof(*rp));
        char speed_text[REPLAY_SPEED_TEXT];
        int r;

        if (!rp) {
                snprintf(err, errsz, "out of memory");
                return -ENOMEM;
        }
        snprintf(rp->path, sizeof(rp->path), "%s", path);
        rp->speed = speed;
        rp->loop = loop;
        rp->fd = -1;
        r = replay_load(rp, path, true, err, errsz);
        if (r < 0)
                goto fail;
        rp->fd = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
        if (rp->fd < 0) {
                r = -errno;
                snprintf(err, errsz, "timerfd: %s", strerror(-r));
                goto fail;
        }
        replay_begin(rp);
        if (speed > 0)
                snprintf(speed_text, sizeof(speed_text), "%g", speed);
        else
                snprintf(speed_text, sizeof(speed_text), "max");
        log_info("replay %s: %zu chunks in, %" PRIu64 " out, %.3f s, speed %s%s%s", path,
                 rp->n_chunks, rp->ref_out_chunks, (double)rp->end_t_us / REPLAY_US_PER_S,
                 speed_text, rp->datagram ? ", as datagrams" : "", loop ? ", looping" : "");
        if (rp->dropped)
                log_warnx("replay %s: the recorder dropped %" PRIu64 " chunks: the recording "
                          "has gaps", path, rp->dropped);
        *ret_replay = rp;
        return 0;
fail:
        replay_close(rp);
        return r;
}

struct replay *replay_close(struct replay *rp)
{
        if (!rp)
                return NULL;
        if (rp->fd >= 0)
                close(rp->fd);
        free(rp->chunks);
        free(rp->blob);
        free(rp);
        return NULL;
}

bool replay_datagram(const struct replay *rp)
{
        return rp->datagram;
}

int replay_fd(const struct replay *rp)
{
        return rp->fd;
}

static void replay_summary(const struct replay *rp)
{
        log_notice("replay %s: replay done: %zu chunks in (%" PRIu64 " bytes), engine sent %"
                   PRIu64 " bytes, recording had %" PRIu64 "%s", rp->path, rp->n_chunks,
                   rp->in_bytes, rp->engine_bytes, rp->ref_out_bytes,
                   rp->loop ? "; starting over" : "");
}

ssize_t replay_read(struct replay *rp, void *buf, size_t size)
{
        uint64_t expirations, now;
        const struct replay_chunk *c;

        /* Clears the readiness; whether the time has come is decided by the clock below. */
        if (read(rp->fd, &expirations, sizeof(expirations)) < 0 && errno != EAGAIN)
                return -errno;
        now = replay_now_ns();
        if (rp->next == rp->n_chunks) {
                uint64_t end = replay_due_ns(rp, rp->end_t_us);

                if (rp->passes == 0)
                        return -ENODATA;        /* done before */
                if (now < end) {
                        replay_arm(rp, end);
                        return -EAGAIN;
                }
                replay_summary(rp);
                if (rp->loop) {
                        replay_begin(rp);
                        return -EAGAIN;
                }
                rp->passes = 0;
                return -ENODATA;
        }
        c = &rp->chunks[rp->next];
        if (now < replay_due_ns(rp, c->t_us)) {
                replay_arm(rp, replay_due_ns(rp, c->t_us));
                return -EAGAIN;
        }
        if (c->len > size)
                return -EMSGSIZE;       /* the channel's buffer holds REC_CHUNK_MAX */
        memcpy(buf, rp->blob + c->off, c->len);
        rp->next++;
        rp->in_bytes += c->len;
        replay_arm(rp, rp->next < rp->n_chunks ? replay_due_ns(rp, rp->chunks[rp->next].t_us)
                                               : replay_due_ns(rp, rp->end_t_us));
        return (ssize_t)c->len;
}

ssize_t replay_write(struct replay *rp, size_t len)
{
        rp->engine_bytes += len;
        return (ssize_t)len;
}
