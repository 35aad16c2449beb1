/*
 * sharedlink-ros2: ROS 2 names (see ros2_names.h).
 */
#include "ros2/ros2_names.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static bool is_alpha(char ch)
{
        return (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z');
}

static bool is_digit(char ch)
{
        return ch >= '0' && ch <= '9';
}

/* A byte of a ROS token. */
static bool token_byte(char ch)
{
        return is_alpha(ch) || is_digit(ch) || ch == '_';
}

/* A byte of a variable name (slp_name_byte's rule, repeated here as the public contract:
 * sharedlink.h, "1 to 47 bytes of letters, digits, '_', '.' and '-'"). */
static bool var_byte(char ch)
{
        return token_byte(ch) || ch == '.' || ch == '-';
}

int ros2_names_map(const char *name, char *out, size_t size)
{
        size_t len = strnlen(name, SL_NAME_SIZE), o = 0;
        bool token_start = true;

        if (len == 0 || len >= SL_NAME_SIZE || size < ROS2_REL_SIZE)
                return -EINVAL;
        for (size_t i = 0; i <= len; i++) {
                char ch = name[i];

                if (i < len && !var_byte(ch))
                        return -EINVAL;
                if (token_start && (i == len || ch == '.' || is_digit(ch)))
                        out[o++] = '_';         /* an empty token, or one starting with a digit */
                token_start = false;
                if (i == len)
                        break;
                if (ch == '.') {
                        out[o++] = '/';
                        token_start = true;
                } else {
                        out[o++] = ch == '-' ? '_' : ch;
                }
        }
        out[o] = '\0';
        return 0;
}

/* Tokens of [A-Za-z0-9_] not starting with a digit, separated by single '/', from s to its end. */
static bool tokens_valid(const char *s)
{
        bool start = true;

        if (!*s)
                return false;
        for (; *s; s++) {
                if (*s == '/') {
                        if (start)
                                return false;   /* empty token */
                        start = true;
                        continue;
                }
                if (!token_byte(*s) || (start && is_digit(*s)))
                        return false;
                start = false;
        }
        return !start;
}

bool ros2_names_valid(const char *s, bool root_ok)
{
        size_t len = strnlen(s, ROS2_NAME_SIZE);

        if (len == 0 || len > ROS2_NAME_MAX || s[0] != '/')
                return false;
        if (len == 1)
                return root_ok;
        return tokens_valid(s + 1);
}

bool ros2_names_valid_relative(const char *s)
{
        return strnlen(s, ROS2_NAME_SIZE) <= ROS2_NAME_MAX && s[0] != '/' && tokens_valid(s);
}

int ros2_names_join(char *out, size_t size, const char *ns, const char *a, const char *b)
{
        bool root = !strcmp(ns, "/");
        int n;

        if (a[0] == '/')
                n = snprintf(out, size, "%s", a);
        else
                n = snprintf(out, size, "%s/%s%s%s", root ? "" : ns, a, b ? "/" : "",
                             b ? b : "");
        if (n < 0 || (size_t)n >= size || (size_t)n > ROS2_NAME_MAX)
                return -ENAMETOOLONG;
        return 0;
}

int ros2_names_dds(char *out, size_t size, const char *full)
{
        int n = snprintf(out, size, ROS2_DDS_PREFIX "%s", full);

        return n < 0 || (size_t)n >= size ? -ENAMETOOLONG : 0;
}

bool ros2_names_reserved(const char *rel)
{
        static const char set[] = ROS2_TOPIC_SET "/";

        return !strcmp(rel, ROS2_TOPIC_EVENTS) || !strcmp(rel, ROS2_TOPIC_SET_ERRORS) ||
               !strncmp(rel, set, sizeof(set) - 1);
}

static int ref_cmp(const void *a, const void *b)
{
        return strcmp(((const struct ros2_names_ref *)a)->name,
                      ((const struct ros2_names_ref *)b)->name);
}

void ros2_names_duplicates(struct ros2_names_ref *refs, size_t n, bool *dup)
{
        if (n < 2)
                return;
        qsort(refs, n, sizeof(*refs), ref_cmp);
        for (size_t i = 1; i < n; i++)
                if (!strcmp(refs[i - 1].name, refs[i].name))
                        dup[refs[i - 1].owner] = dup[refs[i].owner] = true;
}
