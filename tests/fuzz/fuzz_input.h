/*
 * What the session fuzz targets share: the trap on a broken invariant and a reader of the
 * input's bytes that yields zeros once it is used up (so every program ends).
 */
#ifndef SHAREDLINK_TESTS_FUZZ_INPUT_H
#define SHAREDLINK_TESTS_FUZZ_INPUT_H

#include <stddef.h>
#include <stdint.h>

#define CHECK(cond)                                                                            \
        do {                                                                                   \
                if (!(cond))                                                                   \
                        __builtin_trap();                                                      \
        } while (0)

struct input {
        const uint8_t *p;
        size_t n;
};

static inline uint8_t take(struct input *in)
{
        if (in->n == 0)
                return 0;
        in->n--;
        return *in->p++;
}

#endif
