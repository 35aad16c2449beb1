/*
 * libFuzzer target for the Pronto4 dialect's reading of a frame (src/proto/pronto4.c).
 *
 * The input is one datagram of wire bytes (seeds in tests/fuzz/corpus/pronto4/: the frames of
 * docs/pronto4.md), decoded by the SharedLink decoder; every frame is taken apart by
 * p4_decode(). Checks (a broken invariant is a __builtin_trap()):
 *   - the kind is slp_p4_kind_of()'s; only a declaration, an acknowledgement or a
 *     self-describing frame has entries, one per slp_entry_next() step, the bad ones counted;
 *   - every name and value points inside the frame; an OK entry's name is a name and its type
 *     one of T0/T2/T4; a bad entry's kept name is a name; a positional entry has a Q;
 *   - a declaration whose entries are all good re-encodes (slp_encode_declaration(), split into
 *     frames) to frames that p4_decode() reads back as the same names and types in order; an
 *     acknowledgement likewise through slp_encode_acknowledgement() with its values;
 *   - a command is command_ok exactly when slp_encode_command() takes its module and text, and
 *     the frame it encodes reads back as the same module and text;
 *   - p4_setip_text() gives the text it says, or -ENOSPC with a buffer too small.
 */
#include <errno.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "proto/pronto4.h"
#include "fuzz_input.h"

#define FUZZ_NAMES_MAX  SLP_FIELDS_MAX
#define FUZZ_TEXT_MAX   (SLP_VALUE_MAX + 1)

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static struct slp_decoder dec, redec;
static struct p4_message msg, again;
static char names[FUZZ_NAMES_MAX][SLP_VALUE_MAX + 1], values[FUZZ_NAMES_MAX][SLP_VALUE_MAX + 1];
static const char *name_ptrs[FUZZ_NAMES_MAX], *value_ptrs[FUZZ_NAMES_MAX];
static enum slp_type types[FUZZ_NAMES_MAX];
static char buf[SLP_FRAME_MAX];

static bool inside(const struct slp_frame *f, const char *p, size_t len)
{
        return p >= f->raw && p + len <= f->raw + f->raw_len;
}

/* The one frame in buf[0..n), decoded by redec. */
static const struct slp_frame *decode_one(int n)
{
        struct slp_decode_result r = { 0 };
        size_t used = 0;

        CHECK(n > 0);
        slp_decoder_reset(&redec);
        while (used < (size_t)n && r.kind != SLP_RESULT_FRAME)
                used += slp_decoder_feed(&redec, (const uint8_t *)buf + used, (size_t)n - used,
                                         &r);
        CHECK(r.kind == SLP_RESULT_FRAME);
        return r.frame;
}

static void check_entries(const struct slp_frame *f, const struct p4_message *m)
{
        size_t pos = 1, steps = 0, bad = 0;
        struct slp_entry e;
        int r;

        while ((r = slp_entry_next(f, &pos, &e)) != 0)
                steps++;
        CHECK(m->n_entries == steps);
        for (size_t k = 0; k < m->n_entries; k++) {
                const struct p4_entry *pe = &m->entries[k];

                CHECK(pe->name_len == 0 || inside(f, pe->name, pe->name_len));
                CHECK(pe->name_len == 0 || slp_name_check(pe->name, pe->name_len) == 0);
                if (pe->status == P4_ENTRY_BAD) {
                        bad++;
                        continue;
                }
                CHECK(pe->status == P4_ENTRY_OK && pe->name_len > 0);
                CHECK(pe->letter == 'Q' || pe->letter == 'R');
                CHECK(pe->positional == (pe->letter == 'Q'));
                CHECK(slp_type_digit(pe->type) != 0);
                CHECK(!pe->has_value || inside(f, pe->value, pe->value_len));
        }
        CHECK(bad == m->bad_entries);
}

/* A declaration or acknowledgement of good entries goes out and comes back the same. */
static void check_named_roundtrip(const struct slp_frame *f, const struct p4_message *m)
{
        bool decl = m->kind == SLP_P4_DECLARATION;
        struct slp_named_list nl = {
                .dst = f->dst, .src = f->src, .head = m->head, .names = name_ptrs,
                .types = types, .values = value_ptrs, .count = m->n_entries,
        };
        size_t cursor = 0, seen = 0;

        if (m->n_entries == 0 || m->bad_entries > 0 || (!decl && m->head != 'N'))
                return;
        for (size_t k = 0; k < m->n_entries; k++) {
                const struct p4_entry *pe = &m->entries[k];

                if (pe->letter != (decl ? 'Q' : 'R') || pe->value_len > SLP_VALUE_MAX)
                        return;
                memcpy(names[k], pe->name, pe->name_len);
                names[k][pe->name_len] = '\0';
                memcpy(values[k], pe->value ? pe->value : "", pe->value_len);
                values[k][pe->value_len] = '\0';
                name_ptrs[k] = names[k];
                value_ptrs[k] = values[k];
                types[k] = pe->type;
        }
        while (cursor < m->n_entries) {
                size_t first = cursor;
                int n = decl ? slp_encode_declaration(&nl, &cursor, buf, sizeof(buf))
                             : slp_encode_acknowledgement(&nl, &cursor, buf, sizeof(buf));

                if (n == -EMSGSIZE)
                        return;         /* one entry longer than a frame: nothing to compare */
                CHECK(n > 0 && cursor > first);
                p4_decode(decode_one(n), &again);
                CHECK(again.kind == m->kind && again.head == m->head && again.index == first);
                CHECK(again.n_entries == cursor - first && again.bad_entries == 0);
                for (size_t k = 0; k < again.n_entries; k++, seen++) {
                        const struct p4_entry *pe = &again.entries[k];

                        CHECK(pe->name_len == strlen(names[seen]) &&
                              memcmp(pe->name, names[seen], pe->name_len) == 0);
                        if (decl)
                                CHECK(pe->type == types[seen] && !pe->has_value);
                        else
                                CHECK(pe->value_len == strlen(values[seen]) &&
                                      memcmp(pe->value, values[seen], pe->value_len) == 0);
                }
        }
        CHECK(seen == m->n_entries);
}

static void check_command(const struct slp_frame *f, const struct p4_message *m)
{
        char module[SLP_FIELDS_MAX], text[FUZZ_TEXT_MAX];
        int n;

        CHECK(inside(f, m->module, m->module_len));
        CHECK(m->text_len == 0 || inside(f, m->text, m->text_len));
        CHECK(m->extra_fields < f->nfields);
        if (m->module_len >= sizeof(module) || m->text_len >= sizeof(text)) {
                CHECK(!m->command_ok);
                return;
        }
        memcpy(module, m->module, m->module_len);
        module[m->module_len] = '\0';
        memcpy(text, m->text, m->text_len);
        text[m->text_len] = '\0';
        n = slp_encode_command(buf, sizeof(buf), f->dst, f->src, module, text, 0);
        CHECK((n > 0) == m->command_ok || n == -ENOSPC);
        if (n <= 0)
                return;
        p4_decode(decode_one(n), &again);
        CHECK(again.kind == SLP_P4_COMMAND && again.command_ok && again.extra_fields == 0);
        CHECK(again.module_len == m->module_len &&
              memcmp(again.module, m->module, m->module_len) == 0);
        CHECK(again.text_len == m->text_len && memcmp(again.text, m->text, m->text_len) == 0);
}

static void check_frame(const struct slp_frame *f)
{
        p4_decode(f, &msg);
        CHECK(msg.kind == slp_p4_kind_of(f));
        CHECK(msg.head == f->fields[0].letter);
        switch (msg.kind) {
        case SLP_P4_DECLARATION:
        case SLP_P4_ACKNOWLEDGEMENT:
        case SLP_P4_SELF_DESCRIBING:
                check_entries(f, &msg);
                check_named_roundtrip(f, &msg);
                break;
        case SLP_P4_COMMAND:
                CHECK(msg.n_entries == 0);
                check_command(f, &msg);
                break;
        case SLP_P4_MU:
                CHECK(msg.n_entries == 0 && msg.command_ok && msg.head == 'M');
                CHECK(inside(f, msg.module, msg.module_len));
                break;
        default:
                CHECK(msg.n_entries == 0 && !msg.command_ok);
                break;
        }
}

/* The SetIP text of the input's first bytes as an address, into a buffer the input sizes. */
static void check_setip(const uint8_t *data, size_t size)
{
        char address[P4_ADDRESS_MAX], text[P4_SETIP_TEXT_MAX], want[P4_SETIP_TEXT_MAX * 2];
        struct input in = { data, size };
        size_t room = 1 + take(&in) % sizeof(text), len = 0;
        unsigned port = (unsigned)take(&in) << 8 | take(&in);
        int n, w;

        while (len + 1 < sizeof(address) && in.n > 0) {
                char c = (char)take(&in);

                if (c == '\0')
                        break;
                address[len++] = c;
        }
        address[len] = '\0';
        w = snprintf(want, sizeof(want), "0, SetIP, %s, %u", address, port);
        n = p4_setip_text(text, room, address, port);
        if ((size_t)w < room) {
                CHECK(n == w && strcmp(text, want) == 0);
        } else {
                CHECK(n == -ENOSPC);
        }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
        struct slp_decode_result r;
        size_t used = 0;

        if (slp_decoder_init(&dec, SLP_FRAME_MAX) < 0 || slp_decoder_init(&redec, SLP_FRAME_MAX) < 0)
                __builtin_trap();
        while (used < size) {
                used += slp_decoder_feed(&dec, data + used, size - used, &r);
                if (r.kind == SLP_RESULT_FRAME)
                        check_frame(r.frame);
        }
        if (slp_decoder_end(&dec, &r) && r.kind == SLP_RESULT_FRAME)
                check_frame(r.frame);
        check_setip(data, size);
        return 0;
}
