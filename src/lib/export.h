/*
 * Everything builds with -fvisibility=hidden; only the functions of <sharedlink.h> are exported,
 * marked with SL_EXPORT on their definitions (and listed in libsharedlink.sym).
 */
#ifndef SL_EXPORT_H
#define SL_EXPORT_H

#define SL_EXPORT __attribute__((visibility("default")))

#endif
