/*
 * Unit tests of the control-socket client (src/lib/request.c): request lines checked before they
 * leave, every argument of the typed commands refused with -EINVAL before any connection is
 * made, the exact words each command puts on the wire, and the errors when nobody listens or
 * nobody answers. The line grammar itself, reply lines included: test_control_proto.c. Round
 * trips with the real daemon are in tests/integration/test_slctl.c.
 *
 * "Before any connection": the handle's runtime directory is an empty temporary directory, so a
 * call that got as far as connecting would fail with -ECONNREFUSED, never -EINVAL.
 */
#include <errno.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cmocka.h>

#include <sharedlink.h>

#include "common/shmtest.h"
#include "lib/request.h"
#include "shm/table.h"

#define REPLY_SIZE      256
#define SHORT_MS        50      /* a request nobody answers: how long to wait for it */

static const struct shm_var vars[] = {
        { "AutoGpsLat", SHM_DIR_IN, SHM_TYPE_DOUBLE, SHM_LINK_NONE, NULL, SHM_POSITION_NONE },
};

struct fixture {
        char instance[64];
        char dir[64];
        char sock[sizeof(((struct sockaddr_un *)0)->sun_path)];
        struct shm_table *t;
        struct sl_client *c;
        int listen_fd;
};

/* Tables (publishing the socket path when publish), a handle, a directory for the socket. */
static int setup_tables(void **state, int publish)
{
        struct fixture *f = calloc(1, sizeof(*f));
        struct shm_table_config cfg = { .vars = vars, .nvars = 1 };

        if (!f)
                return -1;
        f->listen_fd = -1;
        shmtest_instance(f->instance, sizeof(f->instance), "req");
        cfg.instance = f->instance;
        snprintf(f->dir, sizeof(f->dir), "/tmp/sltest-req.XXXXXX");
        *state = f;
        if (!mkdtemp(f->dir) ||
            snprintf(f->sock, sizeof(f->sock), "%s/%s.sock", f->dir, f->instance) >=
            (int)sizeof(f->sock))
                return -1;
        cfg.control_socket = publish ? f->sock : NULL;
        unsetenv("SHAREDLINK_RUNTIME_DIR");
        return shm_table_create(&cfg, &f->t) < 0 || sl_open(f->instance, &f->c) < 0 ? -1 : 0;
}

static int setup(void **state)
{
        if (setup_tables(state, 0) < 0)
                return -1;
        return sl_set_runtime_dir(((struct fixture *)*state)->c,
                                  ((struct fixture *)*state)->dir) == 0 ? 0 : -1;
}

static int setup_published(void **state)
{
        return setup_tables(state, 1);
}

static int teardown(void **state)
{
        struct fixture *f = *state;

        if (f->listen_fd >= 0)
                close(f->listen_fd);
        unlink(f->sock);
        rmdir(f->dir);
        sl_close(f->c);
        shm_table_destroy(f->t);
        free(f);
        return 0;
}

/* A socket bound at the handle's socket path (listening when listen_too). */
static int bind_socket(struct fixture *f, int listen_too)
{
        struct sockaddr_un sa = { .sun_family = AF_UNIX };
        int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);

        assert_true(fd >= 0);
        snprintf(sa.sun_path, sizeof(sa.sun_path), "%s", f->sock);
        assert_int_equal(bind(fd, (struct sockaddr *)&sa, sizeof(sa)), 0);
        if (listen_too)
                assert_int_equal(listen(fd, 8), 0);
        return fd;
}

/* ---- request lines ------------------------------------------------------------------------- */

static void test_line_check(void **state)
{
        static const struct {
                const char *line;
                int ok;
        } cases[] = {
                { "ping", 1 },
                { "query vehicle A AutoGpsLat 250", 1 },
                { "circe agility visualize D15D15,E1E1E1 current=1 start-timer", 1 },
                { "~!\"#$%&'()*+,-./:;<=>?@[\\]^_`{|}", 1 },
                { "", 0 },
                { " ping", 0 },
                { "ping ", 0 },
                { "query  vehicle", 0 },
                { "query\tvehicle", 0 },
                { "query\nvehicle", 0 },
                { "ping\n", 0 },
                { "ping\r", 0 },
                { "caf\xc3\xa9", 0 },
                { "del\x7f", 0 },
                { " ", 0 },
        };
        char why[REPLY_SIZE], line[SL_REQUEST_LINE_MAX + 2];

        (void)state;
        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
                why[0] = '\0';
                if (cases[i].ok) {
                        assert_int_equal(request_line_check(cases[i].line, why, sizeof(why)), 0);
                } else {
                        assert_int_equal(request_line_check(cases[i].line, why, sizeof(why)),
                                         -EINVAL);
                        assert_true(why[0] != '\0');
                }
        }
        assert_int_equal(request_line_check(NULL, NULL, 0), -EINVAL);

        /* Length: exactly the limit passes, one more byte does not. */
        memset(line, 'x', SL_REQUEST_LINE_MAX);
        line[SL_REQUEST_LINE_MAX] = '\0';
        assert_int_equal(request_line_check(line, why, sizeof(why)), 0);
        line[SL_REQUEST_LINE_MAX] = 'x';
        line[SL_REQUEST_LINE_MAX + 1] = '\0';
        assert_int_equal(request_line_check(line, why, sizeof(why)), -EINVAL);

        /* Words: 32 pass, 33 do not. */
        line[0] = '\0';
        for (int i = 0; i < SL_REQUEST_WORDS_MAX; i++)
                strcat(line, i ? " w" : "w");
        assert_int_equal(request_line_check(line, why, sizeof(why)), 0);
        strcat(line, " w");
        assert_int_equal(request_line_check(line, why, sizeof(why)), -EINVAL);
}

/* ---- arguments refused before any connection ---------------------------------------------- */

enum op { OP_REQUEST, OP_QUERY, OP_ALERT, OP_NETWORK, OP_DEVICE, OP_SYNC, OP_ACTION, OP_COMMAND };

/* One call of a typed command; unused fields stay 0/NULL. */
struct call {
        const char *what;
        enum op op;
        const char *link;
        const char *s1, *s2;            /* address / peer, name / destination */
        long n1, n2;                    /* numbers: roles, caps, keys, sensor time, timeout */
        int h1, h2;                     /* has_* flags, join */
};

static int run_call(struct sl_client *c, const struct call *k, char *reply, size_t size)
{
        switch (k->op) {
        case OP_REQUEST:
                return sl_request(c, k->s1, SHORT_MS, NULL, NULL, reply, size);
        case OP_QUERY:
                return sl_query(c, k->link, k->s1, k->s2, (int)k->n1, reply, size);
        case OP_ALERT:
                return sl_circe_alert(c, k->link, k->s1, reply, size);
        case OP_NETWORK:
                return sl_circe_network_setup(c, k->link, k->s1, k->h1, (int)k->n1, reply, size);
        case OP_DEVICE:
                return sl_circe_device_setup(c, k->link, k->s1, k->h1, k->s2, k->h2, (int)k->n1,
                                             reply, size);
        case OP_SYNC:
                return sl_circe_sync_clocks(c, k->link, NULL, NULL, reply, size);
        case OP_ACTION:
                return sl_circe_emulate_action(c, k->link, k->s1, k->h1, (int)k->n1, k->h2, k->n2,
                                               reply, size);
        case OP_COMMAND: {
                /* sl_command has no reply buffer: its error's text stands in for one. */
                int r = sl_command(c, k->link, k->s1, k->s2);

                snprintf(reply, size, "%s", r == -ECONNREFUSED ? "not running" : sl_strerror(r));
                return r;
        }
        }
        return -ENOSYS;
}

#define LONG_LINK       "abcdefghijklmnopqrstuvwxyz012345"      /* 32 bytes: one too many */
#define LONG_NAME       "abcdefghijklmnopqrstuvwxyz0123456789abcdefghijkl"      /* 48 */
/* 63 and 64 bytes: the longest module / command text, and one too many. */
#define TEXT_63         "0123456789abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0"
#define TEXT_64         TEXT_63 "1"
/* 28 and 29 words in 55 and 57 bytes. */
#define WORDS_28        "a b c d e f g h i j k l m n o p q r s t u v w x y z 0 1"
#define WORDS_29        WORDS_28 " 2"

static const struct call refused[] = {
        { "request: empty", OP_REQUEST, NULL, "", NULL, 0, 0, 0, 0 },
        { "request: NULL", OP_REQUEST, NULL, NULL, NULL, 0, 0, 0, 0 },
        { "request: newline", OP_REQUEST, NULL, "ping\nping", NULL, 0, 0, 0, 0 },
        { "request: double space", OP_REQUEST, NULL, "circe  x", NULL, 0, 0, 0, 0 },
        { "query: NULL link", OP_QUERY, NULL, "A", "AutoGpsLat", 0, 0, 0, 0 },
        { "query: empty link", OP_QUERY, "", "A", "AutoGpsLat", 0, 0, 0, 0 },
        { "query: long link", OP_QUERY, LONG_LINK, "A", "AutoGpsLat", 0, 0, 0, 0 },
        { "query: link with space", OP_QUERY, "veh icle", "A", "AutoGpsLat", 0, 0, 0, 0 },
        { "query: link with control", OP_QUERY, "veh\x01", "A", "AutoGpsLat", 0, 0, 0, 0 },
        { "query: peer Q", OP_QUERY, "vehicle", "Q", "AutoGpsLat", 0, 0, 0, 0 },
        { "query: peer a", OP_QUERY, "vehicle", "a", "AutoGpsLat", 0, 0, 0, 0 },
        { "query: peer AB", OP_QUERY, "vehicle", "AB", "AutoGpsLat", 0, 0, 0, 0 },
        { "query: peer empty", OP_QUERY, "vehicle", "", "AutoGpsLat", 0, 0, 0, 0 },
        { "query: peer NULL", OP_QUERY, "vehicle", NULL, "AutoGpsLat", 0, 0, 0, 0 },
        { "query: name NULL", OP_QUERY, "vehicle", "A", NULL, 0, 0, 0, 0 },
        { "query: name empty", OP_QUERY, "vehicle", "A", "", 0, 0, 0, 0 },
        { "query: name space", OP_QUERY, "vehicle", "A", "Auto Lat", 0, 0, 0, 0 },
        { "query: name bar", OP_QUERY, "vehicle", "A", "Auto|Lat", 0, 0, 0, 0 },
        { "query: name bracket", OP_QUERY, "vehicle", "A", "Auto]", 0, 0, 0, 0 },
        { "query: name 48 bytes", OP_QUERY, "vehicle", "A", LONG_NAME, 0, 0, 0, 0 },
        { "query: timeout -1", OP_QUERY, "vehicle", "A", "AutoGpsLat", -1, 0, 0, 0 },
        { "query: timeout 60001", OP_QUERY, "vehicle", "A", "AutoGpsLat", 60001, 0, 0, 0 },
        { "alert: NULL link", OP_ALERT, NULL, "E1E1E1", NULL, 0, 0, 0, 0 },
        { "alert: NULL address", OP_ALERT, "agility", NULL, NULL, 0, 0, 0, 0 },
        { "alert: lowercase", OP_ALERT, "agility", "e1e1e1", NULL, 0, 0, 0, 0 },
        { "alert: 5 digits", OP_ALERT, "agility", "E1E1E", NULL, 0, 0, 0, 0 },
        { "alert: 7 digits", OP_ALERT, "agility", "E1E1E1E", NULL, 0, 0, 0, 0 },
        { "alert: not hex", OP_ALERT, "agility", "G1E1E1", NULL, 0, 0, 0, 0 },
        { "alert: reserved", OP_ALERT, "agility", "FFFFFF", NULL, 0, 0, 0, 0 },
        { "alert: sign", OP_ALERT, "agility", "+12345", NULL, 0, 0, 0, 0 },
        { "network: roles -1", OP_NETWORK, "agility", "AAAAAA", NULL, -1, 0, 1, 0 },
        { "network: roles 128", OP_NETWORK, "agility", "AAAAAA", NULL, 128, 0, 1, 0 },
        { "network: join 2", OP_NETWORK, "agility", "AAAAAA", NULL, 1, 0, 2, 0 },
        { "network: join -1", OP_NETWORK, "agility", "AAAAAA", NULL, 1, 0, -1, 0 },
        { "network: address", OP_NETWORK, "agility", "AAAAA", NULL, 1, 0, 1, 0 },
        { "device: assign", OP_DEVICE, "agility", "12345G", NULL, 0, 0, 0, 0 },
        { "device: assign reserved", OP_DEVICE, "agility", "FFFFFF", NULL, 0, 0, 0, 0 },
        { "device: dest", OP_DEVICE, "agility", "123456", "12345", 0, 0, 1, 0 },
        { "device: dest NULL", OP_DEVICE, "agility", "123456", NULL, 0, 0, 1, 0 },
        { "device: caps 128", OP_DEVICE, "agility", "123456", NULL, 128, 0, 0, 1 },
        { "device: caps -1", OP_DEVICE, "agility", "123456", NULL, -1, 0, 0, 1 },
        { "sync: link empty", OP_SYNC, "", NULL, NULL, 0, 0, 0, 0 },
        { "action: address", OP_ACTION, "arena", "E1E1E1 ", NULL, 0, 0, 0, 0 },
        { "action: keys 65536", OP_ACTION, "arena", "E1E1E1", NULL, 65536, 0, 1, 0 },
        { "action: keys -1", OP_ACTION, "arena", "E1E1E1", NULL, -1, 0, 1, 0 },
        { "action: time 1000000", OP_ACTION, "arena", "E1E1E1", NULL, 0, 1000000, 0, 1 },
        { "action: time -1", OP_ACTION, "arena", "E1E1E1", NULL, 0, -1, 0, 1 },
        { "command: NULL link", OP_COMMAND, NULL, "ServoPod", "0,TELEOP START", 0, 0, 0, 0 },
        { "command: link space", OP_COMMAND, "a b", "ServoPod", "x", 0, 0, 0, 0 },
        { "command: long link", OP_COMMAND, LONG_LINK, "ServoPod", "x", 0, 0, 0, 0 },
        { "command: NULL module", OP_COMMAND, "vehicle", NULL, "x", 0, 0, 0, 0 },
        { "command: empty module", OP_COMMAND, "vehicle", "", "x", 0, 0, 0, 0 },
        { "command: module space", OP_COMMAND, "vehicle", "Servo Pod", "x", 0, 0, 0, 0 },
        { "command: module comma", OP_COMMAND, "vehicle", "Servo,Pod", "x", 0, 0, 0, 0 },
        { "command: module bar", OP_COMMAND, "vehicle", "Servo|Pod", "x", 0, 0, 0, 0 },
        { "command: module 64", OP_COMMAND, "vehicle", TEXT_64, "x", 0, 0, 0, 0 },
        { "command: text 64", OP_COMMAND, "vehicle", "ServoPod", TEXT_64, 0, 0, 0, 0 },
        { "command: text bar", OP_COMMAND, "vehicle", "ServoPod", "0|x", 0, 0, 0, 0 },
        { "command: text bracket", OP_COMMAND, "vehicle", "ServoPod", "0]", 0, 0, 0, 0 },
        { "command: text [", OP_COMMAND, "vehicle", "ServoPod", "[0", 0, 0, 0, 0 },
        { "command: text tab", OP_COMMAND, "vehicle", "ServoPod", "0\tx", 0, 0, 0, 0 },
        { "command: text newline", OP_COMMAND, "vehicle", "ServoPod", "0\nx", 0, 0, 0, 0 },
        { "command: text 0x7f", OP_COMMAND, "vehicle", "ServoPod", "0\x7f", 0, 0, 0, 0 },
        { "command: text 0xc3", OP_COMMAND, "vehicle", "ServoPod", "\xc3\xa9", 0, 0, 0, 0 },
        { "command: double space", OP_COMMAND, "vehicle", "ServoPod", "0,TELEOP  START", 0, 0, 0,
          0 },
        { "command: leading space", OP_COMMAND, "vehicle", "ServoPod", " 0,TELEOP", 0, 0, 0, 0 },
        { "command: trailing space", OP_COMMAND, "vehicle", "ServoPod", "0,TELEOP ", 0, 0, 0, 0 },
        { "command: only a space", OP_COMMAND, "vehicle", "ServoPod", " ", 0, 0, 0, 0 },
        { "command: 29 words", OP_COMMAND, "vehicle", "ServoPod", WORDS_29, 0, 0, 0, 0 },
};

/* The same commands, one step inside each range: they get as far as connecting. */
static const struct call accepted[] = {
        { "request", OP_REQUEST, NULL, "ping", NULL, 0, 0, 0, 0 },
        { "query", OP_QUERY, "vehicle", "A", "AutoGpsLat", 0, 0, 0, 0 },
        { "query: peer P, 47-byte name", OP_QUERY, "vehicle", "P",
          "abcdefghijklmnopqrstuvwxyz0123456789abcdefghijk", 60000, 0, 0, 0 },
        { "query: 31-byte link", OP_QUERY, "abcdefghijklmnopqrstuvwxyz01234", "A", "X", 1, 0, 0,
          0 },
        { "alert: 000000", OP_ALERT, "agility", "000000", NULL, 0, 0, 0, 0 },
        { "alert: FFFFFE", OP_ALERT, "agility", "FFFFFE", NULL, 0, 0, 0, 0 },
        { "network: roles 127", OP_NETWORK, "agility", "AAAAAA", NULL, 127, 0, 1, 0 },
        { "network: roles 0, leave", OP_NETWORK, "agility", "AAAAAA", NULL, 0, 0, 0, 0 },
        { "device: caps 127, dest ignored", OP_DEVICE, "agility", "123456", "bad", 127, 0, 0, 1 },
        { "device: no options", OP_DEVICE, "agility", "123456", NULL, 0, 0, 0, 0 },
        { "sync", OP_SYNC, "agility", NULL, NULL, 0, 0, 0, 0 },
        { "action: maxima", OP_ACTION, "arena", "E1E1E1", NULL, 65535, 999999, 1, 1 },
        { "action: bad keys not given", OP_ACTION, "arena", "E1E1E1", NULL, -5, -5, 0, 0 },
        { "command", OP_COMMAND, "vehicle", "ServoPod", "0,TELEOP START", 0, 0, 0, 0 },
        { "command: NULL text", OP_COMMAND, "vehicle", "MUI", NULL, 0, 0, 0, 0 },
        { "command: empty text", OP_COMMAND, "vehicle", "a.b-c_9", "", 0, 0, 0, 0 },
        { "command: 63-byte module and text", OP_COMMAND, "vehicle", TEXT_63, TEXT_63, 0, 0, 0,
          0 },
        { "command: 28 words", OP_COMMAND, "vehicle", "Link", WORDS_28, 0, 0, 0, 0 },
        { "command: punctuation", OP_COMMAND, "vehicle", "Link", "0, SetIP, 1.2.3.4:4220, 4000",
          0, 0, 0, 0 },
};

static void test_arguments_refused(void **state)
{
        struct fixture *f = *state;
        char reply[REPLY_SIZE];

        for (size_t i = 0; i < sizeof(refused) / sizeof(refused[0]); i++) {
                int r;

                strcpy(reply, "untouched");
                r = run_call(f->c, &refused[i], reply, sizeof(reply));
                if (r != -EINVAL)
                        fail_msg("%s: %d (%s)", refused[i].what, r, reply);
                assert_true(reply[0] != '\0' && strcmp(reply, "untouched") != 0);
        }
        for (size_t i = 0; i < sizeof(accepted) / sizeof(accepted[0]); i++) {
                int r = run_call(f->c, &accepted[i], reply, sizeof(reply));

                if (r != -ECONNREFUSED)
                        fail_msg("%s: %d (%s)", accepted[i].what, r, reply);
                assert_non_null(strstr(reply, "not running"));
        }
        /* No handle, no buffer: refused, and a NULL reply buffer is fine. */
        assert_int_equal(sl_circe_alert(NULL, "agility", "E1E1E1", reply, sizeof(reply)), -EINVAL);
        assert_int_equal(sl_circe_alert(f->c, "agility", "e1e1e1", NULL, 0), -EINVAL);
        assert_int_equal(sl_query(f->c, "vehicle", "A", "X", 0, NULL, 0), -EINVAL);
        assert_int_equal(sl_request(NULL, "ping", 0, NULL, NULL, NULL, 0), -EINVAL);
        assert_int_equal(sl_command(NULL, "vehicle", "ServoPod", "x"), -EINVAL);
        /* A reply buffer of one byte gets an empty, terminated message. */
        reply[0] = 'x';
        assert_int_equal(sl_circe_alert(f->c, "agility", "FFFFFF", reply, 1), -EINVAL);
        assert_int_equal(reply[0], '\0');
}

static const char *const one_dest[] = { "D15D15" };
static const char *const bad_dest[] = { "D15D15", "d15d15" };
static const char *const reserved_dest[] = { "FFFFFF" };
#define VIS     .size = sizeof(struct sl_circe_visualize), .dests = one_dest, .dest_count = 1

static void test_visualize_refused(void **state)
{
        static const char *many[SL_CIRCE_DESTS_MAX + 1];
        const struct {
                const char *what;
                struct sl_circe_visualize v;
        } cases[] = {
                { "no field", { VIS } },
                { "size 0", { .size = 0, .dests = one_dest, .dest_count = 1, .has_current = 1 } },
                { "size short", { .size = sizeof(size_t), .dests = one_dest, .dest_count = 1 } },
                { "no dests", { .size = sizeof(struct sl_circe_visualize), .has_current = 1 } },
                { "dest count 0", { .size = sizeof(struct sl_circe_visualize), .dests = one_dest,
                                    .has_current = 1 } },
                { "93 dests", { .size = sizeof(struct sl_circe_visualize), .dests = many,
                                .dest_count = SL_CIRCE_DESTS_MAX + 1, .has_current = 1 } },
                { "lowercase dest", { .size = sizeof(struct sl_circe_visualize),
                                      .dests = bad_dest, .dest_count = 2, .has_current = 1 } },
                { "reserved dest", { .size = sizeof(struct sl_circe_visualize),
                                     .dests = reserved_dest, .dest_count = 1, .has_next = 1 } },
                { "current 1000", { VIS, .has_current = 1, .current = 1000 } },
                { "current -1", { VIS, .has_current = 1, .current = -1 } },
                { "next 1000", { VIS, .has_next = 1, .next = 1000 } },
                { "start_timer 2", { VIS, .start_timer = 2 } },
                { "primary 1000000", { VIS, .has_primary = 1, .primary_ms = 1000000 } },
                { "secondary -1", { VIS, .has_secondary = 1, .secondary_ms = -1 } },
                { "faults 100", { VIS, .has_faults = 1, .faults = 100 } },
                { "refusals 100", { VIS, .has_refusals = 1, .refusals = 100 } },
                { "eliminated 2", { VIS, .has_eliminated = 1, .eliminated = 2 } },
                { "placement 1000", { VIS, .has_placement = 1, .placement = 1000 } },
                { "one good, one bad", { VIS, .has_current = 1, .current = 1,
                                         .has_faults = 1, .faults = -3 } },
        };
        struct fixture *f = *state;
        char reply[REPLY_SIZE];

        for (size_t i = 0; i <= SL_CIRCE_DESTS_MAX; i++)
                many[i] = "123456";
        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
                int r;

                reply[0] = '\0';
                r = sl_circe_visualize(f->c, "agility", &cases[i].v, reply, sizeof(reply));
                if (r != -EINVAL)
                        fail_msg("%s: %d (%s)", cases[i].what, r, reply);
                assert_true(reply[0] != '\0');
        }
        assert_int_equal(sl_circe_visualize(f->c, "agility", NULL, reply, sizeof(reply)), -EINVAL);
        {
                /* The most a Visualize may carry still fits a request line. */
                struct sl_circe_visualize v = {
                        .size = sizeof(v), .dests = many, .dest_count = SL_CIRCE_DESTS_MAX,
                        .has_current = 1, .current = 999, .has_next = 1, .next = 999,
                        .start_timer = 1, .has_primary = 1, .primary_ms = 999999,
                        .has_secondary = 1, .secondary_ms = 999999, .has_faults = 1,
                        .faults = 99, .has_refusals = 1, .refusals = 99, .has_eliminated = 1,
                        .eliminated = 1, .has_placement = 1, .placement = 999,
                };

                assert_int_equal(sl_set_command_wait(f->c, SL_WAIT_MAX_MS), 0);
                assert_int_equal(sl_circe_visualize(f->c, LONG_LINK + 1, &v, reply,
                                                    sizeof(reply)), -ECONNREFUSED);
        }
}

/* ---- what goes on the wire ----------------------------------------------------------------- */

/* Accepts one connection, keeps its first line, closes without answering. */
struct recorder {
        int listen_fd;
        char line[SL_REQUEST_LINE_MAX + 2];
};

static void *record_one(void *arg)
{
        struct recorder *rec = arg;
        size_t len = 0;
        int fd = accept(rec->listen_fd, NULL, NULL);

        if (fd < 0)
                return NULL;
        while (len + 1 < sizeof(rec->line)) {
                ssize_t n = read(fd, rec->line + len, 1);

                if (n <= 0 || rec->line[len] == '\n')
                        break;
                len++;
        }
        rec->line[len] = '\0';
        close(fd);
        return NULL;
}

/* Runs one call against a recorder; returns the line it sent (static buffer of rec). */
static const char *sent_by(struct fixture *f, struct recorder *rec, const struct call *k,
                           const struct sl_circe_visualize *v)
{
        char reply[REPLY_SIZE];
        pthread_t th;
        int r;

        rec->listen_fd = f->listen_fd;
        rec->line[0] = '\0';
        assert_int_equal(pthread_create(&th, NULL, record_one, rec), 0);
        if (v)
                r = sl_circe_visualize(f->c, "agility", v, reply, sizeof(reply));
        else
                r = run_call(f->c, k, reply, sizeof(reply));
        pthread_join(th, NULL);
        /* The recorder closed without an answer. */
        assert_int_equal(r, -ECONNRESET);
        assert_non_null(strstr(reply, "closed"));
        return rec->line;
}

static void test_wire_words(void **state)
{
        static const struct {
                struct call call;
                const char *line;
        } cases[] = {
                { { "ping", OP_REQUEST, NULL, "ping", NULL, 0, 0, 0, 0 }, "ping" },
                { { "query", OP_QUERY, "vehicle", "A", "AutoGpsLat", 0, 0, 0, 0 },
                  "query vehicle A AutoGpsLat" },
                { { "query timeout", OP_QUERY, "vehicle", "B", "Name.x", 250, 0, 0, 0 },
                  "query vehicle B Name.x 250" },
                { { "alert", OP_ALERT, "agility", "E1E1E1", NULL, 0, 0, 0, 0 },
                  "circe agility alert E1E1E1" },
                { { "join", OP_NETWORK, "agility", "AAAAAA", NULL, 3, 0, 1, 0 },
                  "circe agility network-setup AAAAAA join 3" },
                { { "leave", OP_NETWORK, "agility", "AAAAAA", NULL, 0, 0, 0, 0 },
                  "circe agility network-setup AAAAAA leave 0" },
                { { "assign", OP_DEVICE, "agility", "123456", NULL, 0, 0, 0, 0 },
                  "circe agility device-setup 123456" },
                { { "assign dest", OP_DEVICE, "agility", "123456", "000000", 0, 0, 1, 0 },
                  "circe agility device-setup 123456 000000" },
                { { "assign caps", OP_DEVICE, "agility", "123456", NULL, 64, 0, 0, 1 },
                  "circe agility device-setup 123456 - 64" },
                { { "assign both", OP_DEVICE, "agility", "123456", "ABCDEF", 0, 0, 1, 1 },
                  "circe agility device-setup 123456 ABCDEF 0" },
                { { "sync", OP_SYNC, "agility", NULL, NULL, 0, 0, 0, 0 },
                  "circe agility sync-clocks" },
                { { "action", OP_ACTION, "arena", "E1E1E1", NULL, 8192, 5000, 1, 1 },
                  "circe arena emulate action E1E1E1 keys=8192 sensor-time=5000" },
                { { "action bare", OP_ACTION, "arena", "AAAAAA", NULL, 0, 0, 0, 0 },
                  "circe arena emulate action AAAAAA" },
                { { "action time 0", OP_ACTION, "arena", "AAAAAA", NULL, 0, 0, 0, 1 },
                  "circe arena emulate action AAAAAA sensor-time=0" },
                { { "command", OP_COMMAND, "vehicle", "ServoPod", "0,TELEOP START", 0, 0, 0, 0 },
                  "command vehicle ServoPod 0,TELEOP START" },
                { { "command no text", OP_COMMAND, "vehicle", "MUI", NULL, 0, 0, 0, 0 },
                  "command vehicle MUI" },
                { { "command empty", OP_COMMAND, "v", "Physics", "", 0, 0, 0, 0 },
                  "command v Physics" },
                { { "command SetIP", OP_COMMAND, "v", "Link", "0, SetIP, 1.2.3.4:4220, 4000", 0,
                    0, 0, 0 },
                  "command v Link 0, SetIP, 1.2.3.4:4220, 4000" },
                /* A last word that reads as the link wait is followed by one (wait=0), so the
                 * daemon takes it for what it is. */
                { { "query wait=5", OP_QUERY, "vehicle", "A", "wait=5", 0, 0, 0, 0 },
                  "query vehicle A wait=5 wait=0" },
                { { "command wait=x", OP_COMMAND, "v", "Link", "0 wait=x", 0, 0, 0, 0 },
                  "command v Link 0 wait=x wait=0" },
                { { "command 28 words", OP_COMMAND, "v", "Link", WORDS_28, 0, 0, 0, 0 },
                  "command v Link " WORDS_28 },
        };
        static const char *const two[] = { "D15D15", "E1E1E1" };
        const struct sl_circe_visualize all = {
                .size = sizeof(all), .dests = two, .dest_count = 2,
                .has_current = 1, .current = 12, .has_next = 1, .next = 13, .start_timer = 1,
                .has_primary = 1, .primary_ms = 1234, .has_secondary = 1, .secondary_ms = 999999,
                .has_faults = 1, .faults = 0, .has_refusals = 1, .refusals = 99,
                .has_eliminated = 1, .eliminated = 1, .has_placement = 1, .placement = 999,
        };
        const struct sl_circe_visualize some = {
                .size = sizeof(some), .dests = one_dest, .dest_count = 1,
                .has_eliminated = 1, .eliminated = 0, .has_faults = 1, .faults = 4,
        };
        const struct call alert = { "alert", OP_ALERT, "agility", "E1E1E1", NULL, 0, 0, 0, 0 };
        struct fixture *f = *state;
        struct recorder rec;

        f->listen_fd = bind_socket(f, 1);
        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++)
                assert_string_equal(sent_by(f, &rec, &cases[i].call, NULL), cases[i].line);
        assert_string_equal(sent_by(f, &rec, NULL, &all),
                            "circe agility visualize D15D15,E1E1E1 current=12 next=13 "
                            "start-timer primary=1234 secondary=999999 faults=0 refusals=99 "
                            "eliminated=1 placement=999");
        assert_string_equal(sent_by(f, &rec, NULL, &some),
                            "circe agility visualize D15D15 faults=4 eliminated=0");

        /* The handle's link wait goes last, on commands, not on raw requests. */
        assert_int_equal(sl_set_command_wait(f->c, 1500), 0);
        assert_string_equal(sent_by(f, &rec, &alert, NULL), "circe agility alert E1E1E1 wait=1500");
        assert_string_equal(sent_by(f, &rec, &cases[2].call, NULL),
                            "query vehicle B Name.x 250 wait=1500");
        assert_string_equal(sent_by(f, &rec, &cases[0].call, NULL), "ping");
        /* 28 text words still leave room for the wait. */
        assert_string_equal(sent_by(f, &rec, &cases[sizeof(cases) / sizeof(cases[0]) - 1].call,
                                    NULL), "command v Link " WORDS_28 " wait=1500");
        assert_int_equal(sl_set_command_wait(f->c, 0), 0);
        assert_string_equal(sent_by(f, &rec, &alert, NULL), "circe agility alert E1E1E1");
}

/* ---- nobody listening, nobody answering ---------------------------------------------------- */

static void test_not_running(void **state)
{
        struct fixture *f = *state;
        char reply[REPLY_SIZE];
        int fd;

        /* No socket file at all. */
        assert_int_equal(sl_request(f->c, "ping", 0, NULL, NULL, reply, sizeof(reply)),
                         -ECONNREFUSED);
        assert_non_null(strstr(reply, f->sock));
        /* A socket file left behind by a daemon that is gone. */
        fd = bind_socket(f, 1);
        close(fd);
        assert_int_equal(sl_request(f->c, "ping", 0, NULL, NULL, reply, sizeof(reply)),
                         -ECONNREFUSED);
        assert_int_equal(sl_circe_alert(f->c, "agility", "E1E1E1", reply, sizeof(reply)),
                         -ECONNREFUSED);
        assert_non_null(strstr(reply, "not running"));
        /* A directory that does not exist. */
        assert_int_equal(sl_set_runtime_dir(f->c, "/nonexistent/sharedlink"), 0);
        assert_int_equal(sl_request(f->c, "ping", 0, NULL, NULL, reply, sizeof(reply)),
                         -ECONNREFUSED);
}

static void test_no_answer(void **state)
{
        struct fixture *f = *state;
        char reply[REPLY_SIZE];

        /* Listening, never accepting: the request is queued, no reply ever comes. */
        f->listen_fd = bind_socket(f, 1);
        assert_int_equal(sl_request(f->c, "ping", SHORT_MS, NULL, NULL, reply, sizeof(reply)),
                         -ETIMEDOUT);
        assert_true(reply[0] != '\0');
}

/* A daemon that never stops answering: every DATA line consumed makes another one arrive, so the
 * socket is never empty when the client reads. */
struct flooder {
        int listen_fd;
        _Atomic int fd;
        size_t lines;
};

static void *flood_accept(void *arg)
{
        struct flooder *fl = arg;
        char ch;
        int fd = accept(fl->listen_fd, NULL, NULL);

        if (fd < 0)
                return NULL;
        while (read(fd, &ch, 1) == 1 && ch != '\n')
                ;
        atomic_store(&fl->fd, fd);
        if (send(fd, "DATA x\n", 7, MSG_NOSIGNAL) != 7)
                atomic_store(&fl->fd, -1);
        return NULL;
}

static int flood_more(const char *text, void *arg)
{
        struct flooder *fl = arg;
        int fd = atomic_load(&fl->fd);

        (void)text;
        fl->lines++;
        if (fd >= 0 && send(fd, "DATA x\n", 7, MSG_NOSIGNAL) != 7)
                return -EIO;
        return 0;
}

static void test_reply_flood(void **state)
{
        struct fixture *f = *state;
        struct flooder fl = { .fd = -1 };
        char reply[REPLY_SIZE];
        pthread_t th;
        int fd;

        f->listen_fd = bind_socket(f, 1);
        fl.listen_fd = f->listen_fd;
        assert_int_equal(pthread_create(&th, NULL, flood_accept, &fl), 0);
        /* The deadline holds even though data never stops coming. */
        assert_int_equal(sl_request(f->c, "ping", SHORT_MS, flood_more, &fl, reply,
                                    sizeof(reply)), -ETIMEDOUT);
        pthread_join(th, NULL);
        assert_true(fl.lines > 0);
        fd = atomic_load(&fl.fd);
        if (fd >= 0)
                close(fd);
}

/* ---- the socket path the tables publish (layout 1.2) --------------------------------------- */

/* The handle connects where the tables say: a listener that never accepts leaves it waiting. */
static void assert_uses_published(struct fixture *f)
{
        char reply[REPLY_SIZE];

        assert_int_equal(sl_request(f->c, "ping", SHORT_MS, NULL, NULL, reply, sizeof(reply)),
                         -ETIMEDOUT);
}

/* The handle connects to "<dir>/<instance>.sock", where nobody listens. */
static void assert_uses_dir(struct fixture *f, const char *dir)
{
        char reply[REPLY_SIZE], want[REPLY_SIZE];

        snprintf(want, sizeof(want), "%s/%s.sock", dir, f->instance);
        assert_int_equal(sl_request(f->c, "ping", SHORT_MS, NULL, NULL, reply, sizeof(reply)),
                         -ECONNREFUSED);
        assert_non_null(strstr(reply, want));
}

static void test_published_precedence(void **state)
{
        struct fixture *f = *state;

        f->listen_fd = bind_socket(f, 1);
        /* Neither a call nor the environment said where: the published path. */
        assert_uses_published(f);
        /* The environment (read at sl_open or sl_set_runtime_dir(NULL)) comes before it. */
        assert_int_equal(setenv("SHAREDLINK_RUNTIME_DIR", "/nonexistent/env", 1), 0);
        assert_int_equal(sl_set_runtime_dir(f->c, NULL), 0);
        assert_uses_dir(f, "/nonexistent/env");
        /* An explicit directory comes first, whatever the environment says. */
        assert_int_equal(sl_set_runtime_dir(f->c, "/nonexistent/set"), 0);
        assert_uses_dir(f, "/nonexistent/set");
        unsetenv("SHAREDLINK_RUNTIME_DIR");
        assert_uses_dir(f, "/nonexistent/set");
        /* Back to no choice: the published path again. */
        assert_int_equal(sl_set_runtime_dir(f->c, NULL), 0);
        assert_uses_published(f);
}

/* A scribbled field (the .in object may be forged): the default, never a crash or overread. */
static void test_published_hostile(void **state)
{
        struct fixture *f = *state;
        struct shmtest_view v;
        struct shm_in_header *h;
        char saved[SHM_SOCKET_PATH_SIZE], other[SHM_SOCKET_PATH_SIZE], name[SHM_OBJECT_NAME_SIZE];
        const char *bad[] = { "relative/x.sock", "/tmp/other.sock", "/tmp/\001/@.sock",
                              "/tmp/@.sockx", "/tmp/@.sock/", "/tmp/x@.sock", "@.sock" };

        f->listen_fd = bind_socket(f, 1);
        assert_int_equal(shm_layout_object_name(f->instance, "in", name, sizeof(name)), 0);
        v = shmtest_view_open(name, 1);
        h = shmtest_in_header(&v);
        assert_non_null(v.base);
        memcpy(saved, h->control_socket, sizeof(saved));
        /* No NUL within the field. */
        memset(h->control_socket, 'A', sizeof(h->control_socket));
        h->control_socket[0] = '/';
        assert_uses_dir(f, SL_RUNTIME_DIR_DEFAULT);
        /* Paths that do not name this instance's socket ("@" stands for the instance). */
        for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
                char *at = strchr(bad[i], '@');
                int n = at ? (int)(at - bad[i]) : (int)strlen(bad[i]);

                snprintf(other, sizeof(other), "%.*s%s%s", n, bad[i], at ? f->instance : "",
                         at ? at + 1 : "");
                memset(h->control_socket, 0, sizeof(h->control_socket));
                memcpy(h->control_socket, other, strlen(other));
                assert_uses_dir(f, SL_RUNTIME_DIR_DEFAULT);
        }
        /* A valid path in an older layout is reserved bytes, not a path. */
        memcpy(h->control_socket, saved, sizeof(saved));
        h->layout_version = (SHM_LAYOUT_MAJOR << 16) | (SHM_LAYOUT_MINOR_SOCKET - 1u);
        assert_uses_dir(f, SL_RUNTIME_DIR_DEFAULT);
        /* Restored: used again. */
        h->layout_version = SHM_LAYOUT_VERSION;
        assert_uses_published(f);
        shmtest_view_close(&v);
}

/* Tables of an older daemon (field empty): the default, as before layout 1.2. */
static void test_published_none(void **state)
{
        struct fixture *f = *state;

        assert_int_equal(sl_set_runtime_dir(f->c, NULL), 0);
        assert_uses_dir(f, SL_RUNTIME_DIR_DEFAULT);
}

static void test_settings(void **state)
{
        struct fixture *f = *state;
        char dir[200], reply[REPLY_SIZE];

        assert_int_equal(sl_set_runtime_dir(NULL, "/tmp"), -EINVAL);
        assert_int_equal(sl_set_runtime_dir(f->c, ""), -EINVAL);
        /* The socket path must fit a sockaddr_un. */
        memset(dir, 'd', sizeof(dir) - 1);
        dir[0] = '/';
        dir[sizeof(dir) - 1] = '\0';
        assert_int_equal(sl_set_runtime_dir(f->c, dir), -ENAMETOOLONG);
        assert_int_equal(sl_request(f->c, "ping", 0, NULL, NULL, reply, sizeof(reply)),
                         -ENAMETOOLONG);
        /* NULL: back to $SHAREDLINK_RUNTIME_DIR. */
        assert_int_equal(setenv("SHAREDLINK_RUNTIME_DIR", f->dir, 1), 0);
        assert_int_equal(sl_set_runtime_dir(f->c, NULL), 0);
        assert_int_equal(sl_request(f->c, "ping", 0, NULL, NULL, reply, sizeof(reply)),
                         -ECONNREFUSED);
        assert_non_null(strstr(reply, f->sock));
        unsetenv("SHAREDLINK_RUNTIME_DIR");
        assert_int_equal(sl_set_runtime_dir(f->c, NULL), 0);
        assert_int_equal(sl_request(f->c, "ping", 0, NULL, NULL, reply, sizeof(reply)),
                         -ECONNREFUSED);
        assert_non_null(strstr(reply, SL_RUNTIME_DIR_DEFAULT "/"));

        assert_int_equal(sl_set_command_wait(NULL, 0), -EINVAL);
        assert_int_equal(sl_set_command_wait(f->c, -1), -EINVAL);
        assert_int_equal(sl_set_command_wait(f->c, SL_WAIT_MAX_MS + 1), -EINVAL);
        assert_int_equal(sl_set_command_wait(f->c, SL_WAIT_MAX_MS), 0);

        /* Every error of the commands has its own message. */
        {
                static const int codes[] = { ECONNREFUSED, ETIMEDOUT, ECONNRESET, ENAMETOOLONG,
                                             EOPNOTSUPP, ENOTCONN, EPROTO, EACCES, EINVAL };

                for (size_t i = 0; i < sizeof(codes) / sizeof(codes[0]); i++) {
                        assert_string_not_equal(sl_strerror(-codes[i]), "unexpected error");
                        for (size_t j = 0; j < i; j++)
                                assert_string_not_equal(sl_strerror(-codes[i]),
                                                        sl_strerror(-codes[j]));
                }
        }
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_line_check),
                cmocka_unit_test_setup_teardown(test_arguments_refused, setup, teardown),
                cmocka_unit_test_setup_teardown(test_visualize_refused, setup, teardown),
                cmocka_unit_test_setup_teardown(test_wire_words, setup, teardown),
                cmocka_unit_test_setup_teardown(test_not_running, setup, teardown),
                cmocka_unit_test_setup_teardown(test_no_answer, setup, teardown),
                cmocka_unit_test_setup_teardown(test_reply_flood, setup, teardown),
                cmocka_unit_test_setup_teardown(test_settings, setup, teardown),
                cmocka_unit_test_setup_teardown(test_published_precedence, setup_published,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_published_hostile, setup_published,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_published_none, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
