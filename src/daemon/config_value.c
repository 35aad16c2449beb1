/*
 * sharedlinkd's own scalar values (config_internal.h): each cfg_get_*() takes one node and the
 * key it belongs to, and either stores the value or reports why not, on top of the toolkit's
 * generic readers (svc/conf.h: strings, integers, booleans, enums, paths).
 */
#include "daemon/config_internal.h"

#include <arpa/inet.h>
#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "proto/sharedlink.h"

#define ENUM_COUNT(t)           (sizeof(t) / sizeof((t)[0]))

static const struct conf_enum_name protocol_names[] = {
        { "sharedlink", CONFIG_PROTOCOL_SHAREDLINK },
        { "circe", CONFIG_PROTOCOL_CIRCE },
};
const struct conf_enum cfg_protocols = { protocol_names, ENUM_COUNT(protocol_names) };
static const struct conf_enum_name transport_names[] = {
        { "serial", CONFIG_TRANSPORT_SERIAL },
        { "udp", CONFIG_TRANSPORT_UDP },
        { "pty", CONFIG_TRANSPORT_PTY },
        { "replay", CONFIG_TRANSPORT_REPLAY },
};
const struct conf_enum cfg_transports = { transport_names, ENUM_COUNT(transport_names) };
static const struct conf_enum_name role_names[] = {
        { "controller", CONFIG_ROLE_CONTROLLER },
        { "mediator", CONFIG_ROLE_MEDIATOR },
};
const struct conf_enum cfg_roles = { role_names, ENUM_COUNT(role_names) };
static const struct conf_enum_name parity_names[] = {
        { "none", CONFIG_PARITY_NONE },
        { "even", CONFIG_PARITY_EVEN },
        { "odd", CONFIG_PARITY_ODD },
};
const struct conf_enum cfg_parities = { parity_names, ENUM_COUNT(parity_names) };
static const struct conf_enum_name flow_names[] = {
        { "none", CONFIG_FLOW_NONE },
        { "rtscts", CONFIG_FLOW_RTSCTS },
        { "xonxoff", CONFIG_FLOW_XONXOFF },
};
const struct conf_enum cfg_flows = { flow_names, ENUM_COUNT(flow_names) };
static const struct conf_enum_name dialect_names[] = {
        { "bulletin", CONFIG_DIALECT_BULLETIN },
        { "pronto4", CONFIG_DIALECT_PRONTO4 },
};
const struct conf_enum cfg_dialects = { dialect_names, ENUM_COUNT(dialect_names) };
static const struct conf_enum_name var_type_names[] = {
        { "string", CONFIG_VAR_STRING },
        { "long", CONFIG_VAR_LONG },
        { "double", CONFIG_VAR_DOUBLE },
};
const struct conf_enum cfg_var_types = { var_type_names, ENUM_COUNT(var_type_names) };

bool cfg_is_name_char(char ch, bool dot)
{
        return (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') ||
               ch == '_' || ch == '-' || (dot && ch == '.');
}

/*
 * Instance and link names: letters, digits, '_' and '-', not starting with '-' (they appear on
 * slctl's command line, in shm names and in socket and variable names; no '.', so the prefix
 * "<link>." of one CIRCE link can never be the start of another's).
 */
int cfg_get_ident(struct ctx *c, const char *key, const struct conf_node *n, char *out, size_t size)
{
        int r = cfg_get_string(c, key, n, out, size);

        if (r < 0)
                return r;
        if (out[0] == '-')
                return cfg_fail(c, n, "%s %s must not start with '-'", key, cfg_quote_node(c, n));
        for (size_t i = 0; out[i]; i++)
                if (!cfg_is_name_char(out[i], false))
                        return cfg_fail(c, n, "%s %s: invalid character '%c' (allowed: letters, "
                                        "digits, _ -)", key, cfg_quote_node(c, n), out[i]);
        return 0;
}

/* Group names as useradd takes them: [A-Za-z_][A-Za-z0-9_.-]*, optionally ending in '$'. */
int cfg_get_group(struct ctx *c, const struct conf_node *n, char *out, size_t size)
{
        int r = cfg_get_string(c, "group", n, out, size);
        size_t len;

        if (r < 0)
                return r;
        len = strlen(out);
        for (size_t i = 0; i < len; i++) {
                char ch = out[i];
                bool ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || ch == '_' ||
                          (i > 0 && ((ch >= '0' && ch <= '9') || ch == '.' || ch == '-')) ||
                          (i > 0 && i + 1 == len && ch == '$');

                if (!ok)
                        return cfg_fail(c, n, "group %s is not a valid group name",
                                        cfg_quote_node(c, n));
        }
        return 0;
}

int cfg_get_sl_address(struct ctx *c, const char *key, const struct conf_node *n, char *ret)
{
        int r = conf_need_scalar(&c->conf, key, n, "a node address");

        if (r < 0)
                return r;
        if (!slp_address_text_valid(n->text, n->len))
                return cfg_fail(c, n, "%s %s is not a SharedLink node address (A..P)", key,
                                cfg_quote_node(c, n));
        *ret = n->text[0];
        return 0;
}

int cfg_get_circe_address(struct ctx *c, const char *key, const struct conf_node *n,
                          uint32_t *ret)
{
        int r = conf_need_scalar(&c->conf, key, n, "a CIRCE address");

        if (r < 0)
                return r;
        r = circe_address_parse(n->text, n->len, ret);
        if (r == -ERANGE)
                return cfg_fail(c, n, "%s FFFFFF is reserved", key);
        if (r < 0)
                return cfg_fail(c, n, "%s %s: expected six uppercase hex digits", key,
                                cfg_quote_node(c, n));
        return 0;
}

/* CIRCE version: PARTS dot-separated numbers of 1..3 digits ("0.2" or "0.2.3"). */
int cfg_get_circe_version(struct ctx *c, const char *key, const struct conf_node *n,
                          unsigned parts, struct config_circe_version *ret)
{
        struct circe_version v;
        const char *example = parts == 2 ? "MAJOR.MINOR (e.g. \"0.2\")"
                                         : "MAJOR.MINOR.PATCH (e.g. \"0.2.3\")";
        int r = conf_need_scalar(&c->conf, key, n, "a version");

        if (r < 0)
                return r;
        if (circe_version_parse(n->text, n->len, parts, &v) < 0)
                return cfg_fail(c, n, "%s: expected %s, got %s", key, example,
                                cfg_quote_node(c, n));
        memcpy(ret->text, n->text, n->len + 1);         /* <= CIRCE_VERSION_LEN_MAX: checked */
        ret->major = v.major;
        ret->minor = v.minor;
        ret->patch = v.patch;
        return 0;
}

/* "IPV4:PORT", "[IPV6]:PORT" or "localhost:PORT"; no name lookups in a pure parser. */
int cfg_get_endpoint(struct ctx *c, const char *key, const struct conf_node *n, uint32_t port_min,
                     struct config_endpoint *ret)
{
        char text[CONFIG_ENDPOINT_MAX], host[CONFIG_ENDPOINT_MAX];
        const char *port_text, *end;
        struct config_endpoint ep;
        struct sockaddr_in *in4 = (struct sockaddr_in *)&ep.addr;
        struct sockaddr_in6 *in6 = (struct sockaddr_in6 *)&ep.addr;
        bool v6 = false;
        uint32_t port = 0;
        int r = cfg_get_string(c, key, n, text, sizeof(text));

        if (r < 0)
                return r;
        if (text[0] == '[') {
                end = strchr(text, ']');
                if (!end || end[1] != ':')
                        goto bad;
                v6 = true;
                memcpy(host, text + 1, (size_t)(end - text - 1));
                host[end - text - 1] = '\0';
                port_text = end + 2;
        } else {
                end = strchr(text, ':');
                if (!end || strchr(end + 1, ':'))
                        goto bad;
                memcpy(host, text, (size_t)(end - text));
                host[end - text] = '\0';
                port_text = end + 1;
        }
        if (!port_text[0])
                goto bad;
        for (const char *p = port_text; *p; p++) {
                if (*p < '0' || *p > '9')
                        goto bad;
                if (port <= UINT16_MAX)         /* stays above the range once it is */
                        port = port * 10 + (uint32_t)(*p - '0');
        }
        if (port < port_min || port > UINT16_MAX)
                return cfg_fail(c, n, "%s: port %s out of range (%u..%u)", key,
                                cfg_number_text(c, port_text, strlen(port_text)), port_min,
                                UINT16_MAX);

        memset(&ep, 0, sizeof(ep));
        memcpy(ep.text, text, sizeof(ep.text));
        if (v6) {
                if (inet_pton(AF_INET6, host, &in6->sin6_addr) != 1)
                        goto bad;
                in6->sin6_family = AF_INET6;
                in6->sin6_port = htons((uint16_t)port);
                ep.addr_len = sizeof(*in6);
        } else {
                if (strcmp(host, "localhost") == 0)
                        strcpy(host, "127.0.0.1");
                if (inet_pton(AF_INET, host, &in4->sin_addr) != 1)
                        goto bad;
                in4->sin_family = AF_INET;
                in4->sin_port = htons((uint16_t)port);
                ep.addr_len = sizeof(*in4);
        }
        *ret = ep;
        return 0;
bad:
        return cfg_fail(c, n, "%s: bad address %s (expected IPV4:PORT, [IPV6]:PORT or "
                        "localhost:PORT)", key, cfg_quote_node(c, n));
}

const char *config_protocol_name(enum config_protocol protocol)
{
        return conf_enum_name(&cfg_protocols, (int)protocol);
}

const char *config_transport_name(enum config_transport transport)
{
        return conf_enum_name(&cfg_transports, (int)transport);
}

const char *config_role_name(enum config_role role)
{
        if (role == CONFIG_ROLE_NONE)
                return "none";
        return conf_enum_name(&cfg_roles, (int)role);
}

const char *config_var_type_name(enum config_var_type type)
{
        return conf_enum_name(&cfg_var_types, (int)type);
}

const char *config_dialect_name(enum config_dialect dialect)
{
        return conf_enum_name(&cfg_dialects, (int)dialect);
}
