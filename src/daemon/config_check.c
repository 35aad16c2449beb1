/*
 * The config module's checks that need more than one key (config_check.h): whether a pronto4
 * peer's lists fit one frame, and the checks across links once all are read.
 */
#include "daemon/config_check.h"

#include <string.h>

#include "proto/sharedlink.h"

#define SOCKET_SUFFIX           ".sock"

/* ---------------------------------------------------------------------------------------------
 * SharedLink peers: the Pronto4 dialect's one-frame check (docs/pronto4.md) */

/*
 * The longest text a value of each type takes on the wire, for the one-frame check. A long is
 * checked against its type before it is sent; a double goes out in its shortest round-trip form
 * (what sl_write_double() with decimals < 0 writes, and what the link re-formats to).
 */
static size_t var_text_max(enum config_var_type type)
{
        switch (type) {
        case CONFIG_VAR_LONG:
                return SLP_LONG_TEXT_MAX;
        case CONFIG_VAR_DOUBLE:
                return SLP_DOUBLE_TEXT_MAX;
        case CONFIG_VAR_STRING:
                break;
        }
        return SLP_VALUE_MAX;
}

/* Bytes of the fields "|T<t>|Q<name>" of a declaration of @vars. */
static size_t declaration_fields_len(const struct config_var *vars, unsigned n)
{
        size_t len = 0;

        for (unsigned i = 0; i < n; i++)
                len += 2 + 1 + 2 + strlen(vars[i].name);
        return len;
}

/*
 * One rule for the type of a name in a pronto4 list (docs/pronto4.md §3): the config's bare name
 * is a string, the wire's name without T a double; the same bare name would be T4 in our
 * declaration and a double in the peer's. So a pronto4 list names every entry's type.
 */
static int check_typed_list(struct ctx *c, const char *key, const struct conf_node *list)
{
        if (!list || list->kind != CONF_NODE_SEQUENCE)
                return 0;       /* learn, or nothing */
        for (const struct conf_node *n = cfg_child(c, list->first); n; n = cfg_next(c, n))
                if (n->kind == CONF_NODE_SCALAR)
                        return cfg_fail(c, n, "%s: %s has no type: a pronto4 list gives each "
                                        "entry's (e.g. {name: %.*s, type: double}; a bare name "
                                        "is a string here but a double on the Pronto4 wire)",
                                        key, cfg_quote_node(c, n), (int)n->len, n->text);
        return 0;
}

/*
 * What a learning peer's lists need at the least: L? and N? are answered with a learned list
 * whole, one frame of "|T<t>|Q<name>" per entry, so learn_max entries of one-letter names must
 * fit max_frame, or the peer could declare a list we can hold but never answer for.
 */
static int check_learn_room(struct ctx *c, const struct config_peer *p, bool crlf,
                            const struct conf_node *max_node, const struct conf_node *learn_node)
{
        const size_t entry_min = 2 + 1 + 2 + 1;         /* "|T0|Qx" */
        size_t base = slp_list_frame_len(0, crlf);
        size_t len = slp_list_frame_len(entry_min * p->learn_max, crlf);

        if (!(p->outbound_learn || p->inbound_learn) || len <= p->max_frame)
                return 0;
        return cfg_fail(c, max_node ? max_node : learn_node, "max_frame %u is too small for what this peer can learn: "
                        "learn_max %u entries take at least %zu bytes as one frame (the answer "
                        "to N? or L?, |T<t>|Q<name> each); lower learn_max to %zu or raise "
                        "max_frame", p->max_frame, p->learn_max, len,
                        p->max_frame > base ? (p->max_frame - base) / entry_min : 0);
}

/*
 * The Pronto4 clients read at most CONFIG_P4_MAX_FRAME_MAX bytes a datagram, want every data
 * frame as one full-length N0 list (a partial one kills the ROS 2 bridge's receiver) and the
 * answers to N? and L? (our typed declarations) as one frame each: the worst case of each must
 * fit max_frame, or the link could never talk to them.
 */
int cfg_check_pronto4_frames(struct ctx *c, const struct config_peer *p, bool crlf,
                             const struct conf_node *out_node, const struct conf_node *in_node,
                             const struct conf_node *max_node)
{
        size_t data = 0, len;
        int r;

        if (p->max_frame > CONFIG_P4_MAX_FRAME_MAX)
                return cfg_fail(c, max_node, "max_frame %u is more than a pronto4 peer reads: "
                                "both Pronto4 clients read a datagram into %u bytes",
                                p->max_frame, CONFIG_P4_MAX_FRAME_MAX);
        r = check_typed_list(c, "outbound", out_node);
        if (r == 0)
                r = check_typed_list(c, "inbound", in_node);
        if (r == 0)
                r = check_learn_room(c, p, crlf, max_node,
                                     p->outbound_learn ? out_node : in_node);
        if (r < 0)
                return r;

        for (unsigned i = 0; i < p->n_outbound; i++)
                data += 2 + var_text_max(p->outbound[i].type);
        len = slp_list_frame_len(data, crlf);
        if (p->n_outbound > 0 && len > p->max_frame)
                return cfg_fail(c, out_node, "outbound: %u variables take up to %zu bytes as one "
                                "frame, more than max_frame %u (a pronto4 peer gets every data "
                                "frame as one full N0 list)", p->n_outbound, len, p->max_frame);
        len = slp_list_frame_len(declaration_fields_len(p->outbound, p->n_outbound), crlf);
        if (p->n_outbound > 0 && len > p->max_frame)
                return cfg_fail(c, out_node, "outbound: its declaration N0|T|Q... takes %zu bytes, "
                                "more than max_frame %u (a pronto4 peer wants it in one frame)",
                                len, p->max_frame);
        len = slp_list_frame_len(declaration_fields_len(p->inbound, p->n_inbound), crlf);
        if (p->n_inbound > 0 && len > p->max_frame)
                return cfg_fail(c, in_node, "inbound: its declaration L0|T|Q... takes %zu bytes, "
                                "more than max_frame %u (a pronto4 peer wants it in one frame)",
                                len, p->max_frame);
        return 0;
}

int cfg_check_list_not_learn(struct ctx *c, const char *key, const struct conf_node *list)
{
        if (list->kind != CONF_NODE_SEQUENCE)
                return 0;
        for (const struct conf_node *n = cfg_child(c, list->first); n; n = cfg_next(c, n))
                if (n->kind == CONF_NODE_SCALAR && cfg_scalar_is(n, "learn"))
                        return cfg_fail(c, n, "%s: the entry learn is a variable named "
                                        "\"learn\": did you mean `%s: learn` (the list the peer "
                                        "declares)? A variable of that name is {name: learn}",
                                        key, key);
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * Whole-instance checks, once every link is read */

/*
 * A serial path is opened by one link only, a pty path created by one link only; one pty link and
 * one serial link on the same path is the back-to-back setup of the demo.
 */
int cfg_check_devices(struct ctx *c)
{
        const struct config *cfg = c->cfg;

        for (unsigned a = 0; a < cfg->n_links; a++) {
                for (unsigned i = 0; i < cfg->links[a].n_devices; i++) {
                        for (unsigned b = 0; b <= a; b++) {
                                const struct config_link *la = &cfg->links[a], *lb = &cfg->links[b];
                                unsigned end = b == a ? i : lb->n_devices;

                                if (la->transport != lb->transport)
                                        continue;
                                for (unsigned j = 0; j < end; j++)
                                        if (strcmp(la->devices[i], lb->devices[j]) == 0)
                                                return cfg_fail(c, c->device_nodes[a][i],
                                                                "device %s is already used by link "
                                                                "\"%s\" (%u:%u)",
                                                                cfg_quote_node(c,
                                                                        c->device_nodes[a][i]),
                                                                lb->name,
                                                                c->device_nodes[b][j]->line,
                                                                c->device_nodes[b][j]->column);
                        }
                }
        }
        return 0;
}

/* CIRCE links publish "<link>.…" names (DESIGN.md §2.8): no configured variable may start so. */
int cfg_check_reserved_names(struct ctx *c)
{
        const struct config *cfg = c->cfg;

        for (unsigned v = 0; v < cfg->n_vars; v++) {
                for (unsigned i = 0; i < cfg->n_links; i++) {
                        const struct config_link *l = &cfg->links[i];
                        size_t len = strlen(l->name);

                        if (l->protocol == CONFIG_PROTOCOL_CIRCE &&
                            strncmp(c->vars[v].name, l->name, len) == 0 &&
                            c->vars[v].name[len] == '.')
                                return cfg_fail(c, c->vars[v].node, "variable name %s is in the "
                                                "namespace of circe link \"%s\"",
                                                cfg_quote_node(c, c->vars[v].node), l->name);
                }
        }
        return 0;
}

/* The control socket "<runtime_dir>/<instance>.sock" must fit in sun_path. */
int cfg_check_socket_path(struct ctx *c)
{
        size_t len = strlen(c->cfg->runtime_dir) + 1 + strlen(c->cfg->instance) +
                     strlen(SOCKET_SUFFIX);

        if (len < CONFIG_SOCKET_PATH_MAX)
                return 0;
        if (c->runtime_dir_node)
                return cfg_fail(c, c->runtime_dir_node, "runtime_dir %s too long: the control "
                                "socket path would be %zu bytes (at most %u)",
                                cfg_quote_node(c, c->runtime_dir_node), len,
                                CONFIG_SOCKET_PATH_MAX - 1);
        return 0;       /* default runtime_dir + instance of <= 32 bytes always fits */
}
