#!/usr/bin/env bash
# `make demo`: sharedlinkd with no hardware (DESIGN.md §2.1).
#
# Starts one daemon on conf/demo.yaml, whose links are connected back to back over ptys, and
# drives it with slctl the way a user would:
#   SharedLink: node_a (node A) <-> node_b (node B). Values written on one side with `slctl set`
#               arrive on the other (`slctl get`, a short `slctl watch`); `slctl stats` at the end.
#   CIRCE:      agility (controller) <-> arena (the built-in mediator emulator); see the marked
#               section below.
#   ROS 2:      when Cyclone DDS is installed, sharedlink-ros2 and a DDS peer (a late joiner, a
#               write through set/, a NavSatFix), unicast on 127.0.0.1 only
#   MQTT:       when mosquitto and its clients are installed, sharedlink-mqtt bridges the instance
#               to a private broker on 127.0.0.1 (marked section below); skipped otherwise.
#   Agility:    when sharedlink-agility is built, it times two runs on the CIRCE pair (one clean,
#               one with a fault and a refusal) and prints the results and the scoreboard URL.
#   Pronto4:    pronto_host (a SharedLink host, node A) <-> pronto (the vehicle side, node B,
#               learning the host's lists) over UDP on loopback, through a relay that prints
#               every datagram; see the marked section below.
# then stops the daemon with SIGTERM and checks that it cleaned up after itself.
#
# Runs as any user: runtime_dir in demo.yaml is under /tmp, and each user gets <runtime_dir>-<uid>. Environment: SHAREDLINK_BUILD (the
# build directory, default build), DEMO_CONF (default conf/demo.yaml). Exit status 0 when
# every step did what it should.
set -euo pipefail

build=${SHAREDLINK_BUILD:-build}
conf=${DEMO_CONF:-conf/demo.yaml}
daemon=$build/sharedlinkd
slctl=$build/slctl
instance=$(sed -n 's/^instance:[[:space:]]*\([^[:space:]#]*\).*/\1/p' "$conf")
rundir=$(sed -n 's/^runtime_dir:[[:space:]]*\([^[:space:]#]*\).*/\1/p' "$conf")
# A directory per user (<runtime_dir>-<uid>): a demo someone else ran leaves theirs, never ours.
# The configuration is copied there with every path under runtime_dir moved along.
if [ -n "$rundir" ]; then
        userdir=$rundir-$(id -u)
        mkdir -p -m 0755 "$userdir" 2>/dev/null || true
        [ -d "$userdir" ] && [ -O "$userdir" ] && [ -w "$userdir" ] ||
                { printf 'demo: %s is not a directory of ours\n' "$userdir" >&2; exit 1; }
        sed "s|$rundir|$userdir|g" "$conf" > "$userdir/demo.yaml"
        conf=$userdir/demo.yaml rundir=$userdir
fi
wait_s=10                       # how long a step may take before the demo gives up
pid=
mqtt_pids=()
agility_pid=

export SHAREDLINK_INSTANCE=$instance SHAREDLINK_RUNTIME_DIR=$rundir

say()  { printf '\n\033[1m== %s\033[0m\n' "$*"; }
run()  { printf '$ %s\n' "$*"; "$@"; }
fail() { printf 'demo: %s\n' "$*" >&2; [ -f "$rundir/sharedlinkd.log" ] && tail -n 20 "$rundir/sharedlinkd.log" >&2; exit 1; }

cleanup() {
        local p
        for p in "${mqtt_pids[@]}"; do
                kill -TERM "$p" 2>/dev/null || true
                wait "$p" 2>/dev/null || true
        done
        if [ -n "$agility_pid" ]; then
                kill -TERM "$agility_pid" 2>/dev/null || true
                wait "$agility_pid" 2>/dev/null || true
        fi
        pronto4_cleanup
        if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then
                kill -TERM "$pid" 2>/dev/null || true
                wait "$pid" 2>/dev/null || true
        fi
}
trap cleanup EXIT

# Polls "$@" every 0.1 s until it succeeds, at most wait_s seconds. (A demo may poll; the tests
# wait on events instead.)
until_ok() {
        local i
        for ((i = 0; i < wait_s * 10; i++)); do
                "$@" >/dev/null 2>&1 && return 0
                sleep 0.1
        done
        return 1
}

# `slctl get NAME` prints VALUE.
value_is() { [ "$("$slctl" get "$1" 2>/dev/null)" = "$2" ]; }

# --- Pronto4: host link (pronto_host) <-> vehicle link (pronto), over UDP, through a relay ------
# tests/peers/udp_tee.py sits between the two links (each link's remote: is the relay, which
# forwards to the other link's local:) and logs every datagram byte for byte; on SIGUSR1 it
# sends a real vehicle ping to the host and a host ping to the vehicle. The relay starts before
# the daemon, so the host's first connect sequence finds it.
have_pronto4=0
grep -q 'dialect: pronto4' "$conf" && have_pronto4=1
p4_tee=
p4_log=$rundir/pronto4-frames.log

# The value of key (local, remote) of link $1 in $conf, quotes removed.
p4_link_addr() {
        awk -v link="$1" -v key="$2:" '$0 ~ "- name: " link "$" { f = 1; next }
                /- name:/ { f = 0 } f && $1 == key { gsub(/"/, "", $2); print $2; exit }' "$conf"
}

pronto4_cleanup() {
        if [ -n "$p4_tee" ] && kill -0 "$p4_tee" 2>/dev/null; then
                kill -TERM "$p4_tee" 2>/dev/null || true
                wait "$p4_tee" 2>/dev/null || true
        fi
        p4_tee=
}

pronto4_relay_start() {
        local host_local host_remote veh_local veh_remote
        [ "$have_pronto4" = 1 ] || return 0
        command -v python3 >/dev/null || fail "the Pronto4 step needs python3 (its frame relay)"
        host_local=$(p4_link_addr pronto_host local)
        host_remote=$(p4_link_addr pronto_host remote)
        veh_local=$(p4_link_addr pronto local)
        veh_remote=$(p4_link_addr pronto remote)
        [ -n "$host_local" ] && [ -n "$veh_remote" ] || fail "$conf: no pronto_host/pronto links"
        python3 tests/peers/udp_tee.py "$host_remote" "$host_local" "$veh_remote" "$veh_local" \
                "$p4_log" >"$rundir/pronto4-relay.out" &
        p4_tee=$!
        until_ok grep -q ready "$rundir/pronto4-relay.out" || fail "the Pronto4 relay did not start"
}

p4_event_seen() { "$slctl" events 2>/dev/null | grep -F -- "$1" >/dev/null; }
p4_logged() { grep -F -- "$1" "$p4_log" >/dev/null; }

pronto4_step() {
        [ "$have_pronto4" = 1 ] || return 0
        say "Pronto4: the vehicle link (pronto) learns the host link's (pronto_host) typed lists"
        until_ok "$slctl" get pronto.A.joy_steer pronto.A.VehicleName ||
                fail "the vehicle link never learned the host's declarations"
        printf '$ %s list | grep -E "^(NAME|veh_start|joy_steer|AutoGpsLat|VehicleName|pronto\\.)"\n' \
                "$slctl"
        "$slctl" list | grep -E '^(NAME|veh_start|joy_steer|AutoGpsLat|VehicleName|pronto\.)'

        say "Pronto4: a ping each way (the relay pings both links; each answers G0)"
        kill -USR1 "$p4_tee"
        until_ok p4_logged "A -> B  [:BA|G0|C6F]" || fail "the host never answered the ping"
        until_ok p4_logged "B -> A  [:AB|G0|C6F]" || fail "the vehicle never answered the ping"
        grep -F 'P0|C78' "$p4_log"
        grep -F 'G0|C6F' "$p4_log"

        say "Pronto4: the host sends a module command; the vehicle link reports it as an event"
        run "$slctl" command pronto_host ServoPod "0,TELEOP START"
        until_ok p4_event_seen ' pronto command module=ServoPod text="0,TELEOP START"' ||
                fail "the command never arrived as an event"
        "$slctl" events | grep ' pronto command '

        say "Pronto4: the host writes; the vehicle reads"
        run "$slctl" set veh_start 1
        run "$slctl" set joy_steer 0.25
        until_ok value_is pronto.A.joy_steer 0.25 || fail "pronto.A.joy_steer never became 0.25"
        run "$slctl" get pronto.A.veh_start pronto.A.joy_steer

        say "Pronto4: the vehicle writes; the host reads"
        run "$slctl" set pronto.A.AutoGpsLat 40.12345678
        run "$slctl" set pronto.A.VehicleName VEH_1
        until_ok value_is VehicleName VEH_1 || fail "VehicleName never became VEH_1"
        run "$slctl" get AutoGpsLat VehicleName

        say "Pronto4: the datagrams exchanged, byte for byte (A = pronto_host, B = pronto)"
        pronto4_cleanup
        cat "$p4_log"
}
# --- end of the Pronto4 part ---------------------------------------------------------------------

[ -x "$daemon" ] || fail "$daemon is not built (run make)"
[ -x "$slctl" ] || fail "$slctl is not built yet (src/cli/ comes with the slctl branch)"
[ -n "$instance" ] && [ -n "$rundir" ] || fail "$conf must set instance and runtime_dir"

say "configuration $conf"
mkdir -p "$rundir" 2>/dev/null || true
[ -d "$rundir" ] && [ -w "$rundir" ] || fail "$rundir is not a directory we may write (another user's demo?)"
check=$("$daemon" -n -c "$conf" 2>&1) || fail "$check"
echo "$check"
have_circe=0
grep -q 'protocol: circe' "$conf" && have_circe=1

pronto4_relay_start
say "start sharedlinkd (log: $rundir/sharedlinkd.log)"
"$daemon" -c "$conf" 2>"$rundir/sharedlinkd.log" &
pid=$!
until_ok "$slctl" list || fail "the daemon did not come up"
# The SharedLink variables (the CIRCE ones are shown in their own part below).
printf '$ %s list | grep -E "^(NAME|a\\.|b\\.)"\n' "$slctl"
"$slctl" list | grep -E '^(NAME|a\.|b\.)'

say "node A writes its GPS fix; node B receives it"
run "$slctl" set a.AutoGpsLat 40.12345678
run "$slctl" set a.AutoGpsLon -113.12345678
run "$slctl" set a.AutoGpsHead 271.5
run "$slctl" set a.AutoGpsVel 3.25
until_ok value_is b.AutoGpsVel 3.25 || fail "b.AutoGpsVel never became 3.25"
run "$slctl" get b.AutoGpsLat b.AutoGpsLon b.AutoGpsHead b.AutoGpsVel

say "node B answers with commands; node A receives them"
run "$slctl" set b.CmdThrottle 25
run "$slctl" set b.CmdSteer -10
until_ok value_is a.CmdSteer -10 || fail "a.CmdSteer never became -10"
run "$slctl" get a.CmdThrottle a.CmdSteer

say "watch b.AutoGpsVel on node B while node A speeds up"
"$slctl" watch b.AutoGpsVel &
watcher=$!
until_ok value_is b.AutoGpsVel 3.25
for v in 3.5 4.0 4.5; do
        sleep 0.3
        "$slctl" set a.AutoGpsVel "$v"
done
until_ok value_is b.AutoGpsVel 4.5 || fail "b.AutoGpsVel never became 4.5"
sleep 0.3
kill -INT "$watcher" 2>/dev/null || true
wait "$watcher" 2>/dev/null || true

say "node B asks node A for a variable by name (SharedLink Q, answered with R/D)"
run "$slctl" query node_b A a.AutoGpsHead

# --- CIRCE: controller (agility) <-> mediator emulator (arena) ---------------------------------
# The controller logs in to the emulator over the pty, the emulated devices appear in the
# controller's table, a gate passage injected on the emulator arrives as an `action` event, a
# visualize command from the controller changes the emulated display, and a clock
# synchronisation succeeds for every device.
# `slctl events` prints "SEQ LINK TYPE key=value ...".
# grep reads all of it (no -q): slctl must not die of SIGPIPE under pipefail.
event_seen() { "$slctl" events 2>/dev/null | grep -- "$1" >/dev/null; }
if [ "$have_circe" = 1 ]; then
        say "CIRCE: the controller (agility) logs in to the mediator emulator (arena)"
        until_ok value_is agility.state connected || fail "agility never connected"
        run "$slctl" get agility.state agility.mediator.version arena.state

        say "CIRCE: the emulated gate, remote and display appear on the controller"
        until_ok value_is agility.device.D15D15.online 1 || fail "the emulated devices never appeared"
        run "$slctl" get agility.device.E1E1E1.capabilities agility.device.E1E1E1.signal \
                agility.device.E1E1E1.battery agility.device.AAAAAA.capabilities \
                agility.device.D15D15.capabilities
        "$slctl" events | grep ' agility device-online ' || true

        say "CIRCE: a gate passage on the emulated gate arrives as an action event"
        run "$slctl" circe arena emulate action E1E1E1 --sensor-time 5000
        until_ok event_seen " agility action device=E1E1E1 sensor_time=5000" ||
                fail "the gate passage never arrived as an event"
        "$slctl" events | grep ' agility action '
        run "$slctl" get agility.device.E1E1E1.sensor_time

        say "CIRCE: the controller changes what the emulated display shows"
        run "$slctl" circe agility visualize D15D15 --current 12 --next 13 --start-timer
        until_ok value_is arena.device.D15D15.current_competitor 12 ||
                fail "the emulated display never showed competitor 12"
        run "$slctl" get arena.device.D15D15.current_competitor \
                arena.device.D15D15.next_competitor arena.device.D15D15.timer_running

        say "CIRCE: synchronise the clocks of every device"
        run "$slctl" circe agility sync-clocks
fi
# --- end of the CIRCE part ----------------------------------------------------------------------

# --- MQTT: sharedlink-mqtt and a private broker -------------------------------------------------
# A broker of our own on a free 127.0.0.1 port (never the system's), the bridge, and the real
# mosquitto clients: a retained value, a write through set/, a gate passage as an event, and a
# refused write with its error reply.
bridge=$build/sharedlink-mqtt
broker=$(command -v mosquitto || echo /usr/sbin/mosquitto)
port_free() { ! (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }
port_open() { ! port_free "$1"; }
# Prints the next message on topic $1 (retained ones included), waiting at most wait_s seconds.
mqtt_next() { mosquitto_sub -p "$mport" -t "$1" -C 1 -W "$wait_s" 2>/dev/null; }
if [ ! -x "$broker" ] || ! command -v mosquitto_sub >/dev/null || ! command -v mosquitto_pub >/dev/null; then
        say "MQTT: skipped (mosquitto or mosquitto-clients not installed: make deps)"
elif [ ! -x "$bridge" ]; then
        say "MQTT: skipped ($bridge is not built)"
else
        say "MQTT: a private broker and sharedlink-mqtt (log: $rundir/mqtt/bridge.log)"
        mkdir -p "$rundir/mqtt"
        mport=
        for try in 1 2 3 4 5 6 7 8; do
                p=$((20000 + RANDOM % 20000))
                port_free "$p" && { mport=$p; break; }
        done
        [ -n "$mport" ] || fail "no free port for the broker"
        printf 'listener %s 127.0.0.1\nallow_anonymous true\n%s' "$mport" \
                "$([ "$(id -u)" = 0 ] && echo 'user root')" > "$rundir/mqtt/broker.conf"
        "$broker" -c "$rundir/mqtt/broker.conf" 2>"$rundir/mqtt/broker.log" &
        mqtt_pids+=($!)
        until_ok port_open "$mport" || fail "the broker did not come up"
        cat > "$rundir/mqtt/bridge.yaml" <<EOC
instance: $instance
broker: {host: 127.0.0.1, port: $mport}
cursor_file: $rundir/mqtt/cursor
writable: ["a.*"]
EOC
        run "$bridge" -n -c "$rundir/mqtt/bridge.yaml"
        "$bridge" -c "$rundir/mqtt/bridge.yaml" 2>"$rundir/mqtt/bridge.log" &
        mqtt_pids+=($!)
        base=sharedlink/$instance
        [ "$(mqtt_next "$base/status")" = online ] || fail "the bridge never came online"
        run mqtt_next "$base/status"
        echo "\$ mosquitto_sub -t $base/b.AutoGpsVel -C 1   # retained"
        mqtt_next "$base/b.AutoGpsVel"
        mqtt_next "$base/b.AutoGpsVel/meta"; echo

        say "MQTT: a write through set/ goes out on node A and comes back on node B"
        run mosquitto_pub -p "$mport" -t "$base/set/a.AutoGpsVel" -m 5.5
        until_ok value_is b.AutoGpsVel 5.5 || fail "b.AutoGpsVel never became 5.5"
        echo "\$ mosquitto_sub -t $base/b.AutoGpsVel -C 1"
        mqtt_next "$base/b.AutoGpsVel"

        if [ "$have_circe" = 1 ]; then
                say "MQTT: a gate passage arrives as an event"
                mqtt_next "$base/events/agility" > "$rundir/mqtt/event.json" &
                sub=$!
                sleep 0.5       # the subscription is in place (a demo may wait; tests do not)
                run "$slctl" circe arena emulate action E1E1E1 --sensor-time 6000
                wait "$sub" || fail "no event arrived over MQTT"
                cat "$rundir/mqtt/event.json"
        fi

        say "MQTT: a write to an inbound variable is refused, with a reason"
        mqtt_next "$base/set/b.AutoGpsVel/error" > "$rundir/mqtt/error.json" &
        sub=$!
        sleep 0.5
        run mosquitto_pub -p "$mport" -t "$base/set/b.AutoGpsVel" -m 1
        wait "$sub" || fail "no error reply arrived"
        cat "$rundir/mqtt/error.json"; echo
        run "$slctl" get b.AutoGpsVel
        for p in "${mqtt_pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; wait "$p" 2>/dev/null || true; done
        mqtt_pids=()
        echo "sharedlink-mqtt and the broker stopped"
fi
# --- end of the MQTT part -----------------------------------------------------------------------

# --- ROS 2: sharedlink-ros2 and a DDS peer standing in for a ROS 2 node ------------------------
# No ROS here: tests/ros2peer/'s Cyclone peer subscribes and publishes as a ROS 2 node does
# (its own copy of the types, the ROS QoS). Loopback unicast only, on a domain of the demo's own.
ros2=$build/sharedlink-ros2
peer=build/tests/ros2peer/peer_cyclone
ros2_xml=$(pwd)/tests/ros2peer/cyclonedds.xml
if [ ! -x "$ros2" ] || [ ! -x "$peer" ]; then
        say "ROS 2: skipped (Cyclone DDS not installed: make deps)"
else
        say "ROS 2: sharedlink-ros2 on DDS domain of our own (log: $rundir/ros2/bridge.log)"
        mkdir -p "$rundir/ros2"
        domain=$((100 + RANDOM % 100))
        ns=/sharedlink/$instance
        cat > "$rundir/ros2/bridge.yaml" <<EOC
instance: $instance
domain_id: $domain
cyclonedds_uri: file://$ros2_xml
writable: ["a.*"]
navsatfix:
  - {topic: gps/fix, latitude: b.AutoGpsLat, longitude: b.AutoGpsLon, frame_id: gps}
EOC
        run "$ros2" -n -c "$rundir/ros2/bridge.yaml"
        "$ros2" -c "$rundir/ros2/bridge.yaml" 2>"$rundir/ros2/bridge.log" &
        mqtt_pids+=($!)
        ros2_peer() { "$peer" "$@" --domain "$domain" --config "$ros2_xml" --timeout-ms $((wait_s * 1000)); }
        say "ROS 2: a late subscriber gets the current value (ros2 topic echo $ns/b/AutoGpsVel)"
        run ros2_peer sub "rt$ns/b/AutoGpsVel" Float64 --durability transient_local ||
                fail "no value over DDS"
        say "ROS 2: a write on $ns/set/a/AutoGpsVel goes out on node A, comes back on node B"
        run ros2_peer pub "rt$ns/set/a/AutoGpsVel" Float64 8.25 --durability volatile ||
                fail "the write found no reader"
        until_ok value_is b.AutoGpsVel 8.25 || fail "b.AutoGpsVel never became 8.25"
        run "$slctl" get b.AutoGpsVel
        say "ROS 2: sensor_msgs/msg/NavSatFix from b.AutoGpsLat and b.AutoGpsLon"
        run ros2_peer sub "rt$ns/gps/fix" NavSatFix --durability transient_local ||
                fail "no NavSatFix over DDS"
        for p in "${mqtt_pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; wait "$p" 2>/dev/null || true; done
        mqtt_pids=()
        echo "sharedlink-ros2 stopped"
fi
# --- end of the ROS 2 part ----------------------------------------------------------------------

# --- Agility: sharedlink-agility times two runs on the CIRCE pair --------------------------------
# The emulated gate E1E1E1 is one combined start/finish gate, AAAAAA the remote, D15D15 the
# display. Ready on the remote synchronises the clocks; the gate is passed twice, the second time
# 2 s later by its sensor clock and by ours (the time counts as high precision only when the two
# agree). The scoreboard's JSON and CSV are read with bash's /dev/tcp: no HTTP client needed.
agility=$build/sharedlink-agility
agility_dir=$rundir/agility
# A subshell: a refused connection ends it, not the demo.
http_body() (   # path: the body of GET path from the scoreboard
        exec 3<>"/dev/tcp/127.0.0.1/$aport" || exit 1
        printf 'GET %s HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n' "$1" >&3
        sed '1,/^\r$/d' <&3 | tr -d '\r'
)
state_is() { http_body /api/state | grep -q "\"state\":\"$1\",\"current\":$2,"; }
remote()   { "$slctl" circe arena emulate action AAAAAA --keys "$1" >/dev/null &&
             "$slctl" circe arena emulate action AAAAAA --keys 0 >/dev/null; }
gate()     { run "$slctl" circe arena emulate action E1E1E1 --sensor-time "$1"; }
# Ready on the remote, then waits for the state with that competitor.
ready()    { echo "(remote: Ready)"; remote 32768; until_ok state_is "$1" "$2" ||
             fail "sharedlink-agility never reached $1 with competitor $2"; }
agility_run() {   # competitor start_ms, then the keys pressed during the run
        local n=$1 t=$2 k
        shift 2
        ready ReadyToStart "$n"
        gate "$t"
        until_ok state_is StartPassed "$n" || fail "the start passage did not count"
        for k in "$@"; do echo "(remote: key $k)"; remote "$k"; done
        sleep 2
        gate $((t + 2000))
        until_ok state_is FinishPassed "$n" || fail "the finish passage did not count"
        ready RunCompleted "$n"
}
if [ ! -x "$agility" ]; then
        say "Agility: skipped ($agility is not built)"
else
        mkdir -p "$agility_dir"
        rm -f "$agility_dir"/results.db*
        cp conf/agility-competitors.csv "$agility_dir/competitors.csv"
        aport=8431
        while ! port_free "$aport"; do aport=$((aport + 1)); done
        cat > "$agility_dir/agility.yaml" <<EOC
instance: $instance
link: agility
class: {name: "Demo jumping", standard_course_time_ms: 40000, max_course_time_ms: 80000,
        intermediates: 0}
gates: {start_finish: E1E1E1, min_delay_ms: 1000}
keypads: [AAAAAA]
displays: [D15D15]
competitors: $agility_dir/competitors.csv
database: $agility_dir/results.db
http: "127.0.0.1:$aport"
EOC
        say "Agility: sharedlink-agility on the controller link (log: $agility_dir/agility.log)"
        run "$agility" -n -c "$agility_dir/agility.yaml"
        "$agility" -c "$agility_dir/agility.yaml" 2>"$agility_dir/agility.log" &
        agility_pid=$!
        until_ok state_is SetupCompleted 1 || fail "sharedlink-agility did not start"

        say "Agility: competitor 1 runs clean (gate at sensor time 5000, then 7000)"
        agility_run 1 5000
        say "Agility: competitor 2 runs with a fault (key 9) and a refusal (key 6)"
        agility_run 2 20000 256 32
        run "$slctl" get arena.device.D15D15.current_competitor arena.device.D15D15.primary_time \
                arena.device.D15D15.faults arena.device.D15D15.refusals arena.device.D15D15.placement

        say "Agility: the results (GET /api/results.csv; stored in $agility_dir/results.db)"
        http_body /api/results.csv
        echo "scoreboard: http://127.0.0.1:$aport/ (live while the demo runs; /api/state, /api/results)"
        kill -TERM "$agility_pid"
        status=0
        wait "$agility_pid" || status=$?
        agility_pid=
        [ "$status" = 0 ] || fail "sharedlink-agility exited with status $status"
        echo "sharedlink-agility stopped"
fi
# --- end of the Agility part --------------------------------------------------------------------
pronto4_step

say "link statistics"
run "$slctl" stats

say "stop (SIGTERM)"
kill -TERM "$pid"
status=0
wait "$pid" || status=$?
pid=
[ "$status" = 0 ] || fail "sharedlinkd exited with status $status"
[ ! -e "$rundir/$instance.sock" ] || fail "the control socket is still there"
[ ! -e "/dev/shm/sharedlink.$instance.in" ] || fail "the shm tables are still there"
echo "sharedlinkd stopped cleanly: socket and shared memory removed"
tail -n 3 "$rundir/sharedlinkd.log"
