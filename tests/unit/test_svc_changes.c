/*
 * svc/changes: the ids sl_changed names handed out one by one, "read everything" when the
 * library says so, a caller's error passed on, a skip that moves the cursor to now, and more
 * ids than one batch. Against a real table made in this process.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include <cmocka.h>

#include <sharedlink.h>

#include "common/shmtest.h"
#include "svc/changes.h"

#define NVARS           4u
#define MANY            (CHANGES_BATCH + 44u)   /* more than one batch, less than the record */
#define SEEN_MAX        (2u * MANY)

struct fixture {
        struct shm_table *t;
        char instance[SHMTEST_INSTANCE_SIZE];
        struct sl_client *c;
        struct changes ch;
        int seen[SEEN_MAX];
        unsigned n;
        int fail_at;                    /* the call of fn that fails (-EIO); -1: none */
};

static int on_id(void *arg, int id)
{
        struct fixture *f = arg;

        if ((int)f->n == f->fail_at)
                return -EIO;
        if (f->n < SEEN_MAX)
                f->seen[f->n] = id;
        f->n++;
        return 0;
}

static int setup(void **state)
{
        struct fixture *f = calloc(1, sizeof(*f));

        *state = f;
        f->fail_at = -1;
        shmtest_instance(f->instance, sizeof(f->instance), "chg");
        if (shmtest_table_strings(f->instance, "v", SHM_DIR_IN, NVARS, &f->t) < 0 ||
            sl_open(f->instance, &f->c) < 0)
                return -1;
        return 0;
}

static int teardown(void **state)
{
        struct fixture *f = *state;

        sl_close(f->c);
        shm_table_destroy(f->t);
        shmtest_unlink(f->instance);
        free(f);
        return 0;
}

static int follow(struct fixture *f, bool skip)
{
        f->n = 0;
        return changes_follow(&f->ch, f->c, skip, on_id, f);
}

static void test_follow(void **state)
{
        struct fixture *f = *state;

        assert_int_equal(follow(f, false), 1);          /* a first call: everything */
        assert_int_equal(f->n, 0);
        assert_int_equal(follow(f, false), 0);
        assert_int_equal(f->n, 0);
        shm_table_begin(f->t);
        shm_table_set_str(f->t, 2, "x");
        shm_table_set_str(f->t, 0, "y");
        shm_table_commit(f->t);
        assert_int_equal(follow(f, false), 0);
        assert_int_equal(f->n, 2);
        assert_int_equal(f->seen[0], sl_find(f->c, "v2"));
        assert_int_equal(f->seen[1], sl_find(f->c, "v0"));
}

static void test_error_and_skip(void **state)
{
        struct fixture *f = *state;

        follow(f, false);
        shm_table_set_str(f->t, 1, "a");
        shm_table_set_str(f->t, 3, "b");
        f->fail_at = 1;
        assert_int_equal(follow(f, false), -EIO);
        assert_int_equal(f->n, 1);
        f->fail_at = -1;
        /* skip: nothing handed out, the cursor at now */
        shm_table_set_str(f->t, 1, "c");
        assert_int_equal(follow(f, true), 1);
        assert_int_equal(f->n, 0);
        assert_int_equal(follow(f, false), 0);
        assert_int_equal(f->n, 0);
}

/* More ids than one batch: every one, in order, in one call. */
static void test_more_than_a_batch(void **state)
{
        struct fixture *f = *state;
        struct shmtest_table tb;
        struct shm_var v = { "big", SHM_DIR_IN, SHM_TYPE_STRING, SHM_LINK_NONE, NULL,
                             SHM_POSITION_NONE };
        struct sl_client *c;
        struct changes ch = { 0 };
        char value[16];

        (void)f;
        shmtest_table_init(&tb, "chgbig");
        shmtest_table_config(&tb, &v, 1, MANY);
        assert_int_equal(shmtest_table_create(&tb), 0);
        assert_int_equal(sl_open(tb.instance, &c), 0);
        assert_int_equal(changes_follow(&ch, c, false, on_id, f), 1);
        for (unsigned i = 0; i < MANY; i++) {
                snprintf(value, sizeof(value), "%u", i);
                assert_int_equal(shm_table_set_str(tb.t, 0, value), 0);
        }
        f->n = 0;
        assert_int_equal(changes_follow(&ch, c, false, on_id, f), 0);
        assert_int_equal(f->n, MANY);
        for (unsigned i = 0; i < MANY; i++)
                assert_int_equal(f->seen[i], 0);
        sl_close(c);
        shmtest_table_destroy(&tb);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_follow, setup, teardown),
                cmocka_unit_test_setup_teardown(test_error_and_skip, setup, teardown),
                cmocka_unit_test_setup_teardown(test_more_than_a_batch, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
