#!/bin/bash
# The last table of `make bench`: every FIGURE line the benchmarks printed in this run, with its
# goal, the ratio value / goal and whether it was met, and the load average of the machine.
#
#   tests/bench/summary.sh LOG
#
# FIGURE|key|label|value|unit|goal, goal: "<=N", "<N", ">=N" or "-" (none).
set -euo pipefail

log=${1:?usage: summary.sh LOG}
echo
echo "== summary: every figure of this run next to its goal (load average $(cut -d' ' -f1-3 /proc/loadavg))"
# The order; figures not named here follow in the order they were printed.
order="read_meta read read_installed-so_meta_in read_installed-so_in read_installed-so_meta_out
read_installed-so_out read_installed-a_meta_in read_installed-a_in read_installed-a_meta_out
read_installed-a_out write pace_ops redis_get redis_get_ratio redis_set unix_rtt pty_floor inbound
inbound_ratio inbound_spin inbound_spin_ratio inbound_spin_cpu outbound_p50 outbound_p99 dstage1
dstage2 dstage3 stage1
stage2 stage3 stage4 codec_sharedlink codec_circe idle_wakeups idle_switches daemon_rss"
awk -F'|' -v order="$order" '
        $1 == "FIGURE" { line[$2] = $0; if (!($2 in seen)) { seen[$2] = 1; keys[n++] = $2 } }
        END {
                printf "%-52s %10s %-5s %8s %7s\n", "figure", "value", "unit", "goal", "ratio"
                m = split(order, want, /[ \n]+/)
                for (i = 1; i <= m; i++)
                        if (want[i] in line) { row(line[want[i]]); done[want[i]] = 1 }
                for (i = 0; i < n; i++)
                        if (!(keys[i] in done)) row(line[keys[i]])
        }
        function row(l,    f, label, value, unit, goal, ratio, verdict, op, target, ok) {
                split(l, f, "|")
                label = f[3]; value = f[4]; unit = f[5]; goal = f[6]
                ratio = "-"; verdict = ""
                if (goal != "-") {
                        op = goal; sub(/[0-9.]+$/, "", op)
                        target = substr(goal, length(op) + 1) + 0
                        if (target > 0) ratio = sprintf("%.2f", value / target)
                        if (op == "<=") ok = value <= target
                        else if (op == "<") ok = value < target
                        else ok = value >= target
                        verdict = ok ? "met" : "MISSED"
                }
                printf "%-52s %10s %-5s %8s %7s  %s\n", label, value, unit, goal, ratio, verdict
        }
' "$log"
