/*
 * svc/service: the command line every daemon documents ([-c FILE] [-n] [-v] [-V], -h; exit 2 on
 * a usage error) and -n's check.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "svc/service.h"

#define CHECK_BAD       "/bad.yaml"
#define ARGS_MAX        8
#define ARG_SIZE        32

static const char *checked;

static int check(const char *path)
{
        checked = path;
        return strcmp(path, CHECK_BAD) == 0 ? SERVICE_EXIT_FAILURE : service_check_ok();
}

static const struct service_desc desc = {
        .name = "testd", .version = "9.9", .config_default = "/etc/testd.yaml", .check = check,
};

/* ARGV (NULL-terminated, without argv[0]) through service_args(). */
static int run(struct service_args *a, const char *const *argv)
{
        static char text[ARGS_MAX][ARG_SIZE];
        char *args[ARGS_MAX + 1];
        int argc = 0;

        for (const char *arg = "testd"; arg && argc < ARGS_MAX; arg = *argv++) {
                snprintf(text[argc], sizeof(text[argc]), "%s", arg);
                args[argc] = text[argc];
                argc++;
        }
        args[argc] = NULL;
        optind = 0;     /* glibc: start getopt afresh */
        checked = NULL;
        *a = (struct service_args){ 0 };
        return service_args(&desc, argc, args, a);
}

static void test_run(void **state)
{
        struct service_args a;

        (void)state;
        assert_int_equal(run(&a, (const char *const[]){ NULL }), SERVICE_CONTINUE);
        assert_string_equal(a.config, "/etc/testd.yaml");
        assert_int_equal(a.verbose, 0);
        assert_int_equal(run(&a, (const char *const[]){ "-c", "/x.yaml", "-v", "-v", NULL }),
                         SERVICE_CONTINUE);
        assert_string_equal(a.config, "/x.yaml");
        assert_int_equal(a.verbose, 2);
        assert_int_equal(run(&a, (const char *const[]){ "-vc/y.yaml", NULL }), SERVICE_CONTINUE);
        assert_string_equal(a.config, "/y.yaml");
        assert_int_equal(a.verbose, 1);
}

static void test_exits(void **state)
{
        struct service_args a;

        (void)state;
        assert_int_equal(run(&a, (const char *const[]){ "-V", NULL }), SERVICE_EXIT_OK);
        assert_int_equal(run(&a, (const char *const[]){ "-h", NULL }), SERVICE_EXIT_OK);
        assert_int_equal(run(&a, (const char *const[]){ "-x", NULL }), SERVICE_EXIT_USAGE);
        assert_int_equal(run(&a, (const char *const[]){ "-c", NULL }), SERVICE_EXIT_USAGE);
        assert_int_equal(run(&a, (const char *const[]){ "extra", NULL }), SERVICE_EXIT_USAGE);
        assert_null(checked);
        /* -n checks the file -c names (after all options), and its answer is the status. */
        assert_int_equal(run(&a, (const char *const[]){ "-n", NULL }), SERVICE_EXIT_OK);
        assert_string_equal(checked, "/etc/testd.yaml");
        assert_int_equal(run(&a, (const char *const[]){ "-n", "-c", CHECK_BAD, NULL }),
                         SERVICE_EXIT_FAILURE);
        assert_string_equal(checked, CHECK_BAD);
        /* A usage error wins over -n. */
        assert_int_equal(run(&a, (const char *const[]){ "-n", "extra", NULL }),
                         SERVICE_EXIT_USAGE);
        assert_null(checked);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_run),
                cmocka_unit_test(test_exits),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
