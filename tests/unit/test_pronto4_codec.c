/*
 * The Pronto4 dialect's reading of a frame (src/proto/pronto4.c), table-driven: each row is a
 * frame of docs/pronto4.md (or a bad variant of one) as text, decoded by the SharedLink decoder
 * with its checksum computed, and what p4_decode() must make of it. Entries are written as
 *     Q<name>:<T>[=<value>]   a good entry (Q or R), its type digit, its D if it has one
 *     !<name>                 a bad entry with a Q field (the name kept when it is one)
 *     ~                       a bad entry without a Q (a stray D, a T without its name ...)
 * separated by single spaces. Also the connect texts of a host (§9).
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "common/wire.h"
#include "proto/pronto4.h"

#define COUNT(a)        (sizeof(a) / sizeof((a)[0]))
#define SPEC_MAX        1024

struct row {
        const char *what;
        const char *frame;              /* ":BA|..." without checksum */
        enum slp_p4_kind kind;
        char head;
        uint32_t index;
        size_t bad;
        const char *entries;
        const char *module;             /* commands and MU: module (and text) */
        const char *text;
        bool command_ok;
        size_t extra;
};

static const struct row rows[] = {
        /* §4: a declaration, one untyped entry (a double) */
        { "declaration", ":BA|N0|T0|Qveh_start|T2|Qjoy_steer|Qsvp_enb_eng", SLP_P4_DECLARATION,
          'N', 0, 0, "Qveh_start:0 Qjoy_steer:2 Qsvp_enb_eng:2", NULL, NULL, false, 0 },
        { "L declaration", ":BA|L0|T2|QAutoGpsLat|T4|QVehicleName", SLP_P4_DECLARATION, 'L', 0,
          0, "QAutoGpsLat:2 QVehicleName:4", NULL, NULL, false, 0 },
        { "continued at 3", ":BA|N3|T0|Qa|T4|Qb", SLP_P4_DECLARATION, 'N', 3, 0, "Qa:0 Qb:4",
          NULL, NULL, false, 0 },
        /* a bad T keeps its place and its name; a bad name keeps its place, not its name */
        { "bad type", ":BA|L0|T9|Qbadtype|T0|Qgood", SLP_P4_DECLARATION, 'L', 0, 1,
          "!badtype Qgood:0", NULL, NULL, false, 0 },
        { "bad name", ":BA|N0|T0|Qsp ace|T0|Qok", SLP_P4_DECLARATION, 'N', 0, 1, "! Qok:0",
          NULL, NULL, false, 0 },
        { "T without its name", ":BA|N0|T0|Qa|T2", SLP_P4_DECLARATION, 'N', 0, 1, "Qa:0 ~",
          NULL, NULL, false, 0 },
        { "stray R in a declaration", ":BA|L0|T0|Qx|Rstray|T2|Qy", SLP_P4_DECLARATION, 'L', 0,
          0, "Qx:0 Rstray:2 Qy:2", NULL, NULL, false, 0 },
        { "L with D is a declaration", ":BA|L0|T0|Qx|D1", SLP_P4_DECLARATION, 'L', 0, 0,
          "Qx:0=1", NULL, NULL, false, 0 },
        /* §5: the acknowledgement */
        { "acknowledgement", ":AB|N0|Rvideo_mux1|D0|Rveh_brake|D100", SLP_P4_ACKNOWLEDGEMENT,
          'N', 0, 0, "Rvideo_mux1:2=0 Rveh_brake:2=100", NULL, NULL, false, 0 },
        { "acknowledgement, R without D", ":AB|N0|Ra|D1|Rb", SLP_P4_ACKNOWLEDGEMENT, 'N', 0, 0,
          "Ra:2=1 Rb:2", NULL, NULL, false, 0 },
        /* §7: self-describing */
        { "self-describing", ":AB|N0|T4|QVehicleName|DVEH_1|T2|QAutoGpsLat|D0",
          SLP_P4_SELF_DESCRIBING, 'N', 0, 0, "QVehicleName:4=VEH_1 QAutoGpsLat:2=0", NULL, NULL,
          false, 0 },
        { "self-describing, Q without D", ":AB|N0|T4|Qa|Dx|T0|Qb", SLP_P4_SELF_DESCRIBING, 'N',
          0, 0, "Qa:4=x Qb:0", NULL, NULL, false, 0 },
        { "self-describing, bad T", ":AB|N0|T5|Qa|Dx|T0|Qb|D1", SLP_P4_SELF_DESCRIBING, 'N', 0,
          1, "!a Qb:0=1", NULL, NULL, false, 0 },
        /* data, queries, ping: no entries */
        { "data", ":BA|N0|D0|D1", SLP_P4_DATA, 'N', 0, 0, "", NULL, NULL, false, 0 },
        { "L?", ":BA|L?", SLP_P4_LIST_QUERY, 'L', SLP_INDEX_QUERY, 0, "", NULL, NULL, false, 0 },
        { "N?", ":BA|N?", SLP_P4_LIST_QUERY, 'N', SLP_INDEX_QUERY, 0, "", NULL, NULL, false, 0 },
        { "ping", ":AB|P0", SLP_P4_PING, 'P', 0, 0, "", NULL, NULL, false, 0 },
        { "pong", ":BA|G0", SLP_P4_PONG, 'G', 0, 0, "", NULL, NULL, false, 0 },
        /* §9: commands */
        { "command", ":BA|EServoPod|D0,TELEOP START", SLP_P4_COMMAND, 'E', 0, 0, "",
          "ServoPod", "0,TELEOP START", true, 0 },
        { "command without text", ":BA|ELink", SLP_P4_COMMAND, 'E', 0, 0, "", "Link", "", true,
          0 },
        { "command, more fields", ":BA|ELink|D0, inbound, on|D1|Qx", SLP_P4_COMMAND, 'E', 0, 0,
          "", "Link", "0, inbound, on", true, 2 },
        { "command, bad module", ":BA|EServo Pod|D0,Stop", SLP_P4_COMMAND, 'E', 0, 0, "",
          "Servo Pod", "0,Stop", false, 0 },
        { "command, text too long", ":BA|EPhysics|D"
          "0123456789012345678901234567890123456789012345678901234567890123", SLP_P4_COMMAND,
          'E', 0, 0, "", "Physics",
          "0123456789012345678901234567890123456789012345678901234567890123", false, 0 },
        { "MUI", ":BA|MUI", SLP_P4_MU, 'M', 0, 0, "", "UI", "", true, 0 },
        { "MW", ":BA|MW", SLP_P4_MU, 'M', 0, 0, "", "W", "", true, 0 },
        { "MX is nothing", ":BA|MX", SLP_P4_OTHER, 'M', 0, 0, "", "", "", false, 0 },
        { "a query", ":BA|Qname", SLP_P4_OTHER, 'Q', 0, 0, "", "", "", false, 0 },
};

/* The frame of ":<dst><src>|..." decoded by a fresh decoder. */
static const struct slp_frame *decode(struct slp_decoder *d, const char *text)
{
        char raw[SLP_FRAME_MAX];
        size_t n = wire_slp_raw(raw, sizeof(raw), text, false), used = 0;
        struct slp_decode_result r = { 0 };

        assert_true(n > 0);
        assert_int_equal(slp_decoder_init(d, SLP_FRAME_MAX), 0);
        while (used < n && r.kind != SLP_RESULT_FRAME)
                used += slp_decoder_feed(d, (const uint8_t *)raw + used, n - used, &r);
        assert_int_equal(r.kind, SLP_RESULT_FRAME);
        return r.frame;
}

static void entries_spec(const struct p4_message *m, char *out, size_t size)
{
        size_t len = 0;

        out[0] = '\0';
        for (size_t k = 0; k < m->n_entries; k++) {
                const struct p4_entry *e = &m->entries[k];
                const char *sep = k ? " " : "";

                if (e->status == P4_ENTRY_BAD && e->positional)
                        len += (size_t)snprintf(out + len, size - len, "%s!%.*s", sep,
                                                (int)e->name_len, e->name ? e->name : "");
                else if (e->status == P4_ENTRY_BAD)
                        len += (size_t)snprintf(out + len, size - len, "%s~", sep);
                else
                        len += (size_t)snprintf(out + len, size - len, "%s%c%.*s:%c", sep,
                                                e->letter, (int)e->name_len, e->name,
                                                slp_type_digit(e->type));
                if (e->status == P4_ENTRY_OK && e->has_value)
                        len += (size_t)snprintf(out + len, size - len, "=%.*s",
                                                (int)e->value_len, e->value);
                assert_true(len < size);
        }
}

static void test_decode_rows(void **state)
{
        static struct slp_decoder d;
        static struct p4_message m;
        char spec[SPEC_MAX];

        (void)state;
        for (size_t i = 0; i < COUNT(rows); i++) {
                const struct row *r = &rows[i];

                p4_decode(decode(&d, r->frame), &m);
                entries_spec(&m, spec, sizeof(spec));
                if (m.kind != r->kind || m.head != r->head || m.index != r->index ||
                    m.bad_entries != r->bad || strcmp(spec, r->entries) != 0)
                        fail_msg("%s: kind %d head %c index %u bad %zu entries \"%s\"", r->what,
                                 m.kind, m.head, m.index, m.bad_entries, spec);
                if (!r->module) {
                        assert_int_equal(m.module_len, 0);
                        continue;
                }
                if (m.module_len != strlen(r->module) ||
                    memcmp(m.module, r->module, m.module_len) != 0 ||
                    m.text_len != strlen(r->text) || memcmp(m.text, r->text, m.text_len) != 0 ||
                    m.command_ok != r->command_ok || m.extra_fields != r->extra)
                        fail_msg("%s: module \"%.*s\" text \"%.*s\" ok %d extra %zu", r->what,
                                 (int)m.module_len, m.module, (int)m.text_len, m.text,
                                 m.command_ok, m.extra_fields);
        }
}

/* A message reused for another frame keeps nothing of the last one. */
static void test_decode_reuse(void **state)
{
        static struct slp_decoder d;
        static struct p4_message m;

        (void)state;
        p4_decode(decode(&d, ":BA|EServoPod|D0,Stop|D1"), &m);
        assert_int_equal(m.extra_fields, 1);
        p4_decode(decode(&d, ":BA|N0|T7|Qa"), &m);
        assert_int_equal(m.kind, SLP_P4_DECLARATION);
        assert_int_equal(m.module_len, 0);
        assert_false(m.command_ok);
        assert_int_equal(m.extra_fields, 0);
        assert_int_equal(m.n_entries, 1);
        p4_decode(decode(&d, ":BA|P0"), &m);
        assert_int_equal(m.n_entries, 0);
        assert_int_equal(m.bad_entries, 0);
}

/* §9: the texts of a host's connect sequence, byte for byte as in the docs' frames. */
static void test_connect_texts(void **state)
{
        char text[P4_SETIP_TEXT_MAX];

        (void)state;
        assert_int_equal(p4_setip_text(text, sizeof(text), "192.168.200.10:4220", 4000),
                         (int)strlen("0, SetIP, 192.168.200.10:4220, 4000"));
        assert_string_equal(text, "0, SetIP, 192.168.200.10:4220, 4000");
        assert_int_equal(p4_setip_text(text, sizeof(text), "[::1]:4220", 4000),
                         (int)strlen("0, SetIP, [::1]:4220, 4000"));
        assert_string_equal(text, "0, SetIP, [::1]:4220, 4000");
        /* Too small a buffer: refused, never cut. */
        assert_int_equal(p4_setip_text(text, 10, "127.0.0.1:1", 4000), -ENOSPC);
        assert_string_equal(P4_CONNECT_MODULE, "Link");
        assert_string_equal(P4_TEXT_OUTBOUND_ON, "0, outbound, on");
        assert_string_equal(P4_TEXT_INBOUND_ON, "0, inbound, on");
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_decode_rows),
                cmocka_unit_test(test_decode_reuse),
                cmocka_unit_test(test_connect_texts),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
