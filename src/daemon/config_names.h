/*
 * The config-file spellings of the configuration's enums: the tables the parser reads them with
 * (svc/conf.h's conf_get_enum) and, for everyone, the spelling of a value.
 */
#ifndef SHAREDLINK_DAEMON_CONFIG_NAMES_H
#define SHAREDLINK_DAEMON_CONFIG_NAMES_H

#include "daemon/config_types.h"

struct conf_enum;

/* For the parser's conf_get_enum(). */
extern const struct conf_enum cfg_protocols, cfg_transports, cfg_roles, cfg_parities, cfg_flows,
                             cfg_dialects, cfg_var_types, cfg_p4_roles;

/* The config-file spelling of an enum value ("sharedlink", "pty", "mediator", "double"...). */
const char *config_protocol_name(enum config_protocol protocol);
const char *config_transport_name(enum config_transport transport);
const char *config_role_name(enum config_role role);
const char *config_var_type_name(enum config_var_type type);
const char *config_dialect_name(enum config_dialect dialect);
const char *config_p4_role_name(enum config_p4_role role);

#endif
