/*
 * Command lines for in-process tests (see words.h).
 */
#include "common/words.h"

#include <string.h>

int words_split(char *line, char **argv, int max)
{
        char *save = NULL;
        int n = 0;

        for (char *w = strtok_r(line, " ", &save); w && n < max; w = strtok_r(NULL, " ", &save))
                argv[n++] = w;
        return n;
}
