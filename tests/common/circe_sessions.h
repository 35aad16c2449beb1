/*
 * The CIRCE specification's example sessions as packet bodies ("OP<TAB>PID:VALUE<TAB>...",
 * without STX, checksum and ETX), shared by the in-process engine test
 * (tests/unit/test_link_circe.c) and the real-daemon test (tests/integration/test_circe.c) so
 * both replay the very same bytes. The examples speak protocol version 1.2.34 (expect "1.2").
 *
 * Naming: CIRCE_S_<session>_<what>; C> is what the controller sends, M> what the mediator sends.
 */
#pragma once

/* Session start and end (every example). */
#define CIRCE_S_LOGIN                   "01\t"                          /* C> */
#define CIRCE_S_LOGOUT                  "02\t"                          /* C> */
#define CIRCE_S_KA                      "51\t010:1.2.34\t012:0\t"       /* M> */
#define CIRCE_S_KA_UNCONF               "51\t010:1.2.34\t012:1\t"       /* M>, unconfigured */

/* "Assigning unique network addresses". */
#define CIRCE_S_ASSIGN_MEDIATOR         "05\t026:123456\t"              /* C> */
#define CIRCE_S_ASSIGN_GATE             "05\t026:222222\t019:32\t"      /* C> */
#define CIRCE_S_ASSIGN_GATE_STATUS      "52\t015:222222\t016:0\t019:32\t020:0\t021:150\t"

/* "Forming a logical network". */
#define CIRCE_S_NET_STATUS_AAAAAA       "52\t015:AAAAAA\t016:0\t019:1\t020:0\t021:200\t"
#define CIRCE_S_NET_STATUS_E1E1E1       "52\t015:E1E1E1\t016:0\t019:32\t020:0\t021:150\t"
#define CIRCE_S_NET_STATUS_E2E2E2       "52\t015:E2E2E2\t016:0\t019:32\t020:0\t021:130\t"
#define CIRCE_S_NET_ALERT_E1E1E1        "03\t014:E1E1E1\t"                      /* C> */
#define CIRCE_S_NET_JOIN_AAAAAA         "04\t014:AAAAAA\t017:1\t020:1\t"        /* C> */
#define CIRCE_S_NET_JOIN_E1E1E1         "04\t014:E1E1E1\t017:1\t020:2\t"        /* C> */
#define CIRCE_S_NET_JOIN_E2E2E2         "04\t014:E2E2E2\t017:1\t020:4\t"        /* C> */

/* "Synchronizing hardware clocks": a remote, and a gate asking for sync (027:1). */
#define CIRCE_S_SYNC_STATUS_AAAAAA      "52\t015:AAAAAA\t016:0\t019:31\t020:3\t021:200\t"
#define CIRCE_S_SYNC_STATUS_E1E1E1      "52\t015:E1E1E1\t016:0\t019:32\t020:4\t021:150\t027:1\t"
#define CIRCE_S_SYNC_CLOCKS             "06\t"                                  /* C> */
#define CIRCE_S_SYNC_DONE_AAAAAA        "52\t015:AAAAAA\t016:0\t019:31\t020:3\t021:200\t027:2\t"
#define CIRCE_S_SYNC_DONE_E1E1E1        "52\t015:E1E1E1\t016:0\t019:32\t020:4\t021:150\t027:2\t"

/* "Race events during a competition run": Ready pressed and released on the remote, the start
 * gate at 5 s, the finish gate at 32 s. */
#define CIRCE_S_RACE_READY_DOWN         "53\t015:AAAAAA\t024:32768\t"
#define CIRCE_S_RACE_READY_UP           "53\t015:AAAAAA\t024:0\t"
#define CIRCE_S_RACE_START              "53\t015:E1E1E1\t025:5000\t"
#define CIRCE_S_RACE_FINISH             "53\t015:E2E2E2\t025:32000\t"

/* Not from the spec: a mediator of the version our links expect by default ("0.2"), a patch
 * level later, and a Log ("ALIVE") that must never count as the link being alive. */
#define CIRCE_S_KA_023                  "51\t010:0.2.3\t012:0\t"
#define CIRCE_S_KA_029                  "51\t010:0.2.9\t012:0\t"
#define CIRCE_S_LOG_ALIVE               "54\t036:414C495645\t"
