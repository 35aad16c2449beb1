/*
 * The ROS 2 test peers' common half (see peer_common.h).
 */
#include "peer_common.h"

#include <errno.h>
#include <inttypes.h>
#include <limits.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ros2/ros2_typehash.h"
#include "svc/json.h"

#define DEFAULT_TIMEOUT_MS      10000
#define ROS_DEFAULT_DEPTH       10      /* rmw_qos_profile_default: KEEP_LAST 10 */
#define PUB_DEFAULT_DEPTH       1       /* a value topic keeps the current value only */
#define LINE_MAX_STDIN          256
#define MS_PER_S                1000
#define NS_PER_MS               1000000
/* '|'-separated fields of a composite pub VALUE (README.md). */
#define DIAG_FIELDS_HEADER_ONLY 3       /* sec|nanosec|frame_id */
#define DIAG_FIELDS_ONE_STATUS  8       /* ...|level|name|message|hardware_id|k=v,k=v */
#define FIX_FIELDS              10      /* sec|nanosec|frame_id|status|service|lat|lon|alt|cov|type */
#define FIELDS_MAX              FIX_FIELDS

struct type_names {
        const char *cli, *ros;
};

static const struct type_names type_names[PEER_TYPE_COUNT] = {
        [PEER_INT64] = { "Int64", "std_msgs/msg/Int64" },
        [PEER_FLOAT64] = { "Float64", "std_msgs/msg/Float64" },
        [PEER_STRING] = { "String", "std_msgs/msg/String" },
        [PEER_DIAGNOSTIC_ARRAY] = { "DiagnosticArray", "diagnostic_msgs/msg/DiagnosticArray" },
        [PEER_NAVSATFIX] = { "NavSatFix", "sensor_msgs/msg/NavSatFix" },
};

static void usage(void)
{
        fputs("usage: peer_X sub TOPIC TYPE [options]\n"
              "       peer_X pub TOPIC TYPE VALUE [options]\n"
              "TYPE: Int64 Float64 String DiagnosticArray NavSatFix (or the ROS/DDS type name)\n"
              "options: --reliability reliable|best_effort  --durability volatile|transient_local\n"
              "         --depth N  --count N (sub)  --readers N (pub)  --timeout-ms N  --domain N\n"
              "         --config FILE  --wait-stdin (pub)  --hold (pub)\n"
              "defaults: sub reliable volatile depth 10 (ROS default), pub reliable\n"
              "          transient_local depth 1; --domain $ROS_DOMAIN_ID or 0\n", stderr);
}

static int parse_int(const char *s, int min, int *ret)
{
        char *end;
        long v;

        errno = 0;
        v = strtol(s, &end, 10);
        if (errno || end == s || *end || v < min || v > INT_MAX)
                return -EINVAL;
        *ret = (int)v;
        return 0;
}

static int parse_type(const char *s, enum peer_type *ret)
{
        for (int t = 0; t < PEER_TYPE_COUNT; t++)
                if (strcmp(s, type_names[t].cli) == 0 || strcmp(s, type_names[t].ros) == 0 ||
                    strcmp(s, peer_type_dds_name((enum peer_type)t)) == 0) {
                        *ret = (enum peer_type)t;
                        return 0;
                }
        return -EINVAL;
}

/* One option with its argument at argv[*i]; advances *i past what it used. */
static int parse_option(int argc, char **argv, int *i, struct peer_args *a)
{
        const char *opt = argv[*i];
        const char *arg = *i + 1 < argc ? argv[*i + 1] : NULL;

        if (strcmp(opt, "--wait-stdin") == 0 || strcmp(opt, "--hold") == 0) {
                if (opt[2] == 'w')
                        a->wait_stdin = true;
                else
                        a->hold = true;
                (*i)++;
                return 0;
        }
        if (!arg)
                return -EINVAL;
        *i += 2;
        if (strcmp(opt, "--reliability") == 0) {
                if (strcmp(arg, "reliable") && strcmp(arg, "best_effort"))
                        return -EINVAL;
                a->reliable = strcmp(arg, "reliable") == 0;
                return 0;
        }
        if (strcmp(opt, "--durability") == 0) {
                if (strcmp(arg, "volatile") && strcmp(arg, "transient_local"))
                        return -EINVAL;
                a->transient_local = strcmp(arg, "transient_local") == 0;
                return 0;
        }
        if (strcmp(opt, "--config") == 0) {
                a->config = arg;
                return 0;
        }
        if (strcmp(opt, "--depth") == 0)
                return parse_int(arg, 1, &a->depth);
        if (strcmp(opt, "--count") == 0)
                return parse_int(arg, 0, &a->count);
        if (strcmp(opt, "--readers") == 0)
                return parse_int(arg, 0, &a->readers);
        if (strcmp(opt, "--timeout-ms") == 0)
                return parse_int(arg, 1, &a->timeout_ms);
        if (strcmp(opt, "--domain") == 0)
                return parse_int(arg, 0, &a->domain);
        return -EINVAL;
}

int peer_args_parse(int argc, char **argv, struct peer_args *ret)
{
        struct peer_args a = { .count = 1, .readers = 1, .timeout_ms = DEFAULT_TIMEOUT_MS,
                               .reliable = true };
        const char *env = getenv("ROS_DOMAIN_ID");
        int i;

        if (argc < 4)
                goto bad;
        if (strcmp(argv[1], "sub") == 0)
                a.cmd = PEER_SUB;
        else if (strcmp(argv[1], "pub") == 0)
                a.cmd = PEER_PUB;
        else
                goto bad;
        a.topic = argv[2];
        if (parse_type(argv[3], &a.type) < 0)
                goto bad;
        a.transient_local = a.cmd == PEER_PUB;
        a.depth = a.cmd == PEER_PUB ? PUB_DEFAULT_DEPTH : ROS_DEFAULT_DEPTH;
        if (env && *env && parse_int(env, 0, &a.domain) < 0)
                goto bad;
        i = 4;
        if (a.cmd == PEER_PUB) {
                if (argc < 5)
                        goto bad;
                a.value = argv[i++];
        }
        while (i < argc)
                if (parse_option(argc, argv, &i, &a) < 0)
                        goto bad;
        *ret = a;
        return 0;
bad:
        usage();
        return -EINVAL;
}

const char *peer_type_dds_name(enum peer_type t)
{
        const struct ros2_typehash *h = ros2_typehash_find(type_names[t].ros);

        return h ? h->dds_name : NULL;
}

const char *peer_type_ros_name(enum peer_type t)
{
        return type_names[t].ros;
}

const char *peer_type_user_data(enum peer_type t)
{
        return ros2_typehash_user_data(type_names[t].ros);
}

char *peer_strdup(const char *s)
{
        return strdup(s ? s : "");
}

/* Splits text at sep into at most max fields (pointers into the copy *ret_copy owns). */
static size_t split(const char *text, char sep, char **fields, size_t max, char **ret_copy)
{
        char *copy = strdup(text), *p = copy;
        size_t n = 0;

        *ret_copy = copy;
        if (!copy)
                return 0;
        while (n < max) {
                char *next = strchr(p, sep);

                fields[n++] = p;
                if (!next)
                        return n;
                *next = '\0';
                p = next + 1;
        }
        return max + 1;         /* more than max: refused by every caller */
}

static int parse_i64(const char *s, int64_t min, int64_t max, int64_t *ret)
{
        char *end;
        long long v;

        errno = 0;
        v = strtoll(s, &end, 10);
        if (errno || end == s || *end || v < min || v > max)
                return -EINVAL;
        *ret = v;
        return 0;
}

static int parse_double(const char *s, double *ret)
{
        char *end;

        errno = 0;
        *ret = strtod(s, &end);
        return errno || end == s || *end ? -EINVAL : 0;
}

static int parse_stamp(char **f, struct peer_value *v)
{
        int64_t sec, nsec;

        if (parse_i64(f[0], INT32_MIN, INT32_MAX, &sec) < 0 ||
            parse_i64(f[1], 0, UINT32_MAX, &nsec) < 0)
                return -EINVAL;
        v->sec = (int32_t)sec;
        v->nanosec = (uint32_t)nsec;
        v->frame_id = peer_strdup(f[2]);
        return v->frame_id ? 0 : -ENOMEM;
}

/* "k=v,k=v" (or "") into the status's values. */
static int parse_key_values(const char *text, struct peer_status *st)
{
        char *f[FIELDS_MAX * FIELDS_MAX], *copy;
        size_t n;
        int r = 0;

        if (!*text)
                return 0;
        n = split(text, ',', f, sizeof(f) / sizeof(f[0]), &copy);
        if (!copy)
                return -ENOMEM;
        if (n > sizeof(f) / sizeof(f[0])) {
                free(copy);
                return -EINVAL;
        }
        st->values = calloc(n, sizeof(*st->values));
        if (!st->values)
                r = -ENOMEM;
        for (size_t i = 0; r == 0 && i < n; i++) {
                char *eq = strchr(f[i], '=');

                if (!eq) {
                        r = -EINVAL;
                        break;
                }
                *eq = '\0';
                st->values[i].key = peer_strdup(f[i]);
                st->values[i].value = peer_strdup(eq + 1);
                st->n_values = i + 1;
                if (!st->values[i].key || !st->values[i].value)
                        r = -ENOMEM;
        }
        free(copy);
        return r;
}

static int parse_diagnostic_array(char **f, size_t n, struct peer_value *v)
{
        struct peer_status *st;
        int64_t level;
        int r;

        if (n != DIAG_FIELDS_HEADER_ONLY && n != DIAG_FIELDS_ONE_STATUS)
                return -EINVAL;
        r = parse_stamp(f, v);
        if (r < 0 || n == DIAG_FIELDS_HEADER_ONLY)
                return r;
        if (parse_i64(f[3], 0, UINT8_MAX, &level) < 0)
                return -EINVAL;
        st = v->status = calloc(1, sizeof(*st));
        if (!st)
                return -ENOMEM;
        v->n_status = 1;
        st->level = (uint8_t)level;
        st->name = peer_strdup(f[4]);
        st->message = peer_strdup(f[5]);
        st->hardware_id = peer_strdup(f[6]);
        if (!st->name || !st->message || !st->hardware_id)
                return -ENOMEM;
        return parse_key_values(f[7], st);
}

static int parse_navsatfix(char **f, size_t n, struct peer_value *v)
{
        char *c[PEER_COVARIANCE_LEN + 1], *copy;
        int64_t status, service, type;
        size_t nc;
        int r;

        if (n != FIX_FIELDS)
                return -EINVAL;
        r = parse_stamp(f, v);
        if (r < 0)
                return r;
        if (parse_i64(f[3], INT8_MIN, INT8_MAX, &status) < 0 ||
            parse_i64(f[4], 0, UINT16_MAX, &service) < 0 ||
            parse_double(f[5], &v->latitude) < 0 || parse_double(f[6], &v->longitude) < 0 ||
            parse_double(f[7], &v->altitude) < 0 || parse_i64(f[9], 0, UINT8_MAX, &type) < 0)
                return -EINVAL;
        v->fix_status = (int8_t)status;
        v->service = (uint16_t)service;
        v->covariance_type = (uint8_t)type;
        nc = split(f[8], ',', c, PEER_COVARIANCE_LEN, &copy);
        if (!copy)
                return -ENOMEM;
        r = nc == PEER_COVARIANCE_LEN ? 0 : -EINVAL;
        for (size_t i = 0; r == 0 && i < PEER_COVARIANCE_LEN; i++)
                r = parse_double(c[i], &v->covariance[i]);
        free(copy);
        return r;
}

int peer_value_parse(enum peer_type t, const char *text, struct peer_value *ret)
{
        struct peer_value v = { .type = t };
        char *f[FIELDS_MAX + 1], *copy = NULL;
        size_t n;
        int r;

        switch (t) {
        case PEER_INT64:
                r = parse_i64(text, INT64_MIN, INT64_MAX, &v.i);
                break;
        case PEER_FLOAT64:
                r = parse_double(text, &v.d);
                break;
        case PEER_STRING:
                v.s = peer_strdup(text);
                r = v.s ? 0 : -ENOMEM;
                break;
        case PEER_DIAGNOSTIC_ARRAY:
        case PEER_NAVSATFIX:
                n = split(text, '|', f, FIELDS_MAX, &copy);
                if (!copy)
                        return -ENOMEM;
                r = t == PEER_NAVSATFIX ? parse_navsatfix(f, n, &v)
                                        : parse_diagnostic_array(f, n, &v);
                free(copy);
                break;
        default:
                r = -EINVAL;
        }
        if (r < 0) {
                peer_value_free(&v);
                return r;
        }
        *ret = v;
        return 0;
}

void peer_value_free(struct peer_value *v)
{
        if (!v)
                return;
        for (size_t i = 0; i < v->n_status; i++) {
                struct peer_status *st = &v->status[i];

                for (size_t k = 0; k < st->n_values; k++) {
                        free(st->values[k].key);
                        free(st->values[k].value);
                }
                free(st->values);
                free(st->name);
                free(st->message);
                free(st->hardware_id);
        }
        free(v->status);
        free(v->s);
        free(v->frame_id);
        memset(v, 0, sizeof(*v));
}

/* Doubles as the shortest text that reads back as the same double (%.17g is exact but shows
 * 0.1 as 0.10000000000000001; try the shorter forms first). */
static void print_double(FILE *f, double d)
{
        char buf[32];

        for (int prec = 15; prec <= 17; prec++) {
                snprintf(buf, sizeof(buf), "%.*g", prec, d);
                if (strtod(buf, NULL) == d)
                        break;
        }
        fputs(buf, f);
}

static void print_header(FILE *f, const struct peer_value *v)
{
        fprintf(f, "{\"stamp\":{\"sec\":%" PRId32 ",\"nanosec\":%" PRIu32 "}", v->sec, v->nanosec);
        json_member_string(f, 0, "frame_id", v->frame_id);
}

static void print_status(FILE *f, const struct peer_status *st)
{
        fprintf(f, "{\"level\":%u", (unsigned)st->level);
        json_member_string(f, 0, "name", st->name);
        json_member_string(f, 0, "message", st->message);
        json_member_string(f, 0, "hardware_id", st->hardware_id);
        json_key(f, 0, "values");
        fputc('[', f);
        for (size_t k = 0; k < st->n_values; k++) {
                fputs(k ? ",{" : "{", f);
                json_member_string(f, 1, "key", st->values[k].key);
                json_member_string(f, 0, "value", st->values[k].value);
                fputc('}', f);
        }
        fputs("]}", f);
}

static void print_navsatfix(FILE *f, const struct peer_value *v)
{
        print_header(f, v);
        fprintf(f, ",\"status\":{\"status\":%d,\"service\":%u},\"latitude\":", v->fix_status,
                (unsigned)v->service);
        print_double(f, v->latitude);
        fputs(",\"longitude\":", f);
        print_double(f, v->longitude);
        fputs(",\"altitude\":", f);
        print_double(f, v->altitude);
        fputs(",\"position_covariance\":[", f);
        for (size_t i = 0; i < PEER_COVARIANCE_LEN; i++) {
                if (i)
                        fputc(',', f);
                print_double(f, v->covariance[i]);
        }
        fprintf(f, "],\"position_covariance_type\":%u}", (unsigned)v->covariance_type);
}

void peer_value_print(FILE *f, const struct peer_value *v)
{
        switch (v->type) {
        case PEER_INT64:
                fprintf(f, "%" PRId64, v->i);
                break;
        case PEER_FLOAT64:
                print_double(f, v->d);
                break;
        case PEER_STRING:
                json_string(f, v->s);
                break;
        case PEER_DIAGNOSTIC_ARRAY:
                print_header(f, v);
                json_key(f, 0, "status");
                fputc('[', f);
                for (size_t i = 0; i < v->n_status; i++) {
                        if (i)
                                fputc(',', f);
                        print_status(f, &v->status[i]);
                }
                fputs("]}", f);
                break;
        case PEER_NAVSATFIX:
                print_navsatfix(f, v);
                break;
        default:
                break;
        }
}

static void print_hex(const void *p, size_t len)
{
        const unsigned char *b = p;

        for (size_t i = 0; i < len; i++)
                printf("%02x", b[i]);
}

void peer_print_sample(const char *topic, const char *type_name, const void *cdr, size_t len,
                       const struct peer_value *v)
{
        printf("sample topic=%s type=%s cdr=", topic, type_name);
        print_hex(cdr, len);
        fputs(" value=", stdout);
        peer_value_print(stdout, v);
        putchar('\n');
        fflush(stdout);
}

void peer_print_writer(const char *topic, const char *type_name, bool reliable,
                       bool transient_local, const void *user_data, size_t len)
{
        const char *u = user_data;

        printf("writer topic=%s type=%s reliability=%s durability=%s user_data=", topic,
               type_name, reliable ? "reliable" : "best_effort",
               transient_local ? "transient_local" : "volatile");
        /* USER_DATA is octets: printable ASCII as it is (the ROS "key=value;" text), the rest
         * as \xHH, so a stray byte shows instead of cutting the line. */
        for (size_t i = 0; i < len; i++) {
                if (u[i] > ' ' && u[i] < 0x7f && u[i] != '\\')
                        putchar(u[i]);
                else
                        printf("\\x%02x", (unsigned char)u[i]);
        }
        putchar('\n');
        fflush(stdout);
}

void peer_print_line(const char *fmt, ...)
{
        va_list ap;

        va_start(ap, fmt);
        vprintf(fmt, ap);
        va_end(ap);
        putchar('\n');
        fflush(stdout);
}

int64_t peer_now_ms(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (int64_t)ts.tv_sec * MS_PER_S + ts.tv_nsec / NS_PER_MS;
}

int64_t peer_left_ms(int64_t start_ms, int timeout_ms)
{
        int64_t left = start_ms + timeout_ms - peer_now_ms();

        return left > 0 ? left : 0;
}

int peer_wait_stdin(void)
{
        char line[LINE_MAX_STDIN];

        return fgets(line, sizeof(line), stdin) ? 0 : -EIO;
}

void peer_hold_stdin(void)
{
        char line[LINE_MAX_STDIN];

        while (fgets(line, sizeof(line), stdin))
                ;
}
