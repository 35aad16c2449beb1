/*
 * libFuzzer target for the SharedLink codec (src/proto/sharedlink.c).
 *
 * Input layout (seeds in tests/fuzz/corpus/sharedlink/ follow it):
 *
 *      byte 0   flags: bits 0-1 decoder max_frame (0 default, 1 SLP_FRAME_MIN, 2 from byte 3,
 *               3 SLP_FRAME_MAX); bit 2 datagram mode (every chunk is a datagram, ended with
 *               slp_decoder_end()); bit 3 re-encode with CR LF; bits 4-7 list encoder: compress,
 *               full refresh, CR LF, make the values valid first.
 *      byte 1-2 seed of the chunk sizes
 *      byte 3   list max_frame (0: default, else 1 + 16 * byte) and decoder max_frame in mode 2
 *      rest     the wire bytes; also, split on ',', the values of an outbound list
 *
 * Checks (abort() with a message on failure):
 *   - the decoder consumes 1..len bytes per call, and all of it when it reports nothing;
 *   - every frame is well formed and at most max_frame; every rejection has a reason and a size;
 *   - bytes reported (frames + rejections) + CR/LF between frames == bytes fed;
 *   - in stream mode, chunking does not change the results (compared with one whole feed);
 *   - every decoded frame re-encodes (or is refused for a value over SLP_VALUE_MAX) and decodes
 *     back to the same addresses and fields; a canonical frame re-encodes to the same bytes;
 *   - the list encoder covers every position once, in frames of at most max_frame with the
 *     right N offsets and values, and fails exactly when a value is invalid or cannot fit;
 *   - Pronto4: slp_value_check() of every decoded value agrees with strtoll()/strtod() (C locale)
 *     as the reference; the declaration and acknowledgement encoders, fed the same values as
 *     names, cover every entry once with its T/Q or R/D pair, and fail at the first bad name;
 *     slp_encode_list_whole() gives one frame exactly when the list fits max_frame.
 */
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "proto/sharedlink.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define HEADER_LEN      4
#define LIST_MAX        512
#define FNV_OFFSET      1469598103934665603ull
#define FNV_PRIME       1099511628211ull

#define CHECK(cond) do { if (!(cond)) check_failed(#cond, __LINE__); } while (0)

static void check_failed(const char *what, int line)
{
        fprintf(stderr, "fuzz_sharedlink: check failed at line %d: %s\n", line, what);
        abort();
}

static struct slp_decoder dec, redec;

struct run {
        uint64_t hash;          /* of every result, in order */
        size_t reported;        /* bytes in frames and rejections */
        size_t fed;
        size_t crlf;            /* CR and LF bytes fed (upper bound on the whitespace) */
        bool reencode;
        bool crlf_flag;
};

static void hash_bytes(struct run *run, const void *p, size_t n)
{
        const uint8_t *b = p;

        for (size_t i = 0; i < n; i++)
                run->hash = (run->hash ^ b[i]) * FNV_PRIME;
}

static void hash_word(struct run *run, uint64_t w)
{
        hash_bytes(run, &w, sizeof(w));
}

static bool printable_value(const char *v, size_t n)
{
        for (size_t i = 0; i < n; i++) {
                unsigned char c = (unsigned char)v[i];
                if (c < 0x20 || c > 0x7e || c == '|' || c == '[' || c == ']')
                        return false;
        }
        return true;
}

/* N and L: "?" or decimal digits, saturated at SLP_INDEX_MAX; anything else is not decoded. */
static uint32_t expected_index(const char *v, size_t n)
{
        uint64_t k = 0;

        if (n == 1 && v[0] == '?')
                return SLP_INDEX_QUERY;
        CHECK(n > 0);
        for (size_t i = 0; i < n; i++) {
                CHECK(v[i] >= '0' && v[i] <= '9');
                k = k * 10 + (uint64_t)(v[i] - '0');
                if (k > SLP_INDEX_MAX)
                        k = SLP_INDEX_MAX;
        }
        return (uint32_t)k;
}

static void check_frame_shape(const struct slp_frame *f, size_t max_frame)
{
        size_t unknown = 0;

        CHECK(f->raw_len >= 9 && f->raw_len <= max_frame);
        CHECK(f->raw[0] == '[' && f->raw[f->raw_len - 1] == ']');
        CHECK(f->dst >= 'A' && f->dst <= 'P' && f->src >= 'A' && f->src <= 'P');
        CHECK(f->dst_index == f->dst - 'A' && f->src_index == f->src - 'A');
        CHECK(f->nfields >= 1 && f->nfields <= SLP_FIELDS_MAX);
        for (size_t i = 0; i < f->nfields; i++) {
                const struct slp_field *fl = &f->fields[i];

                CHECK(fl->letter >= 'A' && fl->letter <= 'Z' && fl->letter != 'C');
                CHECK(fl->value > f->raw && fl->value + fl->len < f->raw + f->raw_len);
                CHECK(printable_value(fl->value, fl->len));
                if (fl->type == SLP_FIELD_UNKNOWN)
                        unknown++;
                else
                        CHECK(fl->type == fl->letter);
                if (fl->type == SLP_FIELD_N || fl->type == SLP_FIELD_L)
                        CHECK(fl->index == expected_index(fl->value, fl->len));
        }
        CHECK(unknown == f->unknown_fields);
}

/* Re-encodes a decoded frame and decodes it again: same addresses, same fields. */
static void check_reencode(const struct slp_frame *f, bool crlf)
{
        static char out[SLP_FRAME_MAX + 8];
        struct slp_decode_result r;
        bool long_value = false, canonical;
        size_t used;
        int n;

        for (size_t i = 0; i < f->nfields; i++)
                long_value |= f->fields[i].len > SLP_VALUE_MAX;
        n = slp_frame_encode(out, sizeof(out), f->dst, f->src, f->fields, f->nfields,
                             crlf ? SLP_ENCODE_CRLF : 0);
        if (long_value) {
                CHECK(n == -EMSGSIZE);
                return;
        }
        CHECK(n > 0);
        /* Only the skipped empty fields and a padded one-digit checksum can change the size. */
        CHECK((size_t)n <= f->raw_len + 1 + (crlf ? 2 : 0));
        if (crlf)
                CHECK(out[n - 2] == '\r' && out[n - 1] == '\n');
        /* Canonical input: no empty field, two uppercase checksum digits. It must not change. */
        canonical = f->empty_fields == 0 && f->raw[f->raw_len - 4] == 'C' &&
                    strchr("0123456789ABCDEF", f->raw[f->raw_len - 3]) &&
                    strchr("0123456789ABCDEF", f->raw[f->raw_len - 2]);
        if (canonical)
                CHECK((size_t)n - (crlf ? 2 : 0) == f->raw_len &&
                      memcmp(out, f->raw, f->raw_len) == 0);
        if ((size_t)n - (crlf ? 2 : 0) > SLP_FRAME_MAX)
                return;         /* a one-digit checksum frame of SLP_FRAME_MAX bytes, padded */

        CHECK(slp_decoder_init(&redec, SLP_FRAME_MAX) == 0);
        used = slp_decoder_feed(&redec, (const uint8_t *)out, (size_t)n, &r);
        CHECK(r.kind == SLP_RESULT_FRAME);
        CHECK(used == (size_t)n - (crlf ? 2 : 0));
        CHECK(r.frame->dst == f->dst && r.frame->src == f->src);
        CHECK(r.frame->nfields == f->nfields);
        CHECK(r.frame->empty_fields == 0 && r.frame->unknown_fields == f->unknown_fields);
        for (size_t i = 0; i < f->nfields; i++) {
                const struct slp_field *a = &f->fields[i], *b = &r.frame->fields[i];

                CHECK(a->letter == b->letter && a->type == b->type && a->index == b->index);
                CHECK(a->len == b->len && memcmp(a->value, b->value, a->len) == 0);
        }
}

/* ---------------------------------------------------------------------------------------------
 * Pronto4 value types, against the C library as the reference (the fuzzer never sets a locale) */

static bool only_chars(const char *v, size_t n, const char *set)
{
        for (size_t i = 0; i < n; i++)
                if (!strchr(set, v[i]))
                        return false;
        return true;
}

static void check_value_types(const char *v, size_t n)
{
        static char z[SLP_VALUE_MAX + 1];
        bool valid = n <= SLP_VALUE_MAX && printable_value(v, n);
        int rl = slp_value_check(SLP_TYPE_LONG, v, n);
        int rd = slp_value_check(SLP_TYPE_DOUBLE, v, n);
        int rs = slp_value_check(SLP_TYPE_STRING, v, n);
        bool sign_digits;
        size_t sign;
        char *end;
        double d;

        CHECK(rs == (n > SLP_VALUE_MAX ? -EMSGSIZE : valid ? 0 : -EINVAL));
        if (!valid) {
                CHECK(rl == rs && rd == rs);
                return;
        }
        memcpy(z, v, n);
        z[n] = '\0';
        /* long: [+-] digits, and strtoll() takes it all without ERANGE. */
        sign = n > 0 && (z[0] == '+' || z[0] == '-');
        sign_digits = n > sign && only_chars(z + sign, n - sign, "0123456789");
        errno = 0;
        (void)strtoll(z, &end, 10);
        CHECK((rl == 0) == (sign_digits && errno == 0 && end == z + n));
        CHECK(rl == 0 || rl == -EINVAL);
        /* double: accepted only if strtod() takes it all and it is finite; a plain decimal that
         * strtod() reads whole to below DBL_MAX must be accepted. */
        errno = 0;
        d = strtod(z, &end);
        if (rd == 0) {
                CHECK(n > 0 && end == z + n && isfinite(d) && fabs(d) <= DBL_MAX);
                CHECK(only_chars(z, n, "0123456789+-.eE"));
        } else {
                CHECK(rd == -EINVAL);
                CHECK(!(n > 0 && only_chars(z, n, "0123456789+-.eE") && end == z + n &&
                        fabs(d) < DBL_MAX));
        }
}

/* The dialect's reading of a frame: a kind in range; entries that always move on, lie inside
 * the frame and are what slp_entry_next() promises. */
static void check_entries(const struct slp_frame *f)
{
        enum slp_p4_kind k = slp_p4_kind_of(f);
        struct slp_entry e;
        size_t pos = 1, prev = 1;
        int r;

        CHECK(k >= SLP_P4_OTHER && k <= SLP_P4_MU);
        while ((r = slp_entry_next(f, &pos, &e)) != 0) {
                CHECK(pos > prev && pos <= f->nfields);
                prev = pos;
                if (r < 0) {
                        CHECK(r == -EINVAL);
                        continue;
                }
                CHECK(r == 1 && (e.letter == 'Q' || e.letter == 'R'));
                CHECK(slp_name_check(e.name, e.name_len) == 0);
                CHECK(e.name > f->raw && e.name + e.name_len < f->raw + f->raw_len);
                CHECK(slp_type_digit(e.type) != 0 && (e.typed || e.type == SLP_TYPE_DOUBLE));
                if (e.has_value)
                        CHECK(e.value > f->raw && e.value + e.value_len < f->raw + f->raw_len);
        }
        CHECK(pos >= f->nfields);
}

static void on_result(struct run *run, const struct slp_decode_result *r)
{
        hash_word(run, (uint64_t)r->kind << 32 | (uint64_t)r->reason);
        hash_word(run, r->bytes);
        run->reported += r->bytes;
        if (r->kind == SLP_RESULT_FRAME) {
                const struct slp_frame *f = r->frame;

                CHECK(r->reason == SLP_REASON_NONE && r->bytes == f->raw_len);
                check_frame_shape(f, dec.max_frame);
                for (size_t i = 0; i < f->nfields; i++)
                        check_value_types(f->fields[i].value, f->fields[i].len);
                check_entries(f);
                hash_bytes(run, f->raw, f->raw_len);
                if (run->reencode)
                        check_reencode(f, run->crlf_flag);
                return;
        }
        CHECK(r->kind == SLP_RESULT_REJECT && r->frame == NULL && r->bytes > 0);
        CHECK(r->reason > SLP_REASON_NONE && r->reason < SLP_REASON_UNKNOWN_FIELD);
        CHECK(strcmp(slp_decode_reason_str(r->reason), "unknown reason") != 0);
        if (r->reason == SLP_REASON_NOISE)
                CHECK(r->bytes <= SLP_NOISE_RUN_MAX);
        else
                CHECK(r->bytes <= dec.max_frame);
}

static void feed(struct run *run, const uint8_t *p, size_t n)
{
        for (size_t i = 0; i < n; i++)
                run->crlf += p[i] == '\r' || p[i] == '\n';
        run->fed += n;
        while (n > 0) {
                struct slp_decode_result r;
                size_t used = slp_decoder_feed(&dec, p, n, &r);

                CHECK(used >= 1 && used <= n);
                if (r.kind == SLP_RESULT_NONE)
                        CHECK(used == n);
                else
                        on_result(run, &r);
                p += used;
                n -= used;
        }
}

static void end(struct run *run)
{
        struct slp_decode_result r;

        if (slp_decoder_end(&dec, &r))
                on_result(run, &r);
        CHECK(!slp_decoder_end(&dec, &r));
        CHECK(run->reported <= run->fed && run->fed - run->reported <= run->crlf);
}

static uint32_t next_rand(uint32_t *s)
{
        /* xorshift32: only needs to spread chunk sizes, not to be good. */
        *s ^= *s << 13;
        *s ^= *s >> 17;
        *s ^= *s << 5;
        return *s;
}

static size_t chunk_size(uint32_t *s, size_t left)
{
        uint32_t r = next_rand(s);
        size_t n;

        switch (r & 3) {
        case 0:  n = 1; break;
        case 1:  n = 1 + (r >> 8) % 16; break;
        case 2:  n = 1 + (r >> 8) % 512; break;
        default: n = left; break;
        }
        return n < left ? n : left;
}

static void fuzz_decoder(const uint8_t *data, size_t size, const uint8_t *wire, size_t len)
{
        static const size_t fixed[] = { SLP_FRAME_DEFAULT, SLP_FRAME_MIN, 0, SLP_FRAME_MAX };
        size_t max_frame = fixed[data[0] & 3];
        bool datagrams = data[0] & 0x4;
        uint32_t seed = ((uint32_t)data[1] << 8 | data[2]) + 1;
        struct run chunked = { .hash = FNV_OFFSET, .reencode = true, .crlf_flag = data[0] & 0x8 };
        struct run whole = { .hash = FNV_OFFSET };
        size_t off = 0;

        (void)size;
        if (max_frame == 0)
                max_frame = SLP_FRAME_MIN + (size_t)data[3] * 8;
        CHECK(slp_decoder_init(&dec, max_frame) == 0);
        while (off < len) {
                size_t n = chunk_size(&seed, len - off);

                feed(&chunked, wire + off, n);
                if (datagrams)
                        end(&chunked);
                off += n;
        }
        end(&chunked);
        CHECK(chunked.fed == len);
        if (datagrams)
                return;

        CHECK(slp_decoder_init(&dec, max_frame) == 0);
        feed(&whole, wire, len);
        end(&whole);
        CHECK(whole.hash == chunked.hash && whole.reported == chunked.reported);
}

/* ---------------------------------------------------------------------------------------------
 * List encoder */

static char list_store[LIST_MAX][SLP_VALUE_MAX + 2];
static const char *list_values[LIST_MAX];
static bool list_changed[LIST_MAX];

static size_t digits(size_t k)
{
        size_t n = 1;

        while (k >= 10) {
                k /= 10;
                n++;
        }
        return n;
}

/* ---------------------------------------------------------------------------------------------
 * Pronto4 named lists (declaration, acknowledgement) and the one-frame data list */

#define NAME_CHARS "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_.-"

static enum slp_type list_types[LIST_MAX];

/* What the named-list encoders must say about position p (names = values = list_values). */
static int named_error(const struct slp_named_list *l, size_t p, bool declaration)
{
        size_t len = strlen(l->names[p]);
        size_t max = l->max_frame ? l->max_frame : SLP_FRAME_DEFAULT;
        size_t entry = declaration ? 4 + 1 + len : 4 + len + len;

        if (len > SLP_VALUE_MAX)
                return -EMSGSIZE;
        if (len == 0 || !only_chars(l->names[p], len, NAME_CHARS))
                return -EINVAL;
        if (6 + digits(p) + entry + 5 + (l->crlf ? 2 : 0) > max)
                return -EMSGSIZE;
        return 0;
}

static void fuzz_named(const struct slp_list *data_list, bool declaration, bool one_frame)
{
        static char out[SLP_FRAME_MAX];
        struct slp_named_list l = {
                .dst = 'B', .src = 'A', .head = declaration && (data_list->count & 1) ? 'L' : 'N',
                .names = list_values, .types = list_types, .values = list_values,
                .count = data_list->count, .max_frame = data_list->max_frame,
                .crlf = data_list->crlf, .one_frame = one_frame,
        };
        size_t max = l.max_frame ? l.max_frame : SLP_FRAME_DEFAULT;
        size_t first_bad, cursor = 0, frames = 0, total = 0;
        int want = 0, r;

        /* "[:BA|N0" + entries + "|C" hh "]" [CR LF]: one_frame fails at the first entry that is
         * bad or overflows, and leaves the cursor at 0. */
        for (first_bad = 0; first_bad < l.count; first_bad++) {
                want = named_error(&l, first_bad, declaration);
                if (want != 0)
                        break;
                total += declaration ? 5 + strlen(l.names[first_bad])
                                     : 4 + 2 * strlen(l.names[first_bad]);
                if (one_frame && 7 + total + 5 + (l.crlf ? 2 : 0) > max) {
                        want = -EMSGSIZE;
                        break;
                }
        }
        if (one_frame && want != 0)
                first_bad = 0;
        while ((r = declaration ? slp_encode_declaration(&l, &cursor, out, sizeof(out))
                                : slp_encode_acknowledgement(&l, &cursor, out, sizeof(out))) > 0) {
                struct slp_decode_result res;
                size_t start, body = (size_t)r - (l.crlf ? 2 : 0);
                const struct slp_frame *f;

                CHECK(++frames <= l.count && (size_t)r <= max && cursor <= first_bad);
                CHECK(!one_frame || cursor == l.count);
                CHECK(slp_decoder_init(&redec, SLP_FRAME_MAX) == 0);
                CHECK(slp_decoder_feed(&redec, (const uint8_t *)out, body, &res) == body);
                CHECK(res.kind == SLP_RESULT_FRAME);
                f = res.frame;
                CHECK(f->dst == 'B' && f->src == 'A' && f->fields[0].letter == l.head);
                start = f->fields[0].index;
                CHECK(start < cursor && f->nfields == 1 + 2 * (cursor - start));
                for (size_t p = start; p < cursor; p++) {
                        const struct slp_field *a = &f->fields[1 + 2 * (p - start)];
                        size_t len = strlen(l.names[p]);

                        CHECK(a[0].letter == (declaration ? 'T' : 'R'));
                        CHECK(a[1].letter == (declaration ? 'Q' : 'D'));
                        CHECK(a[declaration].len == len);
                        CHECK(memcmp(a[declaration].value, l.names[p], len) == 0);
                        if (declaration)
                                CHECK(a[0].len == 1 && a[0].value[0] == slp_type_digit(
                                      l.types[p]));
                        else
                                CHECK(a[1].len == len && memcmp(a[1].value, l.values[p], len) == 0);
                }
        }
        if (want != 0) {
                CHECK(r == want && cursor == first_bad);
        } else {
                CHECK(r == 0 && cursor == l.count);
        }
}

/* One frame for the whole list exactly when every value is good and the total fits. */
static void fuzz_whole(const struct slp_list *l)
{
        static char out[SLP_FRAME_MAX];
        size_t max = l->max_frame ? l->max_frame : SLP_FRAME_DEFAULT;
        size_t total = 4 + 3 + 5 + (l->crlf ? 2 : 0);
        int want = 0, r = slp_encode_list_whole(l, out, sizeof(out));

        for (size_t p = 0; p < l->count && want == 0; p++) {
                bool sent = !l->compress || l->full || l->changed[p];
                const char *v = sent ? l->values[p] : "";
                size_t len = strlen(v);

                want = len > SLP_VALUE_MAX ? -EMSGSIZE : !printable_value(v, len) ? -EINVAL : 0;
                total += 2 + len;
        }
        if (want == 0 && total > max)
                want = -EMSGSIZE;
        if (l->count == 0) {
                CHECK(r == 0);
        } else if (want != 0) {
                CHECK(r == want);
        } else {
                struct slp_decode_result res;
                size_t body = total - (l->crlf ? 2 : 0);

                CHECK(r == (int)total);
                CHECK(slp_decoder_init(&redec, SLP_FRAME_MAX) == 0);
                CHECK(slp_decoder_feed(&redec, (const uint8_t *)out, body, &res) == body);
                CHECK(res.kind == SLP_RESULT_FRAME && res.frame->nfields == 1 + l->count);
                CHECK(res.frame->fields[0].type == SLP_FIELD_N && res.frame->fields[0].index == 0);
        }
}

/* What slp_encode_list() must say about position p: 0 if it can be sent. */
static int position_error(const struct slp_list *l, size_t p)
{
        bool sent = !l->compress || l->full || l->changed[p];
        const char *v = sent ? l->values[p] : "";
        size_t len = strlen(v);
        size_t max = l->max_frame ? l->max_frame : SLP_FRAME_DEFAULT;

        if (len > SLP_VALUE_MAX)
                return -EMSGSIZE;
        if (!printable_value(v, len))
                return -EINVAL;
        /* Alone in a frame that starts here: "[:AB|N" p "|D" v "|C" hh "]" [CR LF] */
        if (6 + digits(p) + 2 + len + 5 + (l->crlf ? 2 : 0) > max)
                return -EMSGSIZE;
        return 0;
}

static void fuzz_list(const uint8_t *data, const uint8_t *wire, size_t len)
{
        static char out[SLP_FRAME_MAX];
        struct slp_list l = {
                .dst = 'A', .src = 'B', .values = list_values, .changed = list_changed,
                .max_frame = data[3] ? 1 + (size_t)data[3] * 16 : 0,
                .compress = data[0] & 0x10, .full = data[0] & 0x20, .crlf = data[0] & 0x40,
        };
        size_t max = l.max_frame ? l.max_frame : SLP_FRAME_DEFAULT;
        bool sanitize = data[0] & 0x80;
        size_t count = 0, vlen = 0, cursor = 0, first_bad, frames = 0;
        int want = 0, r;

        /* Values: the wire bytes split on ',' (at most SLP_VALUE_MAX + 1 bytes each). */
        for (size_t i = 0; i <= len && count < LIST_MAX; i++) {
                if (i == len || wire[i] == ',') {
                        list_store[count][vlen] = '\0';
                        list_values[count] = list_store[count];
                        list_changed[count] = count < len && (wire[count] & 1);
                        count++;
                        vlen = 0;
                        continue;
                }
                if (vlen > SLP_VALUE_MAX)
                        continue;
                char c = (char)wire[i];
                if (sanitize && !printable_value(&c, 1))
                        c = '_';
                if (c == '\0')
                        c = ' ';
                list_store[count][vlen++] = c;
        }
        l.count = count;
        for (first_bad = 0; first_bad < count; first_bad++) {
                want = position_error(&l, first_bad);
                if (want != 0)
                        break;
        }

        while ((r = slp_encode_list(&l, &cursor, out, sizeof(out))) > 0) {
                struct slp_decode_result res;
                size_t start, n = (size_t)r, body = n - (l.crlf ? 2 : 0);
                const struct slp_frame *f;

                CHECK(++frames <= count);
                CHECK(n <= max);
                CHECK(cursor <= first_bad);
                CHECK(slp_decoder_init(&redec, SLP_FRAME_MAX) == 0);
                CHECK(slp_decoder_feed(&redec, (const uint8_t *)out, body, &res) == body);
                CHECK(res.kind == SLP_RESULT_FRAME);
                f = res.frame;
                CHECK(f->dst == 'A' && f->src == 'B' && f->fields[0].type == SLP_FIELD_N);
                start = f->fields[0].index;
                CHECK(start < cursor && f->nfields == 1 + cursor - start);
                for (size_t p = start; p < cursor; p++) {
                        const struct slp_field *fl = &f->fields[1 + p - start];
                        bool sent = !l.compress || l.full || l.changed[p];
                        const char *v = sent ? l.values[p] : "";

                        CHECK(fl->type == SLP_FIELD_D && fl->len == strlen(v));
                        CHECK(memcmp(fl->value, v, fl->len) == 0);
                }
                if (cursor < first_bad) {
                        /* Greedy: a good next position did not fit in this frame. */
                        bool sent = !l.compress || l.full || l.changed[cursor];
                        CHECK(n + 2 + (sent ? strlen(l.values[cursor]) : 0) > max);
                }
        }
        if (first_bad < count) {
                CHECK(r == want);
                CHECK(cursor == first_bad);
        } else {
                CHECK(r == 0 && cursor == count);
        }
        for (size_t p = 0; p < count; p++)
                list_types[p] = (enum slp_type)(2 * (p < len ? wire[p] % 3 : 0));
        fuzz_whole(&l);
        fuzz_named(&l, true, data[1] & 1);
        fuzz_named(&l, false, data[1] & 2);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
        if (size < HEADER_LEN)
                return 0;
        fuzz_decoder(data, size, data + HEADER_LEN, size - HEADER_LEN);
        fuzz_list(data, data + HEADER_LEN, size - HEADER_LEN);
        return 0;
}
