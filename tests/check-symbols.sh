#!/usr/bin/env bash
# The library exports exactly what src/lib/libsharedlink.sym lists, from both of its files
# (make check):
#   - the .so's dynamic symbols: the sl_* functions of the version script, and its version nodes;
#   - the .a's global symbols: the same functions, nothing else (the archive is one relocatable
#     object whose other symbols were made local, Makefile), so a program linked statically may
#     have its own shm_open_table or request_send;
#   - and that program links and runs: one that defines every internal function name of the
#     archive as its own (each would end the program if the library called it) uses sl_open and
#     sl_strerror. With the internal names global it fails to link, or the library calls the
#     program's functions in place of its own.
#
#   tests/check-symbols.sh [BUILD_DIR...]   (default: $SHAREDLINK_BUILD and build; CC from the
#                                            environment, the program only for an unsanitized build)
# Prints one line per check and cmocka's summary lines, which tests/run-tests.sh counts.
set -u
here=$(cd "$(dirname "$0")/.." && pwd)
sym=$here/src/lib/libsharedlink.sym
cc=${CC:-cc}
passed=0 failed=0
tmp=$(mktemp -d /tmp/sl-symbols.XXXXXX)
trap 'rm -rf "$tmp"' EXIT

if [ $# -eq 0 ]; then
    set -- $(printf '%s\n' "${SHAREDLINK_BUILD:-build}" build | awk '!seen[$0]++')
fi

# The functions the version script exports, and its version nodes.
sed -n 's/^[[:space:]]*\(sl_[a-z0-9_]*\);$/\1/p' "$sym" | sort -u >"$tmp/exports"
sed -n 's/^\([A-Z][A-Z0-9_.]*\)[[:space:]]*{.*$/\1/p' "$sym" | sort -u >"$tmp/nodes"
if [ ! -s "$tmp/exports" ] || [ ! -s "$tmp/nodes" ]; then
    echo "check-symbols: no exports or version nodes found in $sym" >&2
    exit 1
fi

result() {  # name status detail-file
    if [ "$2" = 0 ]; then
        passed=$((passed + 1)); echo "ok    $1"
    else
        failed=$((failed + 1)); echo "FAIL  $1"; sed 's/^/      | /' "$3" | head -n 40
    fi
}

# Compares a list of defined global names against the allowed ones; 0 when they are the same.
compare() {  # names allowed out
    local extra missing
    extra=$(comm -23 "$1" "$2")
    missing=$(comm -13 "$1" "$2")
    : >"$3"
    [ -z "$extra" ] || printf 'not in libsharedlink.sym: %s\n' $extra >>"$3"
    [ -z "$missing" ] || printf 'listed but not defined: %s\n' $missing >>"$3"
    [ -z "$extra" ] && [ -z "$missing" ]
}

# A program that defines every internal function name of the archive (a) and uses the library.
collision_program() {  # archive out-dir
    local names=$2/internal.names c=$2/collide.c
    nm "$1" | awk '$2 ~ /^[Tt]$/ {print $3}' | grep -E '^[a-z][a-z0-9_]*$' | \
        grep -vxF -f "$tmp/exports" | grep -E '^(circe|ctlp|shm|client|request|slp)_' | \
        sort -u >"$names"
    if [ ! -s "$names" ]; then
        echo "no internal function names found in $1" >"$2/log"
        return 1
    fi
    {
        echo '#include <errno.h>'
        echo '#include <stdio.h>'
        echo '#include <unistd.h>'
        echo '#include <sharedlink.h>'
        echo 'static void taken(const char *name)'
        echo '{ fprintf(stderr, "the library called the program'"'"'s %s\n", name); _exit(1); }'
        while read -r n; do
            echo "void $n(void); void $n(void) { taken(\"$n\"); }"
        done <"$names"
        echo 'int main(void)'
        echo '{'
        echo '        struct sl_client *c = NULL;'
        echo '        int r = sl_open("check-symbols-absent", &c);'
        echo '        printf("sl_open: %d (%s)\n", r, sl_strerror(r));'
        echo '        sl_close(c);'
        echo '        return r == -ENOENT ? 0 : 1;'
        echo '}'
    } >"$c"
    "$cc" -std=c11 -I"$here/include" -o "$2/collide" "$c" "$1" -lpthread >"$2/log" 2>&1 &&
        "$2/collide" >>"$2/log" 2>&1
}

for b in "$@"; do
    a=$b/libsharedlink.a so=$b/libsharedlink.so.1
    for f in "$a" "$so"; do
        if [ ! -e "$f" ]; then
            echo "check-symbols: $f missing (make $f)" >&2
            exit 1
        fi
    done
    nm -g --defined-only "$a" | awk 'NF == 3 {print $3}' | sort -u >"$tmp/a.names"
    compare "$tmp/a.names" "$tmp/exports" "$tmp/a.out"
    result "$a: globals are the sl_* exports" $? "$tmp/a.out"
    nm -D --defined-only "$so" | awk 'NF == 3 {sub(/@.*/, "", $3); print $3}' | sort -u \
        >"$tmp/so.names"
    sort -u "$tmp/exports" "$tmp/nodes" >"$tmp/so.allowed"
    compare "$tmp/so.names" "$tmp/so.allowed" "$tmp/so.out"
    result "$so: dynamic symbols are the sl_* exports and version nodes" $? "$tmp/so.out"
    # A sanitized archive needs its runtime at link time: its names are checked above.
    if nm "$a" | grep -q ' U __asan_\| U __tsan_'; then
        continue
    fi
    mkdir -p "$tmp/prog"
    collision_program "$a" "$tmp/prog"
    result "$a: a program with the library's internal names links and runs" $? "$tmp/prog/log"
done

if [ "$failed" -eq 0 ]; then
    echo "[  PASSED  ] $passed test(s)."
else
    echo "[  PASSED  ] $passed test(s)."
    echo "[  FAILED  ] $failed test(s)"
    exit 1
fi
