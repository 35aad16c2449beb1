/*
 * sharedlinkd's own scalar values (config_value.h): each cfg_get_*() takes one node and the
 * key it belongs to, and either stores the value or reports why not, on top of the toolkit's
 * generic readers (svc/conf.h: strings, integers, booleans, enums, paths).
 */
#include "daemon/config_value.h"

#include <arpa/inet.h>
#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "proto/sharedlink.h"
#include "shm/layout.h"

bool cfg_is_name_char(char ch, bool dot)
{
        return (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') ||
               ch == '_' || ch == '-' || (dot && ch == '.');
}

/* Instance and link names: the one rule of shm_layout_ident_bad. */
int cfg_get_ident(struct ctx *c, const char *key, const struct conf_node *n, char *out, size_t size)
{
        int r = cfg_get_string(c, key, n, out, size);
        long bad;

        if (r < 0)
                return r;
        bad = shm_layout_ident_bad(out);
        if (bad == 0 && out[0] == '-')
                return cfg_fail(c, n, "%s %s must not start with '-'", key, cfg_quote_node(c, n));
        if (bad >= 0)
                return cfg_fail(c, n, "%s %s: invalid character '%c' (allowed: letters, "
                                "digits, _ -)", key, cfg_quote_node(c, n), out[bad]);
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
