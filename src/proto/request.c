/*
 * The control-command vocabulary (request.h has the requests): one table per request, and the
 * one encoder and the one decoder that walk it. A field says how its argument is written (a
 * number, an address, a name ...), where it stands (in its place, optional in its place, as
 * KEY=VALUE in any order, or the rest of the words) and where its value lives in struct
 * reqp_request, so the checks, the messages and both directions come from the same line.
 */
#include "proto/request.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#define AT(member)      offsetof(struct reqp_request, member)
#define HAS_NONE        SIZE_MAX        /* a field with no has_* flag: always present */
#define NUMBER_DIGITS_MAX 9u            /* every number here fits (999999 is the largest) */
#define NUMBER_WORD_MAX 16              /* "sensor-time=999999" and such, without the key */
#define SHOWN_MAX       24              /* bytes of a refused word quoted in a message */
#define LIST_MAX        160             /* a list of names in a message */
#define SYNC_SUCCEEDED  "succeeded"
#define SYNC_TIMED_OUT  "timed-out"

/* How an argument is written. */
enum field_type {
        T_NUMBER,                       /* decimal digits, min..max */
        T_CHOICE,                       /* one of two words: yes (true) or no (false) */
        T_SWITCH,                       /* an option without value: present means true */
        T_ADDRESS,                      /* a CIRCE address (circe_address_parse) */
        T_ADDRESSES,                    /* CIRCE addresses separated by commas, 1..max */
        T_PEER,                         /* a SharedLink node, "A".."P" */
        T_NAME,                         /* a variable name (slp_name_check, < REQP_NAME_SIZE) */
        T_MODULE,                       /* a Pronto4 module (slp_name_check) */
        T_TEXT,                         /* the rest of the words: a module command's text */
};

/* Where it stands. */
enum field_form {
        FORM_POSITIONAL,                /* in its place, mandatory */
        FORM_OPTIONAL,                  /* in its place, may be left out (from the end) */
        FORM_OPTION,                    /* KEY=VALUE (or KEY for a switch), any order */
        FORM_REST,                      /* every word left */
};

/* How its value is stored. */
enum field_store {
        S_BOOL,
        S_U8,
        S_U16,
        S_U32,
        S_CHARS,                        /* a NUL-terminated array of size bytes */
};

struct field {
        const char *name;               /* in messages; the KEY of an option; the setters' key */
        enum field_type type;
        enum field_form form;
        enum field_store store;
        size_t offset;                  /* the value (T_ADDRESSES: the uint16_t count) */
        size_t size;                    /* S_CHARS: the array's size */
        size_t has;                     /* its bool has_* flag, HAS_NONE */
        size_t list;                    /* T_ADDRESSES: the uint32_t array */
        uint32_t min, max;              /* T_NUMBER; T_ADDRESSES: max entries */
        bool dash;                      /* FORM_OPTIONAL: "-" stands for "not given" */
        const char *yes, *no;           /* T_CHOICE */
};

struct spec {
        const char *verb;               /* the first word */
        const char *op;                 /* the words after LINK that name a CIRCE operation */
        bool link;                      /* LINK is the second word */
        bool wait;                      /* takes a trailing wait=MS */
        enum reqp_reply reply;
        enum circe_op circe_op;         /* CIRCE kinds: the op of u.circe */
        bool for_controller;            /* CIRCE kinds: for a controller, else a mediator */
        const char *usage;
        const char *need_one;           /* at least one FORM_OPTION must be given: "X" in
                                         * "NAME needs at least one X" */
        const struct field *fields;
        size_t n_fields;
        /* A rule across fields, after each is checked (NULL: none): 0 or fail(). */
        int (*check)(const struct reqp_request *r, char *err, size_t errsz);
};

/* ---- The tables ------------------------------------------------------------------------------ */

#define NUMBER(key, form_, store_, member, has_, min_, max_)                                   \
        { .name = key, .type = T_NUMBER, .form = form_, .store = store_, .offset = AT(member),   \
          .has = has_, .min = min_, .max = max_ }
#define CHARS(key, type_, member, size_)                                                       \
        { .name = key, .type = type_, .form = FORM_POSITIONAL, .store = S_CHARS,               \
          .offset = AT(member), .size = size_, .has = HAS_NONE }
#define ADDRESS(key, form_, member, has_)                                                      \
        { .name = key, .type = T_ADDRESS, .form = form_, .store = S_U32, .offset = AT(member),   \
          .has = has_, .max = CIRCE_ADDRESS_MAX }
#define FIELDS(array)   .fields = array, .n_fields = sizeof(array) / sizeof(array[0])

static const struct field query_fields[] = {
        CHARS("peer", T_PEER, u.query.peer, REQP_PEER_SIZE),
        CHARS("variable name", T_NAME, u.query.name, REQP_NAME_SIZE),
        NUMBER("timeout", FORM_OPTIONAL, S_U32, u.query.timeout_ms, AT(u.query.has_timeout), 1,
               REQP_QUERY_TIMEOUT_MAX_MS),
};

static const struct field peer_ping_fields[] = {
        CHARS("peer", T_PEER, u.ping.peer, REQP_PEER_SIZE),
        NUMBER("timeout", FORM_OPTIONAL, S_U32, u.ping.timeout_ms, AT(u.ping.has_timeout), 1,
               REQP_QUERY_TIMEOUT_MAX_MS),
};

static const struct field command_fields[] = {
        CHARS("module", T_MODULE, u.command.module, REQP_MODULE_SIZE),
        { .name = "command text", .type = T_TEXT, .form = FORM_REST, .store = S_CHARS,
          .offset = AT(u.command.text), .size = REQP_TEXT_SIZE, .has = HAS_NONE },
};

static const struct field alert_fields[] = {
        ADDRESS("address", FORM_POSITIONAL, u.circe.u.alert.dest, HAS_NONE),
};

static const struct field network_setup_fields[] = {
        ADDRESS("address", FORM_POSITIONAL, u.circe.u.network_setup.dest, HAS_NONE),
        { .name = "membership", .type = T_CHOICE, .form = FORM_POSITIONAL, .store = S_BOOL,
          .offset = AT(u.circe.u.network_setup.set_membership), .has = HAS_NONE, .max = 1,
          .yes = "join", .no = "leave" },
        NUMBER("roles", FORM_POSITIONAL, S_U8, u.circe.u.network_setup.roles, HAS_NONE, 0,
               CIRCE_ROLES_MAX),
};

static const struct field device_setup_fields[] = {
        ADDRESS("address to assign", FORM_POSITIONAL, u.circe.u.device_setup.assign, HAS_NONE),
        { .name = "destination", .type = T_ADDRESS, .form = FORM_OPTIONAL, .store = S_U32,
          .offset = AT(u.circe.u.device_setup.dest), .has = AT(u.circe.u.device_setup.has_dest),
          .max = CIRCE_ADDRESS_MAX, .dash = true },
        { .name = "capabilities", .type = T_NUMBER, .form = FORM_OPTIONAL, .store = S_U8,
          .offset = AT(u.circe.u.device_setup.capabilities),
          .has = AT(u.circe.u.device_setup.has_capabilities), .max = CIRCE_CAPABILITIES_MAX,
          .dash = true },
};

/* The display fields in the order they are sent (the order of the usage). */
static const struct field visualize_fields[] = {
        { .name = "destination", .type = T_ADDRESSES, .form = FORM_POSITIONAL, .store = S_U16,
          .offset = AT(u.circe.u.visualize.dest_count), .has = HAS_NONE,
          .list = AT(u.circe.u.visualize.dests), .min = 1, .max = CIRCE_VISUALIZE_DEST_MAX },
        NUMBER("current", FORM_OPTION, S_U16, u.circe.u.visualize.current,
               AT(u.circe.u.visualize.has_current), 0, CIRCE_COMPETITOR_MAX),
        NUMBER("next", FORM_OPTION, S_U16, u.circe.u.visualize.next,
               AT(u.circe.u.visualize.has_next), 0, CIRCE_COMPETITOR_MAX),
        { .name = "start-timer", .type = T_SWITCH, .form = FORM_OPTION, .store = S_BOOL,
          .offset = AT(u.circe.u.visualize.start_timer), .has = HAS_NONE, .max = 1 },
        NUMBER("primary", FORM_OPTION, S_U32, u.circe.u.visualize.primary_ms,
               AT(u.circe.u.visualize.has_primary), 0, CIRCE_TIME_MS_MAX),
        NUMBER("secondary", FORM_OPTION, S_U32, u.circe.u.visualize.secondary_ms,
               AT(u.circe.u.visualize.has_secondary), 0, CIRCE_TIME_MS_MAX),
        NUMBER("faults", FORM_OPTION, S_U8, u.circe.u.visualize.faults,
               AT(u.circe.u.visualize.has_faults), 0, CIRCE_COUNT_MAX),
        NUMBER("refusals", FORM_OPTION, S_U8, u.circe.u.visualize.refusals,
               AT(u.circe.u.visualize.has_refusals), 0, CIRCE_COUNT_MAX),
        NUMBER("eliminated", FORM_OPTION, S_BOOL, u.circe.u.visualize.eliminated,
               AT(u.circe.u.visualize.has_eliminated), 0, 1),
        NUMBER("placement", FORM_OPTION, S_U16, u.circe.u.visualize.placement,
               AT(u.circe.u.visualize.has_placement), 0, CIRCE_PLACEMENT_MAX),
};

static const struct field emulate_action_fields[] = {
        ADDRESS("device", FORM_POSITIONAL, u.circe.u.notify_action.origin, HAS_NONE),
        NUMBER("keys", FORM_OPTION, S_U16, u.circe.u.notify_action.keys,
               AT(u.circe.u.notify_action.has_keys), 0, CIRCE_KEYS_MAX),
        NUMBER("sensor-time", FORM_OPTION, S_U32, u.circe.u.notify_action.sensor_time_ms,
               AT(u.circe.u.notify_action.has_sensor_time), 0, CIRCE_TIME_MS_MAX),
};

static int fail(char *err, size_t errsz, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

/* A bare module request (MUI, MUO, ML, MW) is a frame of its name alone: no text to carry. */
static int command_check(const struct reqp_request *r, char *err, size_t errsz)
{
        const struct reqp_command *c = &r->u.command;

        if (c->text[0] && slp_p4_bare_request(c->module, strlen(c->module)))
                return fail(err, errsz, "%s is a bare module request: it takes no text",
                            c->module);
        return 0;
}

#define CIRCE(op_, code, controller, usage_)                                                   \
        .verb = "circe", .op = op_, .link = true, .wait = true, .circe_op = code,               \
        .for_controller = controller, .usage = "circe LINK " op_ usage_ " [wait=MS]"

static const struct spec specs[REQP_KIND_COUNT] = {
        [REQP_PING] = { .verb = "ping", .reply = REQP_REPLY_PING, .usage = "ping" },
        [REQP_STATS] = { .verb = "stats", .reply = REQP_REPLY_LINES, .usage = "stats" },
        [REQP_RECORD] = { .verb = "record", .link = true, .reply = REQP_REPLY_RECORDING,
                          .usage = "record LINK" },
        [REQP_QUERY] = { .verb = "query", .link = true, .wait = true, .reply = REQP_REPLY_VALUE,
                         .usage = "query LINK PEER NAME [TIMEOUT_MS] [wait=MS]",
                         FIELDS(query_fields) },
        [REQP_COMMAND] = { .verb = "command", .link = true, .wait = true,
                           .reply = REQP_REPLY_OK,
                           .usage = "command LINK MODULE [TEXT...] [wait=MS]",
                           FIELDS(command_fields), .check = command_check },
        [REQP_PEER_PING] = { .verb = "ping-peer", .link = true, .wait = true,
                             .reply = REQP_REPLY_RTT,
                             .usage = "ping-peer LINK PEER [TIMEOUT_MS] [wait=MS]",
                             FIELDS(peer_ping_fields) },
        [REQP_CIRCE_ALERT] = { CIRCE("alert", CIRCE_OP_ALERT, true, " ADDR"),
                               .reply = REQP_REPLY_OK, FIELDS(alert_fields) },
        [REQP_CIRCE_NETWORK_SETUP] = { CIRCE("network-setup", CIRCE_OP_NETWORK_SETUP, true,
                                             " ADDR join|leave ROLES"),
                                       .reply = REQP_REPLY_OK, FIELDS(network_setup_fields) },
        [REQP_CIRCE_DEVICE_SETUP] = { CIRCE("device-setup", CIRCE_OP_DEVICE_SETUP, true,
                                            " ASSIGN [DEST|-] [CAPABILITIES|-]"),
                                      .reply = REQP_REPLY_OK, FIELDS(device_setup_fields) },
        [REQP_CIRCE_SYNC_CLOCKS] = { CIRCE("sync-clocks", CIRCE_OP_SYNC_CLOCKS, true, ""),
                                     .reply = REQP_REPLY_SYNC },
        [REQP_CIRCE_VISUALIZE] = { CIRCE("visualize", CIRCE_OP_VISUALIZE, true,
                                         " ADDR[,ADDR...] [current=N] [next=N] [start-timer] "
                                         "[primary=MS] [secondary=MS] [faults=N] [refusals=N] "
                                         "[eliminated=0|1] [placement=N]"),
                                   .reply = REQP_REPLY_OK, .need_one = "display field",
                                   FIELDS(visualize_fields) },
        [REQP_CIRCE_EMULATE_ACTION] = { CIRCE("emulate action", CIRCE_OP_NOTIFY_ACTION, false,
                                              " ADDR [keys=N] [sensor-time=MS]"),
                                        .reply = REQP_REPLY_OK,
                                        FIELDS(emulate_action_fields) },
};

/* The usage of a request whose operation is not known yet. */
#define CIRCE_USAGE     "circe LINK OPERATION [ARGUMENTS...] [wait=MS]"

/* ---- Small helpers ---------------------------------------------------------------------------- */

/* Writes the reason into err (NULL/0 allowed), cut to fit; returns -EINVAL. */
static int fail(char *err, size_t errsz, const char *fmt, ...)
{
        va_list ap;

        if (err && errsz) {
                va_start(ap, fmt);
                vsnprintf(err, errsz, fmt, ap);
                va_end(ap);
        }
        return -EINVAL;
}

static const struct spec *spec_of(enum reqp_kind kind)
{
        return (unsigned)kind < REQP_KIND_COUNT ? &specs[kind] : NULL;
}

static bool *bool_at(struct reqp_request *r, size_t offset)
{
        return (bool *)((char *)r + offset);
}

static bool bool_of(const struct reqp_request *r, size_t offset)
{
        return *(const bool *)((const char *)r + offset);
}

/* Stores v (already in range) in the field's width. */
static void store_number(struct reqp_request *r, size_t offset, enum field_store store,
                         uint32_t v)
{
        char *p = (char *)r + offset;
        uint8_t u8 = (uint8_t)v;
        uint16_t u16 = (uint16_t)v;

        switch (store) {
        case S_BOOL:
                *(bool *)p = v != 0;
                break;
        case S_U8:
                memcpy(p, &u8, sizeof(u8));
                break;
        case S_U16:
                memcpy(p, &u16, sizeof(u16));
                break;
        case S_U32:
                memcpy(p, &v, sizeof(v));
                break;
        case S_CHARS:
                break;
        }
}

static uint32_t load_number(const struct reqp_request *r, size_t offset, enum field_store store)
{
        const char *p = (const char *)r + offset;
        uint8_t u8;
        uint16_t u16;
        uint32_t u32 = 0;

        switch (store) {
        case S_BOOL:
                return *(const bool *)p;
        case S_U8:
                memcpy(&u8, p, sizeof(u8));
                return u8;
        case S_U16:
                memcpy(&u16, p, sizeof(u16));
                return u16;
        case S_U32:
                memcpy(&u32, p, sizeof(u32));
                return u32;
        case S_CHARS:
                break;
        }
        return 0;
}

static bool present(const struct reqp_request *r, const struct field *f)
{
        if (f->has != HAS_NONE)
                return bool_of(r, f->has);
        if (f->type == T_SWITCH)
                return bool_of(r, f->offset);
        return true;
}

/* Decimal digits only, at most NUMBER_DIGITS_MAX of them; 0 or -EINVAL. */
static int parse_decimal(const char *s, uint32_t *ret)
{
        size_t n = strlen(s);
        uint32_t v = 0;

        if (n == 0 || n > NUMBER_DIGITS_MAX)
                return -EINVAL;
        for (size_t i = 0; i < n; i++) {
                if (s[i] < '0' || s[i] > '9')
                        return -EINVAL;
                v = v * 10u + (uint32_t)(s[i] - '0');
        }
        *ret = v;
        return 0;
}

/* ---- Checking one argument -------------------------------------------------------------------- */

static int check_link(const char *link, char *err, size_t errsz)
{
        size_t len;

        if (!link)
                return fail(err, errsz, "no link name");
        len = strnlen(link, REQP_LINK_SIZE);
        if (len == 0 || len >= REQP_LINK_SIZE)
                return fail(err, errsz, "bad link name: 1..%d bytes expected",
                            (int)REQP_LINK_SIZE - 1);
        for (size_t i = 0; i < len; i++)
                if (!ctlp_is_word_byte((unsigned char)link[i]))
                        return fail(err, errsz, "link name contains a space or a byte that is "
                                    "not printable ASCII");
        return 0;
}

static int check_address(const struct field *f, const char *s, size_t len, uint32_t *ret,
                         char *err, size_t errsz)
{
        int r = circe_address_parse(s, len, ret);

        if (r == -ERANGE)
                return fail(err, errsz, "bad %s FFFFFF: the address is reserved", f->name);
        if (r < 0)
                return fail(err, errsz, "bad %s \"%.*s\": six uppercase hex digits expected",
                            f->name, (int)(len > SHOWN_MAX ? SHOWN_MAX : len), s);
        return 0;
}

/*
 * A module command's text: the wire charset, at most REQP_TEXT_SIZE - 1 bytes, words separated by
 * single spaces (the line splits on spaces: a leading, trailing or double one would not arrive
 * as sent), at most REQP_TEXT_WORDS_MAX words.
 */
static int check_text(const struct field *f, const char *text, char *err, size_t errsz)
{
        size_t len = strnlen(text, REQP_TEXT_SIZE);
        unsigned words = 0;

        if (len >= REQP_TEXT_SIZE)
                return fail(err, errsz, "%s longer than %d bytes", f->name, REQP_TEXT_SIZE - 1);
        if (slp_value_check(SLP_TYPE_STRING, text, len) < 0)
                return fail(err, errsz, "%s has a byte outside 0x20-0x7E, or | [ ]", f->name);
        for (size_t i = 0; i < len; i++) {
                if (text[i] != ' ')
                        continue;
                if (i == 0 || i + 1u == len || text[i + 1u] == ' ')
                        return fail(err, errsz, "%s has a leading, trailing or double space",
                                    f->name);
                words++;
        }
        words += len > 0;
        if (words > REQP_TEXT_WORDS_MAX)
                return fail(err, errsz, "%s has more than %d words", f->name,
                            REQP_TEXT_WORDS_MAX);
        return 0;
}

/* Appends one address to a destination list. */
static int list_append(struct reqp_request *r, const struct field *f, const char *s, size_t len,
                       char *err, size_t errsz)
{
        uint32_t count = load_number(r, f->offset, f->store), a;
        int rc;

        if (count >= f->max)
                return fail(err, errsz, "%s: more than %u %ss", specs[r->kind].op, f->max,
                            f->name);
        rc = check_address(f, s, len, &a, err, errsz);
        if (rc < 0)
                return rc;
        memcpy((char *)r + f->list + count * sizeof(uint32_t), &a, sizeof(a));
        store_number(r, f->offset, f->store, count + 1u);
        return 0;
}

/* A comma-separated list of addresses, the way the decoder reads it. */
static int list_parse(struct reqp_request *r, const struct field *f, const char *s, char *err,
                      size_t errsz)
{
        for (;;) {
                const char *comma = strchr(s, ',');
                size_t len = comma ? (size_t)(comma - s) : strlen(s);
                int rc = list_append(r, f, s, len, err, errsz);

                if (rc < 0 || !comma)
                        return rc;
                s = comma + 1;
        }
}

/* Sets field f of r from the text of its argument (the decoder's word, a setter's string). */
static int field_set_text(struct reqp_request *r, const struct field *f, const char *text,
                          char *err, size_t errsz)
{
        size_t len = strlen(text);
        uint32_t v = 0;
        int rc = 0;

        switch (f->type) {
        case T_NUMBER:
                if (parse_decimal(text, &v) < 0 || v < f->min || v > f->max)
                        return fail(err, errsz, "bad %s \"%.*s\": a decimal number %u..%u "
                                    "expected", f->name, SHOWN_MAX, text, f->min, f->max);
                store_number(r, f->offset, f->store, v);
                break;
        case T_CHOICE:
                if (strcmp(text, f->yes) == 0)
                        v = 1;
                else if (strcmp(text, f->no) != 0)
                        return fail(err, errsz, "bad %s \"%.*s\": %s or %s expected", f->name,
                                    SHOWN_MAX, text, f->yes, f->no);
                store_number(r, f->offset, f->store, v);
                break;
        case T_SWITCH:
                store_number(r, f->offset, f->store, 1);
                break;
        case T_ADDRESS:
                rc = check_address(f, text, len, &v, err, errsz);
                if (rc == 0)
                        store_number(r, f->offset, f->store, v);
                break;
        case T_ADDRESSES:
                return list_append(r, f, text, len, err, errsz);
        case T_PEER:
                if (!slp_address_text_valid(text, len))
                        return fail(err, errsz, "bad peer \"%.16s\": a node address A..P "
                                    "expected", text);
                break;
        case T_NAME:
                if (len >= REQP_NAME_SIZE || slp_name_check(text, len) < 0)
                        return fail(err, errsz, "bad %s \"%.48s\": 1..%d bytes of letters, "
                                    "digits, _ . -", f->name, text, (int)REQP_NAME_SIZE - 1);
                break;
        case T_MODULE:
                if (slp_name_check(text, len) < 0)
                        return fail(err, errsz, "bad %s \"%.64s\": 1..%d bytes of letters, "
                                    "digits, _ . -", f->name, text, REQP_MODULE_SIZE - 1);
                break;
        case T_TEXT:
                rc = check_text(f, text, err, errsz);
                break;
        }
        if (rc < 0)
                return rc;
        if (f->store == S_CHARS) {
                if (len >= f->size)     /* not reached: every check above bounds the length */
                        return fail(err, errsz, "%s too long", f->name);
                memcpy((char *)r + f->offset, text, len + 1u);
        }
        if (f->has != HAS_NONE)
                *bool_at(r, f->has) = true;
        return 0;
}

static const struct field *field_by_name(const struct spec *s, const char *name, size_t len)
{
        for (size_t i = 0; i < s->n_fields; i++)
                if (strlen(s->fields[i].name) == len && strncmp(s->fields[i].name, name, len) == 0)
                        return &s->fields[i];
        return NULL;
}

/* ---- Requests and the setters ---------------------------------------------------------------- */

void reqp_init(struct reqp_request *r, enum reqp_kind kind)
{
        const struct spec *s = spec_of(kind);

        memset(r, 0, sizeof(*r));
        r->kind = kind;
        if (s)
                r->u.circe.op = s->circe_op;
}

const char *reqp_name(enum reqp_kind kind)
{
        const struct spec *s = spec_of(kind);

        return s ? (s->op ? s->op : s->verb) : "?";
}

const char *reqp_verb(enum reqp_kind kind)
{
        const struct spec *s = spec_of(kind);

        return s ? s->verb : "?";
}

bool reqp_has_link(enum reqp_kind kind)
{
        const struct spec *s = spec_of(kind);

        return s && s->link;
}

bool reqp_circe_for_controller(enum reqp_kind kind)
{
        const struct spec *s = spec_of(kind);

        return s && s->circe_op != CIRCE_OP_NONE && s->for_controller;
}

enum reqp_reply reqp_reply_shape(enum reqp_kind kind)
{
        const struct spec *s = spec_of(kind);

        return s ? s->reply : REQP_REPLY_OK;
}

int reqp_set_link(struct reqp_request *r, const char *link, char *err, size_t errsz)
{
        int rc = check_link(link, err, errsz);

        if (rc == 0)
                memcpy(r->link, link, strlen(link) + 1u);
        return rc;
}

/* The field called key of r's kind, or NULL with a message. */
static const struct field *setter_field(const struct reqp_request *r, const char *key, char *err,
                                        size_t errsz)
{
        const struct spec *s = spec_of(r->kind);
        const struct field *f = s && key ? field_by_name(s, key, strlen(key)) : NULL;

        if (!f)
                fail(err, errsz, "%s takes no argument \"%s\"", reqp_name(r->kind),
                     key ? key : "");
        return f;
}

int reqp_set_text(struct reqp_request *r, const char *key, const char *text, char *err,
                  size_t errsz)
{
        const struct field *f = setter_field(r, key, err, errsz);
        struct reqp_request copy;
        int rc;

        if (!f)
                return -EINVAL;
        /* On a copy: r is unchanged on failure (a list append writes before it is sure). */
        copy = *r;
        rc = field_set_text(&copy, f, text ? text : "", err, errsz);
        if (rc == 0)
                *r = copy;
        return rc;
}

int reqp_set_number(struct reqp_request *r, const char *key, long value, char *err,
                    size_t errsz)
{
        const struct field *f = setter_field(r, key, err, errsz);
        long min, max;

        if (!f)
                return -EINVAL;
        if (f->type != T_NUMBER && f->type != T_CHOICE && f->type != T_SWITCH)
                return fail(err, errsz, "%s is not a number", f->name);
        min = f->type == T_NUMBER ? (long)f->min : 0;
        max = f->type == T_NUMBER ? (long)f->max : 1;
        if (value < min || value > max)
                return fail(err, errsz, "bad %s %ld: %ld..%ld expected", f->name, value, min, max);
        store_number(r, f->offset, f->store, (uint32_t)value);
        if (f->has != HAS_NONE)
                *bool_at(r, f->has) = true;
        return 0;
}

/* ---- Encoding ---------------------------------------------------------------------------------- */

/* Appends word (NUL-terminated) to the line; 0 or -EMSGSIZE. */
static int add(struct ctlp_builder *b, const char *word, char *err, size_t errsz)
{
        switch (ctlp_builder_add(b, word, strlen(word))) {
        case CTLP_REASON_NONE:
                return 0;
        case CTLP_REASON_TOO_LONG:
        case CTLP_REASON_TOO_MANY_WORDS:
                fail(err, errsz, "request longer than %d bytes or %d words", CTLP_LINE_MAX - 1,
                     CTLP_WORDS_MAX);
                return -EMSGSIZE;
        default:
                /* Not reached: every word was checked before. */
                return fail(err, errsz, "a word of the request is empty or not printable ASCII");
        }
}

/* Appends the words of space-separated text (checked: single spaces). */
static int add_words(struct ctlp_builder *b, const char *text, char *err, size_t errsz)
{
        char word[CTLP_LINE_MAX];

        while (*text) {
                size_t n = strcspn(text, " ");
                int rc;

                if (n >= sizeof(word))
                        return fail(err, errsz, "a word longer than a request line");
                memcpy(word, text, n);
                word[n] = '\0';
                rc = add(b, word, err, errsz);
                if (rc < 0)
                        return rc;
                text += n + (text[n] == ' ');
        }
        return 0;
}

/* A stored string: NUL-terminated within its array, or NULL. */
static const char *chars_of(const struct reqp_request *r, const struct field *f)
{
        const char *p = (const char *)r + f->offset;

        return memchr(p, '\0', f->size) ? p : NULL;
}

/*
 * The text of field f's value as the decoder wants it (without KEY=), into word (size
 * CTLP_LINE_MAX), checked the way the decoder checks it: 0 or -EINVAL.
 */
static int field_word(const struct reqp_request *r, const struct field *f, char *word, char *err,
                      size_t errsz)
{
        struct reqp_request scratch;
        uint32_t v = 0;
        size_t len = 0;
        const char *s;

        switch (f->type) {
        case T_NUMBER:
                v = load_number(r, f->offset, f->store);
                if (v < f->min || v > f->max)
                        return fail(err, errsz, "bad %s %u: %u..%u expected", f->name, v, f->min,
                                    f->max);
                snprintf(word, CTLP_LINE_MAX, "%u", v);
                return 0;
        case T_CHOICE:
                strcpy(word, bool_of(r, f->offset) ? f->yes : f->no);
                return 0;
        case T_SWITCH:
                strcpy(word, f->name);
                return 0;
        case T_ADDRESS:
                v = load_number(r, f->offset, f->store);
                if (v > CIRCE_ADDRESS_MAX || v == CIRCE_ADDRESS_RESERVED)
                        return fail(err, errsz, "bad %s 0x%X: 000000..FFFFFE expected", f->name,
                                    v);
                circe_address_format(v, word);
                return 0;
        case T_ADDRESSES:
                v = load_number(r, f->offset, f->store);
                if (v < f->min || v > f->max)
                        return fail(err, errsz, "bad %s count %u: %u..%u expected", f->name, v,
                                    f->min, f->max);
                for (uint32_t i = 0; i < v; i++) {
                        uint32_t a;

                        memcpy(&a, (const char *)r + f->list + i * sizeof(uint32_t), sizeof(a));
                        if (a > CIRCE_ADDRESS_MAX || a == CIRCE_ADDRESS_RESERVED)
                                return fail(err, errsz, "bad %s 0x%X: 000000..FFFFFE expected",
                                            f->name, a);
                        if (i)
                                word[len++] = ',';
                        circe_address_format(a, word + len);
                        len += CIRCE_ADDRESS_LEN;
                }
                word[len] = '\0';
                return 0;
        case T_PEER:
        case T_NAME:
        case T_MODULE:
        case T_TEXT:
                s = chars_of(r, f);
                if (!s)
                        return fail(err, errsz, "%s not terminated", f->name);
                /* The checks of the setters, on a scratch request. */
                reqp_init(&scratch, r->kind);
                if (field_set_text(&scratch, f, s, err, errsz) < 0)
                        return -EINVAL;
                strcpy(word, s);
                return 0;
        }
        return fail(err, errsz, "%s: unknown type", f->name);
}

/* Appends the positional fields: the optional ones up to the last one given, "-" for those
 * left out before it. */
static int encode_positionals(struct ctlp_builder *b, const struct reqp_request *r,
                              const struct spec *s, char *word, char *err, size_t errsz)
{
        size_t last = 0;
        int rc;

        for (size_t i = 0; i < s->n_fields; i++)
                if (s->fields[i].form == FORM_POSITIONAL ||
                    (s->fields[i].form == FORM_OPTIONAL && present(r, &s->fields[i])))
                        last = i + 1;
        for (size_t i = 0; i < last; i++) {
                const struct field *f = &s->fields[i];

                if (f->form != FORM_POSITIONAL && f->form != FORM_OPTIONAL)
                        continue;
                if (!present(r, f)) {
                        if (!f->dash)
                                return fail(err, errsz, "%s: %s left out before a later "
                                            "argument", s->usage, f->name);
                        strcpy(word, "-");
                } else {
                        rc = field_word(r, f, word, err, errsz);
                        if (rc < 0)
                                return rc;
                }
                rc = add(b, word, err, errsz);
                if (rc < 0)
                        return rc;
        }
        return 0;
}

/* Appends the rest and the options; returns how many options were given, or an error. */
static int encode_options(struct ctlp_builder *b, const struct reqp_request *r,
                          const struct spec *s, char *word, char *err, size_t errsz)
{
        char opt[CTLP_LINE_MAX];
        int given = 0, rc;

        for (size_t i = 0; i < s->n_fields; i++) {
                const struct field *f = &s->fields[i];

                if (f->form == FORM_REST) {
                        rc = field_word(r, f, word, err, errsz);
                        if (rc == 0)
                                rc = add_words(b, word, err, errsz);
                        if (rc < 0)
                                return rc;
                }
                if (f->form != FORM_OPTION || !present(r, f))
                        continue;
                given++;
                rc = field_word(r, f, word, err, errsz);
                if (rc < 0)
                        return rc;
                if (f->type == T_SWITCH)
                        rc = add(b, f->name, err, errsz);
                else if ((size_t)snprintf(opt, sizeof(opt), "%s=%s", f->name, word) >=
                         sizeof(opt))
                        rc = fail(err, errsz, "%s too long", f->name);
                else
                        rc = add(b, opt, err, errsz);
                if (rc < 0)
                        return rc;
        }
        return given;
}

/* Appends wait=MS when there is one, or "wait=0" when the last word would read as one. */
static int encode_wait(struct ctlp_builder *b, const struct reqp_request *r,
                       const struct spec *s, char *err, size_t errsz)
{
        char word[NUMBER_WORD_MAX + sizeof(CTLP_WAIT_PREFIX)];
        const char *last = strrchr(b->line, ' ');

        if (!s->wait) {
                if (r->wait_ms)
                        return fail(err, errsz, "%s takes no wait", s->verb);
                return 0;
        }
        if (r->wait_ms > CTLP_WAIT_MAX_MS)
                return fail(err, errsz, "bad wait %u: 0..%d expected", r->wait_ms,
                            CTLP_WAIT_MAX_MS);
        last = last ? last + 1 : b->line;
        if (r->wait_ms == 0 && strncmp(last, CTLP_WAIT_PREFIX, strlen(CTLP_WAIT_PREFIX)) != 0)
                return 0;
        snprintf(word, sizeof(word), CTLP_WAIT_PREFIX "%u", r->wait_ms);
        return add(b, word, err, errsz);
}

int reqp_encode(const struct reqp_request *r, char *buf, size_t size, char *err, size_t errsz)
{
        const struct spec *s = r ? spec_of(r->kind) : NULL;
        char word[CTLP_LINE_MAX];
        struct ctlp_builder b;
        int rc, given;

        if (!s)
                return fail(err, errsz, "no such request");
        ctlp_builder_init(&b);
        rc = add(&b, s->verb, err, errsz);
        if (rc == 0 && s->link) {
                rc = check_link(memchr(r->link, '\0', sizeof(r->link)) ? r->link : NULL, err,
                                errsz);
                if (rc == 0)
                        rc = add(&b, r->link, err, errsz);
        }
        if (rc == 0 && s->op)
                rc = add_words(&b, s->op, err, errsz);
        if (rc == 0)
                rc = encode_positionals(&b, r, s, word, err, errsz);
        if (rc < 0)
                return rc;
        given = encode_options(&b, r, s, word, err, errsz);
        if (given < 0)
                return given;
        if (s->need_one && given == 0)
                return fail(err, errsz, "%s needs at least one %s", reqp_name(r->kind),
                            s->need_one);
        rc = s->check ? s->check(r, err, errsz) : 0;
        if (rc == 0)
                rc = encode_wait(&b, r, s, err, errsz);
        if (rc < 0)
                return rc;
        if (b.len + 1u > size) {
                fail(err, errsz, "no room for the request");
                return -ENOBUFS;
        }
        memcpy(buf, b.line, b.len + 1u);
        return (int)b.len;
}

/* ---- Decoding ---------------------------------------------------------------------------------- */

static int usage(const struct spec *s, const char *text, const char *why, char *err, size_t errsz)
{
        return fail(err, errsz, "usage: %s (%s)", s ? s->usage : text, why);
}

/* Takes a trailing wait=MS off (after VERB LINK only): 0, or -EINVAL. */
static int take_wait(int *argc, char *const *argv, uint32_t *ret, char *err, size_t errsz)
{
        const size_t plen = strlen(CTLP_WAIT_PREFIX);
        const char *last;
        uint32_t ms;

        if (*argc < 3 || strncmp(argv[*argc - 1], CTLP_WAIT_PREFIX, plen) != 0)
                return 0;
        last = argv[*argc - 1] + plen;
        if (parse_decimal(last, &ms) < 0 || ms > CTLP_WAIT_MAX_MS)
                return fail(err, errsz, "bad wait \"%.*s\": a decimal number 0..%d expected",
                            SHOWN_MAX, last, CTLP_WAIT_MAX_MS);
        (*argc)--;
        *ret = ms;
        return 0;
}

/* The request a verb starts, for verbs without an operation word. */
static const struct spec *spec_by_verb(const char *verb, bool *ret_has_op)
{
        for (size_t k = 0; k < REQP_KIND_COUNT; k++)
                if (strcmp(specs[k].verb, verb) == 0) {
                        *ret_has_op = specs[k].op != NULL;
                        return &specs[k];
                }
        return NULL;
}

/* The CIRCE operations' first words, "alert, network-setup, ...", into list. */
static void op_list(const char *verb, char *list, size_t size)
{
        size_t len = 0;

        list[0] = '\0';
        for (size_t k = 0; k < REQP_KIND_COUNT && len < size; k++) {
                if (!specs[k].op || strcmp(specs[k].verb, verb) != 0)
                        continue;
                len += (size_t)snprintf(list + len, size - len, "%s%.*s", len ? ", " : "",
                                        (int)strcspn(specs[k].op, " "), specs[k].op);
        }
}

/*
 * The operation named by words[0..n) (after VERB LINK): its spec and how many words name it, or
 * -EINVAL. An operation whose first word matches and the next does not is a usage error.
 */
static int spec_by_op(const char *verb, char *const *words, int n, const struct spec **ret,
                      char *err, size_t errsz)
{
        char list[LIST_MAX];

        for (size_t k = 0; k < REQP_KIND_COUNT; k++) {
                const char *op = specs[k].op;
                size_t first = op ? strcspn(op, " ") : 0;

                if (!op || strcmp(specs[k].verb, verb) != 0 || strlen(words[0]) != first ||
                    strncmp(words[0], op, first) != 0)
                        continue;
                if (op[first] == '\0') {
                        *ret = &specs[k];
                        return 1;
                }
                if (n < 2 || strcmp(words[1], op + first + 1) != 0)
                        return usage(&specs[k], NULL, "missing or unknown words", err, errsz);
                *ret = &specs[k];
                return 2;
        }
        op_list(verb, list, sizeof(list));
        return fail(err, errsz, "unknown CIRCE operation \"%.32s\" (%s)", words[0], list);
}

/* The option names, "current=N, next=N, start-timer, ...", into list. */
static void option_list(const struct spec *s, char *list, size_t size)
{
        size_t len = 0;

        list[0] = '\0';
        for (size_t i = 0; i < s->n_fields && len < size; i++)
                if (s->fields[i].form == FORM_OPTION)
                        len += (size_t)snprintf(list + len, size - len, "%s%s%s", len ? ", " : "",
                                                s->fields[i].name,
                                                s->fields[i].type == T_SWITCH ? "" : "=N");
}

/* One KEY=VALUE (or KEY) word. */
static int decode_option(struct reqp_request *r, const struct spec *s, const char *word,
                         char *err, size_t errsz)
{
        const char *eq = strchr(word, '=');
        size_t klen = eq ? (size_t)(eq - word) : strlen(word);
        const struct field *f = field_by_name(s, word, klen);
        const char *name = reqp_name(r->kind);
        char list[LIST_MAX];

        if (!f || f->form != FORM_OPTION) {
                option_list(s, list, sizeof(list));
                return fail(err, errsz, "%s: unknown argument \"%.*s\" (%s)", name, SHOWN_MAX,
                            word, list);
        }
        if (present(r, f))
                return fail(err, errsz, "%s: %s given twice", name, f->name);
        if (f->type == T_SWITCH && eq)
                return fail(err, errsz, "%s: %s takes no value", name, f->name);
        if (f->type != T_SWITCH && !eq)
                return fail(err, errsz, "%s: %s needs a value (%s=N)", name, f->name, f->name);
        return field_set_text(r, f, eq ? eq + 1 : "", err, errsz);
}

/* Joins words[0..n) with single spaces into text (size bytes); 0 or -EINVAL. */
static int join_words(const struct field *f, char *const *words, int n, char *text, size_t size,
                      char *err, size_t errsz)
{
        size_t len = 0;

        text[0] = '\0';
        for (int i = 0; i < n; i++) {
                size_t w = strlen(words[i]);

                if (len + (i > 0) + w >= size)
                        return fail(err, errsz, "%s longer than %zu bytes", f->name, size - 1u);
                if (i > 0)
                        text[len++] = ' ';
                memcpy(text + len, words[i], w + 1u);
                len += w;
        }
        return 0;
}

/* The arguments words[0..n) of a request of spec s into r. */
static int decode_fields(struct reqp_request *r, const struct spec *s, char *const *words, int n,
                         char *err, size_t errsz)
{
        int mandatory = 0, places = 0, i = 0, given = 0, rc;
        bool more = false;              /* options or a rest take the words left */

        for (size_t k = 0; k < s->n_fields; k++) {
                mandatory += s->fields[k].form == FORM_POSITIONAL;
                places += s->fields[k].form <= FORM_OPTIONAL;
                more |= s->fields[k].form >= FORM_OPTION;
        }
        if (n < mandatory)
                return usage(s, NULL, "missing arguments", err, errsz);
        if (!more && n > places)
                return usage(s, NULL, "too many arguments", err, errsz);
        for (size_t k = 0; k < s->n_fields; k++) {
                const struct field *f = &s->fields[k];

                if (f->form > FORM_OPTIONAL || i == n)
                        continue;
                if (f->form == FORM_OPTIONAL && f->dash && strcmp(words[i], "-") == 0)
                        rc = 0;
                else if (f->type == T_ADDRESSES)
                        rc = list_parse(r, f, words[i], err, errsz);
                else
                        rc = field_set_text(r, f, words[i], err, errsz);
                if (rc < 0)
                        return rc;
                i++;
        }
        for (size_t k = 0; k < s->n_fields; k++) {
                const struct field *f = &s->fields[k];
                char text[CTLP_LINE_MAX];

                if (f->form != FORM_REST)
                        continue;
                rc = join_words(f, words + i, n - i, text, f->size, err, errsz);
                if (rc == 0)
                        rc = field_set_text(r, f, text, err, errsz);
                if (rc < 0)
                        return rc;
                i = n;
        }
        for (; i < n; i++, given++) {
                rc = decode_option(r, s, words[i], err, errsz);
                if (rc < 0)
                        return rc;
        }
        if (s->need_one && given == 0)
                return fail(err, errsz, "%s needs at least one %s", reqp_name(r->kind),
                            s->need_one);
        return 0;
}

int reqp_decode(int argc, char *const *argv, struct reqp_request *ret, char *err, size_t errsz)
{
        const struct spec *s;
        struct reqp_request r;
        uint32_t wait_ms = 0;
        bool has_op = false;
        int head, rc;

        if (err && errsz)
                err[0] = '\0';
        if (argc < 1 || !argv[0][0])
                return fail(err, errsz, "empty request");
        s = spec_by_verb(argv[0], &has_op);
        if (!s)
                return fail(err, errsz, "unknown request \"%.64s\"", argv[0]);
        if (s->wait) {
                rc = take_wait(&argc, argv, &wait_ms, err, errsz);
                if (rc < 0)
                        return rc;
        }
        head = 1 + s->link + has_op;
        if (argc < head)
                return usage(has_op ? NULL : s, CIRCE_USAGE, "missing arguments", err, errsz);
        if (has_op) {
                rc = spec_by_op(s->verb, argv + 2, argc - 2, &s, err, errsz);
                if (rc < 0)
                        return rc;
                head += rc - 1;
        }
        reqp_init(&r, (enum reqp_kind)(s - specs));
        r.wait_ms = wait_ms;
        if (s->link) {
                rc = reqp_set_link(&r, argv[1], err, errsz);
                if (rc < 0)
                        return rc;
        }
        rc = decode_fields(&r, s, argv + head, argc - head, err, errsz);
        if (rc == 0 && s->check)
                rc = s->check(&r, err, errsz);
        if (rc < 0)
                return rc;
        *ret = r;
        return 0;
}

/* ---- Replies ---------------------------------------------------------------------------------- */

void reqp_sync_result_format(char *buf, size_t size, uint32_t address, bool succeeded)
{
        char addr[CIRCE_ADDRESS_LEN + 1];

        circe_address_format(address, addr);
        snprintf(buf, size, "%s %s", addr, succeeded ? SYNC_SUCCEEDED : SYNC_TIMED_OUT);
}

int reqp_sync_result_parse(const char *text, uint32_t *ret_address, bool *ret_succeeded)
{
        const char *outcome = text + CIRCE_ADDRESS_LEN + 1;
        uint32_t a;
        bool ok;

        if (strnlen(text, CIRCE_ADDRESS_LEN + 1u) <= CIRCE_ADDRESS_LEN ||
            text[CIRCE_ADDRESS_LEN] != ' ' || circe_address_parse(text, CIRCE_ADDRESS_LEN, &a) < 0)
                return -EPROTO;
        if (strcmp(outcome, SYNC_SUCCEEDED) == 0)
                ok = true;
        else if (strcmp(outcome, SYNC_TIMED_OUT) == 0)
                ok = false;
        else
                return -EPROTO;
        *ret_address = a;
        *ret_succeeded = ok;
        return 0;
}
