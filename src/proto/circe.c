/*
 * CIRCE codec: framer, validating parser, encoder.  Contract: PROTOCOLS.md section 2.
 *
 * Byte stream grammar (what the framer cuts into packets):
 *
 *      stream = *( noise / packet )
 *      noise  = any byte but STX (a stray ETX is counted apart)
 *      packet = STX *( any byte but STX, ETX ) ETX         ; at most CIRCE_PACKET_MAX bytes
 *
 * Framer states (struct circe_decoder.state):
 *
 *      HUNT     between packets.  STX -> PACKET; ETX -> stray ETX, counted; else noise, counted.
 *      PACKET   STX seen, bytes kept in buf.  ETX -> parse the packet, one result, HUNT.
 *               STX -> the partial packet is abandoned (one result), a new one starts: PACKET.
 *               a byte that would make the packet longer than CIRCE_PACKET_MAX -> one OVERLONG
 *               result, DISCARD.  Any other byte is kept.
 *      DISCARD  rest of an overlong packet.  STX -> PACKET; anything else (ETX too) dropped,
 *               counted.
 *
 * Packet grammar (what the parser checks, in this order; the first failure drops the packet):
 *
 *      packet = STX op TAB *( pid ":" value TAB ) [ CC ] ETX
 *      op = 2DIGIT   pid = 3DIGIT   CC = 2HEXDIG   value = *( any byte but NUL, STX, ETX, TAB )
 *
 *      1. framing    STX first, ETX last, neither inside, at most CIRCE_PACKET_MAX bytes
 *      2. checksum   present iff the byte before ETX is not TAB (the reference implementation's
 *                    rule); then it is TAB + 2 hex digits (either case) and equals the sum of
 *                    every byte from STX through that TAB, mod 256
 *      3. header     2 digits + TAB
 *      4. operation  a known code
 *      5. syntax     every parameter is 3 digits ":" value TAB, no NUL in the value
 *      6. values     type, length, range of every parameter kept (see below)
 *      7. mandatory  every mandatory parameter present (Visualize: 014 and one display field)
 *
 * Field practice of the reference implementation: a parameter not allowed for the operation is
 * skipped, its value unchecked; a repeated parameter keeps its first occurrence, later ones are
 * skipped unchecked.  Only 014 in Visualize repeats legitimately: each one is a destination.
 */
#include "proto/circe.h"

#include <errno.h>
#include <string.h>

/* ---- Tables ---------------------------------------------------------------------------------- */

#define PARAM_ID_LIMIT 39               /* parameter ids 000..038 have a table entry */
#define PARAM_ID_DIGITS 3
#define OP_CODE_DIGITS 2
#define OP_CODE_LIMIT 55                /* operation codes 00..54 have a table entry */
#define HEADER_LEN (1 + OP_CODE_DIGITS + 1)     /* STX op TAB */
#define CHECKSUM_DIGITS 2
#define VERSION_PART_DIGITS 3
#define BOOL_MAX 1

/* A set of parameter ids; every id a table knows is below 64. */
#define PBIT(id) (UINT64_C(1) << (id))

enum param_type {
        PT_UNKNOWN = 0,
        PT_INTEGER,                     /* digits only; booleans are integers of range 0-1 */
        PT_ADDRESS,                     /* exactly 6 uppercase hex digits, not FFFFFF */
        PT_VERSION,                     /* 1-3 digits "." 1-3 digits "." 1-3 digits */
        PT_BINARY,                      /* non-empty uppercase hex pairs */
};

struct param_spec {
        uint8_t type;                   /* enum param_type */
        uint8_t max_len;                /* characters; 0: bounded by CIRCE_LOG_MAX (binary) */
        uint32_t min, max;              /* integers only */
};

/* PROTOCOLS.md 2.3, row by row.  028/029 allow 4 characters but only 0-999 (as the spec). */
static const struct param_spec param_specs[PARAM_ID_LIMIT] = {
        [CIRCE_PARAM_PROTOCOL_VERSION]   = { PT_VERSION, CIRCE_VERSION_LEN_MAX, 0, 0 },
        [CIRCE_PARAM_MEDIATOR_STATUS]    = { PT_INTEGER, 3, 0, CIRCE_STATUS_MAX },
        [CIRCE_PARAM_DESTINATION]        = { PT_ADDRESS, CIRCE_ADDRESS_LEN, 0, 0 },
        [CIRCE_PARAM_ORIGIN]             = { PT_ADDRESS, CIRCE_ADDRESS_LEN, 0, 0 },
        [CIRCE_PARAM_GET_MEMBERSHIP]     = { PT_INTEGER, 1, 0, BOOL_MAX },
        [CIRCE_PARAM_SET_MEMBERSHIP]     = { PT_INTEGER, 1, 0, BOOL_MAX },
        [CIRCE_PARAM_CAPABILITIES]       = { PT_INTEGER, 3, 0, CIRCE_CAPABILITIES_MAX },
        [CIRCE_PARAM_ROLES]              = { PT_INTEGER, 3, 0, CIRCE_ROLES_MAX },
        [CIRCE_PARAM_SIGNAL]             = { PT_INTEGER, 3, 0, CIRCE_LEVEL_MAX },
        [CIRCE_PARAM_BATTERY]            = { PT_INTEGER, 3, 0, CIRCE_LEVEL_MAX },
        [CIRCE_PARAM_ALIGNED]            = { PT_INTEGER, 1, 0, BOOL_MAX },
        [CIRCE_PARAM_INPUT_KEYS]         = { PT_INTEGER, 5, 0, CIRCE_KEYS_MAX },
        [CIRCE_PARAM_SENSOR_TIME]        = { PT_INTEGER, 6, 0, CIRCE_TIME_MS_MAX },
        [CIRCE_PARAM_ASSIGN_ADDRESS]     = { PT_ADDRESS, CIRCE_ADDRESS_LEN, 0, 0 },
        [CIRCE_PARAM_CLOCK_SYNC]         = { PT_INTEGER, 1, 1, 2 },
        [CIRCE_PARAM_CURRENT_COMPETITOR] = { PT_INTEGER, 4, 0, CIRCE_COMPETITOR_MAX },
        [CIRCE_PARAM_NEXT_COMPETITOR]    = { PT_INTEGER, 4, 0, CIRCE_COMPETITOR_MAX },
        [CIRCE_PARAM_START_TIMER]        = { PT_INTEGER, 1, 1, 1 },
        [CIRCE_PARAM_PRIMARY_TIMER]      = { PT_INTEGER, 6, 0, CIRCE_TIME_MS_MAX },
        [CIRCE_PARAM_FAULTS]             = { PT_INTEGER, 2, 0, CIRCE_COUNT_MAX },
        [CIRCE_PARAM_REFUSALS]           = { PT_INTEGER, 2, 0, CIRCE_COUNT_MAX },
        [CIRCE_PARAM_ELIMINATED]         = { PT_INTEGER, 1, 0, BOOL_MAX },
        [CIRCE_PARAM_PLACEMENT]          = { PT_INTEGER, 3, 0, CIRCE_PLACEMENT_MAX },
        [CIRCE_PARAM_LOG_DATA]           = { PT_BINARY, 0, 0, 0 },
        [CIRCE_PARAM_VERSION_MISMATCH]   = { PT_INTEGER, 1, 0, BOOL_MAX },
        [CIRCE_PARAM_SECONDARY_TIMER]    = { PT_INTEGER, 6, 0, CIRCE_TIME_MS_MAX },
};

/* Visualize's display fields: at least one must be present. */
#define VISUALIZE_DISPLAY_SET                                                                  \
        (PBIT(CIRCE_PARAM_ELIMINATED) | PBIT(CIRCE_PARAM_CURRENT_COMPETITOR) |                 \
         PBIT(CIRCE_PARAM_NEXT_COMPETITOR) | PBIT(CIRCE_PARAM_START_TIMER) |                   \
         PBIT(CIRCE_PARAM_PRIMARY_TIMER) | PBIT(CIRCE_PARAM_SECONDARY_TIMER) |                 \
         PBIT(CIRCE_PARAM_FAULTS) | PBIT(CIRCE_PARAM_REFUSALS) | PBIT(CIRCE_PARAM_PLACEMENT))

#define NOTIFY_STATUS_MANDATORY                                                                \
        (PBIT(CIRCE_PARAM_ORIGIN) | PBIT(CIRCE_PARAM_GET_MEMBERSHIP) |                         \
         PBIT(CIRCE_PARAM_CAPABILITIES) | PBIT(CIRCE_PARAM_ROLES) | PBIT(CIRCE_PARAM_SIGNAL))

struct op_spec {
        const char *name;               /* NULL: not an operation */
        bool from_controller;
        uint64_t allowed;               /* parameters the operation may carry */
        uint64_t mandatory;             /* parameters it must carry */
        uint64_t any_of;                /* of these, at least one (0: no such rule) */
};

/* PROTOCOLS.md 2.2, with the errata: 012 in Keep Alive, 026 in Device Setup, 037 in Status. */
static const struct op_spec op_specs[OP_CODE_LIMIT] = {
        [CIRCE_OP_LOGIN] = { "Login", true, 0, 0, 0 },
        [CIRCE_OP_LOGOUT] = { "Logout", true, 0, 0, 0 },
        [CIRCE_OP_ALERT] = { "Alert", true, PBIT(CIRCE_PARAM_DESTINATION),
                             PBIT(CIRCE_PARAM_DESTINATION), 0 },
        [CIRCE_OP_NETWORK_SETUP] = {
                "Network Setup", true,
                PBIT(CIRCE_PARAM_DESTINATION) | PBIT(CIRCE_PARAM_SET_MEMBERSHIP) |
                        PBIT(CIRCE_PARAM_ROLES),
                PBIT(CIRCE_PARAM_DESTINATION) | PBIT(CIRCE_PARAM_SET_MEMBERSHIP) |
                        PBIT(CIRCE_PARAM_ROLES),
                0 },
        [CIRCE_OP_DEVICE_SETUP] = {
                "Device Setup", true,
                PBIT(CIRCE_PARAM_DESTINATION) | PBIT(CIRCE_PARAM_ASSIGN_ADDRESS) |
                        PBIT(CIRCE_PARAM_CAPABILITIES),
                PBIT(CIRCE_PARAM_ASSIGN_ADDRESS), 0 },
        [CIRCE_OP_SYNC_CLOCKS] = { "Synchronize Clocks", true, 0, 0, 0 },
        [CIRCE_OP_VISUALIZE] = {
                "Visualize", true,
                PBIT(CIRCE_PARAM_DESTINATION) | VISUALIZE_DISPLAY_SET,
                PBIT(CIRCE_PARAM_DESTINATION), VISUALIZE_DISPLAY_SET },
        [CIRCE_OP_KEEP_ALIVE] = {
                "Keep Alive", false,
                PBIT(CIRCE_PARAM_PROTOCOL_VERSION) | PBIT(CIRCE_PARAM_MEDIATOR_STATUS),
                PBIT(CIRCE_PARAM_PROTOCOL_VERSION) | PBIT(CIRCE_PARAM_MEDIATOR_STATUS), 0 },
        [CIRCE_OP_NOTIFY_STATUS] = {
                "Notify Status", false,
                NOTIFY_STATUS_MANDATORY | PBIT(CIRCE_PARAM_BATTERY) | PBIT(CIRCE_PARAM_ALIGNED) |
                        PBIT(CIRCE_PARAM_CLOCK_SYNC) | PBIT(CIRCE_PARAM_VERSION_MISMATCH),
                NOTIFY_STATUS_MANDATORY, 0 },
        [CIRCE_OP_NOTIFY_ACTION] = {
                "Notify Action", false,
                PBIT(CIRCE_PARAM_ORIGIN) | PBIT(CIRCE_PARAM_INPUT_KEYS) |
                        PBIT(CIRCE_PARAM_SENSOR_TIME),
                PBIT(CIRCE_PARAM_ORIGIN), 0 },
        [CIRCE_OP_LOG] = { "Log", false, PBIT(CIRCE_PARAM_LOG_DATA), PBIT(CIRCE_PARAM_LOG_DATA), 0 },
};

/* A Visualize with one more destination than the bound cannot fit in a legal packet. */
_Static_assert((CIRCE_VISUALIZE_DEST_MAX + 1) * (PARAM_ID_DIGITS + 1 + CIRCE_ADDRESS_LEN + 1) +
                       HEADER_LEN + sizeof("030:1\t") - 1 + 1 > CIRCE_PACKET_MAX,
               "CIRCE_VISUALIZE_DEST_MAX below what a packet can hold");
/* The largest Log fits a packet without checksum, one more byte does not. */
_Static_assert(HEADER_LEN + PARAM_ID_DIGITS + 1 + 2 * CIRCE_LOG_MAX + 1 + 1 == CIRCE_PACKET_MAX,
               "CIRCE_LOG_MAX does not match CIRCE_PACKET_MAX");

static const char *const reason_strs[CIRCE_REASON_COUNT] = {
        [CIRCE_REASON_NONE] = "no error",
        [CIRCE_REASON_OVERLONG] = "overlong packet",
        [CIRCE_REASON_ABANDONED] = "packet abandoned by a new STX",
        [CIRCE_REASON_BAD_FRAMING] = "bad framing",
        [CIRCE_REASON_CHECKSUM_SYNTAX] = "malformed checksum",
        [CIRCE_REASON_BAD_CHECKSUM] = "bad checksum",
        [CIRCE_REASON_BAD_HEADER] = "bad header",
        [CIRCE_REASON_UNKNOWN_OP] = "unknown operation",
        [CIRCE_REASON_BAD_PARAM_SYNTAX] = "bad parameter syntax",
        [CIRCE_REASON_VALUE_LENGTH] = "bad value length",
        [CIRCE_REASON_VALUE_TYPE] = "bad value type",
        [CIRCE_REASON_VALUE_RANGE] = "value out of range",
        [CIRCE_REASON_MISSING_PARAM] = "missing mandatory parameter",
};

static const char hex_upper[] = "0123456789ABCDEF";

/* ---- Small helpers --------------------------------------------------------------------------- */

static const struct op_spec *op_spec_get(unsigned code)
{
        if (code >= OP_CODE_LIMIT || !op_specs[code].name)
                return NULL;
        return &op_specs[code];
}

static bool is_digit(uint8_t c)
{
        return c >= '0' && c <= '9';
}

/* Uppercase hex digit value, or -1. */
static int hex_upper_val(uint8_t c)
{
        if (is_digit(c))
                return c - '0';
        if (c >= 'A' && c <= 'F')
                return c - 'A' + 10;
        return -1;
}

/* Hex digit value in either case (checksums only), or -1. */
static int hex_any_val(uint8_t c)
{
        if (c >= 'a' && c <= 'f')
                return c - 'a' + 10;
        return hex_upper_val(c);
}

/* ---- Value checks (step 6) ------------------------------------------------------------------- */

static enum circe_reason check_integer(const struct param_spec *ps, const uint8_t *v, size_t len,
                                       uint32_t *ret_num)
{
        uint32_t n = 0;

        if (len == 0 || len > ps->max_len)
                return CIRCE_REASON_VALUE_LENGTH;
        for (size_t i = 0; i < len; i++) {
                if (!is_digit(v[i]))
                        return CIRCE_REASON_VALUE_TYPE;
                n = n * 10 + (uint32_t)(v[i] - '0');    /* max_len <= 6: no overflow */
        }
        if (n < ps->min || n > ps->max)
                return CIRCE_REASON_VALUE_RANGE;
        *ret_num = n;
        return CIRCE_REASON_NONE;
}

static enum circe_reason check_address(const uint8_t *v, size_t len, uint32_t *ret_addr)
{
        uint32_t a = 0;

        if (len != CIRCE_ADDRESS_LEN)
                return CIRCE_REASON_VALUE_LENGTH;
        for (size_t i = 0; i < len; i++) {
                int x = hex_upper_val(v[i]);
                if (x < 0)
                        return CIRCE_REASON_VALUE_TYPE;
                a = a << 4 | (uint32_t)x;
        }
        if (a == CIRCE_ADDRESS_RESERVED)
                return CIRCE_REASON_VALUE_RANGE;
        *ret_addr = a;
        return CIRCE_REASON_NONE;
}

/* parts (1..CIRCE_VERSION_PARTS) numbers of 1-3 digits, dot-separated; the wire has 3. */
static enum circe_reason check_version(const uint8_t *v, size_t len, unsigned parts,
                                       struct circe_version *ret_ver)
{
        uint16_t part[CIRCE_VERSION_PARTS] = { 0 };
        size_t i = 0;

        if (len == 0 || len > CIRCE_VERSION_LEN_MAX)
                return CIRCE_REASON_VALUE_LENGTH;
        if (parts == 0 || parts > CIRCE_VERSION_PARTS)
                return CIRCE_REASON_VALUE_TYPE;
        for (unsigned k = 0; k < parts; k++) {
                size_t digits = 0;

                if (k > 0) {
                        if (i >= len || v[i] != '.')
                                return CIRCE_REASON_VALUE_TYPE;
                        i++;
                }
                while (i < len && is_digit(v[i]) && digits < VERSION_PART_DIGITS) {
                        part[k] = (uint16_t)(part[k] * 10 + (v[i] - '0'));
                        i++;
                        digits++;
                }
                if (digits == 0)
                        return CIRCE_REASON_VALUE_TYPE;
        }
        if (i != len)
                return CIRCE_REASON_VALUE_TYPE;
        ret_ver->major = part[0];
        ret_ver->minor = part[1];
        ret_ver->patch = part[2];
        return CIRCE_REASON_NONE;
}

static enum circe_reason check_binary(const uint8_t *v, size_t len)
{
        if (len == 0 || len / 2 > CIRCE_LOG_MAX)
                return CIRCE_REASON_VALUE_LENGTH;
        if (len % 2 != 0)
                return CIRCE_REASON_VALUE_TYPE;
        for (size_t i = 0; i < len; i++)
                if (hex_upper_val(v[i]) < 0)
                        return CIRCE_REASON_VALUE_TYPE;
        return CIRCE_REASON_NONE;
}

/* A checked value, whatever its type. */
struct value {
        uint32_t num;                   /* integer, boolean or address */
        struct circe_version version;
        const uint8_t *raw;             /* binary: the hex digits */
        size_t raw_len;
};

static enum circe_reason check_value(unsigned id, const uint8_t *v, size_t len, struct value *val)
{
        const struct param_spec *ps = &param_specs[id];

        switch ((enum param_type)ps->type) {
        case PT_INTEGER:
                return check_integer(ps, v, len, &val->num);
        case PT_ADDRESS:
                return check_address(v, len, &val->num);
        case PT_VERSION:
                return check_version(v, len, CIRCE_VERSION_PARTS, &val->version);
        case PT_BINARY:
                val->raw = v;
                val->raw_len = len;
                return check_binary(v, len);
        case PT_UNKNOWN:
                break;
        }
        /* Unreachable: only ids an operation allows get here, and they all have a type. */
        return CIRCE_REASON_BAD_PARAM_SYNTAX;
}

/* ---- Storing a checked value into the typed message ------------------------------------------ */

static void store_log(struct circe_log *l, const struct value *val)
{
        l->len = (uint16_t)(val->raw_len / 2);
        for (size_t i = 0; i < l->len; i++)
                l->data[i] = (uint8_t)(hex_upper_val(val->raw[2 * i]) << 4 |
                                       hex_upper_val(val->raw[2 * i + 1]));
}

static void store_visualize(struct circe_visualize *v, unsigned id, const struct value *val)
{
        switch (id) {
        case CIRCE_PARAM_ELIMINATED:
                v->has_eliminated = true;
                v->eliminated = val->num != 0;
                break;
        case CIRCE_PARAM_CURRENT_COMPETITOR:
                v->has_current = true;
                v->current = (uint16_t)val->num;
                break;
        case CIRCE_PARAM_NEXT_COMPETITOR:
                v->has_next = true;
                v->next = (uint16_t)val->num;
                break;
        case CIRCE_PARAM_START_TIMER:
                v->start_timer = true;
                break;
        case CIRCE_PARAM_PRIMARY_TIMER:
                v->has_primary = true;
                v->primary_ms = val->num;
                break;
        case CIRCE_PARAM_SECONDARY_TIMER:
                v->has_secondary = true;
                v->secondary_ms = val->num;
                break;
        case CIRCE_PARAM_FAULTS:
                v->has_faults = true;
                v->faults = (uint8_t)val->num;
                break;
        case CIRCE_PARAM_REFUSALS:
                v->has_refusals = true;
                v->refusals = (uint8_t)val->num;
                break;
        case CIRCE_PARAM_PLACEMENT:
                v->has_placement = true;
                v->placement = (uint16_t)val->num;
                break;
        }
}

static void store_notify_status(struct circe_notify_status *s, unsigned id,
                                const struct value *val)
{
        switch (id) {
        case CIRCE_PARAM_ORIGIN:
                s->origin = val->num;
                break;
        case CIRCE_PARAM_GET_MEMBERSHIP:
                s->membership = val->num != 0;
                break;
        case CIRCE_PARAM_CAPABILITIES:
                s->capabilities = (uint8_t)val->num;
                break;
        case CIRCE_PARAM_ROLES:
                s->roles = (uint8_t)val->num;
                break;
        case CIRCE_PARAM_SIGNAL:
                s->signal = (uint8_t)val->num;
                break;
        case CIRCE_PARAM_BATTERY:
                s->has_battery = true;
                s->battery = (uint8_t)val->num;
                break;
        case CIRCE_PARAM_ALIGNED:
                s->has_aligned = true;
                s->aligned = val->num != 0;
                break;
        case CIRCE_PARAM_CLOCK_SYNC:
                s->has_clock_sync = true;
                s->clock_sync = (uint8_t)val->num;
                break;
        case CIRCE_PARAM_VERSION_MISMATCH:
                s->has_version_mismatch = true;
                s->version_mismatch = val->num != 0;
                break;
        }
}

/* id is allowed for m->op and seen for the first time (Visualize's 014 is handled apart). */
static void store_value(struct circe_msg *m, unsigned id, const struct value *val)
{
        switch (m->op) {
        case CIRCE_OP_ALERT:
                m->u.alert.dest = val->num;
                break;
        case CIRCE_OP_NETWORK_SETUP:
                if (id == CIRCE_PARAM_DESTINATION)
                        m->u.network_setup.dest = val->num;
                else if (id == CIRCE_PARAM_SET_MEMBERSHIP)
                        m->u.network_setup.set_membership = val->num != 0;
                else
                        m->u.network_setup.roles = (uint8_t)val->num;
                break;
        case CIRCE_OP_DEVICE_SETUP:
                if (id == CIRCE_PARAM_DESTINATION) {
                        m->u.device_setup.has_dest = true;
                        m->u.device_setup.dest = val->num;
                } else if (id == CIRCE_PARAM_ASSIGN_ADDRESS) {
                        m->u.device_setup.assign = val->num;
                } else {
                        m->u.device_setup.has_capabilities = true;
                        m->u.device_setup.capabilities = (uint8_t)val->num;
                }
                break;
        case CIRCE_OP_VISUALIZE:
                store_visualize(&m->u.visualize, id, val);
                break;
        case CIRCE_OP_KEEP_ALIVE:
                if (id == CIRCE_PARAM_PROTOCOL_VERSION)
                        m->u.keep_alive.version = val->version;
                else
                        m->u.keep_alive.status = (uint16_t)val->num;
                break;
        case CIRCE_OP_NOTIFY_STATUS:
                store_notify_status(&m->u.notify_status, id, val);
                break;
        case CIRCE_OP_NOTIFY_ACTION:
                if (id == CIRCE_PARAM_ORIGIN) {
                        m->u.notify_action.origin = val->num;
                } else if (id == CIRCE_PARAM_INPUT_KEYS) {
                        m->u.notify_action.has_keys = true;
                        m->u.notify_action.keys = (uint16_t)val->num;
                } else {
                        m->u.notify_action.has_sensor_time = true;
                        m->u.notify_action.sensor_time_ms = val->num;
                }
                break;
        case CIRCE_OP_LOG:
                store_log(&m->u.log, val);
                break;
        default:
                break;          /* operations without parameters allow none */
        }
}

/* ---- Packet parser --------------------------------------------------------------------------- */

/* Most parameters a packet can hold: each takes 5 bytes at least ("ddd:" TAB). */
#define PARAMS_MAX ((CIRCE_PACKET_MAX - HEADER_LEN - 1) / (PARAM_ID_DIGITS + 2))

/* A parameter that passed step 5: its id and where its value lies in the packet. */
struct param_ref {
        uint16_t id;
        uint16_t pos;
        uint16_t len;
};

_Static_assert(CIRCE_PACKET_MAX <= UINT16_MAX, "struct param_ref holds 16-bit positions");

/* Step 1: STX first, ETX last, neither inside.  Also sums every byte before the ETX, from which
 * step 2 takes its checksum. */
static bool parse_framing(const uint8_t *pkt, size_t len, unsigned *ret_sum)
{
        unsigned sum = CIRCE_STX;

        if (len < 2 || pkt[0] != CIRCE_STX || pkt[len - 1] != CIRCE_ETX)
                return false;
        for (size_t i = 1; i < len - 1; i++) {
                if (pkt[i] == CIRCE_STX || pkt[i] == CIRCE_ETX)
                        return false;
                sum += pkt[i];
        }
        *ret_sum = sum;
        return true;
}

/* Step 2 for pkt[0..end), pkt[end] being ETX and sum the sum of pkt[0..end); sets
 * *ret_body_end, the end of what the checksum covers. */
static enum circe_reason parse_checksum(const uint8_t *pkt, size_t end, unsigned sum,
                                        struct circe_result *ret, size_t *ret_body_end)
{
        int hi, lo;

        /* The reference implementation's rule: TAB right before ETX means no checksum. */
        if (pkt[end - 1] == CIRCE_TAB) {
                *ret_body_end = end;
                return CIRCE_REASON_NONE;
        }
        /* Present: TAB CC right before ETX, and that TAB is not the STX slot. */
        if (end < HEADER_LEN || pkt[end - CHECKSUM_DIGITS - 1] != CIRCE_TAB)
                return CIRCE_REASON_CHECKSUM_SYNTAX;
        hi = hex_any_val(pkt[end - 2]);
        lo = hex_any_val(pkt[end - 1]);
        if (hi < 0 || lo < 0)
                return CIRCE_REASON_CHECKSUM_SYNTAX;
        sum -= (unsigned)pkt[end - 2] + pkt[end - 1];   /* STX through the last TAB */
        if ((sum & 0xFF) != (unsigned)(hi << 4 | lo))
                return CIRCE_REASON_BAD_CHECKSUM;
        ret->has_checksum = true;
        *ret_body_end = end - CHECKSUM_DIGITS;
        return CIRCE_REASON_NONE;
}

/* Step 5 for pkt[HEADER_LEN..end), pkt[end - 1] being TAB: every parameter is "ddd:" value TAB
 * with no NUL in the value.  Fills refs[0..*ret_count). */
static bool parse_syntax(const uint8_t *pkt, size_t end, struct param_ref refs[PARAMS_MAX],
                         size_t *ret_count)
{
        size_t n = 0, pos = HEADER_LEN;

        while (pos < end) {
                size_t vpos = pos + PARAM_ID_DIGITS + 1, v;

                /* n < PARAMS_MAX always holds within CIRCE_PACKET_MAX; kept as a guard. */
                if (end - pos < PARAM_ID_DIGITS + 2 || n >= PARAMS_MAX)
                        return false;
                if (!is_digit(pkt[pos]) || !is_digit(pkt[pos + 1]) || !is_digit(pkt[pos + 2]) ||
                    pkt[pos + PARAM_ID_DIGITS] != ':')
                        return false;
                /* pkt[end - 1] is TAB, so this scan stops inside the region. */
                for (v = vpos; pkt[v] != CIRCE_TAB; v++)
                        if (pkt[v] == '\0')
                                return false;
                refs[n].id = (uint16_t)((pkt[pos] - '0') * 100 + (pkt[pos + 1] - '0') * 10 +
                                        (pkt[pos + 2] - '0'));
                refs[n].pos = (uint16_t)vpos;
                refs[n].len = (uint16_t)(v - vpos);
                n++;
                pos = v + 1;
        }
        *ret_count = n;
        return true;
}

/* Step 6: checks and stores what the operation keeps, counts what it skips; *ret_seen gets
 * the ids kept. */
static enum circe_reason parse_values(const uint8_t *pkt, const struct param_ref *refs,
                                      size_t count, const struct op_spec *os,
                                      struct circe_result *ret, uint64_t *ret_seen)
{
        struct circe_msg *m = &ret->msg;
        uint64_t seen = 0;

        for (size_t i = 0; i < count; i++) {
                unsigned id = refs[i].id;
                struct value val;
                enum circe_reason r;
                bool dest_list;

                if (id >= PARAM_ID_LIMIT || !(os->allowed & PBIT(id))) {
                        ret->skipped++;
                        continue;
                }
                dest_list = m->op == CIRCE_OP_VISUALIZE && id == CIRCE_PARAM_DESTINATION;
                if (!dest_list && (seen & PBIT(id))) {
                        ret->repeated++;
                        continue;
                }
                r = check_value(id, pkt + refs[i].pos, refs[i].len, &val);
                if (r != CIRCE_REASON_NONE) {
                        ret->param = id;
                        return r;
                }
                seen |= PBIT(id);
                if (dest_list) {
                        struct circe_visualize *v = &m->u.visualize;
                        /* Cannot happen within CIRCE_PACKET_MAX (see the _Static_assert). */
                        if (v->dest_count >= CIRCE_VISUALIZE_DEST_MAX)
                                return CIRCE_REASON_OVERLONG;
                        v->dests[v->dest_count++] = val.num;
                } else {
                        store_value(m, id, &val);
                }
        }
        *ret_seen = seen;
        return CIRCE_REASON_NONE;
}

/* Zeroes the part of m that op uses, so absent optional fields read as zero. */
static void msg_clear(struct circe_msg *m, enum circe_op op)
{
        m->op = op;
        switch (op) {
        case CIRCE_OP_ALERT:
                memset(&m->u.alert, 0, sizeof(m->u.alert));
                break;
        case CIRCE_OP_NETWORK_SETUP:
                memset(&m->u.network_setup, 0, sizeof(m->u.network_setup));
                break;
        case CIRCE_OP_DEVICE_SETUP:
                memset(&m->u.device_setup, 0, sizeof(m->u.device_setup));
                break;
        case CIRCE_OP_VISUALIZE:
                memset(&m->u.visualize, 0, sizeof(m->u.visualize));
                break;
        case CIRCE_OP_KEEP_ALIVE:
                memset(&m->u.keep_alive, 0, sizeof(m->u.keep_alive));
                break;
        case CIRCE_OP_NOTIFY_STATUS:
                memset(&m->u.notify_status, 0, sizeof(m->u.notify_status));
                break;
        case CIRCE_OP_NOTIFY_ACTION:
                memset(&m->u.notify_action, 0, sizeof(m->u.notify_action));
                break;
        case CIRCE_OP_LOG:
                memset(&m->u.log, 0, sizeof(m->u.log));
                break;
        default:
                break;          /* no parameters */
        }
}

static enum circe_reason parse_packet(const uint8_t *pkt, size_t len, struct circe_result *ret)
{
        struct param_ref refs[PARAMS_MAX];
        const struct op_spec *os;
        size_t end, body_end, count;
        uint64_t seen = 0, missing;   /* = 0: gcc -fsanitize=thread warns maybe-uninitialized */
        unsigned sum;
        enum circe_reason r;

        /* 1. framing */
        if (len > CIRCE_PACKET_MAX)
                return CIRCE_REASON_OVERLONG;
        if (!parse_framing(pkt, len, &sum))
                return CIRCE_REASON_BAD_FRAMING;
        end = len - 1;

        /* 2. checksum */
        r = parse_checksum(pkt, end, sum, ret, &body_end);
        if (r != CIRCE_REASON_NONE)
                return r;

        /* 3. header, 4. operation */
        if (body_end < HEADER_LEN || !is_digit(pkt[1]) || !is_digit(pkt[2]) ||
            pkt[HEADER_LEN - 1] != CIRCE_TAB)
                return CIRCE_REASON_BAD_HEADER;
        os = op_spec_get((unsigned)((pkt[1] - '0') * 10 + (pkt[2] - '0')));
        if (!os)
                return CIRCE_REASON_UNKNOWN_OP;

        /* 5. syntax of every parameter, before any value is looked at */
        if (!parse_syntax(pkt, body_end, refs, &count))
                return CIRCE_REASON_BAD_PARAM_SYNTAX;

        /* 6. values */
        msg_clear(&ret->msg, (enum circe_op)(os - op_specs));
        r = parse_values(pkt, refs, count, os, ret, &seen);
        if (r != CIRCE_REASON_NONE)
                return r;

        /* 7. mandatory parameters */
        missing = os->mandatory & ~seen;
        if (missing) {
                ret->param = (unsigned)__builtin_ctzll(missing);
                return CIRCE_REASON_MISSING_PARAM;
        }
        if (os->any_of && !(os->any_of & seen))
                return CIRCE_REASON_MISSING_PARAM;      /* param 0: one of a group */
        return CIRCE_REASON_NONE;
}

/* Fills every field of *ret but msg (only msg.op is cleared). */
static void result_reset(struct circe_result *ret, const uint8_t *pkt, size_t len)
{
        ret->kind = CIRCE_RESULT_NONE;
        ret->reason = CIRCE_REASON_NONE;
        ret->param = 0;
        ret->skipped = 0;
        ret->repeated = 0;
        ret->has_checksum = false;
        ret->packet = pkt;
        ret->packet_len = len;
        ret->msg.op = CIRCE_OP_NONE;
}

static void result_reject(struct circe_result *ret, enum circe_reason reason)
{
        ret->kind = CIRCE_RESULT_REJECTED;
        ret->reason = reason;
        ret->skipped = 0;               /* counts of a dropped packet mean nothing */
        ret->repeated = 0;
        ret->msg.op = CIRCE_OP_NONE;
}

void circe_decode(const uint8_t *pkt, size_t len, struct circe_result *ret)
{
        enum circe_reason r;

        result_reset(ret, pkt, len);
        r = parse_packet(pkt, len, ret);
        if (r != CIRCE_REASON_NONE) {
                result_reject(ret, r);
                return;
        }
        ret->kind = CIRCE_RESULT_MESSAGE;
}

const char *circe_reason_str(enum circe_reason reason)
{
        if ((unsigned)reason >= CIRCE_REASON_COUNT)
                return "unknown reason";
        return reason_strs[reason];
}

/* ---- Framer ---------------------------------------------------------------------------------- */

void circe_decoder_init(struct circe_decoder *d)
{
        memset(d, 0, sizeof(*d));
        d->state = CIRCE_DECODER_HUNT;
}

static void decoder_start(struct circe_decoder *d)
{
        d->buf[0] = CIRCE_STX;
        d->len = 1;
        d->state = CIRCE_DECODER_PACKET;
}

/* In PACKET: keeps the ordinary bytes (neither STX nor ETX) at the head of p that still leave
 * room for ETX, in one go; returns how many.  Only a fast path for the loop below. */
static size_t decoder_take_run(struct circe_decoder *d, const uint8_t *p, size_t n)
{
        size_t room = CIRCE_PACKET_MAX - 1 - d->len, k = 0;

        if (n > room)
                n = room;
        while (k < n && p[k] != CIRCE_STX && p[k] != CIRCE_ETX) {
                d->buf[d->len + k] = p[k];
                k++;
        }
        d->len += k;
        return k;
}

/* ETX arrived: parse buf, leave one result. */
static void decoder_finish(struct circe_decoder *d, struct circe_result *ret)
{
        d->buf[d->len++] = CIRCE_ETX;
        d->state = CIRCE_DECODER_HUNT;
        circe_decode(d->buf, d->len, ret);
        if (ret->kind == CIRCE_RESULT_MESSAGE) {
                d->stats.messages++;
                d->stats.skipped_params += ret->skipped;
                d->stats.repeated_params += ret->repeated;
        } else {
                d->stats.rejected[ret->reason]++;
        }
}

static void decoder_reject(struct circe_decoder *d, enum circe_reason reason,
                           struct circe_result *ret)
{
        result_reset(ret, d->buf, d->len);
        result_reject(ret, reason);
        d->stats.rejected[reason]++;
}

size_t circe_decoder_feed(struct circe_decoder *d, const uint8_t *buf, size_t len,
                          struct circe_result *ret)
{
        size_t i = 0;

        result_reset(ret, NULL, 0);
        while (i < len) {
                uint8_t c = buf[i++];

                switch (d->state) {
                case CIRCE_DECODER_HUNT:
                        if (c == CIRCE_STX)
                                decoder_start(d);
                        else if (c == CIRCE_ETX)
                                d->stats.stray_etx++;
                        else
                                d->stats.noise++;
                        break;
                case CIRCE_DECODER_DISCARD:
                        if (c == CIRCE_STX)
                                decoder_start(d);
                        else
                                d->stats.discarded++;
                        break;
                case CIRCE_DECODER_PACKET:
                        if (c == CIRCE_ETX) {
                                decoder_finish(d, ret);
                                goto out;
                        }
                        if (c == CIRCE_STX) {
                                /* The result points at buf[0..len); decoder_start() rewrites
                                 * only buf[0], which holds STX already. */
                                decoder_reject(d, CIRCE_REASON_ABANDONED, ret);
                                decoder_start(d);
                                goto out;
                        }
                        /* Keep room for the ETX that must still come. */
                        if (d->len >= CIRCE_PACKET_MAX - 1) {
                                decoder_reject(d, CIRCE_REASON_OVERLONG, ret);
                                d->state = CIRCE_DECODER_DISCARD;
                                d->stats.discarded++;
                                goto out;
                        }
                        d->buf[d->len++] = c;
                        i += decoder_take_run(d, buf + i, len - i);
                        break;
                }
        }
out:
        d->stats.bytes += i;
        return i;
}

/* ---- Encoder --------------------------------------------------------------------------------- */

/* Writes what fits, counts everything, remembers the first invalid value. */
struct writer {
        char *buf;
        size_t size;
        size_t len;
        unsigned sum;
        bool invalid;
};

static void put_byte(struct writer *w, uint8_t c)
{
        if (w->len < w->size)
                w->buf[w->len] = (char)c;
        w->len++;
        w->sum += c;
}

static void put_uint(struct writer *w, uint32_t n)
{
        char digits[10];
        size_t k = 0;

        do {
                digits[k++] = (char)('0' + n % 10);
                n /= 10;
        } while (n);
        while (k)
                put_byte(w, (uint8_t)digits[--k]);
}

static void put_param_head(struct writer *w, unsigned id)
{
        put_byte(w, (uint8_t)('0' + id / 100));
        put_byte(w, (uint8_t)('0' + id / 10 % 10));
        put_byte(w, (uint8_t)('0' + id % 10));
        put_byte(w, ':');
}

static void put_param_int(struct writer *w, unsigned id, uint32_t n)
{
        const struct param_spec *ps = &param_specs[id];

        if (n < ps->min || n > ps->max)
                w->invalid = true;
        put_param_head(w, id);
        put_uint(w, n);
        put_byte(w, CIRCE_TAB);
}

static void put_param_bool(struct writer *w, unsigned id, bool b)
{
        put_param_int(w, id, b ? 1 : 0);
}

static void put_param_addr(struct writer *w, unsigned id, uint32_t a)
{
        if (a >= CIRCE_ADDRESS_RESERVED)        /* FFFFFF and anything wider than 24 bits */
                w->invalid = true;
        put_param_head(w, id);
        for (int shift = 20; shift >= 0; shift -= 4)
                put_byte(w, (uint8_t)hex_upper[(a >> shift) & 0xF]);
        put_byte(w, CIRCE_TAB);
}

static void put_param_version(struct writer *w, unsigned id, const struct circe_version *v)
{
        if (v->major > CIRCE_VERSION_PART_MAX || v->minor > CIRCE_VERSION_PART_MAX ||
            v->patch > CIRCE_VERSION_PART_MAX)
                w->invalid = true;
        put_param_head(w, id);
        put_uint(w, v->major);
        put_byte(w, '.');
        put_uint(w, v->minor);
        put_byte(w, '.');
        put_uint(w, v->patch);
        put_byte(w, CIRCE_TAB);
}

static void put_param_hex(struct writer *w, unsigned id, const uint8_t *data, size_t len)
{
        if (len == 0 || len > CIRCE_LOG_MAX) {
                w->invalid = true;
                return;
        }
        put_param_head(w, id);
        for (size_t i = 0; i < len; i++) {
                put_byte(w, (uint8_t)hex_upper[data[i] >> 4]);
                put_byte(w, (uint8_t)hex_upper[data[i] & 0xF]);
        }
        put_byte(w, CIRCE_TAB);
}

/* Spec order for Visualize: lowest precedence first, destinations last. */
static void put_visualize(struct writer *w, const struct circe_visualize *v)
{
        bool any = v->has_eliminated || v->has_current || v->has_next || v->start_timer ||
                   v->has_primary || v->has_secondary || v->has_faults || v->has_refusals ||
                   v->has_placement;

        if (!any || v->dest_count == 0 || v->dest_count > CIRCE_VISUALIZE_DEST_MAX) {
                w->invalid = true;
                return;
        }
        if (v->has_eliminated)
                put_param_bool(w, CIRCE_PARAM_ELIMINATED, v->eliminated);
        if (v->has_current)
                put_param_int(w, CIRCE_PARAM_CURRENT_COMPETITOR, v->current);
        if (v->has_next)
                put_param_int(w, CIRCE_PARAM_NEXT_COMPETITOR, v->next);
        if (v->start_timer)
                put_param_int(w, CIRCE_PARAM_START_TIMER, 1);
        if (v->has_primary)
                put_param_int(w, CIRCE_PARAM_PRIMARY_TIMER, v->primary_ms);
        if (v->has_secondary)
                put_param_int(w, CIRCE_PARAM_SECONDARY_TIMER, v->secondary_ms);
        if (v->has_faults)
                put_param_int(w, CIRCE_PARAM_FAULTS, v->faults);
        if (v->has_refusals)
                put_param_int(w, CIRCE_PARAM_REFUSALS, v->refusals);
        if (v->has_placement)
                put_param_int(w, CIRCE_PARAM_PLACEMENT, v->placement);
        for (size_t i = 0; i < v->dest_count; i++)
                put_param_addr(w, CIRCE_PARAM_DESTINATION, v->dests[i]);
}

static void put_notify_status(struct writer *w, const struct circe_notify_status *s)
{
        put_param_addr(w, CIRCE_PARAM_ORIGIN, s->origin);
        put_param_bool(w, CIRCE_PARAM_GET_MEMBERSHIP, s->membership);
        put_param_int(w, CIRCE_PARAM_CAPABILITIES, s->capabilities);
        put_param_int(w, CIRCE_PARAM_ROLES, s->roles);
        put_param_int(w, CIRCE_PARAM_SIGNAL, s->signal);
        if (s->has_battery)
                put_param_int(w, CIRCE_PARAM_BATTERY, s->battery);
        if (s->has_aligned)
                put_param_bool(w, CIRCE_PARAM_ALIGNED, s->aligned);
        if (s->has_clock_sync)
                put_param_int(w, CIRCE_PARAM_CLOCK_SYNC, s->clock_sync);
        if (s->has_version_mismatch)
                put_param_bool(w, CIRCE_PARAM_VERSION_MISMATCH, s->version_mismatch);
}

static void put_params(struct writer *w, const struct circe_msg *m)
{
        switch (m->op) {
        case CIRCE_OP_ALERT:
                put_param_addr(w, CIRCE_PARAM_DESTINATION, m->u.alert.dest);
                break;
        case CIRCE_OP_NETWORK_SETUP:
                put_param_addr(w, CIRCE_PARAM_DESTINATION, m->u.network_setup.dest);
                put_param_bool(w, CIRCE_PARAM_SET_MEMBERSHIP, m->u.network_setup.set_membership);
                put_param_int(w, CIRCE_PARAM_ROLES, m->u.network_setup.roles);
                break;
        case CIRCE_OP_DEVICE_SETUP:
                /* The reference writer's order, not id order: 014, 026, 019. */
                if (m->u.device_setup.has_dest)
                        put_param_addr(w, CIRCE_PARAM_DESTINATION, m->u.device_setup.dest);
                put_param_addr(w, CIRCE_PARAM_ASSIGN_ADDRESS, m->u.device_setup.assign);
                if (m->u.device_setup.has_capabilities)
                        put_param_int(w, CIRCE_PARAM_CAPABILITIES,
                                      m->u.device_setup.capabilities);
                break;
        case CIRCE_OP_VISUALIZE:
                put_visualize(w, &m->u.visualize);
                break;
        case CIRCE_OP_KEEP_ALIVE:
                put_param_version(w, CIRCE_PARAM_PROTOCOL_VERSION, &m->u.keep_alive.version);
                put_param_int(w, CIRCE_PARAM_MEDIATOR_STATUS, m->u.keep_alive.status);
                break;
        case CIRCE_OP_NOTIFY_STATUS:
                put_notify_status(w, &m->u.notify_status);
                break;
        case CIRCE_OP_NOTIFY_ACTION:
                put_param_addr(w, CIRCE_PARAM_ORIGIN, m->u.notify_action.origin);
                if (m->u.notify_action.has_keys)
                        put_param_int(w, CIRCE_PARAM_INPUT_KEYS, m->u.notify_action.keys);
                if (m->u.notify_action.has_sensor_time)
                        put_param_int(w, CIRCE_PARAM_SENSOR_TIME,
                                      m->u.notify_action.sensor_time_ms);
                break;
        case CIRCE_OP_LOG:
                put_param_hex(w, CIRCE_PARAM_LOG_DATA, m->u.log.data, m->u.log.len);
                break;
        default:
                break;          /* Login, Logout, Synchronize Clocks: no parameters */
        }
}

int circe_encode(const struct circe_msg *m, int with_checksum, char *buf, size_t size)
{
        struct writer w = { .buf = buf, .size = size };
        unsigned code = (unsigned)m->op;

        if (!op_spec_get(code))
                return -EINVAL;
        put_byte(&w, CIRCE_STX);
        put_byte(&w, (uint8_t)('0' + code / 10));
        put_byte(&w, (uint8_t)('0' + code % 10));
        put_byte(&w, CIRCE_TAB);
        put_params(&w, m);
        if (with_checksum) {
                unsigned sum = w.sum & 0xFF;    /* STX through the last TAB */
                put_byte(&w, (uint8_t)hex_upper[sum >> 4]);
                put_byte(&w, (uint8_t)hex_upper[sum & 0xF]);
        }
        put_byte(&w, CIRCE_ETX);
        if (w.invalid)
                return -EINVAL;
        if (w.len > CIRCE_PACKET_MAX)
                return -EMSGSIZE;
        if (w.len > size)
                return -ENOBUFS;
        return (int)w.len;
}

/* ---- Helpers --------------------------------------------------------------------------------- */

static bool visualize_equal(const struct circe_visualize *a, const struct circe_visualize *b)
{
        if (a->dest_count != b->dest_count || a->dest_count > CIRCE_VISUALIZE_DEST_MAX)
                return false;
        for (size_t i = 0; i < a->dest_count; i++)
                if (a->dests[i] != b->dests[i])
                        return false;
        return a->has_eliminated == b->has_eliminated &&
               (!a->has_eliminated || a->eliminated == b->eliminated) &&
               a->has_current == b->has_current && (!a->has_current || a->current == b->current) &&
               a->has_next == b->has_next && (!a->has_next || a->next == b->next) &&
               a->start_timer == b->start_timer &&
               a->has_primary == b->has_primary &&
               (!a->has_primary || a->primary_ms == b->primary_ms) &&
               a->has_secondary == b->has_secondary &&
               (!a->has_secondary || a->secondary_ms == b->secondary_ms) &&
               a->has_faults == b->has_faults && (!a->has_faults || a->faults == b->faults) &&
               a->has_refusals == b->has_refusals &&
               (!a->has_refusals || a->refusals == b->refusals) &&
               a->has_placement == b->has_placement &&
               (!a->has_placement || a->placement == b->placement);
}

static bool notify_status_equal(const struct circe_notify_status *a,
                                const struct circe_notify_status *b)
{
        return a->origin == b->origin && a->membership == b->membership &&
               a->capabilities == b->capabilities && a->roles == b->roles &&
               a->signal == b->signal &&
               a->has_battery == b->has_battery && (!a->has_battery || a->battery == b->battery) &&
               a->has_aligned == b->has_aligned && (!a->has_aligned || a->aligned == b->aligned) &&
               a->has_clock_sync == b->has_clock_sync &&
               (!a->has_clock_sync || a->clock_sync == b->clock_sync) &&
               a->has_version_mismatch == b->has_version_mismatch &&
               (!a->has_version_mismatch || a->version_mismatch == b->version_mismatch);
}

bool circe_msg_equal(const struct circe_msg *a, const struct circe_msg *b)
{
        if (a->op != b->op)
                return false;
        switch (a->op) {
        case CIRCE_OP_ALERT:
                return a->u.alert.dest == b->u.alert.dest;
        case CIRCE_OP_NETWORK_SETUP:
                return a->u.network_setup.dest == b->u.network_setup.dest &&
                       a->u.network_setup.set_membership == b->u.network_setup.set_membership &&
                       a->u.network_setup.roles == b->u.network_setup.roles;
        case CIRCE_OP_DEVICE_SETUP: {
                const struct circe_device_setup *x = &a->u.device_setup, *y = &b->u.device_setup;
                return x->has_dest == y->has_dest && (!x->has_dest || x->dest == y->dest) &&
                       x->assign == y->assign && x->has_capabilities == y->has_capabilities &&
                       (!x->has_capabilities || x->capabilities == y->capabilities);
        }
        case CIRCE_OP_VISUALIZE:
                return visualize_equal(&a->u.visualize, &b->u.visualize);
        case CIRCE_OP_KEEP_ALIVE:
                return a->u.keep_alive.version.major == b->u.keep_alive.version.major &&
                       a->u.keep_alive.version.minor == b->u.keep_alive.version.minor &&
                       a->u.keep_alive.version.patch == b->u.keep_alive.version.patch &&
                       a->u.keep_alive.status == b->u.keep_alive.status;
        case CIRCE_OP_NOTIFY_STATUS:
                return notify_status_equal(&a->u.notify_status, &b->u.notify_status);
        case CIRCE_OP_NOTIFY_ACTION: {
                const struct circe_notify_action *x = &a->u.notify_action;
                const struct circe_notify_action *y = &b->u.notify_action;
                return x->origin == y->origin && x->has_keys == y->has_keys &&
                       (!x->has_keys || x->keys == y->keys) &&
                       x->has_sensor_time == y->has_sensor_time &&
                       (!x->has_sensor_time || x->sensor_time_ms == y->sensor_time_ms);
        }
        case CIRCE_OP_LOG:
                return a->u.log.len == b->u.log.len && a->u.log.len <= CIRCE_LOG_MAX &&
                       memcmp(a->u.log.data, b->u.log.data, a->u.log.len) == 0;
        default:
                return true;    /* no parameters, or both CIRCE_OP_NONE */
        }
}

const char *circe_op_str(enum circe_op op)
{
        const struct op_spec *os = op_spec_get((unsigned)op);

        return os ? os->name : NULL;
}

bool circe_op_from_controller(enum circe_op op)
{
        const struct op_spec *os = op_spec_get((unsigned)op);

        return os && os->from_controller;
}

bool circe_capabilities_compliant(unsigned capabilities)
{
        const unsigned all = CIRCE_CAP_CONTROL_KEYPAD | CIRCE_CAP_NUMERIC_KEYPAD |
                             CIRCE_CAP_START_SENSOR | CIRCE_CAP_FINISH_SENSOR |
                             CIRCE_CAP_INTERMEDIATE_SENSOR | CIRCE_CAP_TIME_SENSOR |
                             CIRCE_CAP_DISPLAY;

        if (capabilities == 0 || (capabilities & ~all))
                return false;
        /* A time sensor or a display is a device of its own kind: nothing else may be set. */
        if ((capabilities & CIRCE_CAP_TIME_SENSOR) && capabilities != CIRCE_CAP_TIME_SENSOR)
                return false;
        if ((capabilities & CIRCE_CAP_DISPLAY) && capabilities != CIRCE_CAP_DISPLAY)
                return false;
        return true;
}

void circe_address_format(uint32_t addr, char out[CIRCE_ADDRESS_LEN + 1])
{
        for (int i = CIRCE_ADDRESS_LEN - 1; i >= 0; i--) {
                out[i] = hex_upper[addr & 0xF];
                addr >>= 4;
        }
        out[CIRCE_ADDRESS_LEN] = '\0';
}

int circe_address_parse(const char *s, size_t len, uint32_t *ret_addr)
{
        uint32_t a;
        enum circe_reason r = check_address((const uint8_t *)s, len, &a);

        if (r != CIRCE_REASON_NONE)
                return r == CIRCE_REASON_VALUE_RANGE ? -ERANGE : -EINVAL;
        *ret_addr = a;
        return 0;
}

int circe_version_parse(const char *s, size_t len, unsigned parts,
                        struct circe_version *ret_version)
{
        struct circe_version v;

        if (check_version((const uint8_t *)s, len, parts, &v) != CIRCE_REASON_NONE)
                return -EINVAL;
        *ret_version = v;
        return 0;
}
