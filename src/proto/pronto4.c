/*
 * The Pronto4 dialect's reading of a frame (pronto4.h; docs/pronto4.md is the contract, its
 * Decisions are quoted where they apply).
 */
#include "proto/pronto4.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

/* The Q field among fields [from, to) of a bad entry, or NULL. */
static const struct slp_field *bad_entry_name(const struct slp_frame *f, size_t from, size_t to)
{
        for (size_t i = from; i < to && i < f->nfields; i++)
                if (f->fields[i].letter == 'Q')
                        return &f->fields[i];
        return NULL;
}

/* Decision (§4): a bad entry with a Q keeps its place (unmapped), so the positions after it
 * stay right; its name is kept when it is one, so answers and acknowledgements list it. */
static void entries_read(const struct slp_frame *f, struct p4_message *m)
{
        size_t at = 1;

        for (;;) {
                struct p4_entry *pe = &m->entries[m->n_entries];
                size_t before = at;
                struct slp_entry e;
                int r = slp_entry_next(f, &at, &e);

                if (r == 0 || m->n_entries >= SLP_FIELDS_MAX)
                        return;
                memset(pe, 0, sizeof(*pe));
                if (r > 0) {
                        pe->status = P4_ENTRY_OK;
                        pe->name = e.name;
                        pe->name_len = e.name_len;
                        pe->value = e.value;
                        pe->value_len = e.value_len;
                        pe->has_value = e.has_value;
                        pe->type = e.type;
                        pe->letter = e.letter;
                        pe->positional = e.letter == 'Q';
                } else {
                        const struct slp_field *q = bad_entry_name(f, before, at);

                        pe->status = P4_ENTRY_BAD;
                        pe->type = SLP_TYPE_DOUBLE;
                        pe->positional = q != NULL;
                        if (q && slp_name_check(q->value, q->len) == 0) {
                                pe->name = q->value;
                                pe->name_len = q->len;
                        }
                        m->bad_entries++;
                }
                m->n_entries++;
        }
}

/* E<module>|D<text> (§9): the module a name, the text a value; what follows is unknown. */
static void command_read(const struct slp_frame *f, struct p4_message *m)
{
        const struct slp_field *mod = &f->fields[0];
        const struct slp_field *t = f->nfields > 1 && f->fields[1].letter == 'D' ? &f->fields[1]
                                                                                 : NULL;

        m->module = mod->value;
        m->module_len = mod->len;
        m->text = t ? t->value : "";
        m->text_len = t ? t->len : 0;
        m->command_ok = slp_name_check(mod->value, mod->len) == 0 &&
                        (!t || t->len <= SLP_VALUE_MAX);
        m->extra_fields = f->nfields - (t ? 2 : 1);
}

void p4_decode(const struct slp_frame *frame, struct p4_message *ret_message)
{
        struct p4_message *m = ret_message;

        m->kind = slp_p4_kind_of(frame);
        m->head = frame->nfields > 0 ? frame->fields[0].letter : '\0';
        m->index = frame->nfields > 0 ? frame->fields[0].index : 0;
        m->n_entries = 0;
        m->bad_entries = 0;
        m->module = m->text = "";
        m->module_len = m->text_len = 0;
        m->command_ok = false;
        m->extra_fields = 0;
        switch (m->kind) {
        case SLP_P4_DECLARATION:
        case SLP_P4_ACKNOWLEDGEMENT:
        case SLP_P4_SELF_DESCRIBING:
                entries_read(frame, m);
                break;
        case SLP_P4_COMMAND:
                command_read(frame, m);
                break;
        case SLP_P4_MU:
                m->module = frame->fields[0].value;
                m->module_len = frame->fields[0].len;
                m->command_ok = true;
                break;
        default:
                break;
        }
}

int p4_setip_text(char *buf, size_t size, const char *address, unsigned remote_port)
{
        int n = snprintf(buf, size, "0, SetIP, %s, %u", address, remote_port);

        return n >= 0 && (size_t)n < size ? n : -ENOSPC;
}
