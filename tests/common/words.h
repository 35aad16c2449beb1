/*
 * Command lines for in-process tests of the command parsers: split at spaces, the way a control
 * request reaches an engine (without the control protocol's quoting, which test_control_proto
 * covers).
 */
#pragma once

/* Splits line at spaces into argv, in place, at most max words; returns the count. */
int words_split(char *line, char **argv, int max);
