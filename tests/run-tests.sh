#!/usr/bin/env bash
# Runs the test binaries that `make check` built and prints one line per binary and a total.
# Usage: run-tests.sh [--unit "BIN..."] [--replay "BIN..."] [--stress "BIN..."] [--integration "BIN..."]
#                     [--python "SCRIPT..."]
#                     [--peers "SCRIPT..."]   (scripts are run as they are: python3 must be there)
# Each binary gets TEST_TIMEOUT seconds (default 300); cmocka's own "[  PASSED  ] N test(s)." and
# "[  FAILED  ] N test(s)" lines are summed so the total counts test cases, not binaries.
# --python scripts run under $PYTHON (default python3) and print the same two lines.
set -u
timeout_s=${TEST_TIMEOUT:-300}
passed=0 failed=0 failed_bins=()
logdir=${SHAREDLINK_BUILD:-build}/test-logs
# Configurations the tests load (tests/common/testdata.h), wherever the binaries run from.
export SHAREDLINK_TESTDATA=${SHAREDLINK_TESTDATA:-$(cd "$(dirname "$0")" && pwd)/data}
mkdir -p "$logdir"

run_one() {  # kind binary [args...]
    local kind=$1 bin=$2; shift 2
    local name log rc p f
    name=${run_name:-$(basename "$bin")}
    log="$logdir/$name.log"
    timeout --kill-after=10 "$timeout_s" "$bin" "$@" >"$log" 2>&1
    rc=$?
    p=$(sed -n 's/^\[  PASSED  \] \([0-9]*\) test(s)\./\1/p' "$log" | awk '{s+=$1} END {print s+0}')
    f=$(sed -n 's/^\[  FAILED  \] \([0-9]*\) test(s)\(,.*\)\{0,1\}$/\1/p' "$log" | awk '{s+=$1} END {print s+0}')
    # Binaries that are not cmocka suites (replayers, stress tests) count as one test each.
    if [ "$p" = 0 ] && [ "$f" = 0 ]; then
        if [ $rc -eq 0 ]; then p=1; else f=1; fi
    elif [ $rc -ne 0 ] && [ "$f" = 0 ]; then
        f=1   # crashed or timed out after its last report
    fi
    passed=$((passed + p)); failed=$((failed + f))
    if [ $rc -eq 0 ] && [ "$f" = 0 ]; then
        printf 'PASS  %-12s %-32s %s\n' "$kind" "$name" "$(tail -n 1 "$log")"
    else
        [ $rc -eq 124 ] && echo "TIMEOUT after ${timeout_s}s: $name"
        printf 'FAIL  %-12s %-32s (exit %d) log: %s\n' "$kind" "$name" "$rc" "$log"
        sed 's/^/      | /' "$log" | tail -n 60
        failed_bins+=("$name")
    fi
}

while [ $# -gt 0 ]; do
    kind=${1#--}; list=$2; shift 2
    for bin in $list; do
        case $kind in
            replay) n=$(basename "$bin" -replay); n=${n#fuzz_}
                    run_one "$kind" "$bin" "tests/fuzz/corpus/$n" ;;
            python) run_name=${bin//\//-} \
                        run_one "$kind" "${PYTHON:-python3}" "$bin" ;;
            *)      run_one "$kind" "$bin" ;;
        esac
    done
done

echo "check: $passed passed, $failed failed"
[ ${#failed_bins[@]} -eq 0 ] || { echo "failed: ${failed_bins[*]}"; exit 1; }
