/*
 * The toolkit's configuration reader: one YAML file into a tree of nodes with positions, and
 * readers that take one node (a scalar, or a mapping against a table of keys) into a C value or
 * an error "FILE:LINE:COL: text". Every daemon reads its file with it, so one file style and one
 * set of messages serve them all. Decisions (documented for users in conf/sharedlinkd.yaml):
 *
 * - Numbers and booleans must be plain (unquoted) scalars; strings may be plain or quoted.
 *   Integers are decimal digits only; leading zeros are refused (YAML 1.1 reads them as octal).
 * - Booleans are true/false (also True/TRUE/False/FALSE, the YAML 1.2 core schema); yes/no/on/off
 *   are refused, not guessed.
 * - A plain empty value, "~" or "null" is a missing value, never a default.
 * - Anchors, aliases, merge keys ("<<") and tags are refused; so is a second document.
 * - Strings may not contain control characters (double-quoted escapes could produce them).
 * - Unknown keys and duplicate keys are errors; the first error wins.
 *
 * Files: conf.c (the tree, errors, quoting, mappings), conf_value.c (scalars, key tables).
 *
 * A daemon declares each mapping as a table of struct conf_key (name, type, range, field, or
 * a handler) and reads it with conf_table_read(); see docs/services.md.
 */
#ifndef SHAREDLINK_SVC_CONF_H
#define SHAREDLINK_SVC_CONF_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define CONF_NONE               UINT32_MAX      /* no node */
#define CONF_NODES_MAX          65536u  /* YAML nodes (scalars, lists, mappings) per file */
#define CONF_DEPTH_MAX          16u     /* nesting */
#define CONF_ERROR_MAX          512u
#define CONF_QUOTE_MAX          40u     /* bytes of user text echoed in a message */
#define CONF_QUOTE_BUF          (CONF_QUOTE_MAX * 4u + 8u)
#define CONF_QUOTE_SLOTS        2u      /* quoted texts one message may hold */
#define CONF_TABLE_MAX          64u     /* keys of one conf_table_read() table */

enum conf_node_kind {
        CONF_NODE_SCALAR,
        CONF_NODE_SEQUENCE,
        CONF_NODE_MAPPING,
};

struct conf_node {
        enum conf_node_kind kind;
        bool plain;                     /* scalar written as a plain (unquoted, non-block) scalar */
        unsigned line, column;          /* 1-based */
        char *text;                     /* scalar bytes + NUL (may contain NULs from escapes) */
        size_t len;
        uint32_t first, last, next;     /* children; a mapping's are key, value, key, value... */
        uint32_t count;
};

struct conf_error {
        unsigned line, column;          /* 1-based; 0 when the error has no position */
        char message[CONF_ERROR_MAX];   /* "FILE:LINE:COL: text" or "FILE: text", no newline */
};

/* One read of one file. */
struct conf {
        const char *filename;
        const char *text;
        size_t text_len;
        struct conf_error err;          /* the first error */
        struct conf_node *nodes;
        uint32_t n_nodes, cap_nodes;
        char quote[CONF_QUOTE_SLOTS][CONF_QUOTE_BUF];
        unsigned quote_next;
};

/* ---- conf.c: the file, errors, the tree ---- */

/*
 * Starts a read of LEN bytes of TEXT (need not be NUL-terminated; a UTF-8 BOM is skipped);
 * FILENAME prefixes messages (NULL: "<config>"). 0, or -EINVAL (no input) or -EFBIG (more than
 * INPUT_MAX bytes) with the error set.
 */
int conf_init(struct conf *c, const char *filename, const char *text, size_t len,
              size_t input_max);

/* Builds the tree; *ret_root is CONF_NONE for an empty stream. 0 or -EINVAL/-ENOMEM. */
int conf_tree_build(struct conf *c, uint32_t *ret_root);

/* Frees the tree (the struct itself is the caller's). */
void conf_free(struct conf *c);

/* Sets the error "FILE:LINE:COL: text" (LINE 0: "FILE: text") unless one is set; -EINVAL. */
int conf_fail_at(struct conf *c, unsigned line, unsigned column, const char *fmt, ...)
        __attribute__((format(printf, 4, 5)));
/* The same at node N's position. */
int conf_fail(struct conf *c, const struct conf_node *n, const char *fmt, ...)
        __attribute__((format(printf, 3, 4)));
/* "out of memory"; returns -ENOMEM. */
int conf_fail_nomem(struct conf *c);

/* User text for a message, quoted and escaped (one of CONF_QUOTE_SLOTS buffers, reused). */
const char *conf_quote(struct conf *c, const char *s, size_t len);
const char *conf_quote_node(struct conf *c, const struct conf_node *n);
/* A number as written, unquoted, cut short. */
const char *conf_number_text(struct conf *c, const char *s, size_t len);
/* "a list", "a mapping" or the quoted scalar, for "expected X, got Y". */
const char *conf_describe(struct conf *c, const struct conf_node *n);

/* Node I (NULL for CONF_NONE), and the node after N among its parent's children. */
const struct conf_node *conf_child(const struct conf *c, uint32_t i);
const struct conf_node *conf_next(const struct conf *c, const struct conf_node *n);
/* N is a scalar holding exactly S; N is a plain empty, "~" or "null" scalar. */
bool conf_scalar_is(const struct conf_node *n, const char *s);
bool conf_is_null(const struct conf_node *n);

/*
 * Checks mapping MAP's keys against a key table (all scalars, no merge key, no unknown key, no
 * duplicate) and files each value under its key's index in vals[] (NULL when absent), keys[]
 * likewise. WHAT ends the unknown-key message ("in link"). The table is N_KNOWN entries of
 * STRIDE bytes, each starting with its name (a const char *): an array of names, or of structs
 * whose first member is the name; CONF_KEYS(table) passes the last three arguments.
 */
int conf_map_read(struct conf *c, const struct conf_node *map, const char *what,
                  const void *known, size_t n_known, size_t stride,
                  const struct conf_node **keys, const struct conf_node **vals);
#define CONF_KEYS(table)        (table), sizeof(table) / sizeof((table)[0]), sizeof((table)[0])
/* N is a list or a mapping (KIND); a null N is reported as a missing value of WHAT. */
int conf_need_kind(struct conf *c, const char *what, const struct conf_node *n,
                   enum conf_node_kind kind);

/* ---- conf_value.c: one scalar N, the value of KEY (which starts every message) ---- */

struct conf_enum_name {
        const char *name;
        int value;
};

/* The spellings of one enum, as the file writes them. */
struct conf_enum {
        const struct conf_enum_name *names;
        size_t count;
};

/* A scalar that is not null ("KEY: missing value"), else "KEY: expected EXPECTED, got ...". */
int conf_need_scalar(struct conf *c, const char *key, const struct conf_node *n,
                     const char *expected);
/* Not empty, no control characters, shorter than SIZE. */
int conf_get_string(struct conf *c, const char *key, const struct conf_node *n, char *out,
                    size_t size);
/* Plain decimal integer in [MIN, MAX], no leading zeros. */
int conf_get_uint(struct conf *c, const char *key, const struct conf_node *n, uint32_t min,
                  uint32_t max, uint32_t *ret);
int conf_get_bool(struct conf *c, const char *key, const struct conf_node *n, bool *ret);
int conf_get_enum(struct conf *c, const char *key, const struct conf_node *n,
                  const struct conf_enum *e, int *ret);
/* The spelling of VALUE in E, or "?". */
const char *conf_enum_name(const struct conf_enum *e, int value);
/* A string that starts with '/'. */
int conf_get_path(struct conf *c, const char *key, const struct conf_node *n, char *out,
                  size_t size);

/* ---- conf_value.c: a mapping read through a table of keys ---- */

enum conf_type {
        CONF_STRING,                    /* char[size] at offset */
        CONF_PATH,                      /* an absolute path, char[size] at offset */
        CONF_UINT,                      /* uint32_t at offset, in [min, max] */
        CONF_INT,                       /* int at offset, in [min, max] (max <= INT_MAX) */
        CONF_BOOL,                      /* bool at offset */
        CONF_ENUM,                      /* int-sized enum at offset, spelled as in names */
        CONF_MAPPING,                   /* a nested mapping of keys, into the same object */
        CONF_CUSTOM,                    /* parse() reads the node */
};

struct conf_key;

/* Reads or checks node N (a value of the key, or the mapping) into OBJ; 0 or -errno. */
typedef int conf_key_fn(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                        void *obj);

struct conf_key {
        const char *name;               /* first: a conf_map_read() table */
        enum conf_type type;
        size_t offset, size;            /* the field in OBJ (size: of a string buffer) */
        uint32_t min, max;              /* CONF_UINT, CONF_INT */
        const struct conf_enum *names;  /* CONF_ENUM */
        const struct conf_key *keys;    /* CONF_MAPPING: its table ... */
        size_t n_keys;                  /* ... of n_keys keys */
        conf_key_fn *parse;             /* CONF_CUSTOM: reads the value */
        conf_key_fn *check;             /* any type, optional: runs once the value was read */
};

/* Rows of a key table for a field F of struct S (S and F as in offsetof). */
#define CONF_FIELD(S, F)                offsetof(S, F), sizeof(((S *)0)->F)
#define CONF_KEY_STRING(name, S, F)     { name, CONF_STRING, CONF_FIELD(S, F), 0, 0, NULL, NULL, \
                                          0, NULL, NULL }
#define CONF_KEY_PATH(name, S, F)       { name, CONF_PATH, CONF_FIELD(S, F), 0, 0, NULL, NULL, 0, \
                                          NULL, NULL }
#define CONF_KEY_UINT(name, S, F, min, max) { name, CONF_UINT, CONF_FIELD(S, F), min, max, NULL, \
                                          NULL, 0, NULL, NULL }
#define CONF_KEY_INT(name, S, F, min, max) { name, CONF_INT, CONF_FIELD(S, F), min, max, NULL, \
                                          NULL, 0, NULL, NULL }
#define CONF_KEY_BOOL(name, S, F)       { name, CONF_BOOL, CONF_FIELD(S, F), 0, 0, NULL, NULL, 0, \
                                          NULL, NULL }
#define CONF_KEY_ENUM(name, S, F, e)    { name, CONF_ENUM, CONF_FIELD(S, F), 0, 0, e, NULL, 0, \
                                          NULL, NULL }
#define CONF_KEY_MAPPING(name, table, check) { name, CONF_MAPPING, 0, 0, 0, 0, NULL, table, \
                                          sizeof(table) / sizeof((table)[0]), NULL, check }
#define CONF_KEY_CUSTOM(name, parse)    { name, CONF_CUSTOM, 0, 0, 0, 0, NULL, NULL, 0, parse, \
                                          NULL }

/*
 * Reads mapping MAP (a null or non-mapping MAP is "WHAT: missing value" or "WHAT: expected a
 * mapping") through the table KEYS: unknown and duplicate keys are errors (the unknown-key
 * message ends with IN: "at top level"; a CONF_MAPPING key's says "in NAME"), each key present
 * is read into OBJ by its type, in file order, then checked by its check(); keys absent leave
 * OBJ as it is (the caller set the defaults).
 */
int conf_table_read(struct conf *c, const struct conf_node *map, const char *what,
                    const char *in, const struct conf_key *keys, size_t n_keys, void *obj);

/* ---- conf_value.c: a whole file through its root table ---- */

/*
 * Reads LEN bytes of TEXT (at most INPUT_MAX; NAME in messages) and its top-level mapping through
 * the table KEYS into OBJ, which the caller filled with the defaults (an empty file, or one that
 * is only "~", leaves it so). OBJ may be half written on failure: read into a scratch copy. 0, or
 * -EINVAL / -ENOMEM / -EFBIG with "NAME:LINE:COL: message" in err (err_size bytes).
 */
int conf_read_text(const char *name, const char *text, size_t len, size_t input_max,
                   const struct conf_key *keys, size_t n_keys, void *obj, char *err,
                   size_t err_size);

/* conf_read_text() on the file PATH (at most INPUT_MAX bytes); a file that cannot be read is
 * "PATH: reason" (-errno). */
int conf_read_file(const char *path, size_t input_max, const struct conf_key *keys,
                   size_t n_keys, void *obj, char *err, size_t err_size);

#endif
