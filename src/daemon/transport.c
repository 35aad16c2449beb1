/*
 * Transports: serial, pty, udp (see transport.h).
 */
#define _GNU_SOURCE     /* posix_openpt, ptsname_r */
#include "daemon/transport.h"

#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include "daemon/replay.h"

#define TRANSPORT_PORT_MAX      65535
#define TRANSPORT_PORT_LEN      8       /* "65535" and NUL, with room */
#define TRANSPORT_PTS_MAX       64      /* "/dev/pts/NNN" */
#define TRANSPORT_NAME_MAX      (TRANSPORT_PATH_MAX + 2 * TRANSPORT_ADDR_MAX)
#define TRANSPORT_TMP_SUFFIX    24      /* ".<pid>.tmp" */

struct transport {
        enum transport_kind kind;
        int fd;
        char name[TRANSPORT_NAME_MAX];

        struct serial_port serial;              /* serial */

        int pty_slave_fd;                       /* pty: held open, see transport.h */
        char pty_slave[TRANSPORT_PTS_MAX];
        char pty_link[TRANSPORT_PATH_MAX];
        bool pty_linked;

        bool udp_connected;                     /* udp: remote given, socket connected */
        bool udp_have_peer;                     /* udp, unconnected: last sender known */
        struct sockaddr_storage udp_peer;
        socklen_t udp_peer_len;

        struct replay *replay;                  /* replay */
        bool datagram;                          /* transport_params_datagram() */
};

/* ---------------------------------------------------------------------------------------------
 * Parameters */

void transport_params_init(struct transport_params *params, enum transport_kind kind)
{
        memset(params, 0, sizeof(*params));
        params->kind = kind;
        serial_config_default(&params->serial);
}

int transport_params_add_device(struct transport_params *params, const char *path)
{
        if (params->n_devices >= TRANSPORT_DEVICES_MAX)
                return -ENOSPC;
        if (strlen(path) >= TRANSPORT_PATH_MAX)
                return -ENAMETOOLONG;
        strcpy(params->devices[params->n_devices++], path);
        return 0;
}

int transport_params_set_udp(struct transport_params *params, const char *local,
                             const char *remote)
{
        if ((local && strlen(local) >= TRANSPORT_ADDR_MAX) ||
            (remote && strlen(remote) >= TRANSPORT_ADDR_MAX))
                return -ENAMETOOLONG;
        snprintf(params->local, sizeof(params->local), "%s", local ? local : "");
        snprintf(params->remote, sizeof(params->remote), "%s", remote ? remote : "");
        return 0;
}

/* Splits "host:port" or "[v6]:port"; returns NULL or a reason. */
static const char *transport_split_addr(const char *s, char *host, size_t hostsz, char *port,
                                        bool port_zero_ok)
{
        const char *colon, *h = s;
        size_t hlen;
        char *end;
        unsigned long num;

        if (s[0] == '[') {
                const char *close = strchr(s, ']');

                if (!close || close[1] != ':')
                        return "IPv6 address must be written [addr]:port";
                h = s + 1;
                hlen = (size_t)(close - h);
                colon = close + 1;
        } else {
                colon = strchr(s, ':');
                if (!colon)
                        return "address must be host:port";
                if (strchr(colon + 1, ':'))
                        return "IPv6 address must be written [addr]:port";
                hlen = (size_t)(colon - s);
        }
        if (hlen == 0 || hlen >= hostsz)
                return "address has no host or a host too long";
        memcpy(host, h, hlen);
        host[hlen] = '\0';
        if (colon[1] < '0' || colon[1] > '9')
                return "port must be a number";
        errno = 0;
        num = strtoul(colon + 1, &end, 10);
        if (errno || *end || num > TRANSPORT_PORT_MAX || (num == 0 && !port_zero_ok))
                return "port must be 1..65535";
        snprintf(port, TRANSPORT_PORT_LEN, "%u", (unsigned)num);
        return NULL;
}

const char *transport_params_check(const struct transport_params *params)
{
        char host[TRANSPORT_ADDR_MAX], port[TRANSPORT_PORT_LEN];
        const char *why;

        switch (params->kind) {
        case TRANSPORT_SERIAL:
                if (params->n_devices == 0 || params->n_devices > TRANSPORT_DEVICES_MAX)
                        return "serial needs 1..8 devices";
                break;
        case TRANSPORT_PTY:
                if (params->n_devices != 1)
                        return "pty needs exactly one device (the symlink path)";
                break;
        case TRANSPORT_REPLAY:
                if (params->n_devices != 1 || params->devices[0][0] == '\0' ||
                    strnlen(params->devices[0], TRANSPORT_PATH_MAX) == TRANSPORT_PATH_MAX)
                        return "replay needs exactly one file";
                if (params->replay_speed < 0)
                        return "replay speed must be positive (0 for max)";
                return NULL;
        case TRANSPORT_UDP:
                if (!params->local[0] && !params->remote[0])
                        return "udp needs a local or a remote address";
                if (params->local[0]) {
                        why = transport_split_addr(params->local, host, sizeof(host), port, true);
                        if (why)
                                return why;
                }
                if (params->remote[0]) {
                        why = transport_split_addr(params->remote, host, sizeof(host), port,
                                                   false);
                        if (why)
                                return why;
                }
                return NULL;
        default:
                return "unknown transport";
        }
        for (unsigned i = 0; i < params->n_devices; i++)
                if (params->devices[i][0] == '\0' ||
                    strnlen(params->devices[i], TRANSPORT_PATH_MAX) == TRANSPORT_PATH_MAX)
                        return "empty or unterminated device path";
        return serial_config_check(&params->serial);
}

/* ---------------------------------------------------------------------------------------------
 * Serial */

static int transport_open_serial(struct transport *t, const struct transport_params *p,
                                 unsigned index, char *err, size_t errsz)
{
        int r = serial_open(p->devices[index], &p->serial, &t->serial, err, errsz);

        if (r < 0)
                return r;
        t->fd = t->serial.fd;
        snprintf(t->name, sizeof(t->name), "%s", p->devices[index]);
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * Pty */

/* Points `path` at target atomically; refuses to replace anything but a symlink. */
static int transport_link_pty(const char *target, const char *path, char *err, size_t errsz)
{
        char tmp[TRANSPORT_PATH_MAX + TRANSPORT_TMP_SUFFIX];
        struct stat st;
        int r;

        if (lstat(path, &st) == 0 && !S_ISLNK(st.st_mode)) {
                snprintf(err, errsz, "refusing to replace %s: not a symlink", path);
                return -EEXIST;
        }
        snprintf(tmp, sizeof(tmp), "%s.%ld.tmp", path, (long)getpid());
        /* A leftover from an earlier process with our pid; again only ever a symlink. */
        if (lstat(tmp, &st) == 0) {
                if (!S_ISLNK(st.st_mode)) {
                        snprintf(err, errsz, "refusing to replace %s: not a symlink", tmp);
                        return -EEXIST;
                }
                unlink(tmp);
        }
        if (symlink(target, tmp) < 0) {
                r = -errno;
                snprintf(err, errsz, "symlink %s: %s", tmp, strerror(-r));
                return r;
        }
        if (rename(tmp, path) < 0) {
                r = -errno;
                unlink(tmp);
                snprintf(err, errsz, "rename to %s: %s", path, strerror(-r));
                return r;
        }
        return 0;
}

/* Removes our symlink, unless somebody pointed it elsewhere meanwhile. */
static void transport_unlink_pty(struct transport *t)
{
        char target[TRANSPORT_PTS_MAX];
        ssize_t n;

        if (!t->pty_linked)
                return;
        n = readlink(t->pty_link, target, sizeof(target) - 1);
        if (n > 0) {
                target[n] = '\0';
                if (strcmp(target, t->pty_slave) == 0)
                        unlink(t->pty_link);
        }
        t->pty_linked = false;
}

static int transport_open_pty(struct transport *t, const struct transport_params *p, char *err,
                              size_t errsz)
{
        char why[TRANSPORT_ERR_MAX];
        int r;

        t->fd = posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
        if (t->fd < 0) {
                r = -errno;
                snprintf(err, errsz, "posix_openpt: %s", strerror(-r));
                return r;
        }
        if (grantpt(t->fd) < 0 || unlockpt(t->fd) < 0 ||
            ptsname_r(t->fd, t->pty_slave, sizeof(t->pty_slave)) != 0 ||
            fcntl(t->fd, F_SETFL, fcntl(t->fd, F_GETFL) | O_NONBLOCK) < 0) {
                r = -errno;
                snprintf(err, errsz, "pty setup: %s", strerror(-r));
                return r;
        }
        t->pty_slave_fd = open(t->pty_slave, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
        if (t->pty_slave_fd < 0) {
                r = -errno;
                snprintf(err, errsz, "open %s: %s", t->pty_slave, strerror(-r));
                return r;
        }
        /* The termios of a pty lives with the slave: a peer gets it raw when it opens it. */
        r = serial_apply(t->pty_slave_fd, &p->serial, why, sizeof(why));
        if (r < 0) {
                snprintf(err, errsz, "%s: %s", t->pty_slave, why);
                return r;
        }
        r = transport_link_pty(t->pty_slave, p->devices[0], err, errsz);
        if (r < 0)
                return r;
        snprintf(t->pty_link, sizeof(t->pty_link), "%s", p->devices[0]);
        t->pty_linked = true;
        snprintf(t->name, sizeof(t->name), "%s", p->devices[0]);
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * UDP */

static bool transport_host_is_localhost(const char *host)
{
        return strcasecmp(host, "localhost") == 0;
}

/* Resolves a split address without touching DNS: numeric hosts, or "localhost" (files). */
static int transport_resolve(const char *host, const char *port, int family, bool passive,
                             struct sockaddr_storage *ret_addr, socklen_t *ret_len)
{
        struct addrinfo hints = {
                .ai_family = family,
                .ai_socktype = SOCK_DGRAM,
                .ai_flags = AI_NUMERICSERV | (passive ? AI_PASSIVE : 0) |
                            (transport_host_is_localhost(host) ? 0 : AI_NUMERICHOST),
        };
        struct addrinfo *res;
        int r = getaddrinfo(host, port, &hints, &res);

        if (r != 0)
                return r == EAI_SYSTEM ? -errno : -EADDRNOTAVAIL;
        if (res->ai_addrlen > sizeof(*ret_addr)) {
                freeaddrinfo(res);
                return -EAFNOSUPPORT;
        }
        memcpy(ret_addr, res->ai_addr, res->ai_addrlen);
        *ret_len = res->ai_addrlen;
        freeaddrinfo(res);
        return 0;
}

struct transport_endpoint {
        bool given, resolved;
        char host[TRANSPORT_ADDR_MAX], port[TRANSPORT_PORT_LEN];
        struct sockaddr_storage addr;
        socklen_t len;
};

/* Resolves local and remote to one family: a numeric address decides it, "localhost" follows. */
static int transport_resolve_pair(struct transport_endpoint *ep, const char *const text[2],
                                  char *err, size_t errsz)
{
        int family = AF_UNSPEC;

        for (int pass = 0; pass < 2; pass++) {
                for (int i = 0; i < 2; i++) {
                        int r;

                        if (!ep[i].given || ep[i].resolved)
                                continue;
                        /* First pass: numeric hosts only; second: the rest. */
                        if (pass == 0 && transport_host_is_localhost(ep[i].host))
                                continue;
                        r = transport_resolve(ep[i].host, ep[i].port, family, i == 0,
                                              &ep[i].addr, &ep[i].len);
                        if (r < 0) {
                                snprintf(err, errsz, "udp address %s: %s", text[i],
                                              r == -EADDRNOTAVAIL ?
                                              "not a numeric address or localhost of the "
                                              "same family as the other" : strerror(-r));
                                return r;
                        }
                        ep[i].resolved = true;
                        family = ep[i].addr.ss_family;
                }
        }
        return family;
}

static int transport_open_udp(struct transport *t, const struct transport_params *p, char *err,
                              size_t errsz)
{
        const char *const text[2] = { p->local, p->remote };
        struct transport_endpoint ep[2] = { { 0 } };
        int family, r;

        for (int i = 0; i < 2; i++) {
                const char *why;

                if (!text[i][0])
                        continue;
                why = transport_split_addr(text[i], ep[i].host, sizeof(ep[i].host), ep[i].port,
                                           i == 0);
                if (why) {
                        snprintf(err, errsz, "udp address %s: %s", text[i], why);
                        return -EINVAL;
                }
                ep[i].given = true;
        }
        if (!ep[0].given && !ep[1].given) {
                snprintf(err, errsz, "udp needs a local or a remote address");
                return -EINVAL;
        }
        family = transport_resolve_pair(ep, text, err, errsz);
        if (family < 0)
                return family;
        t->fd = socket(family, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
        if (t->fd < 0) {
                r = -errno;
                snprintf(err, errsz, "udp socket: %s", strerror(-r));
                return r;
        }
        if (ep[0].given && bind(t->fd, (const struct sockaddr *)&ep[0].addr, ep[0].len) < 0) {
                r = -errno;
                snprintf(err, errsz, "udp bind %s: %s", p->local, strerror(-r));
                return r;
        }
        if (ep[1].given) {
                if (connect(t->fd, (const struct sockaddr *)&ep[1].addr, ep[1].len) < 0) {
                        r = -errno;
                        snprintf(err, errsz, "udp connect %s: %s", p->remote, strerror(-r));
                        return r;
                }
                t->udp_connected = true;
        }
        snprintf(t->name, sizeof(t->name), "udp %s -> %s", p->local[0] ? p->local : "*",
                 p->remote[0] ? p->remote : "(last sender)");
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * Common */

int transport_open(const struct transport_params *params, unsigned device_index,
                   struct transport **ret_transport, char *err, size_t errsz)
{
        const char *why = transport_params_check(params);
        struct transport *t;
        int r;

        if (why) {
                snprintf(err, errsz, "%s", why);
                return -EINVAL;
        }
        if (params->kind == TRANSPORT_SERIAL && device_index >= params->n_devices) {
                snprintf(err, errsz, "no device %u", device_index);
                return -EINVAL;
        }
        t = calloc(1, sizeof(*t));
        if (!t) {
                snprintf(err, errsz, "out of memory");
                return -ENOMEM;
        }
        t->kind = params->kind;
        t->datagram = transport_params_datagram(params);
        t->fd = -1;
        t->serial.fd = -1;
        t->pty_slave_fd = -1;
        switch (params->kind) {
        case TRANSPORT_SERIAL:
                r = transport_open_serial(t, params, device_index, err, errsz);
                break;
        case TRANSPORT_PTY:
                r = transport_open_pty(t, params, err, errsz);
                break;
        case TRANSPORT_REPLAY:
                r = replay_open(params->devices[0], params->replay_speed, params->replay_loop,
                                &t->replay, err, errsz);
                if (r == 0 && replay_datagram(t->replay) != t->datagram) {
                        /* The engine was set up for the other kind: it would decode wrongly. */
                        snprintf(err, errsz, "%s: the recording's transport changed since the "
                                 "link was set up (restart the daemon to play it)",
                                 params->devices[0]);
                        t->replay = replay_close(t->replay);
                        r = -ESTALE;
                }
                if (r == 0) {
                        t->fd = replay_fd(t->replay);
                        snprintf(t->name, sizeof(t->name), "%s", params->devices[0]);
                }
                break;
        default:
                r = transport_open_udp(t, params, err, errsz);
                break;
        }
        if (r < 0) {
                transport_close(t);
                return r;
        }
        *ret_transport = t;
        return 0;
}

struct transport *transport_close(struct transport *t)
{
        if (!t)
                return NULL;
        switch (t->kind) {
        case TRANSPORT_SERIAL:
                serial_close(&t->serial);       /* owns t->fd */
                break;
        case TRANSPORT_PTY:
                transport_unlink_pty(t);
                if (t->pty_slave_fd >= 0)
                        close(t->pty_slave_fd);
                if (t->fd >= 0)
                        close(t->fd);
                break;
        case TRANSPORT_REPLAY:
                replay_close(t->replay);        /* owns t->fd */
                break;
        default:
                if (t->fd >= 0)
                        close(t->fd);
                break;
        }
        free(t);
        return NULL;
}

int transport_fd(const struct transport *t)
{
        return t->fd;
}

bool transport_params_datagram(const struct transport_params *params)
{
        return params->kind == TRANSPORT_UDP ||
               (params->kind == TRANSPORT_REPLAY && params->replay_datagram);
}

bool transport_is_datagram(const struct transport *t)
{
        return t->datagram;
}

const char *transport_name(const struct transport *t)
{
        return t->name;
}

const char *transport_pty_slave(const struct transport *t)
{
        return t->kind == TRANSPORT_PTY ? t->pty_slave : NULL;
}

static ssize_t transport_read_udp(struct transport *t, void *buf, size_t size)
{
        struct sockaddr_storage from;
        socklen_t fromlen = sizeof(from);
        ssize_t n;

        do {
                /* MSG_TRUNC: the real length comes back, so a cut datagram is noticed. */
                n = recvfrom(t->fd, buf, size, MSG_TRUNC, (struct sockaddr *)&from, &fromlen);
        } while (n < 0 && errno == EINTR);
        if (n < 0)
                return errno == EWOULDBLOCK ? -EAGAIN : -errno;
        if (!t->udp_connected) {
                t->udp_peer = from;
                t->udp_peer_len = fromlen;
                t->udp_have_peer = true;
        }
        return (size_t)n > size ? -EMSGSIZE : n;
}

ssize_t transport_read(struct transport *t, void *buf, size_t size)
{
        ssize_t n;

        if (t->kind == TRANSPORT_UDP)
                return transport_read_udp(t, buf, size);
        if (t->kind == TRANSPORT_REPLAY)
                return replay_read(t->replay, buf, size);
        do {
                n = read(t->fd, buf, size);
        } while (n < 0 && errno == EINTR);
        if (n == 0 && size > 0)
                return -EPIPE;          /* a tty reads 0 only once hung up (VMIN=1) */
        if (n < 0)
                return errno == EWOULDBLOCK ? -EAGAIN : -errno;
        return n;
}

ssize_t transport_write(struct transport *t, const void *buf, size_t len)
{
        ssize_t n;

        if (t->kind == TRANSPORT_REPLAY)
                return replay_write(t->replay, len);
        do {
                if (t->kind != TRANSPORT_UDP)
                        n = write(t->fd, buf, len);
                else if (t->udp_connected)
                        n = send(t->fd, buf, len, MSG_NOSIGNAL);
                else if (t->udp_have_peer)
                        n = sendto(t->fd, buf, len, MSG_NOSIGNAL,
                                   (const struct sockaddr *)&t->udp_peer, t->udp_peer_len);
                else
                        return -EDESTADDRREQ;
        } while (n < 0 && errno == EINTR);
        if (n < 0)
                return errno == EWOULDBLOCK ? -EAGAIN : -errno;
        return n;
}

bool transport_reopens(enum transport_kind kind)
{
        return kind != TRANSPORT_REPLAY;
}

const char *transport_end_reason(const struct transport *t, int err)
{
        return t->kind == TRANSPORT_REPLAY && err == -ENODATA ? "end of recording" : NULL;
}

bool transport_error_fatal(const struct transport *t, int err)
{
        if (err == -EAGAIN)
                return false;
        if (t->kind != TRANSPORT_UDP)
                return true;
        switch (-err) {
        case ECONNREFUSED:      /* ICMP port unreachable from an earlier datagram */
        case EMSGSIZE:
        case EDESTADDRREQ:
        case ENETUNREACH:
        case EHOSTUNREACH:
        case ENETDOWN:
        case EHOSTDOWN:
        case ENOBUFS:
        case EPERM:             /* a firewall rule */
        case EACCES:
                return false;
        default:
                return true;
        }
}
