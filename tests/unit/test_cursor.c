/*
 * Unit tests for the toolkit's event cursor file (src/svc/cursor.c): the atomic replacement, the
 * format sharedlink-mqtt has always written (a file of an older bridge still loads), the
 * refusal of anything that is not a cursor of the same program.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "svc/cursor.h"

#define OWNER "sharedlink-mqtt"

static void test_cursor(void **state)
{
        char dir[] = "/tmp/bcur.XXXXXX", path[64], tmp[80];
        struct cursor c = { .epoch = 0x1234abcdull, .cursor = 281474976710657ull,
                                   .seq = 99 }, got;
        FILE *f;

        (void)state;
        assert_non_null(mkdtemp(dir));
        snprintf(path, sizeof(path), "%s/c", dir);
        snprintf(tmp, sizeof(tmp), "%s.tmp", path);
        assert_int_equal(cursor_load(path, OWNER, &got), -ENOENT);
        assert_int_equal(cursor_store(path, OWNER, &c, false), 0);
        assert_int_equal(cursor_load(path, OWNER, &got), 0);
        assert_memory_equal(&got, &c, sizeof(c));
        c.seq = 100;
        assert_int_equal(cursor_store(path, OWNER, &c, true), 0);
        assert_int_equal(cursor_load(path, OWNER, &got), 0);
        assert_int_equal(got.seq, 100);
        assert_int_equal(access(tmp, F_OK), -1);        /* renamed, not left behind */
        /* Anything else is not a cursor: the bridge starts at the oldest event instead. */
        static const char *const bad[] = {
                "", "sharedlink-mqtt-cursor 1 12 3\n", "sharedlink-mqtt-cursor 2 1 2 3\n",
                "sharedlink-mqtt-cursor 1 1 2 3", "sharedlink-mqtt-cursor 1 1 2 3 4\n",
                "other 1 1 2 3\n", "sharedlink-mqtt-cursor 1 zz 2 3\n",
                /* another program's cursor: never taken for one's own */
                "sharedlink-ros2-cursor 1 1 2 3\n", "sharedlink-mqttx-cursor 1 1 2 3\n",
        };
        for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
                f = fopen(path, "w");
                assert_non_null(f);
                fputs(bad[i], f);
                fclose(f);
                if (cursor_load(path, OWNER, &got) != -EBADMSG)
                        fail_msg("accepted as a cursor: \"%s\"", bad[i]);
        }
        /* A directory that cannot be written: an error, never a half-written cursor. */
        assert_int_equal(cursor_store("/proc/no/such/c", OWNER, &c, false), -ENOENT);
        unlink(path);
        rmdir(dir);
}

/* The line sharedlink-mqtt wrote before the cursor moved into the toolkit, byte for byte. */
static void test_cursor_format(void **state)
{
        char dir[] = "/tmp/bcur.XXXXXX", path[64], line[128] = "";
        struct cursor c = { .epoch = 0x1882f3a9c10ull, .cursor = 17, .seq = 5 }, got;
        FILE *f;

        (void)state;
        assert_non_null(mkdtemp(dir));
        snprintf(path, sizeof(path), "%s/c", dir);
        assert_int_equal(cursor_store(path, OWNER, &c, false), 0);
        f = fopen(path, "r");
        assert_non_null(f);
        assert_non_null(fgets(line, sizeof(line), f));
        fclose(f);
        assert_string_equal(line, "sharedlink-mqtt-cursor 1 000001882f3a9c10 17 5\n");
        assert_int_equal(cursor_load(path, "sharedlink-ros2", &got), -EBADMSG);
        assert_int_equal(cursor_store(path, "sharedlink-ros2", &c, false), 0);
        assert_int_equal(cursor_load(path, "sharedlink-ros2", &got), 0);
        assert_int_equal(got.epoch, c.epoch);
        assert_int_equal(cursor_load(path, OWNER, &got), -EBADMSG);
        unlink(path);
        rmdir(dir);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_cursor),
                cmocka_unit_test(test_cursor_format),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
