#!/bin/bash
# sl_read as a user measures it (make bench): install into a temporary prefix, build
# examples/read_latency.c with pkg-config against the installed shared library and once against
# the installed libsharedlink.a, and once against the build tree through
# build/sharedlink-uninstalled.pc; run them against the installed daemon on one pty link (2
# outbound, 2 inbound variables), with one value of each direction set.
#
#   tests/bench/bench_install.sh BUILD_DIR     (MAKE, CC from the environment)
#
# Prints the read_latency tables and FIGURE lines for tests/bench/summary.sh.
set -euo pipefail

build=${1:?usage: bench_install.sh BUILD_DIR}
make=${MAKE:-make}
cc=${CC:-cc}
start_s=10
instance=bench-install-$$
tmp=$(mktemp -d /tmp/sl-bench-install.XXXXXX)
pid=

cleanup() {
        if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then
                kill -TERM "$pid"
                wait "$pid" 2>/dev/null || true
        fi
        rm -rf "$tmp"
}
trap cleanup EXIT

prefix=$tmp/usr
$make --no-print-directory install PREFIX="$prefix" SYSCONFDIR="$tmp/etc" LDCONFIG=true \
        >"$tmp/install.log" 2>&1 || { cat "$tmp/install.log" >&2; exit 1; }
export PKG_CONFIG_PATH=$prefix/lib/pkgconfig
libdir=$(pkg-config --variable=libdir sharedlink)
# The ordinary way: the shared library (found at run time through the rpath).
$cc -O2 -o "$tmp/read_latency" examples/read_latency.c \
        $(pkg-config --cflags --libs sharedlink) -Wl,-rpath,"$libdir"
# The static archive: the .a named explicitly (the linker prefers the .so given -l), with the
# private libraries pkg-config --static adds.
$cc -O2 -o "$tmp/read_latency_static" examples/read_latency.c \
        $(pkg-config --cflags sharedlink) "$libdir/libsharedlink.a" \
        $(pkg-config --static --libs-only-l sharedlink | sed 's/-lsharedlink//')
# The build tree, without installing: sharedlink-uninstalled.pc (pkg-config picks NAME-uninstalled
# when it is on the path).
PKG_CONFIG_PATH=$build $cc -O2 -o "$tmp/read_latency_uninstalled" examples/read_latency.c \
        $(PKG_CONFIG_PATH=$build pkg-config --cflags --libs sharedlink)

cat >"$tmp/bench.yaml" <<EOF
instance: $instance
runtime_dir: $tmp/run
links:
  - name: p
    protocol: sharedlink
    transport: pty
    device: $tmp/run/p.tty
    address: B
    peers:
      - address: A
        period_ms: 100
        on_change: true
        outbound: [Out0, Out1]
        inbound: [In0, In1]
EOF
"$prefix/sbin/sharedlinkd" -c "$tmp/bench.yaml" 2>"$tmp/daemon.log" &
pid=$!
slctl=$prefix/bin/slctl
for ((i = 0; i < start_s * 10; i++)); do
        [ -e "$tmp/run/p.tty" ] && "$slctl" -i "$instance" get Out0 >/dev/null 2>&1 && break
        sleep 0.1
done
value=40.12345678901234567890123456789
"$slctl" -i "$instance" set Out0 "$value"
# An inbound frame for In0 and In1 from node A: [:BA|N0|Dv|Dv|Chh] with the checksum of the bytes
# from ':' up to and including 'C'.
body=":BA|N0|D$value|D$value|C"
sum=0
for ((i = 0; i < ${#body}; i++)); do
        printf -v ch '%d' "'${body:i:1}"
        sum=$((sum + ch))
done
printf '[%s%02X]\r\n' "$body" $((sum & 255)) >"$tmp/run/p.tty"
for ((i = 0; i < start_s * 10; i++)); do
        [ "$("$slctl" -i "$instance" get In0 2>/dev/null)" = "$value" ] && break
        sleep 0.1
done
[ "$("$slctl" -i "$instance" get In0)" = "$value" ] || {
        echo "bench_install: the inbound frame did not arrive" >&2
        cat "$tmp/daemon.log" >&2
        exit 1
}

# FIGURE|key|label|value|unit|goal from a read_latency table: the median of the rounds.
figures() {
        awk -v tag="$1" '
                / with metadata / && $1 == "In0," { printf "FIGURE|read_%s_meta_in|sl_read + meta, inbound (%s)|%s|ns|<=25\n", tag, tag, $(NF) }
                / without metadata / && $1 == "In0," { printf "FIGURE|read_%s_in|sl_read, inbound (%s)|%s|ns|<=15\n", tag, tag, $(NF) }
                / with metadata / && $1 == "Out0," { printf "FIGURE|read_%s_meta_out|sl_read + meta, outbound (%s)|%s|ns|<=25\n", tag, tag, $(NF) }
                / without metadata / && $1 == "Out0," { printf "FIGURE|read_%s_out|sl_read, outbound (%s)|%s|ns|<=15\n", tag, tag, $(NF) }'
}

echo "read_latency against the installed library ($prefix), daemon pid $pid:"
"$tmp/read_latency" -i "$instance" In0 Out0 | tee "$tmp/shared.txt"
figures installed-so <"$tmp/shared.txt"
echo "read_latency linked against the installed libsharedlink.a:"
"$tmp/read_latency_static" -i "$instance" In0 Out0 | tee "$tmp/static.txt"
figures installed-a <"$tmp/static.txt"
echo "read_latency built against the build tree (sharedlink-uninstalled.pc), one round:"
"$tmp/read_latency_uninstalled" -i "$instance" -r 1 In0
