/*
 * libFuzzer target for the configuration parser (config_parse(), pure: no file I/O).
 * Beyond "no crash, no leak" (the sanitizers), it checks what must hold for every input:
 * an error message names the file and, for a bad config, a 1-based position; an accepted config
 * stays within its bounds, parses the same way twice, and each link equals itself.
 * Corpus: tests/fuzz/corpus/config/ (the shipped configs and the unit tests' bad cases).
 */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "daemon/config.h"

#define FUZZ_FILENAME "fuzz.yaml"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check_error(int r, const struct config_error *e)
{
        char prefix[64];

        if (!memchr(e->message, '\0', sizeof(e->message)))
                abort();
        if (strncmp(e->message, FUZZ_FILENAME ":", strlen(FUZZ_FILENAME ":")) != 0)
                abort();
        if (r == -EINVAL) {
                if (e->line == 0 || e->column == 0)
                        abort();
                snprintf(prefix, sizeof(prefix), FUZZ_FILENAME ":%u:%u: ", e->line, e->column);
                if (strncmp(e->message, prefix, strlen(prefix)) != 0)
                        abort();
        } else if (r != -EFBIG && r != -ENOMEM) {
                abort();
        }
}

/* What the Pronto4 settings of an accepted peer always satisfy (docs/pronto4.md). */
static void check_dialect(const struct config_peer *p)
{
        bool learned = p->outbound_learn || p->inbound_learn;

        if ((p->outbound_learn && p->n_outbound) || (p->inbound_learn && p->n_inbound))
                abort();
        if (p->dialect == CONFIG_DIALECT_BULLETIN) {
                if (p->declare || learned || p->learn_max != 0)
                        abort();
                return;
        }
        if (p->dialect != CONFIG_DIALECT_PRONTO4)
                abort();
        if (p->declare && (learned || p->n_outbound + p->n_inbound == 0))
                abort();
        if (learned != (p->learn_max >= CONFIG_LEARN_MAX_MIN && p->learn_max <=
                        CONFIG_LEARN_MAX_MAX) || (!learned && p->learn_max != 0))
                abort();
}

static void check_config(const struct config *c, const struct config *again)
{
        unsigned vars = 0;

        if (c->n_links == 0 || c->n_links > CONFIG_LINKS_MAX || c->n_vars > CONFIG_VARS_MAX ||
            c->n_links != again->n_links || c->n_vars != again->n_vars)
                abort();
        for (unsigned i = 0; i < c->n_links; i++) {
                const struct config_link *l = &c->links[i];

                if (!config_link_equal(l, l) || !config_link_equal(l, &again->links[i]) ||
                    config_link_find(c, l->name) != l)
                        abort();
                if (l->sl.n_peers > CONFIG_PEERS_MAX || l->n_devices > CONFIG_DEVICES_MAX ||
                    l->circe.n_emulate > CONFIG_EMULATE_MAX)
                        abort();
                for (unsigned j = 0; j < l->sl.n_peers; j++) {
                        vars += l->sl.peers[j].n_outbound + l->sl.peers[j].n_inbound;
                        check_dialect(&l->sl.peers[j]);
                }
        }
        if (vars != c->n_vars)
                abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
        struct config *c = NULL, *again = NULL;
        struct config_error e;
        int r = config_parse((const char *)data, size, FUZZ_FILENAME, &c, &e);

        if (r < 0) {
                if (c)
                        abort();
                check_error(r, &e);
                return 0;
        }
        /* Deterministic: the same text gives the same config. */
        if (config_parse((const char *)data, size, FUZZ_FILENAME, &again, &e) != 0)
                abort();
        check_config(c, again);
        config_free(again);
        config_free(c);
        return 0;
}
