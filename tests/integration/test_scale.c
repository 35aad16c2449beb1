/*
 * The real sharedlinkd at the instance's cap (CONFIG_VARS_MAX, 4,096 configured variables): 16
 * SharedLink links on pty pairs, each with one peer (B) whose outbound and inbound lists hold
 * 128 variables each, "o<link>_<pos>" and "i<link>_<pos>". The daemon starts with them, the
 * library finds every one where the configuration put it, values go both ways at both ends of the
 * table (its first and last outbound variables, its first and last inbound ones; ids 0 and 4,095
 * are among them), and `slctl list` shows every variable once.
 *
 * Work is bounded by counts (4,096 look-ups, one `slctl list`, four frames each way); every wait
 * is for an event with a timeout that only turns a hang into a failure. The daemon starts once,
 * for the whole group.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>
#include <sharedlink.h>

#include "common/harness.h"
#include "common/slwait.h"
#include "common/wire.h"
#include "daemon/config_types.h"

#define SCALE_VARS      4096u           /* the cap this test is at (issue 23: raised from 1,024) */
#define LINKS           CONFIG_LINKS_MAX
#define PER_LIST        (SCALE_VARS / LINKS / 2u)       /* one outbound, one inbound list a link */
#define OWN             'A'             /* every link's own address */
#define PEER            'B'             /* and its one peer's */
#define START_MS        30000           /* failure bounds only, never a measurement */
#define WAIT_MS         10000
#define YAML_MAX        (128u * 1024u)  /* 4,096 names of up to 8 bytes and 16 links' keys */
#define LIST_OUT_MAX    (1024u * 1024u) /* `slctl list`: 4,097 lines of about 50 bytes */
#define LINE_MAX_T      1024
#define FRAMES_MAX      8               /* frames read from a master before giving up on one */
#define NAME_SIZE       16

_Static_assert(PER_LIST <= CONFIG_LIST_MAX, "a list of the test fits a list of the config");
_Static_assert(SCALE_VARS == 2u * LINKS * PER_LIST, "the lists add up to the cap");

struct scale {
        struct harness h;
        struct sl_client *c;
        int master[LINKS], slave[LINKS];
};

enum dir { DIR_OUT, DIR_IN };

static void var_name(char *buf, enum dir d, unsigned link, unsigned pos)
{
        snprintf(buf, NAME_SIZE, "%c%u_%u", d == DIR_OUT ? 'o' : 'i', link, pos);
}

/* Appends to the configuration; a configuration larger than YAML_MAX is a bug of the test. */
static void yaml_add(char *buf, size_t *len, const char *fmt, ...)
        __attribute__((format(printf, 3, 4)));

static void yaml_add(char *buf, size_t *len, const char *fmt, ...)
{
        va_list ap;
        int n;

        va_start(ap, fmt);
        n = vsnprintf(buf + *len, YAML_MAX - *len, fmt, ap);
        va_end(ap);
        if (n < 0 || (size_t)n >= YAML_MAX - *len) {
                fprintf(stderr, "test_scale: the configuration outgrew YAML_MAX\n");
                abort();
        }
        *len += (size_t)n;
}

static void yaml_list(char *buf, size_t *len, const char *key, enum dir d, unsigned link)
{
        char name[NAME_SIZE];

        yaml_add(buf, len, "        %s: [", key);
        for (unsigned j = 0; j < PER_LIST; j++) {
                var_name(name, d, link, j);
                yaml_add(buf, len, "%s%s", j ? ", " : "", name);
        }
        yaml_add(buf, len, "]\n");
}

/* Links l0..l15 on <dir>/tty<k> (the slaves of our ptys): no periodic send, every write sent at
 * once, never stale, so that a frame on a master is the one a write caused. */
static char *config_build(struct scale *s)
{
        char *yaml = malloc(YAML_MAX), pts[HARNESS_PATH_MAX], dev[HARNESS_PATH_MAX + 16];
        size_t len = 0;

        assert_non_null(yaml);
        yaml_add(yaml, &len, "links:\n");
        for (unsigned k = 0; k < LINKS; k++) {
                assert_int_equal(harness_openpty(&s->master[k], &s->slave[k], pts), 0);
                snprintf(dev, sizeof(dev), "%s/tty%u", s->h.dir, k);
                assert_int_equal(symlink(pts, dev), 0);
                yaml_add(yaml, &len,
                         "  - name: l%u\n"
                         "    protocol: sharedlink\n"
                         "    transport: serial\n"
                         "    device: %s\n"
                         "    address: %c\n"
                         "    peers:\n"
                         "      - address: %c\n"
                         "        period_ms: 0\n"
                         "        on_change: true\n"
                         "        min_interval_ms: 0\n"
                         "        stale_ms: 0\n", k, dev, OWN, PEER);
                yaml_list(yaml, &len, "outbound", DIR_OUT, k);
                yaml_list(yaml, &len, "inbound", DIR_IN, k);
        }
        return yaml;
}

static int group_setup(void **state)
{
        struct scale *s = calloc(1, sizeof(*s));
        char why[HARNESS_WHY_MAX];
        char *yaml;
        int r;

        if (!s || harness_init(&s->h, "scale") < 0)
                return -1;
        for (unsigned k = 0; k < LINKS; k++)
                s->master[k] = s->slave[k] = -1;
        *state = s;
        yaml = config_build(s);
        r = harness_start_config(&s->h, "scale.yaml", yaml, START_MS, why, sizeof(why));
        free(yaml);
        if (r < 0) {
                fprintf(stderr, "test_scale: the daemon did not start: %s\n", why);
                return -1;
        }
        return sl_open(s->h.instance, &s->c) == 0 ? 0 : -1;
}

static int group_teardown(void **state)
{
        struct scale *s = *state;

        if (!s)
                return 0;
        sl_close(s->c);
        harness_cleanup(&s->h);
        for (unsigned k = 0; k < LINKS; k++) {
                harness_close_fd(&s->master[k]);
                harness_close_fd(&s->slave[k]);
        }
        free(s);
        return 0;
}

/* The id of a variable the configuration has: where it says, in the configuration's order. */
static int expect_var(struct scale *s, enum dir d, unsigned link, unsigned pos)
{
        struct sl_var_info info = { .size = sizeof(info) };
        char name[NAME_SIZE];
        int id;

        var_name(name, d, link, pos);
        id = sl_find(s->c, name);
        if (id < 0)
                fail_msg("sl_find(%s): %s", name, sl_strerror(id));
        assert_int_equal(sl_info(s->c, id, &info), 0);
        assert_string_equal(info.name, name);
        assert_int_equal(info.direction, d == DIR_OUT ? SL_DIR_OUT : SL_DIR_IN);
        assert_int_equal(info.link, (int)link);
        assert_int_equal(info.position, (int)pos);
        assert_int_equal(info.peer[0], PEER);
        assert_int_equal(info.peer[1], '\0');
        return id;
}

/* ---------------------------------------------------------------------------------------------
 * Tests */

/* Every configured variable is there, once, where the configuration put it: ids 0..4,095 in the
 * configuration's order (link by link, each peer's outbound list before its inbound one). */
static void test_find_all(void **state)
{
        struct scale *s = *state;
        bool *seen = calloc(SCALE_VARS, sizeof(*seen));

        assert_non_null(seen);
        assert_int_equal(CONFIG_VARS_MAX, SCALE_VARS);
        assert_int_equal(sl_count(s->c), (int)SCALE_VARS);
        for (unsigned k = 0; k < LINKS; k++)
                for (unsigned d = DIR_OUT; d <= DIR_IN; d++)
                        for (unsigned j = 0; j < PER_LIST; j++) {
                                int id = expect_var(s, (enum dir)d, k, j);

                                assert_int_equal(id, (int)((k * 2u + d) * PER_LIST + j));
                                assert_false(seen[id]);
                                seen[id] = true;
                        }
        free(seen);
}

/* Reads lines from link's master until one is exactly the frame [:BA|text|Cxx] CR LF; at most
 * FRAMES_MAX lines (nothing else was written, so the first frame should be it). */
static void expect_frame(struct scale *s, unsigned link, const char *text)
{
        char want[LINE_MAX_T], line[LINE_MAX_T];

        wire_slp_frame(want, sizeof(want), PEER, OWN, text, true);
        for (int i = 0; i < FRAMES_MAX; i++) {
                ssize_t n = harness_read_until(s->master[link], line, sizeof(line), '\n',
                                               WAIT_MS);

                if (n <= 0)
                        fail_msg("link %u: no frame %s (%zd)", link, want, n);
                if (strcmp(line, want) == 0)
                        return;
        }
        fail_msg("link %u: frame %s not among the first %d", link, want, FRAMES_MAX);
}

/* Writes value to outbound variable pos of link: it goes out on that link's master at once. */
static void write_end(struct scale *s, unsigned link, unsigned pos, const char *value)
{
        char body[LINE_MAX_T];

        assert_int_equal(sl_write(s->c, expect_var(s, DIR_OUT, link, pos), value), 0);
        snprintf(body, sizeof(body), "N%u|D%s", pos, value);
        expect_frame(s, link, body);
}

/* The peer sets its outbound position pos on link: inbound variable pos of link reads value. */
static void read_end(struct scale *s, unsigned link, unsigned pos, const char *value)
{
        char frame[LINE_MAX_T], body[LINE_MAX_T], name[NAME_SIZE], last[SL_VALUE_SIZE];
        size_t n;

        expect_var(s, DIR_IN, link, pos);
        snprintf(body, sizeof(body), "N%u|D%s", pos, value);
        n = wire_slp_frame(frame, sizeof(frame), OWN, PEER, body, true);
        assert_int_equal(harness_write_all(s->master[link], frame, n, WAIT_MS), 0);
        var_name(name, DIR_IN, link, pos);
        if (slwait_value(s->c, name, value, WAIT_MS, last, sizeof(last)) < 0)
                fail_msg("%s never read %s (last \"%s\")", name, value, last);
}

/* The four ends: values land where they belong, whatever the table's size. */
static const struct end {
        enum dir d;
        unsigned link, pos;
        const char *value;
} ends[] = {
        { DIR_OUT, 0, 0, "first-out" },                         /* id 0 */
        { DIR_OUT, LINKS - 1, PER_LIST - 1, "last-out" },
        { DIR_IN, 0, 0, "first-in" },
        { DIR_IN, LINKS - 1, PER_LIST - 1, "last-in" },         /* id 4,095 */
};

/* The row of name in `slctl list`'s output, or NULL. */
static const char *list_row(const char *out, const char *name)
{
        size_t len = strlen(name);

        for (const char *p = out; p && *p; p = strchr(p, '\n'), p = p ? p + 1 : NULL)
                if (strncmp(p, name, len) == 0 && p[len] == ' ')
                        return p;
        return NULL;
}

/* Counts `slctl list`'s rows (after its header) by name: every variable exactly once. */
static void list_check_all(const char *out)
{
        bool *seen = calloc(SCALE_VARS, sizeof(*seen));
        unsigned rows = 0;
        const char *p = strchr(out, '\n');

        assert_non_null(seen);
        assert_int_equal(strncmp(out, "NAME ", 5), 0);
        for (p = p ? p + 1 : NULL; p && *p; p = strchr(p, '\n'), p = p ? p + 1 : NULL) {
                unsigned k, j, index;
                char kind, after;

                if (sscanf(p, "%c%u_%u%c", &kind, &k, &j, &after) != 4 || after != ' ' ||
                    (kind != 'o' && kind != 'i') || k >= LINKS || j >= PER_LIST)
                        fail_msg("slctl list: a row not of the configuration: %.60s", p);
                index = (k * 2u + (kind == 'i')) * PER_LIST + j;
                assert_false(seen[index]);
                seen[index] = true;
                rows++;
        }
        assert_int_equal(rows, SCALE_VARS);
        free(seen);
}

/* Values both ways at both ends of the table, then `slctl list`: every variable once, the ends
 * with their values. */
static void test_ends_and_list(void **state)
{
        struct scale *s = *state;
        const char *const argv[] = { harness_slctl_path(), "list", NULL };
        char *out = malloc(LIST_OUT_MAX);
        int r;

        assert_non_null(out);
        assert_int_equal(slwait_link_state(s->c, 0, "up", WAIT_MS), 0);
        assert_int_equal(slwait_link_state(s->c, LINKS - 1, "up", WAIT_MS), 0);
        for (size_t i = 0; i < sizeof(ends) / sizeof(ends[0]); i++) {
                if (ends[i].d == DIR_OUT)
                        write_end(s, ends[i].link, ends[i].pos, ends[i].value);
                else
                        read_end(s, ends[i].link, ends[i].pos, ends[i].value);
        }

        r = harness_run(&s->h, out, LIST_OUT_MAX, WAIT_MS, argv);
        if (r != 0)
                fail_msg("slctl list: exit %d", r);
        assert_true(strlen(out) < LIST_OUT_MAX - 1);    /* all of it, not cut */
        list_check_all(out);
        for (size_t i = 0; i < sizeof(ends) / sizeof(ends[0]); i++) {
                char name[NAME_SIZE];
                const char *row, *eol;
                size_t vlen = strlen(ends[i].value);

                var_name(name, ends[i].d, ends[i].link, ends[i].pos);
                row = list_row(out, name);
                assert_non_null(row);
                eol = strchr(row, '\n');
                assert_non_null(eol);
                /* the value is the row's last column */
                assert_true((size_t)(eol - row) > vlen && eol[-(long)vlen - 1] == ' ');
                assert_memory_equal(eol - vlen, ends[i].value, vlen);
        }
        free(out);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_find_all),
                cmocka_unit_test(test_ends_and_list),
        };

        return cmocka_run_group_tests(tests, group_setup, group_teardown);
}
