# sharedlink: one non-recursive GNU Makefile.
#
# Conventions (add a file, not a rule):
#   src/proto/*.c, src/shm/*.c     pure codecs / table layout, archived per directory
#   src/svc/*.c                    the service toolkit every daemon shares (docs/services.md):
#                                  archived, linked into sharedlinkd, sharedlink-mqtt and slctl
#   src/daemon/*.c                 sharedlinkd (main.c holds main(), the rest is archived for tests)
#   src/lib/*.c + LIB_SHM_SRC      libsharedlink.so.1 / .a (exports: src/lib/libsharedlink.sym),
#     + LIB_PROTO_SRC              with the client's src/shm files and the codecs it speaks
#                                  (control, CIRCE, SharedLink); the .so keeps only used code
#   src/cli/*.c                    slctl, linked against libsharedlink.a (all but main.c also
#                                  archived for unit tests)
#   src/mqtt/*.c                   sharedlink-mqtt (main.c holds main(), the rest is archived for
#                                  tests), linked against libsharedlink.so and libmosquitto only
#   src/agility/agility_*.c        sharedlink-agility's pure core (run state machine, timing, keys,
#                                  ranking, display model, competitor CSV), archived for tests
#   src/agility/agilityd_*.c       sharedlink-agility's daemon modules (class file, SQLite, HTTP,
#     + src/agility/main.c         the loop), archived for tests; linked against libsharedlink.so,
#                                  libsqlite3 and libmicrohttpd
#   tests/common/*.c               helpers linked into every test binary
#   tests/unit/test_*.c            one cmocka binary per module, run by `make check`
#   tests/integration/test_*.c     cmocka binaries that start the real daemon, run by `make check`
#   tests/stress/stress_*.c        stress tests, run by `make check` (asan) and again built with tsan
#   tests/fuzz/fuzz_*.c            libFuzzer targets; corpus in tests/fuzz/corpus/<name>/
#   tests/bench/bench_*.c          benchmarks, built optimised by `make bench`
#   tests/peers/test_*.py          self-tests of the Python test peers, run by `make check`
#   src/ros2/*.c                   sharedlink-ros2 (main.c holds main(), the rest is archived for
#     + src/ros2/idl/*.idl         tests, with the C that idlc makes of the IDL in build/.../gen/ros2/),
#                                  linked against libsharedlink.so and Cyclone DDS (libddsc) only
#   examples/*.c                   programs built only on <sharedlink.h> and pkg-config
#   man/*.[1-8]                    man pages, installed by `make install` (section = suffix)
#   python/sharedlink/*.py         the Python package (ctypes), installed into PYTHONDIR;
#                                  python/tests/ run by `make check` (tests/python/*.c: helpers)
#   completion/slctl.bash          bash completion, installed into BASHCOMPDIR
#
# Build variants: `make` -> build/ (optimised, hardened); SAN=asan -> build/asan/ (ASan+UBSan);
# SAN=tsan -> build/tsan/.  `make check` = the asan build + every test.

SHELL      := /bin/bash
.SECONDARY:
.DELETE_ON_ERROR:
.DEFAULT_GOAL := all

VERSION    := 0.1.0
SOVERSION  := 1
PREFIX     ?= /usr/local
DESTDIR    ?=
BINDIR     ?= $(PREFIX)/bin
SBINDIR    ?= $(PREFIX)/sbin
LIBDIR     ?= $(PREFIX)/lib
INCDIR     ?= $(PREFIX)/include
SYSCONFDIR ?= /etc
UNITDIR    ?= $(PREFIX)/lib/systemd/system
MANDIR     ?= $(PREFIX)/share/man
PKGCONFIGDIR ?= $(LIBDIR)/pkgconfig
SYSUSERSDIR  ?= $(PREFIX)/lib/sysusers.d
TMPFILESDIR  ?= $(PREFIX)/lib/tmpfiles.d
BASHCOMPDIR  ?= $(PREFIX)/share/bash-completion/completions
# The Python package goes where PYTHON looks for packages under PREFIX (python/sitedir.py):
# Debian's /usr/lib/python3/dist-packages for PREFIX=/usr. Empty (python missing): not installed.
PYTHON       ?= python3
PYTHONDIR    ?= $(shell $(PYTHON) python/sitedir.py '$(PREFIX)' 2>/dev/null)

CC         ?= cc
SAN        ?=
WERROR     ?= 1
WITH_SYSTEMD ?= 1
FUZZ_TIME  ?= 600
TEST_TIMEOUT ?= 300
V          ?= 0

# Quiet build lines ("  CC  src/x.c"); V=1 prints the full commands.
ifeq ($(V),0)
Q     := @
quiet  = @printf '  %-4s %s\n' '$(1)' '$@';
else
Q     :=
quiet  =
endif

# python3: the Python binding (python/tests) and tests/peers/ (the Pronto4 test peer), in `make check`.
# mosquitto: the MQTT bridge's tests start a broker of their own (and mosquitto_passwd); openssl
# makes their throwaway TLS certificates. sqlite3 and libmicrohttpd: sharedlink-agility's results
# database and scoreboard; chromium: test_agility renders that scoreboard in a headless browser.
DEB_PKGS       := gcc make pkg-config libyaml-dev libsystemd-dev libcmocka-dev python3 \
                  libmosquitto-dev mosquitto mosquitto-clients openssl libsqlite3-dev \
                  libmicrohttpd-dev chromium
# cyclonedds-dev and -tools (idlc): sharedlink-ros2 and the ROS 2 test peers; libfastrtps-dev,
# libfastcdr-dev and g++: the Fast DDS test peer (tests/ros2peer/, built only where present).
DEB_PKGS       += cyclonedds-dev cyclonedds-tools libfastrtps-dev libfastcdr-dev g++
DEB_PKGS_EXTRA := clang libclang-rt-14-dev redis-server valgrind

# ---------------------------------------------------------------------------------------------
# Dependencies: when pkg-config cannot find one, run `make deps` once before anything else.

PC_REQUIRED := yaml-0.1 cmocka libmosquitto sqlite3 libmicrohttpd CycloneDDS
ifeq ($(WITH_SYSTEMD),1)
PC_REQUIRED += libsystemd
endif

NODEPS_GOALS := deps deps-extra clean help uninstall
ifeq ($(filter-out $(NODEPS_GOALS),$(or $(MAKECMDGOALS),all)),)
else
# `make check` and `make bench` also run the Python binding: they need $(PYTHON) too.
NEED_PYTHON := $(if $(filter check bench,$(MAKECMDGOALS)),&& command -v $(PYTHON) >/dev/null)
ifneq ($(shell pkg-config --exists $(PC_REQUIRED) 2>/dev/null $(NEED_PYTHON) && echo ok),ok)
$(info sharedlink: build dependencies missing ($(PC_REQUIRED)$(if $(NEED_PYTHON), $(PYTHON))); running 'make deps')
DEPS_RESULT := $(shell $(MAKE) --no-print-directory deps >&2 && echo ok)
ifneq ($(DEPS_RESULT),ok)
$(error 'make deps' failed; install the packages above and try again)
endif
endif
endif

YAML_CFLAGS := $(shell pkg-config --cflags yaml-0.1 2>/dev/null)
YAML_LIBS   := $(shell pkg-config --libs yaml-0.1 2>/dev/null)
CMOCKA_CFLAGS := $(shell pkg-config --cflags cmocka 2>/dev/null)
CMOCKA_LIBS   := $(shell pkg-config --libs cmocka 2>/dev/null)
MOSQ_CFLAGS   := $(shell pkg-config --cflags libmosquitto 2>/dev/null)
MOSQ_LIBS     := $(shell pkg-config --libs libmosquitto 2>/dev/null)
SQLITE_CFLAGS := $(shell pkg-config --cflags sqlite3 2>/dev/null)
SQLITE_LIBS   := $(shell pkg-config --libs sqlite3 2>/dev/null)
MHD_CFLAGS    := $(shell pkg-config --cflags libmicrohttpd 2>/dev/null)
MHD_LIBS      := $(shell pkg-config --libs libmicrohttpd 2>/dev/null)
DDS_CFLAGS    := $(shell pkg-config --cflags CycloneDDS 2>/dev/null)
DDS_LIBS      := $(shell pkg-config --libs CycloneDDS 2>/dev/null)
IDLC          ?= idlc
ifeq ($(WITH_SYSTEMD),1)
SYSTEMD_CFLAGS := $(shell pkg-config --cflags libsystemd 2>/dev/null) -DHAVE_LIBSYSTEMD=1
SYSTEMD_LIBS   := $(shell pkg-config --libs libsystemd 2>/dev/null)
else
SYSTEMD_CFLAGS := -DHAVE_LIBSYSTEMD=0
SYSTEMD_LIBS   :=
endif

# ---------------------------------------------------------------------------------------------
# Flags (STYLE.md)

WARN := -Wall -Wextra -Wshadow -Wstrict-prototypes -Wmissing-prototypes -Wpointer-arith \
        -Wcast-qual -Wwrite-strings -Wformat=2 -Wundef -Wvla -Wimplicit-fallthrough
ifeq ($(WERROR),1)
WARN += -Werror
endif

ifeq ($(SAN),asan)
O        := build/asan
OPT      := -O1 -g -fno-omit-frame-pointer
SANFLAGS := -fsanitize=address,undefined -fno-sanitize-recover=all
HARDEN   :=
else ifeq ($(SAN),tsan)
O        := build/tsan
OPT      := -O1 -g
SANFLAGS := -fsanitize=thread
HARDEN   :=
else ifeq ($(SAN),)
O        := build
OPT      := -O2 -g
SANFLAGS :=
HARDEN   := -D_FORTIFY_SOURCE=2 -fstack-protector-strong
else
$(error SAN must be empty, asan or tsan)
endif

CPPFLAGS_ALL := -Iinclude -Isrc -D_DEFAULT_SOURCE -DSHAREDLINK_VERSION='"$(VERSION)"'
# One section per function and object: the shared library links with --gc-sections and keeps only
# what its exports reach (the codecs and src/shm files it shares with the daemon are mostly
# daemon code); the code itself is the same, so nothing else gets slower.
CFLAGS_ALL   := -std=c11 $(OPT) $(WARN) $(HARDEN) $(SANFLAGS) -fPIC -fvisibility=hidden \
                -ffunction-sections -fdata-sections \
                -MMD -MP $(YAML_CFLAGS) $(SYSTEMD_CFLAGS) $(MOSQ_CFLAGS) $(SQLITE_CFLAGS) \
                $(MHD_CFLAGS) $(DDS_CFLAGS) $(CFLAGS)
LDFLAGS_ALL  := $(SANFLAGS) -Wl,-z,relro,-z,now $(LDFLAGS)
LDFLAGS_EXE  := $(LDFLAGS_ALL) -pie
TEST_CFLAGS  := $(CMOCKA_CFLAGS) -Itests

# ---------------------------------------------------------------------------------------------
# Sources

PROTO_SRC  := $(wildcard src/proto/*.c)
SHM_SRC    := $(wildcard src/shm/*.c)
LIB_SRC    := $(wildcard src/lib/*.c)
# The library builds requests with the command vocabulary (which checks CIRCE and SharedLink
# arguments with the codecs' own rules) and parses replies with the control protocol; hidden
# symbols, so they are not exported.
LIB_PROTO_SRC := $(filter src/proto/control.c src/proto/request.c src/proto/circe.c \
                           src/proto/sharedlink.c,$(PROTO_SRC))
# The shared-memory files a client needs (reading and writing slots, events, futex waits, object
# names); the table, guard and wake files are the daemon's side only. The .so links with -z defs,
# so a file missing here fails the build rather than the first program that loads the library.
LIB_SHM_SRC := $(filter src/shm/changes.c src/shm/events.c src/shm/futex.c src/shm/layout.c src/shm/slot.c,$(SHM_SRC))
LIB_OBJ      = $(call obj,$(LIB_SRC) $(LIB_PROTO_SRC) $(LIB_SHM_SRC))
SVC_SRC    := $(wildcard src/svc/*.c)
DAEMON_MAIN:= $(wildcard src/daemon/main.c)
DAEMON_SRC := $(filter-out src/daemon/main.c,$(wildcard src/daemon/*.c))
CLI_SRC    := $(wildcard src/cli/*.c)
MQTT_MAIN  := $(wildcard src/mqtt/main.c)
MQTT_SRC   := $(filter-out src/mqtt/main.c,$(wildcard src/mqtt/*.c))
AGILITY_SRC:= $(wildcard src/agility/agility_*.c)
AGILITYD_MAIN := $(wildcard src/agility/main.c)
AGILITYD_SRC  := $(wildcard src/agility/agilityd_*.c)
ROS2_MAIN  := $(wildcard src/ros2/main.c)
ROS2_SRC   := $(filter-out src/ros2/main.c,$(wildcard src/ros2/*.c))
ROS2_IDL   := $(wildcard src/ros2/idl/*.idl)
TCOMMON_SRC:= $(wildcard tests/common/*.c)
UNIT_SRC   := $(wildcard tests/unit/test_*.c)
INTEG_SRC  := $(wildcard tests/integration/test_*.c)
STRESS_SRC := $(wildcard tests/stress/stress_*.c)
FUZZ_SRC   := $(wildcard tests/fuzz/fuzz_*.c)
BENCH_SRC  := $(wildcard tests/bench/bench_*.c)
EXAMPLE_SRC:= $(wildcard examples/*.c)
PYHELP_SRC := $(wildcard tests/python/*.c)
PY_SRC     := $(filter-out %/_paths.py,$(wildcard python/sharedlink/*.py))
# Test peers (scripts, no build): each test_*.py prints cmocka's summary lines.
PEER_TESTS := $(wildcard tests/peers/test_*.py tests/ros2peer/test_typehash.py)

obj = $(patsubst %.c,$(O)/obj/%.o,$(1))

A_PROTO  := $(O)/internal/libproto.a
A_SHM    := $(O)/internal/libshm.a
A_CLIENT := $(O)/internal/libclient.a
A_DAEMON := $(O)/internal/libdaemon.a
A_TCOMMON:= $(O)/internal/libtestcommon.a
A_CLI    := $(O)/internal/libcli.a
A_MQTT   := $(O)/internal/libmqtt.a
A_SVC    := $(O)/internal/libsvc.a
A_AGILITY:= $(O)/internal/libagility.a
A_AGILITYD := $(O)/internal/libagilityd.a
A_ROS2   := $(O)/internal/libros2.a
INTERNAL_ARCHIVES := $(A_TCOMMON) $(A_DAEMON) $(A_MQTT) $(A_ROS2) $(A_AGILITYD) $(A_AGILITY) $(A_CLIENT) \
                     $(A_CLI) $(A_SVC) $(A_PROTO) $(A_SHM)
SYS_LIBS := $(YAML_LIBS) $(SYSTEMD_LIBS) -lpthread -lutil -lm

LIBSL_SO   := $(O)/libsharedlink.so.$(SOVERSION)
LIBSL_A    := $(O)/libsharedlink.a
LIBSL_SYM  := src/lib/libsharedlink.sym
# The exported function names of libsharedlink.sym, one a line (sed -n).
LIBSL_SYM_SED := 's/^[[:space:]]*\(sl_[a-z0-9_]*\);$$/\1/p'
SHAREDLINKD:= $(O)/sharedlinkd
SLCTL      := $(O)/slctl
MQTT_BRIDGE:= $(O)/sharedlink-mqtt
AGILITYD   := $(O)/sharedlink-agility
ROS2_BRIDGE:= $(O)/sharedlink-ros2
PCFILE     := $(O)/sharedlink.pc

UNIT_BIN   := $(patsubst tests/%.c,$(O)/tests/%,$(UNIT_SRC))
INTEG_BIN  := $(patsubst tests/%.c,$(O)/tests/%,$(INTEG_SRC))
STRESS_BIN := $(patsubst tests/%.c,$(O)/tests/%,$(STRESS_SRC))
REPLAY_BIN := $(patsubst tests/fuzz/%.c,$(O)/tests/fuzz/%-replay,$(FUZZ_SRC))
EXAMPLE_BIN:= $(patsubst examples/%.c,$(O)/examples/%,$(EXAMPLE_SRC))
PYHELP_BIN := $(patsubst tests/%.c,$(O)/tests/%,$(PYHELP_SRC))

PROGRAMS := $(if $(DAEMON_MAIN),$(SHAREDLINKD)) $(if $(CLI_SRC),$(SLCTL)) \
            $(if $(LIB_SRC),$(LIBSL_SO) $(LIBSL_A) $(PCFILE)) $(if $(MQTT_MAIN),$(MQTT_BRIDGE)) \
            $(if $(AGILITYD_MAIN),$(AGILITYD)) $(if $(ROS2_MAIN),$(ROS2_BRIDGE))

# ---------------------------------------------------------------------------------------------
# Top-level targets

.PHONY: all check bench fuzz deps deps-extra clean help

all: $(PROGRAMS) $(INTERNAL_ARCHIVES)

help:
	@echo "make            build sharedlinkd, slctl, libsharedlink into build/"
	@echo "make check      ASan/UBSan build + every unit, fuzz-replay, stress and integration test"
	@echo "make bench      optimised benchmarks (prints figures and ratios)"
	@echo "make fuzz       libFuzzer (clang) on every target for FUZZ_TIME seconds (default 600)"
	@echo "make demo       run the no-hardware demo"
	@echo "make deps       install the build dependencies with apt-get (root) or print the command"
	@echo "make install    install into PREFIX (/usr/local) under DESTDIR; make uninstall removes it"

# Builds the asan variant of everything, the tsan variant of the stress tests and the optimised
# benchmarks (built, not run: see bench-build), then runs every test binary once, with one total
# at the end; tests/check-symbols.sh holds the asan and the optimised library to the exports of
# libsharedlink.sym.
# The Python tests drive the asan sharedlinkd and slctl, but load the optimised library: an ASan
# library in a Python that is not built with ASan needs libasan preloaded into the interpreter
# (and into everything it starts), which depends on the Python build; the binding's own memory
# contract is checked instead by the layout comparison (tests/python/layout.c) and by the size
# check every Client makes at open.
check:
	$(MAKE) --no-print-directory SAN=asan test-build
	$(if $(STRESS_SRC),$(MAKE) --no-print-directory SAN=tsan test-build-tsan)
	$(MAKE) --no-print-directory SAN= build/libsharedlink.so.$(SOVERSION) build/libsharedlink.a
	$(if $(BENCH_SRC),$(MAKE) --no-print-directory SAN= bench-build)
	$(if $(ROS2PEER_BINS),$(MAKE) --no-print-directory SAN= $(ROS2PEER_BINS))
	@TEST_TIMEOUT=$(TEST_TIMEOUT) SHAREDLINK_BUILD=build/asan PYTHON=$(PYTHON) \
	    SHAREDLINK_LIB=$(CURDIR)/build/libsharedlink.so.$(SOVERSION) \
	    SHAREDLINK_LAYOUT=$(CURDIR)/build/asan/tests/python/layout tests/run-tests.sh \
	    --unit "$(call variant_bins,build/asan,$(UNIT_SRC))" \
	    --replay "$(patsubst tests/fuzz/%.c,build/asan/tests/fuzz/%-replay,$(FUZZ_SRC))" \
	    --stress "$(call variant_bins,build/asan,$(STRESS_SRC))" \
	    --tsan "$(call variant_bins,build/tsan,$(STRESS_SRC))" \
	    --integration "$(call variant_bins,build/asan,$(INTEG_SRC))" \
	    --symbols tests/check-symbols.sh \
	    $(if $(PY_SRC),--python python/tests/run.py) \
	    --peers "$(PEER_TESTS)"

variant_bins = $(patsubst tests/%.c,$(1)/tests/%,$(2))

.PHONY: test-build test-build-tsan
test-build: all $(UNIT_BIN) $(REPLAY_BIN) $(STRESS_BIN) $(INTEG_BIN) $(EXAMPLE_BIN) $(PYHELP_BIN)
test-build-tsan: $(STRESS_BIN)

# The no-hardware demo (tests/demo.sh): the optimised build, one daemon on conf/demo.yaml.
demo: all
	@SHAREDLINK_BUILD=$(O) tests/demo.sh

deps:
	@if [ "$$(id -u)" = 0 ]; then \
	    echo "sharedlink: apt-get install $(DEB_PKGS)"; \
	    DEBIAN_FRONTEND=noninteractive apt-get update -qq && \
	    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $(DEB_PKGS); \
	else \
	    echo "sharedlink: not root; install the build dependencies with:"; \
	    echo "  sudo apt-get install -y $(DEB_PKGS)"; \
	    exit 1; \
	fi

# What `make fuzz` and `make bench` need beyond the build: clang with libFuzzer, redis-server.
deps-extra:
	@if [ "$$(id -u)" = 0 ]; then \
	    DEBIAN_FRONTEND=noninteractive apt-get update -qq && \
	    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $(DEB_PKGS_EXTRA); \
	else \
	    echo "sharedlink: not root; install with:"; \
	    echo "  sudo apt-get install -y $(DEB_PKGS_EXTRA)"; \
	    exit 1; \
	fi

clean:
	rm -rf build

# ---------------------------------------------------------------------------------------------
# Objects and archives

$(O)/obj/%.o: %.c
	@mkdir -p $(@D)
	$(call quiet,CC)$(CC) $(CPPFLAGS_ALL) $(CPPFLAGS) $(CFLAGS_ALL) $(if $(filter tests/% examples/%,$<),$(TEST_CFLAGS)) -c -o $@ $<

$(O)/internal/%.a:
	@mkdir -p $(@D)
	$(call quiet,AR)rm -f $@
	$(Q)$(AR) rcs $@ $^ $(if $^,,$(O)/obj/empty.o)

$(A_PROTO): $(call obj,$(PROTO_SRC))
$(A_SHM): $(call obj,$(SHM_SRC))
$(A_CLIENT): $(call obj,$(LIB_SRC))
$(A_DAEMON): $(call obj,$(DAEMON_SRC))
$(A_TCOMMON): $(call obj,$(TCOMMON_SRC))
# slctl's modules for unit tests (main.c holds main()).
$(A_CLI): $(call obj,$(filter-out src/cli/main.c,$(CLI_SRC)))
$(A_MQTT): $(call obj,$(MQTT_SRC))
$(A_SVC): $(call obj,$(SVC_SRC))
$(A_AGILITY): $(call obj,$(AGILITY_SRC))
$(A_AGILITYD): $(call obj,$(AGILITYD_SRC))
# sharedlink-ros2's types: idlc makes C of the IDL in the tree at build time (ros2_dds.c and
# ros2_bridge.c include its header); the tests' DDS peer has IDL of its own (tests/integration/
# ros2/), compiled the same way, so the bridge's types are checked against an independent copy.
ROS2_GEN_DIR := $(O)/gen/ros2
ROS2_GEN_C   := $(patsubst src/ros2/idl/%.idl,$(ROS2_GEN_DIR)/%.c,$(ROS2_IDL))
$(ROS2_GEN_DIR)/%.c $(ROS2_GEN_DIR)/%.h: src/ros2/idl/%.idl
	@mkdir -p $(@D)
	$(call quiet,IDLC)$(IDLC) -o $(@D) $<
# The types' object is linked into the program only, not archived: test_ros2 links its own
# copy of the same symbols, and the archive would otherwise resolve them first.
$(A_ROS2): $(call obj,$(ROS2_SRC))
$(call obj,$(ROS2_SRC) $(ROS2_MAIN)): CPPFLAGS += -I$(ROS2_GEN_DIR)
$(call obj,$(ROS2_SRC) $(ROS2_MAIN)): | $(ROS2_GEN_C)

# An archive with no members still needs one object to be a valid archive.
$(INTERNAL_ARCHIVES): | $(O)/obj/empty.o
$(O)/obj/empty.o:
	@mkdir -p $(@D)
	$(call quiet,CC)echo 'typedef int sharedlink_empty_unit;' | $(CC) -x c -c -o $@ -

LINK_INTERNAL = -Wl,--start-group $(INTERNAL_ARCHIVES) -Wl,--end-group $(SYS_LIBS)

# ---------------------------------------------------------------------------------------------
# Programs and the library

$(SHAREDLINKD): $(call obj,$(DAEMON_MAIN)) $(A_DAEMON) $(A_SVC) $(A_PROTO) $(A_SHM)
	$(call quiet,LD)$(CC) $(LDFLAGS_EXE) -o $@ $(filter %.o,$^) -Wl,--start-group $(A_DAEMON) $(A_SVC) \
	    $(A_PROTO) $(A_SHM) -Wl,--end-group $(SYS_LIBS)

$(LIBSL_SO): $(LIB_OBJ) $(LIBSL_SYM)
	$(call quiet,LD)$(CC) $(LDFLAGS_ALL) -shared -Wl,-soname,libsharedlink.so.$(SOVERSION) \
	    -Wl,--version-script=$(LIBSL_SYM) -Wl,--gc-sections -Wl,-z,defs -o $@ $(filter %.o,$^) \
	    -lpthread
	$(Q)ln -sf libsharedlink.so.$(SOVERSION) $(O)/libsharedlink.so

# The archive holds one relocatable object whose only globals are the exported functions: linked
# statically, the library's internal names (shm_*, circe_*, request_*, ...) would otherwise be
# globals of the program and collide with its own; -fvisibility=hidden hides them from the .so
# only. tests/check-symbols.sh (make check) holds both files to libsharedlink.sym.
LD      ?= ld
OBJCOPY ?= objcopy
LIBSL_EXPORTS := $(O)/libsharedlink.exports
LIBSL_A_OBJ   := $(O)/libsharedlink.o

$(LIBSL_EXPORTS): $(LIBSL_SYM)
	@mkdir -p $(@D)
	$(call quiet,GEN)sed -n $(LIBSL_SYM_SED) $< > $@

$(LIBSL_A_OBJ): $(LIB_OBJ) $(LIBSL_EXPORTS) Makefile
	$(call quiet,LD)$(LD) -r -o $@.tmp $(LIB_OBJ)
	$(Q)$(OBJCOPY) --keep-global-symbols=$(LIBSL_EXPORTS) $@.tmp $@ && rm -f $@.tmp

$(LIBSL_A): $(LIBSL_A_OBJ)
	$(call quiet,AR)rm -f $@
	$(Q)$(AR) rcs $@ $^

$(PCFILE): Makefile
	@mkdir -p $(@D)
	$(call quiet,GEN)printf '%s\n' 'prefix=$(PREFIX)' 'libdir=$(LIBDIR)' 'includedir=$(INCDIR)' '' \
	    'Name: sharedlink' 'Description: client library for sharedlinkd shared variables' \
	    'Version: $(VERSION)' 'Libs: -L$${libdir} -lsharedlink' 'Libs.private: -lpthread' \
	    'Cflags: -I$${includedir}' > $@

# pkg-config's convention for building against a tree that is not installed: with the build
# directory on PKG_CONFIG_PATH, `pkg-config sharedlink` picks sharedlink-uninstalled.pc. It names
# the build tree by absolute path, with an rpath so programs run without LD_LIBRARY_PATH.
PCFILE_UNINST := $(O)/sharedlink-uninstalled.pc
all: $(if $(LIB_SRC),$(PCFILE_UNINST))
$(PCFILE_UNINST): Makefile
	@mkdir -p $(@D)
	$(call quiet,GEN)printf '%s\n' 'libdir=$(abspath $(O))' 'includedir=$(abspath include)' '' \
	    'Name: sharedlink' 'Description: client library for sharedlinkd shared variables (build tree)' \
	    'Version: $(VERSION)' 'Libs: -L$${libdir} -Wl,-rpath,$${libdir} -lsharedlink' \
	    'Libs.private: -lpthread' 'Cflags: -I$${includedir}' > $@

# The toolkit (svc) is code, not data: slctl's data still comes only through the library.
$(SLCTL): $(call obj,$(CLI_SRC) src/proto/recording.c) $(LIBSL_A) $(A_SVC)
	$(call quiet,LD)$(CC) $(LDFLAGS_EXE) -o $@ $^ -lpthread

# The bridge links the shared library the installed way: only its exported (versioned) symbols
# resolve, which proves the public API is enough. RUNPATH $ORIGIN finds the library next to the
# binary in the build tree; installed, the system's library path finds it.
$(MQTT_BRIDGE): $(call obj,$(MQTT_MAIN)) $(A_MQTT) $(A_SVC) $(LIBSL_SO)
	$(call quiet,LD)$(CC) $(LDFLAGS_EXE) -o $@ $(filter %.o,$^) $(A_MQTT) $(A_SVC) -L$(O) -lsharedlink \
	    -Wl,-rpath,'$$ORIGIN' $(MOSQ_LIBS) $(YAML_LIBS) $(SYSTEMD_LIBS) -lpthread

# sharedlink-agility the same way: its data only through the public library.
$(AGILITYD): $(call obj,$(AGILITYD_MAIN)) $(A_AGILITYD) $(A_AGILITY) $(A_SVC) $(LIBSL_SO)
	$(call quiet,LD)$(CC) $(LDFLAGS_EXE) -o $@ $(filter %.o,$^) $(A_AGILITYD) $(A_AGILITY) $(A_SVC) \
	    -L$(O) -lsharedlink -Wl,-rpath,'$$ORIGIN' $(SQLITE_LIBS) $(MHD_LIBS) $(YAML_LIBS) \
	    $(SYSTEMD_LIBS) -lpthread

# sharedlink-ros2 the same way: its data only through the public library, DDS through libddsc.
$(ROS2_BRIDGE): $(call obj,$(ROS2_MAIN) $(ROS2_GEN_C)) $(A_ROS2) $(A_SVC) $(LIBSL_SO)
	$(call quiet,LD)$(CC) $(LDFLAGS_EXE) -o $@ $(filter %.o,$^) $(A_ROS2) $(A_SVC) \
	    -L$(O) -lsharedlink -Wl,-rpath,'$$ORIGIN' $(DDS_LIBS) $(YAML_LIBS) $(SYSTEMD_LIBS) -lpthread

# ---------------------------------------------------------------------------------------------
# Install (DESIGN.md §2.1): `make install PREFIX=/usr/local DESTDIR=`, and `make uninstall`.
# Paths come from the variables at the top; DESTDIR is prepended to each and recorded nowhere.
# Two kinds of files carry the configured paths: sharedlink.pc (rebuilt whenever PREFIX, LIBDIR or
# INCDIR differ from the last build's, through a stamp holding them) and the systemd units (the
# files in systemd/ name /usr/local/sbin and /etc; ExecStart= is rewritten here, and the install
# fails if it was not). The configuration is installed only where none exists yet.

.PHONY: install uninstall FORCE

INSTALL      ?= install
LDCONFIG     ?= ldconfig
MAN_PAGES    := $(wildcard man/*.[1-8])
mandir_of     = $(DESTDIR)$(MANDIR)/man$(subst .,,$(suffix $(1)))
# One alias page per exported function, so that `man sl_read` opens libsharedlink(3).
MAN_ALIASES   = $(shell sed -n $(LIBSL_SYM_SED) $(LIBSL_SYM))
UNIT_FILES   := $(wildcard systemd/*.service)
UNIT_SED     := -e 's@^ExecStart=/usr/local/sbin/\(sharedlinkd\|sharedlink-mqtt\|sharedlink-agility\|sharedlink-ros2\) @ExecStart=$(SBINDIR)/\1 @' \
                -e 's|^\(ExecStart=.* -c \)/etc/sharedlink/|\1$(SYSCONFDIR)/sharedlink/|'
TMPFILES_SED := -e 's|^d /etc/sharedlink |d $(SYSCONFDIR)/sharedlink |'
CONF_DEST    := $(DESTDIR)$(SYSCONFDIR)/sharedlink/sharedlinkd.yaml
MQTT_CONF_DEST := $(DESTDIR)$(SYSCONFDIR)/sharedlink/sharedlink-mqtt.yaml
AGILITY_CONF_DEST := $(DESTDIR)$(SYSCONFDIR)/sharedlink/sharedlink-agility.yaml
ROS2_CONF_DEST    := $(DESTDIR)$(SYSCONFDIR)/sharedlink/sharedlink-ros2.yaml
AGILITY_CSV_DEST  := $(DESTDIR)$(SYSCONFDIR)/sharedlink/agility-competitors.csv
PC_STAMP     := $(O)/install-paths

ifneq ($(filter install,$(MAKECMDGOALS)),)
ifneq ($(SAN),)
$(error make install installs the optimised build: run it without SAN=)
endif
endif

# Written only when the paths changed (a read-only build tree stays untouched), so the .pc
# file is remade only then.
$(PC_STAMP): FORCE
	@mkdir -p $(@D)
	@want=$$(printf '%s\n' '$(PREFIX)' '$(LIBDIR)' '$(INCDIR)'); \
	    [ "$$(cat $@ 2>/dev/null)" = "$$want" ] || printf '%s\n' "$$want" > $@
$(PCFILE): $(PC_STAMP)
FORCE:

install: all
	$(INSTALL) -d $(DESTDIR)$(SBINDIR) $(DESTDIR)$(BINDIR) $(DESTDIR)$(LIBDIR) \
	    $(DESTDIR)$(PKGCONFIGDIR) $(DESTDIR)$(INCDIR) $(DESTDIR)$(UNITDIR) \
	    $(DESTDIR)$(SYSUSERSDIR) $(DESTDIR)$(TMPFILESDIR) $(DESTDIR)$(SYSCONFDIR)/sharedlink \
	    $(sort $(foreach p,$(MAN_PAGES),$(call mandir_of,$(p))))
	$(INSTALL) -m 0755 $(SHAREDLINKD) $(DESTDIR)$(SBINDIR)/sharedlinkd
	$(if $(CLI_SRC),$(INSTALL) -m 0755 $(SLCTL) $(DESTDIR)$(BINDIR)/slctl)
	$(if $(MQTT_MAIN),$(INSTALL) -m 0755 $(MQTT_BRIDGE) $(DESTDIR)$(SBINDIR)/sharedlink-mqtt)
	$(if $(AGILITYD_MAIN),$(INSTALL) -m 0755 $(AGILITYD) $(DESTDIR)$(SBINDIR)/sharedlink-agility)
	$(if $(ROS2_MAIN),$(INSTALL) -m 0755 $(ROS2_BRIDGE) $(DESTDIR)$(SBINDIR)/sharedlink-ros2)
	$(INSTALL) -m 0755 $(LIBSL_SO) $(DESTDIR)$(LIBDIR)/libsharedlink.so.$(SOVERSION)
	ln -sf libsharedlink.so.$(SOVERSION) $(DESTDIR)$(LIBDIR)/libsharedlink.so
	$(INSTALL) -m 0644 $(LIBSL_A) $(DESTDIR)$(LIBDIR)/libsharedlink.a
	$(INSTALL) -m 0644 $(PCFILE) $(DESTDIR)$(PKGCONFIGDIR)/sharedlink.pc
	$(INSTALL) -m 0644 include/sharedlink.h $(DESTDIR)$(INCDIR)/sharedlink.h
	$(foreach p,$(MAN_PAGES),$(INSTALL) -m 0644 $(p) $(call mandir_of,$(p))/$(notdir $(p)) &&) true
	@for f in $(MAN_ALIASES); do \
	    echo '.so man3/libsharedlink.3' > $(DESTDIR)$(MANDIR)/man3/$$f.3 || exit 1; \
	done; echo "man3: an alias of libsharedlink.3 for each of $(words $(MAN_ALIASES)) functions"
	@set -e; for u in $(UNIT_FILES); do \
	    d=$(DESTDIR)$(UNITDIR)/$${u##*/}; \
	    sed $(UNIT_SED) $$u > $$d.tmp; \
	    if ! grep -qF 'ExecStart=$(SBINDIR)/sharedlinkd ' $$d.tmp && \
	       ! grep -qF 'ExecStart=$(SBINDIR)/sharedlink-mqtt ' $$d.tmp && \
	       ! grep -qF 'ExecStart=$(SBINDIR)/sharedlink-agility ' $$d.tmp && \
	       ! grep -qF 'ExecStart=$(SBINDIR)/sharedlink-ros2 ' $$d.tmp; then \
	        echo "make install: $$u: ExecStart= does not name /usr/local/sbin/sharedlinkd," \
	             "sharedlink-mqtt, sharedlink-agility or sharedlink-ros2" >&2; \
	        rm -f $$d.tmp; exit 1; \
	    fi; \
	    chmod 0644 $$d.tmp; mv -f $$d.tmp $$d; echo "$$d: $$(grep '^ExecStart=' $$d)"; \
	done
	$(INSTALL) -m 0644 systemd/sharedlink.sysusers $(DESTDIR)$(SYSUSERSDIR)/sharedlink.conf
	$(INSTALL) -d $(DESTDIR)$(BASHCOMPDIR)
	$(INSTALL) -m 0644 completion/slctl.bash $(DESTDIR)$(BASHCOMPDIR)/slctl
	@# The package records where the library went, so it loads with no LD_LIBRARY_PATH.
	@if [ -z '$(PYTHONDIR)' ]; then \
	    echo "python: no $(PYTHON): the sharedlink package is not installed (set PYTHONDIR)"; \
	else set -e; d='$(DESTDIR)$(PYTHONDIR)/sharedlink'; \
	    $(INSTALL) -d "$$d"; $(INSTALL) -m 0644 $(PY_SRC) "$$d/"; \
	    printf '%s\n' '# Written by make install: where it put the library (after $$SHAREDLINK_LIB, tried first).' \
	        'LIBRARY = "$(LIBDIR)/libsharedlink.so.$(SOVERSION)"' > "$$d/_paths.py"; \
	    chmod 0644 "$$d/_paths.py"; \
	    echo "$$d: the Python package (loads $(LIBDIR)/libsharedlink.so.$(SOVERSION))"; \
	fi
	sed $(TMPFILES_SED) systemd/sharedlink.tmpfiles > $(DESTDIR)$(TMPFILESDIR)/sharedlink.conf
	chmod 0644 $(DESTDIR)$(TMPFILESDIR)/sharedlink.conf
	@if [ -e $(CONF_DEST) ]; then echo "$(CONF_DEST): exists, kept"; \
	else $(INSTALL) -m 0644 conf/sharedlinkd.yaml $(CONF_DEST) && echo "$(CONF_DEST): installed"; fi
	@if [ -e $(MQTT_CONF_DEST) ]; then echo "$(MQTT_CONF_DEST): exists, kept"; \
	else $(INSTALL) -m 0640 conf/sharedlink-mqtt.yaml $(MQTT_CONF_DEST) && \
	    echo "$(MQTT_CONF_DEST): installed"; fi
	@for f in sharedlink-agility.yaml:$(AGILITY_CONF_DEST) agility-competitors.csv:$(AGILITY_CSV_DEST) \
	    sharedlink-ros2.yaml:$(ROS2_CONF_DEST); do \
	    d=$${f#*:}; if [ -e $$d ]; then echo "$$d: exists, kept"; \
	    else $(INSTALL) -m 0644 conf/$${f%%:*} $$d && echo "$$d: installed"; fi; done
	@# A library installed straight into the system is found by the loader only after this.
	@if [ -z "$(DESTDIR)" ] && [ "$$(id -u)" = 0 ] && command -v $(LDCONFIG) >/dev/null; then \
	    echo $(LDCONFIG); $(LDCONFIG); fi

# Removes what install put there; the configuration only when it is still the one shipped.
uninstall:
	rm -f $(DESTDIR)$(SBINDIR)/sharedlinkd $(DESTDIR)$(BINDIR)/slctl \
	    $(DESTDIR)$(SBINDIR)/sharedlink-mqtt $(DESTDIR)$(SBINDIR)/sharedlink-agility \
	    $(DESTDIR)$(SBINDIR)/sharedlink-ros2 \
	    $(DESTDIR)$(LIBDIR)/libsharedlink.so.$(SOVERSION) $(DESTDIR)$(LIBDIR)/libsharedlink.so \
	    $(DESTDIR)$(LIBDIR)/libsharedlink.a $(DESTDIR)$(PKGCONFIGDIR)/sharedlink.pc \
	    $(DESTDIR)$(INCDIR)/sharedlink.h \
	    $(addprefix $(DESTDIR)$(UNITDIR)/,$(notdir $(UNIT_FILES))) \
	    $(DESTDIR)$(SYSUSERSDIR)/sharedlink.conf $(DESTDIR)$(TMPFILESDIR)/sharedlink.conf \
	    $(foreach p,$(MAN_PAGES),$(call mandir_of,$(p))/$(notdir $(p))) \
	    $(foreach f,$(MAN_ALIASES),$(DESTDIR)$(MANDIR)/man3/$(f).3) \
	    $(DESTDIR)$(BASHCOMPDIR)/slctl
	@if [ -n '$(PYTHONDIR)' ]; then d='$(DESTDIR)$(PYTHONDIR)/sharedlink'; \
	    rm -f $(addprefix "$$d"/,$(notdir $(PY_SRC)) _paths.py); rm -rf "$$d/__pycache__"; \
	    [ ! -d "$$d" ] || rmdir "$$d"; fi
	@for f in sharedlink-agility.yaml:$(AGILITY_CONF_DEST) agility-competitors.csv:$(AGILITY_CSV_DEST) \
	    sharedlink-ros2.yaml:$(ROS2_CONF_DEST); do \
	    d=$${f#*:}; if cmp -s conf/$${f%%:*} $$d; then rm -f $$d; \
	    elif [ -e $$d ]; then echo "$$d: changed since install, kept"; fi; done
	@if cmp -s conf/sharedlink-mqtt.yaml $(MQTT_CONF_DEST); then rm -f $(MQTT_CONF_DEST); \
	elif [ -e $(MQTT_CONF_DEST) ]; then echo "$(MQTT_CONF_DEST): changed since install, kept"; fi
	@if cmp -s conf/sharedlinkd.yaml $(CONF_DEST); then rm -f $(CONF_DEST); \
	    rmdir $(DESTDIR)$(SYSCONFDIR)/sharedlink 2>/dev/null || true; \
	elif [ -e $(CONF_DEST) ]; then echo "$(CONF_DEST): changed since install, kept"; fi

# ---------------------------------------------------------------------------------------------
# Tests

# Tests that speak MQTT themselves (tests/common/mqtt.c) also link libmosquitto.
MQTT_TESTS := $(O)/tests/integration/test_mqtt $(O)/bench/bench_mqtt
$(MQTT_TESTS): EXTRA_LIBS := $(MOSQ_LIBS)
# The integration test runs the bridge under test.
$(O)/tests/integration/test_mqtt: | $(MQTT_BRIDGE)
# sharedlink-agility's tests read its database themselves; the integration test runs it.
AGILITYD_TESTS := $(O)/tests/integration/test_agility $(patsubst tests/%.c,$(O)/tests/%,\
                  $(wildcard tests/unit/test_agilityd_*.c))
$(AGILITYD_TESTS): EXTRA_LIBS := $(SQLITE_LIBS) $(MHD_LIBS)
$(O)/tests/integration/test_agility: | $(AGILITYD)
# test_ros2 is a DDS peer with its own copy of the types (tests/integration/ros2/*.idl through
# idlc) and runs the bridge under test.
ROS2_TEST_IDL   := $(wildcard tests/integration/ros2/*.idl)
ROS2_TEST_GEN   := $(patsubst tests/integration/ros2/%.idl,$(O)/gen/tests/ros2/%.c,$(ROS2_TEST_IDL))
ROS2_TEST_OBJ   := $(patsubst %.c,$(O)/obj/%.o,$(ROS2_TEST_GEN))
$(O)/gen/tests/ros2/%.c $(O)/gen/tests/ros2/%.h: tests/integration/ros2/%.idl
	@mkdir -p $(@D)
	$(call quiet,IDLC)$(IDLC) -t -o $(@D) $<
# The test reads serialized samples (dds/ddsi/ddsi_serdata.h), whose inline atomics spell the
# GNU keyword asm, which -std=c11 does not have.
$(O)/obj/tests/integration/test_ros2.o: CPPFLAGS += -I$(O)/gen/tests/ros2 -Dasm=__asm__
$(O)/obj/tests/integration/test_ros2.o: | $(ROS2_TEST_GEN)
$(O)/tests/integration/test_ros2: $(ROS2_TEST_OBJ)
$(O)/tests/integration/test_ros2: EXTRA_LIBS := $(ROS2_TEST_OBJ) $(DDS_LIBS)
$(O)/tests/integration/test_ros2: | $(ROS2_BRIDGE)

# The ROS 2 type hashes (src/ros2/ros2_typehash.c) need nothing of DDS: their unit test links them
# from an archive of their own, which adds nothing where another archive has them already
# (tests/ros2peer/test_typehash.py recomputes the values themselves).
ROS2_TYPEHASH_A := $(O)/internal/libros2typehash.a
$(ROS2_TYPEHASH_A): $(call obj,src/ros2/ros2_typehash.c)
$(O)/tests/unit/test_ros2_typehash: $(ROS2_TYPEHASH_A)
$(O)/tests/unit/test_ros2_typehash: EXTRA_LIBS := $(ROS2_TYPEHASH_A)

# The ROS 2 test peers (tests/ros2peer/README.md): peer_cyclone (C, Cyclone DDS, types compiled by
# idlc from their own IDL) and peer_fastdds (C++, Fast DDS 2.9 and Fast CDR, which ship no .pc:
# found by their header), each built only where its library is; `make check` builds them
# optimised into build/tests/ros2peer/ and runs their self-test when both are there.
ROS2PEER_CYCLONE := $(if $(shell pkg-config --exists CycloneDDS 2>/dev/null && \
                      command -v idlc >/dev/null && echo y),build/tests/ros2peer/peer_cyclone)
ROS2PEER_FASTDDS := $(if $(shell printf '\043if !__has_include(<fastdds/dds/domain/DomainParticipant.hpp>)\n\043error\n\043endif\n' | \
                      $(CXX) -x c++ -fsyntax-only - 2>/dev/null && echo y),build/tests/ros2peer/peer_fastdds)
ROS2PEER_BINS    := $(ROS2PEER_CYCLONE) $(ROS2PEER_FASTDDS)
PEER_TESTS       += $(if $(and $(ROS2PEER_CYCLONE),$(ROS2PEER_FASTDDS)),tests/ros2peer/test_peers.py)
# make demo's ROS 2 step speaks to sharedlink-ros2 through the Cyclone peer.
demo: $(ROS2PEER_CYCLONE)
ROS2PEER_GEN     := $(O)/gen/ros2peer
ROS2PEER_COMMON  := $(call obj,tests/ros2peer/peer_common.c src/ros2/ros2_typehash.c)
CYCLONE_LIBS     := $(shell pkg-config --libs CycloneDDS 2>/dev/null)
FASTDDS_LIBS     := -lfastrtps -lfastcdr

$(ROS2PEER_GEN)/ros2peer_types.c: tests/ros2peer/ros2peer_types.idl
	@mkdir -p $(@D)
	$(call quiet,IDLC)idlc -t -o $(@D) $<
$(ROS2PEER_GEN)/ros2peer_types.h: $(ROS2PEER_GEN)/ros2peer_types.c
$(ROS2PEER_GEN)/ros2peer_types.o: $(ROS2PEER_GEN)/ros2peer_types.c
	$(call quiet,CC)$(CC) -std=gnu11 $(OPT) $(SANFLAGS) -fPIC -c -o $@ $<
# Cyclone's serdata headers use GNU C (asm), hence gnu11 for the one file that includes them
# (TEST_CFLAGS comes last on the compile line).
$(O)/obj/tests/ros2peer/peer_cyclone.o: TEST_CFLAGS += -std=gnu11 -I$(ROS2PEER_GEN)
$(O)/obj/tests/ros2peer/peer_cyclone.o: $(ROS2PEER_GEN)/ros2peer_types.h
$(O)/tests/ros2peer/peer_cyclone: $(O)/obj/tests/ros2peer/peer_cyclone.o \
                                  $(ROS2PEER_GEN)/ros2peer_types.o $(ROS2PEER_COMMON) $(A_SVC)
	@mkdir -p $(@D)
	$(call quiet,LD)$(CC) $(LDFLAGS_EXE) -o $@ $^ $(CYCLONE_LIBS)
# bench_ros2 subscribes with the peers' copy of the types; without Cyclone it only says so.
$(O)/obj/tests/bench/bench_ros2.o: TEST_CFLAGS += -I$(ROS2PEER_GEN) \
                                   -DHAVE_CYCLONEDDS=$(if $(ROS2PEER_CYCLONE),1,0)
$(O)/obj/tests/bench/bench_ros2.o: $(if $(ROS2PEER_CYCLONE),$(ROS2PEER_GEN)/ros2peer_types.h)
$(O)/bench/bench_ros2: $(if $(ROS2PEER_CYCLONE),$(ROS2PEER_GEN)/ros2peer_types.o)
$(O)/bench/bench_ros2: EXTRA_LIBS := $(if $(ROS2PEER_CYCLONE),$(ROS2PEER_GEN)/ros2peer_types.o \
                                     $(CYCLONE_LIBS))
$(O)/tests/ros2peer/peer_fastdds: tests/ros2peer/peer_fastdds.cpp tests/ros2peer/peer_common.h \
                                  $(ROS2PEER_COMMON) $(A_SVC)
	@mkdir -p $(@D)
	$(call quiet,CXX)$(CXX) -std=c++17 $(OPT) -Wall -Wextra -Wshadow $(if $(filter 1,$(WERROR)),-Werror) \
	    $(HARDEN) $(SANFLAGS) -fPIE -Isrc -o $@ $< $(ROS2PEER_COMMON) $(A_SVC) $(LDFLAGS_EXE) $(FASTDDS_LIBS)

$(O)/tests/%: $(O)/obj/tests/%.o $(INTERNAL_ARCHIVES)
	@mkdir -p $(@D)
	$(call quiet,LD)$(CC) $(LDFLAGS_EXE) -o $@ $< $(LINK_INTERNAL) $(CMOCKA_LIBS) $(EXTRA_LIBS)

# Fuzz targets replayed over their saved corpus with the test compiler.
$(O)/tests/fuzz/%-replay: $(O)/obj/tests/fuzz/%.o $(O)/obj/tests/fuzz/replay_main.o $(INTERNAL_ARCHIVES)
	@mkdir -p $(@D)
	$(call quiet,LD)$(CC) $(LDFLAGS_EXE) -o $@ $< $(O)/obj/tests/fuzz/replay_main.o $(LINK_INTERNAL)

# Examples link the installed way: the public header and libsharedlink only.
$(O)/examples/%: examples/%.c $(LIBSL_A)
	@mkdir -p $(@D)
	$(call quiet,LD)$(CC) -std=c11 $(OPT) $(WARN) $(SANFLAGS) -Iinclude -o $@ $< $(LIBSL_A) -lpthread

# ---------------------------------------------------------------------------------------------
# libFuzzer (clang) and benchmarks (optimised, no sanitizers)

FUZZ_CC    ?= clang
FUZZ_O     := build/fuzz
# svc/waker.c waits through the client library (sl_wait_with), which the daemon's targets leave out.
FUZZ_LIBSRC:= $(PROTO_SRC) $(SHM_SRC) $(filter-out src/svc/waker.c,$(SVC_SRC)) $(DAEMON_SRC) \
	$(AGILITY_SRC)
# The MQTT targets (fuzz_mqtt_*) run the bridge's logic on the client library and real tables
# (tests/common/shmtest.c); libmosquitto's side and main() stay out.
FUZZ_MQTT_LIBSRC := $(PROTO_SRC) $(SHM_SRC) $(SVC_SRC) $(LIB_SRC) tests/common/shmtest.c \
	$(filter-out src/mqtt/bridge_mqtt.c,$(MQTT_SRC))
FUZZ_NAMES := $(patsubst tests/fuzz/fuzz_%.c,%,$(FUZZ_SRC))

fuzz:
	@command -v $(FUZZ_CC) >/dev/null || { echo "make fuzz needs clang: make deps-extra"; exit 1; }
	@mkdir -p $(FUZZ_O)
	@set -e; for n in $(FUZZ_NAMES); do \
	    case $$n in mqtt_*) src='$(FUZZ_MQTT_LIBSRC)' ;; *) src='$(FUZZ_LIBSRC)' ;; esac; \
	    $(FUZZ_CC) -std=c11 -g -O1 -Iinclude -Isrc -Itests -D_DEFAULT_SOURCE $(YAML_CFLAGS) $(SYSTEMD_CFLAGS) \
	        -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
	        -o $(FUZZ_O)/fuzz_$$n tests/fuzz/fuzz_$$n.c $$src $(YAML_LIBS) $(SYSTEMD_LIBS) -lpthread -lm; \
	done
	@set -e; for n in $(FUZZ_NAMES); do \
	    mkdir -p $(FUZZ_O)/corpus-$$n; \
	    echo "== fuzz_$$n for $(FUZZ_TIME) s"; \
	    $(FUZZ_O)/fuzz_$$n -max_total_time=$(FUZZ_TIME) -print_final_stats=1 \
	        $(FUZZ_O)/corpus-$$n tests/fuzz/corpus/$$n 2>&1 | tail -n 12; \
	done

bench:
	$(MAKE) --no-print-directory SAN= bench-run

.PHONY: bench-run
BENCH_BIN := $(patsubst tests/bench/%.c,$(O)/bench/%,$(BENCH_SRC))
$(O)/bench/%: $(O)/obj/tests/bench/%.o $(INTERNAL_ARCHIVES)
	@mkdir -p $(@D)
	$(call quiet,LD)$(CC) $(LDFLAGS_EXE) -o $@ $< $(LINK_INTERNAL) $(EXTRA_LIBS)

# The Python read next to the C one (tests/bench/python_read.py): its C side goes through the
# shared library, as the binding does.
PYBENCH       := $(wildcard tests/bench/python_read.py)
PYBENCH_C     := $(O)/bench/read_loop
$(PYBENCH_C): tests/bench/read_loop.c $(LIBSL_SO)
	@mkdir -p $(@D)
	$(call quiet,LD)$(CC) -std=c11 -D_DEFAULT_SOURCE $(OPT) $(WARN) -Iinclude -o $@ $< $(LIBSL_SO) \
	    -Wl,-rpath,$(CURDIR)/$(O)

# `make check` builds (does not run) every benchmark the way `make bench` does, so a change that
# breaks one fails the check instead of the next `make bench`.
.PHONY: bench-build
bench-build: $(BENCH_BIN) $(if $(PYBENCH),$(PYBENCH_C))

# Every benchmark, the Python read next to the C one, then sl_read from a program built against
# a temporary `make install` (tests/bench/bench_install.sh), then one table of every figure next
# to its goal.
BENCH_LOG := $(O)/bench/bench.log
bench-run: all bench-build
	@set -eo pipefail; : > $(BENCH_LOG); \
	    for b in $(BENCH_BIN); do echo "== $$b"; SHAREDLINK_BUILD=$(O) $$b | tee -a $(BENCH_LOG); done; \
	    $(if $(PYBENCH),echo "== $(PYBENCH)"; SHAREDLINK_BUILD=$(O) \
	    SHAREDLINK_LIB=$(CURDIR)/$(LIBSL_SO) $(PYTHON) $(PYBENCH) | tee -a $(BENCH_LOG);) \
	    echo "== tests/bench/bench_install.sh"; \
	    MAKE="$(MAKE)" CC="$(CC)" tests/bench/bench_install.sh $(O) | tee -a $(BENCH_LOG); \
	    tests/bench/summary.sh $(BENCH_LOG)

-include $(shell find build -name '*.d' 2>/dev/null)
