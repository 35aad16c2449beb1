/*
 * Layout helpers shared by the daemon and the library: geometry, header checks, name tables, and
 * the value/name/instance grammars.
 */
#include "shm/layout.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <string.h>

#include "proto/sharedlink.h"           /* the value and name bytes (inline: no link to it) */

/* FNV-1a, 32 bits: the offset basis and the prime. */
#define LAYOUT_FNV_BASIS        2166136261u
#define LAYOUT_FNV_PRIME        16777619u

#define SHM_COUNTER_NAME(id, name, scope) name,
static const char *const counter_names[] = { SHM_COUNTER_LIST(SHM_COUNTER_NAME) };
#undef SHM_COUNTER_NAME

#define SHM_COUNTER_SCOPE(id, name, scope) SHM_SCOPE_##scope,
static const unsigned counter_scopes[] = { SHM_COUNTER_LIST(SHM_COUNTER_SCOPE) };
#undef SHM_COUNTER_SCOPE

#define SHM_EVENT_NAME(id, name) name,
static const char *const event_names[] = { SHM_EVENT_LIST(SHM_EVENT_NAME) };
#undef SHM_EVENT_NAME

static const char *const type_names[SHM_TYPE_COUNT] = { "string", "long", "double" };

static uint64_t align_up(uint64_t v, uint64_t a)
{
        return (v + a - 1u) / a * a;
}

void shm_layout_in_geometry(uint32_t capacity, uint32_t event_capacity,
                            struct shm_in_geometry *ret_geometry)
{
        struct shm_in_geometry g;

        g.links_offset = sizeof(struct shm_in_header);
        g.events_offset = align_up(g.links_offset + (uint64_t)SHM_LINKS_MAX * sizeof(struct shm_link),
                                   SHM_CACHE_LINE);
        g.dir_offset = align_up(g.events_offset + (uint64_t)event_capacity * sizeof(struct shm_event),
                                SHM_CACHE_LINE);
        g.slots_offset = align_up(g.dir_offset + (uint64_t)capacity * sizeof(struct shm_dir_entry),
                                  SHM_CACHE_LINE);
        g.total_size = g.slots_offset + (uint64_t)capacity * sizeof(struct shm_slot);
        g.link_texts_offset = align_up(g.total_size, SHM_CACHE_LINE);
        g.link_texts_end = g.link_texts_offset +
                           (uint64_t)SHM_LINKS_MAX * sizeof(struct shm_link_text);
        g.changes_offset = align_up(g.link_texts_end, SHM_CACHE_LINE);
        g.changes_capacity = shm_layout_changes_capacity(capacity);
        g.object_size = g.changes_offset + SHM_CHANGES_HEAD +
                        (uint64_t)g.changes_capacity * sizeof(uint64_t);
        *ret_geometry = g;
}

uint32_t shm_layout_changes_capacity(uint32_t capacity)
{
        uint32_t c = SHM_CHANGES_MIN;

        while (c < capacity && c < SHM_CAPACITY_MAX)
                c <<= 1;
        return c;
}

void shm_layout_out_geometry(uint32_t out_capacity, struct shm_out_geometry *ret_geometry)
{
        struct shm_out_geometry g;

        g.total_size = sizeof(struct shm_out_header) +
                       (uint64_t)out_capacity * sizeof(struct shm_slot);
        g.touched_words = (out_capacity + SHM_TOUCHED_WORD_BITS - 1u) / SHM_TOUCHED_WORD_BITS;
        g.touched_offset = align_up(g.total_size, SHM_CACHE_LINE);
        /* Whole cache lines: the map shares none with a slot. */
        g.object_size = g.touched_offset +
                        align_up((uint64_t)g.touched_words * sizeof(uint64_t), SHM_CACHE_LINE);
        *ret_geometry = g;
}

uint64_t shm_layout_out_size(uint32_t out_capacity)
{
        struct shm_out_geometry g;

        shm_layout_out_geometry(out_capacity, &g);
        return g.total_size;
}

int shm_layout_check_in(const struct shm_in_header *h, uint64_t object_size)
{
        struct shm_in_geometry g;
        uint64_t magic;

        if (object_size < sizeof(*h))
                return -EAGAIN;         /* created but not sized yet */
        magic = atomic_load_explicit(&h->magic, memory_order_acquire);
        if (magic == 0)
                return -EAGAIN;         /* magic is written last: not ready yet */
        if (magic != SHM_IN_MAGIC)
                return -EPROTO;
        if ((h->layout_version >> 16) != SHM_LAYOUT_MAJOR ||
            h->header_size != sizeof(*h) ||
            h->slot_size != sizeof(struct shm_slot) ||
            h->dir_entry_size != sizeof(struct shm_dir_entry) ||
            h->link_max != SHM_LINKS_MAX ||
            h->link_size != sizeof(struct shm_link) ||
            h->counter_max != SHM_COUNTERS_MAX ||
            h->event_size != sizeof(struct shm_event))
                return -EPROTO;
        if (h->capacity > SHM_CAPACITY_MAX || h->out_capacity > h->capacity ||
            h->event_capacity < SHM_EVENTS_MIN || h->event_capacity > SHM_EVENTS_MAX ||
            (h->event_capacity & (h->event_capacity - 1u)) != 0)
                return -EPROTO;
        shm_layout_in_geometry(h->capacity, h->event_capacity, &g);
        if (h->links_offset != g.links_offset || h->events_offset != g.events_offset ||
            h->dir_offset != g.dir_offset || h->slots_offset != g.slots_offset ||
            h->total_size != g.total_size || g.total_size > object_size)
                return -EPROTO;
        return 0;
}

int shm_layout_has_link_texts(const struct shm_in_header *h, uint64_t object_size)
{
        struct shm_in_geometry g;

        if ((h->layout_version & 0xffffu) < SHM_LAYOUT_MINOR_LINK_TEXT ||
            h->link_text_size != sizeof(struct shm_link_text))
                return 0;
        shm_layout_in_geometry(h->capacity, h->event_capacity, &g);
        return h->link_texts_offset == g.link_texts_offset && g.link_texts_end <= object_size;
}

int shm_layout_has_changes(const struct shm_in_header *h, uint64_t object_size)
{
        struct shm_in_geometry g;

        if ((h->layout_version & 0xffffu) < SHM_LAYOUT_MINOR_CHANGES)
                return 0;
        shm_layout_in_geometry(h->capacity, h->event_capacity, &g);
        return h->changes_offset == g.changes_offset &&
               h->changes_capacity == g.changes_capacity && g.object_size <= object_size;
}

int shm_layout_check_out(const struct shm_out_header *h, uint64_t object_size)
{
        uint64_t magic;

        if (object_size < sizeof(*h))
                return -EAGAIN;
        magic = atomic_load_explicit(&h->magic, memory_order_acquire);
        if (magic == 0)
                return -EAGAIN;
        if (magic != SHM_OUT_MAGIC)
                return -EPROTO;
        if ((h->layout_version >> 16) != SHM_LAYOUT_MAJOR || h->header_size != sizeof(*h) ||
            h->slot_size != sizeof(struct shm_slot) || h->capacity > SHM_CAPACITY_MAX ||
            h->slots_offset != sizeof(*h) ||
            h->total_size != shm_layout_out_size(h->capacity) || h->total_size > object_size)
                return -EPROTO;
        /* 1.6: a map that is not where the daemon made it means a scribbled header, which the
         * daemon's scan refuses (and recreates the object): so must a client, or its write
         * lands in an object about to be thrown away. */
        if ((h->layout_version & 0xffffu) >= SHM_LAYOUT_MINOR_TOUCHED &&
            !shm_layout_has_touched(h, object_size))
                return -EPROTO;
        return 0;
}

int shm_layout_has_touched(const struct shm_out_header *h, uint64_t object_size)
{
        struct shm_out_geometry g;

        if ((h->layout_version & 0xffffu) < SHM_LAYOUT_MINOR_TOUCHED)
                return 0;
        shm_layout_out_geometry(h->capacity, &g);
        return h->touched_offset == g.touched_offset && h->touched_words == g.touched_words &&
               g.object_size <= object_size;
}

const char *shm_layout_counter_name(unsigned i)
{
        if (i >= SHM_COUNTER_COUNT)
                return NULL;
        return counter_names[i];
}

unsigned shm_layout_counter_scope(const char *name)
{
        for (unsigned i = 0; name && i < SHM_COUNTER_COUNT; i++)
                if (strcmp(counter_names[i], name) == 0)
                        return counter_scopes[i];
        return 0;
}

const char *shm_layout_event_name(unsigned t)
{
        if (t >= SHM_EVENT_TYPE_COUNT)
                return "unknown";
        return event_names[t];
}

const char *shm_layout_type_name(unsigned t)
{
        if (t >= SHM_TYPE_COUNT)
                return "unknown";
        return type_names[t];
}

int shm_layout_value_char(int c)
{
        return c >= 0 && c <= UCHAR_MAX && slp_value_byte((unsigned char)c);
}

/*
 * The value check eight bytes at a time (SWAR, "Bit Twiddling Hacks": haszero/hasless/hasmore):
 * every client read of an outbound variable validates the client-writable slot, and a loop of
 * four compares per byte was a third of such a read. Each test below is exact for "some byte of
 * the word": a borrow or carry can only spill into a byte above one that already matched.
 */
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define LAYOUT_SWAR             1
#define LAYOUT_ONES             UINT64_C(0x0101010101010101)
#define LAYOUT_HIGHS            (LAYOUT_ONES * 0x80u)
#define LAYOUT_FILL             (LAYOUT_ONES * (uint64_t)'A')   /* pads a short last word */

/* Bit 7 of some byte set when that byte of x is 0 (exact for "any"). */
static uint64_t swar_zero(uint64_t x)
{
        return (x - LAYOUT_ONES) & ~x & LAYOUT_HIGHS;
}

/* Nonzero when a byte of x is no slp_value_byte(): outside 0x20..0x7e or one of | [ ]. */
static uint64_t swar_bad(uint64_t x)
{
        uint64_t below = (x - LAYOUT_ONES * SLP_VALUE_BYTE_MIN) & ~x & LAYOUT_HIGHS;
        uint64_t above = ((x + LAYOUT_ONES * (127u - SLP_VALUE_BYTE_MAX)) | x) & LAYOUT_HIGHS;

        return below | above | swar_zero(x ^ (LAYOUT_ONES * (uint64_t)'|')) |
               swar_zero(x ^ (LAYOUT_ONES * (uint64_t)'[')) |
               swar_zero(x ^ (LAYOUT_ONES * (uint64_t)']'));
}
#endif

#if defined(__SSE2__)
#include <emmintrin.h>

/*
 * A bit set for each of the 16 bytes at p that is no slp_value_byte(). As signed bytes,
 * 0x80-0xff are negative: "< 0x20" catches them with the control characters, and 0x7f is the
 * only byte above 0x7e left.
 */
static unsigned layout_bad16(const char *p)
{
        const __m128i space = _mm_set1_epi8(SLP_VALUE_BYTE_MIN),
                      del = _mm_set1_epi8(SLP_VALUE_BYTE_MAX + 1);
        const __m128i bar = _mm_set1_epi8('|'), open = _mm_set1_epi8('['),
                      close = _mm_set1_epi8(']');
        __m128i x = _mm_loadu_si128((const __m128i *)(const void *)p);
        __m128i b = _mm_or_si128(_mm_or_si128(_mm_cmplt_epi8(x, space), _mm_cmpeq_epi8(x, del)),
                                 _mm_or_si128(_mm_cmpeq_epi8(x, bar),
                                              _mm_or_si128(_mm_cmpeq_epi8(x, open),
                                                           _mm_cmpeq_epi8(x, close))));

        return (unsigned)_mm_movemask_epi8(b);
}
#endif

int shm_layout_value_check(const char *v, size_t len)
{
        size_t i = 0;

        if (len > SHM_VALUE_MAX)
                return -EINVAL;
#if defined(__SSE2__)
        /* 16 bytes at a time, the last 16 overlapping what came before: no load past len (a
         * value sl_write checks is the caller's string, which may end at a page's end). */
        if (len >= 16u) {
                for (; i + 16u <= len; i += 16u)
                        if (layout_bad16(v + i))
                                return -EINVAL;
                return i < len && layout_bad16(v + len - 16u) ? -EINVAL : 0;
        }
#endif
#if defined(LAYOUT_SWAR)
        for (; i + 8u <= len; i += 8u) {
                uint64_t w;

                memcpy(&w, v + i, sizeof(w));
                if (swar_bad(w))
                        return -EINVAL;
        }
        if (i < len && len >= 8u) {
                uint64_t w;

                /* The last eight bytes, some of them checked already: one load of a known
                 * size (a copy of len - i bytes was a call to memcpy, a third of the check). */
                memcpy(&w, v + len - 8u, sizeof(w));
                if (swar_bad(w))
                        return -EINVAL;
        } else if (i < len) {
                uint64_t w = LAYOUT_FILL;

                memcpy(&w, v + i, len - i);     /* the low bytes; the others stay 'A' */
                if (swar_bad(w))
                        return -EINVAL;
        }
        return 0;
#else
        for (; i < len; i++)
                if (!shm_layout_value_char((unsigned char)v[i]))
                        return -EINVAL;
        return 0;
#endif
}

/*
 * The check over a whole value field: a client read of an outbound variable validates the slot it
 * copied, and the word-at-a-time check was still a third of that read. The field is always
 * SHM_VALUE_SIZE bytes, so every vector load is in bounds; bytes at and past len are masked out
 * of the verdict.
 */
int shm_layout_value_check_field(const char *v, size_t len)
{
#if defined(__SSE2__)
        uint64_t bad = 0;

        if (len > SHM_VALUE_MAX)
                return -EINVAL;
        for (unsigned i = 0; i < SHM_VALUE_SIZE / 16u; i++)
                bad |= (uint64_t)layout_bad16(v + 16u * i) << (16u * i);
        return bad & ((UINT64_C(1) << len) - 1u) ? -EINVAL : 0;
#else
        return shm_layout_value_check(v, len);
#endif
}

uint32_t shm_layout_name_hash(const char *name)
{
        uint32_t h = LAYOUT_FNV_BASIS;

        for (size_t i = 0; i < SHM_NAME_SIZE && name[i]; i++)
                h = (h ^ (unsigned char)name[i]) * LAYOUT_FNV_PRIME;
        return h;
}

int shm_layout_name_check(const char *name)
{
        size_t len;

        if (!name)
                return -EINVAL;
        len = strnlen(name, SHM_NAME_SIZE);
        if (len == 0 || len > SHM_NAME_MAX)
                return -EINVAL;
        for (size_t i = 0; i < len; i++)
                if (!slp_name_byte(name[i]))
                        return -EINVAL;
        return 0;
}

long shm_layout_ident_bad(const char *name)
{
        if (name[0] == '-')
                return 0;
        for (long i = 0; name[i]; i++) {
                char c = name[i];

                if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                      c == '_' || c == '-'))
                        return i;
        }
        return -1;
}

int shm_layout_instance_check(const char *instance)
{
        size_t len;

        if (!instance)
                return -EINVAL;
        len = strnlen(instance, SHM_INSTANCE_MAX + 1u);
        if (len == 0 || len > SHM_INSTANCE_MAX || shm_layout_ident_bad(instance) >= 0)
                return -EINVAL;
        return 0;
}

int shm_layout_object_name(const char *instance, const char *suffix, char *buf, size_t size)
{
        int n;

        if (shm_layout_instance_check(instance) < 0)
                return -EINVAL;
        n = snprintf(buf, size, "/sharedlink.%s.%s", instance, suffix);
        if (n < 0 || (size_t)n >= size)
                return -ENAMETOOLONG;
        return 0;
}
