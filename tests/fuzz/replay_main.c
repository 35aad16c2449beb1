/*
 * Corpus replayer: links a libFuzzer target with an ordinary main() so that `make check` runs every
 * saved input through it with gcc and the sanitizers, no clang needed.
 * Usage: fuzz_X-replay PATH...   (files, or directories whose regular files are all replayed)
 */
#include <dirent.h>
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define REPLAY_MAX_INPUT (1u << 20)

static int replay_file(const char *path)
{
        static uint8_t buf[REPLAY_MAX_INPUT];
        FILE *f = fopen(path, "rb");
        size_t n;

        if (!f) {
                fprintf(stderr, "replay: %s: %s\n", path, strerror(errno));
                return -1;
        }
        n = fread(buf, 1, sizeof(buf), f);
        fclose(f);
        /* Hand the target a buffer of exactly the input's size so ASan sees overreads. */
        uint8_t *copy = malloc(n ? n : 1);
        if (!copy)
                return -1;
        memcpy(copy, buf, n);
        LLVMFuzzerTestOneInput(copy, n);
        free(copy);
        return 0;
}

static int cmp_str(const void *a, const void *b)
{
        return strcmp(*(char *const *)a, *(char *const *)b);
}

static int replay_dir(const char *dir, unsigned *count)
{
        DIR *d = opendir(dir);
        struct dirent *e;
        char **names = NULL;
        size_t n = 0, cap = 0;
        int r = 0;

        if (!d) {
                fprintf(stderr, "replay: %s: %s\n", dir, strerror(errno));
                return -1;
        }
        while ((e = readdir(d))) {
                if (e->d_name[0] == '.')
                        continue;
                if (n == cap) {
                        cap = cap ? cap * 2 : 64;
                        char **nn = realloc(names, cap * sizeof(*names));
                        if (!nn) { r = -1; break; }
                        names = nn;
                }
                size_t len = strlen(dir) + strlen(e->d_name) + 2;
                names[n] = malloc(len);
                if (!names[n]) { r = -1; break; }
                snprintf(names[n], len, "%s/%s", dir, e->d_name);
                n++;
        }
        closedir(d);
        if (n)
                qsort(names, n, sizeof(*names), cmp_str);  /* a stable order makes failures repeatable */
        for (size_t i = 0; i < n; i++) {
                struct stat st;
                if (r == 0 && stat(names[i], &st) == 0 && S_ISREG(st.st_mode)) {
                        if (replay_file(names[i]) < 0)
                                r = -1;
                        else
                                (*count)++;
                }
                free(names[i]);
        }
        free(names);
        return r;
}

int main(int argc, char **argv)
{
        unsigned count = 0;

        for (int i = 1; i < argc; i++) {
                struct stat st;
                if (stat(argv[i], &st) < 0) {
                        fprintf(stderr, "replay: %s: %s\n", argv[i], strerror(errno));
                        return 1;
                }
                if ((S_ISDIR(st.st_mode) ? replay_dir(argv[i], &count)
                                         : (replay_file(argv[i]) < 0 ? -1 : (count++, 0))) < 0)
                        return 1;
        }
        if (count == 0) {
                fprintf(stderr, "replay: no inputs replayed (empty corpus?)\n");
                return 1;
        }
        printf("replayed %u inputs\n", count);
        return 0;
}
