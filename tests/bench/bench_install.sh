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
# Each program is started LAUNCHES times, alternating with the other: one launch is a draw of
# where the kernel put its stack (ASLR) and of what the machine did meanwhile (this VM's host
# halves its memory pipeline for seconds at a time, and whole launches then run 1.6-1.9x slower,
# every case at once: bench_shm's section 4 shows it with a pace probe beside the reads). The
# figure is the median over the launches of each launch's median, and the slowest launch is
# printed next to it; bench_shm's section 4 also scans the stack's place with ASLR off.
LAUNCHES=20

# Reads read_latency's table on stdin: "NAME median" for the four rows.
medians() {
        awk '$1 == "In0," && / with metadata / { print "meta_in", $(NF) }
             $1 == "In0," && / without metadata / { print "in", $(NF) }
             $1 == "Out0," && / with metadata / { print "meta_out", $(NF) }
             $1 == "Out0," && / without metadata / { print "out", $(NF) }'
}

# figures TAG: the figures (median over launches) and the slowest launch, from $tmp/TAG.all.
figures() {
        local tag=$1
        awk -v tag="$tag" '
                { v[$1] = v[$1] " " $2 }
                END {
                        split("meta_in in meta_out out", keys, " ")
                        for (i = 1; i <= 4; i++) {
                                k = keys[i]; n = split(substr(v[k], 2), a, " ")
                                for (x = 1; x <= n; x++) for (y = x + 1; y <= n; y++)
                                        if (a[y] + 0 < a[x] + 0) { t = a[x]; a[x] = a[y]; a[y] = t }
                                meta = k ~ /^meta/; dir = k ~ /in$/ ? "inbound" : "outbound"
                                what = "sl_read" (meta ? " + meta" : "") ", " dir " (" tag ")"
                                printf "FIGURE|read_%s_%s|%s|%s|ns|%s\n", tag, k, what,
                                       a[int((n + 1) / 2)], meta ? "<=25" : "<=15"
                                printf "FIGURE|read_%s_%s_worst|%s, slowest of %d launches|%s|ns|-\n",
                                       tag, k, what, n, a[n]
                        }
                }' "$tmp/$tag.all"
}

# launches TAG PROGRAM TAG PROGRAM: runs the two LAUNCHES times each, alternating (other work on
# the machine comes and goes: one program's launches all in a row would meet other conditions
# than the other's), then prints for each its first table, one line per launch, and the figures.
launches() {
        local tags=("$1" "$3") progs=("$2" "$4") k i tag
        for tag in "${tags[@]}"; do
                : >"$tmp/$tag.all"
        done
        for ((k = 1; k <= LAUNCHES; k++)); do
                for i in 0 1; do
                        tag=${tags[i]}
                        "${progs[i]}" -i "$instance" In0 Out0 >"$tmp/$tag.$k"
                        medians <"$tmp/$tag.$k" >>"$tmp/$tag.all"
                done
        done
        for i in 0 1; do
                tag=${tags[i]}
                echo "read_latency ${what[i]}, $LAUNCHES launches, alternating with the other:"
                cat "$tmp/$tag.1"
                for ((k = 1; k <= LAUNCHES; k++)); do
                        printf '  launch %d: %s\n' "$k" \
                                "$(medians <"$tmp/$tag.$k" | awk '{ printf "%s %s ns  ", $1, $2 }')"
                done
                figures "$tag"
        done
}

echo "read_latency against the installed library ($prefix), daemon pid $pid"
what=("against the installed libsharedlink.so" "linked against the installed libsharedlink.a")
launches installed-so "$tmp/read_latency" installed-a "$tmp/read_latency_static"
echo "read_latency built against the build tree (sharedlink-uninstalled.pc), one round:"
"$tmp/read_latency_uninstalled" -i "$instance" -r 1 In0
