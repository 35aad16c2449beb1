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
awk -F'|' '
        $1 == "FIGURE" {
                label = $3; value = $4; unit = $5; goal = $6
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
        BEGIN { printf "%-52s %10s %-5s %8s %7s\n", "figure", "value", "unit", "goal", "ratio" }
' "$log"
