/*
 * The config-file spellings of the configuration's enums (config_names.h).
 */
#include "daemon/config_names.h"

#include "svc/conf.h"

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
static const struct conf_enum_name p4_role_names[] = {
        { "host", CONFIG_P4_HOST },
        { "vehicle", CONFIG_P4_VEHICLE },
};
const struct conf_enum cfg_p4_roles = { p4_role_names, ENUM_COUNT(p4_role_names) };
static const struct conf_enum_name var_type_names[] = {
        { "string", CONFIG_VAR_STRING },
        { "long", CONFIG_VAR_LONG },
        { "double", CONFIG_VAR_DOUBLE },
};
const struct conf_enum cfg_var_types = { var_type_names, ENUM_COUNT(var_type_names) };

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

const char *config_p4_role_name(enum config_p4_role role)
{
        return conf_enum_name(&cfg_p4_roles, (int)role);
}
