/*
 * Retry pacing (see backoff.h).
 */
#include "svc/backoff.h"

void backoff_reset(struct backoff *b)
{
        b->delay_ms = BACKOFF_MIN_MS;
        b->due_ms = 0;
}

bool backoff_due(const struct backoff *b, uint64_t now_ms)
{
        return now_ms >= b->due_ms;
}

uint64_t backoff_due_ms(const struct backoff *b)
{
        return b->due_ms;
}

bool backoff_failed(struct backoff *b, uint64_t now_ms)
{
        bool first = b->delay_ms == BACKOFF_MIN_MS;

        b->due_ms = now_ms + b->delay_ms;
        b->delay_ms = b->delay_ms > BACKOFF_MAX_MS / 2u ? BACKOFF_MAX_MS : b->delay_ms * 2u;
        return first;
}
