/*
 * The Kairos Pronto4 dialect of SharedLink (docs/pronto4.md): what a received frame means, taken
 * apart once, and the texts of a host's connect sequence. It builds on the SharedLink codec
 * (proto/sharedlink.h: the frame decoder, the T types, the value and name checks and the
 * encoders of declarations, acknowledgements, list queries, commands and whole lists).
 *
 * Pure code, as the SharedLink codec: no syscalls, no allocation, no logging, no global state.
 * The caller owns the message; it points into the decoded frame and is valid as the frame is.
 *
 *      struct p4_message *m = ...;     // about 80 KiB: keep it in the link, not on a small stack
 *      p4_decode(r.frame, m);          // one frame from the SharedLink decoder
 *      switch (m->kind) {
 *      case SLP_P4_DECLARATION: ... m->entries[0 .. m->n_entries) in declared order ...
 *      case SLP_P4_COMMAND:     ... m->command_ok, m->module, m->text ...
 *      }
 *
 * Names carry the prefix p4_ / P4_.
 */
#ifndef SHAREDLINK_PROTO_PRONTO4_H
#define SHAREDLINK_PROTO_PRONTO4_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "proto/sharedlink.h"

/* ---------------------------------------------------------------------------------------------
 * Received frames */

/* What one entry of a declaration, an acknowledgement or a self-describing frame is. */
enum p4_entry_status {
        P4_ENTRY_OK = 0,                /* [T<t>] Q<name> or R<name>, optional D: see letter */
        P4_ENTRY_BAD,                   /* a T that is not 0/2/4, a bad name, a T without its
                                         * name, a stray D or another letter (slp_entry_next) */
};

/*
 * One entry, in the order of the frame. A bad entry keeps the name of its Q field when that is
 * a valid name (so a declaration lists it at its position), else name_len 0; `positional` says
 * whether it had a Q field at all (a declaration gives it a position, unmapped).
 */
struct p4_entry {
        const char *name;
        const char *value;              /* has_value only */
        uint16_t name_len, value_len;
        enum slp_type type;             /* SLP_TYPE_DOUBLE when not typed (Decision, §3) */
        uint8_t status;                 /* enum p4_entry_status */
        char letter;                    /* 'Q' or 'R' (OK entries) */
        bool has_value;
        bool positional;                /* OK with a Q, or bad with a Q field */
};

/* A Pronto4 frame taken apart (docs/pronto4.md §2-§9). */
struct p4_message {
        enum slp_p4_kind kind;
        char head;                      /* the first field's letter: N/L (declaration, list
                                         * query), E (command), M (MU) */
        uint32_t index;                 /* declaration: its start position, N<k> / L<k> */

        /* Declaration, acknowledgement, self-describing frame: every entry after the head. */
        size_t n_entries;
        size_t bad_entries;             /* entries with P4_ENTRY_BAD */
        struct p4_entry entries[SLP_FIELDS_MAX];

        /* Command "E<module>[|D<text>]"; for the bare MUI/MUO/ML/MW, module is what follows the
         * M ("UI", "L" ...) and head is 'M'. */
        const char *module, *text;      /* text "" when absent */
        uint16_t module_len, text_len;
        bool command_ok;                /* module a name and text at most SLP_VALUE_MAX bytes */
        size_t extra_fields;            /* fields after E<module>|D<text>: unknown */
};

/* Takes @frame apart into @ret_message; never fails (what cannot be read is marked bad). */
void p4_decode(const struct slp_frame *frame, struct p4_message *ret_message);

/* ---------------------------------------------------------------------------------------------
 * The connect sequence of a host (§9): E<P4_CONNECT_MODULE>|D<text>, each its own datagram */

#define P4_CONNECT_MODULE       "Link"
#define P4_TEXT_OUTBOUND_ON     "0, outbound, on"
#define P4_TEXT_INBOUND_ON      "0, inbound, on"
/* "<ip>:<port>" of the host, IPv6 in brackets: what SetIP carries. */
#define P4_ADDRESS_MAX          64
/* "0, SetIP, <address>, <port>"; the command encoder still refuses more than SLP_VALUE_MAX. */
#define P4_SETIP_TEXT_MAX       (P4_ADDRESS_MAX + 32)

/* Writes "0, SetIP, <address>, <remote_port>" into buf[size]: its length, or -ENOSPC. */
int p4_setip_text(char *buf, size_t size, const char *address, unsigned remote_port);

#endif
