# bash completion for slctl (sharedlink).
#
# `make install` puts it in $(PREFIX)/share/bash-completion/completions/slctl, where the
# bash-completion package loads it on first use; without that package: source this file.
#
# Commands, options and their fixed values come from here; variable names, link names, peers and
# device addresses from the running daemon, through the slctl being completed (`slctl list`,
# `slctl stats`), with the -i INSTANCE already on the line; record's FILE from the file system.
# Nothing is printed on errors: with no daemon running, only the fixed words complete.

_slctl_commands="list get set watch events stats query ping command record circe help"
_slctl_circe_ops="alert network-setup device-setup sync-clocks visualize emulate"

# _slctl_run PROG ARGS...: runs slctl quietly, stdout only.
_slctl_run()
{
        local prog=$1
        shift
        "$prog" "$@" 2>/dev/null
}

# Fields of `slctl list` (NAME DIR LINK PEER ...): prints column $1 of the rows where the awk
# condition $2 holds.
_slctl_list()
{
        _slctl_run "$_slctl_prog" "${_slctl_inst[@]}" list | awk -v col="$1" \
                "NR > 1 && ($2) { print \$col }"
}

# Peers (SharedLink) or device addresses (CIRCE) of link $1: the PEER column of its variables.
_slctl_devices()
{
        _slctl_list 4 "\$3 == \"$1\" && \$4 != \"-\"" | sort -u
}

# Link names of `slctl stats` ("link NAME (PROTOCOL): ..."), of protocol $1 (empty: all).
_slctl_links()
{
        _slctl_run "$_slctl_prog" "${_slctl_inst[@]}" stats | awk -v proto="$1" \
                '$1 == "link" && (proto == "" || $3 == "(" proto "):") { print $2 }'
}

# Instances with tables in /dev/shm (sharedlink.NAME.in).
_slctl_instances()
{
        local f
        for f in /dev/shm/sharedlink.*.in; do
                [ -e "$f" ] || continue
                f=${f#/dev/shm/sharedlink.}
                printf '%s\n' "${f%.in}"
        done
}

# COMPREPLY = the words of $1 (blank-separated) that start with $cur.
_slctl_reply()
{
        mapfile -t COMPREPLY < <(compgen -W "$1" -- "$cur")
}

_slctl()
{
        local cur=${COMP_WORDS[COMP_CWORD]} prev=${COMP_WORDS[COMP_CWORD-1]}
        local _slctl_prog=${COMP_WORDS[0]} _slctl_inst=() command="" ci=0 i
        COMPREPLY=()

        # Global options, then the command word.
        for ((i = 1; i < COMP_CWORD; i++)); do
                case ${COMP_WORDS[i]} in
                -i)     _slctl_inst=(-i "${COMP_WORDS[i+1]}"); ((i++)) ;;
                -i?*)   _slctl_inst=("${COMP_WORDS[i]}") ;;
                -*)     ;;
                *)      command=${COMP_WORDS[i]}; ci=$i; break ;;
                esac
        done
        if [ -z "$command" ]; then
                case $prev in
                -i)     _slctl_reply "$(_slctl_instances)"; return 0 ;;
                esac
                case $cur in
                -*)     _slctl_reply "-i -h --help --version" ;;
                *)      _slctl_reply "$_slctl_commands" ;;
                esac
                return 0
        fi

        # Words after the command that are not options (nor an option's value): the positionals.
        local pos=() w
        local valued=" --count --duration --timeout --wait --roles --assign --dest --capabilities "
        valued+="--keys "
        valued+="--sensor-time --current --next --primary --secondary --faults --refusals "
        valued+="--eliminated --placement "
        for ((i = ci + 1; i < COMP_CWORD; i++)); do
                w=${COMP_WORDS[i]}
                if [[ $valued == *" $w "* ]]; then
                        ((i++))
                elif [[ $w != -* ]]; then
                        pos+=("$w")
                fi
        done
        # An option's value: nothing to offer but the fixed choices and --dest's devices.
        if [[ $valued == *" $prev "* ]]; then
                case $prev in
                --eliminated)   _slctl_reply "0 1" ;;
                --dest)         _slctl_reply "$(_slctl_devices "${pos[0]}")" ;;
                esac
                return 0
        fi

        local opts=""
        case $command in
        list)   opts="--json" ;;
        get)    opts="--strict" ;;
        watch)  opts="--count --timeout" ;;
        events) opts="--follow --new --count --timeout" ;;
        stats)  opts="--json --all" ;;
        query|ping) opts="--timeout --wait" ;;
        command) opts="--wait" ;;
        record) opts="--duration --count" ;;
        esac
        if [[ $cur == -* ]]; then
                case $command in
                circe)
                        case ${pos[1]} in
                        network-setup)  opts="--join --leave --roles" ;;
                        device-setup)   opts="--assign --dest --capabilities" ;;
                        visualize)      opts="--current --next --start-timer --primary \
--secondary --faults --refusals --eliminated --placement" ;;
                        emulate)        opts="--keys --sensor-time" ;;
                        esac
                        opts+=" --wait" ;;
                esac
                _slctl_reply "$opts --help"
                return 0
        fi

        case $command in
        get|watch)
                _slctl_reply "$(_slctl_list 1 1)" ;;
        set)
                [ ${#pos[@]} -eq 0 ] && _slctl_reply "$(_slctl_list 1 '$2 == "out"')" ;;
        help)
                [ ${#pos[@]} -eq 0 ] && _slctl_reply "$_slctl_commands" ;;
        query|ping)
                case ${#pos[@]} in
                0)      _slctl_reply "$(_slctl_links sharedlink)" ;;
                1)      _slctl_reply "$(_slctl_devices "${pos[0]}")" ;;     # its peers
                esac ;;
        command)
                [ ${#pos[@]} -eq 0 ] && _slctl_reply "$(_slctl_links sharedlink)" ;;
        record)
                # Any link, then the file to write (or - for standard output, typed as is).
                case ${#pos[@]} in
                0)      _slctl_reply "$(_slctl_links "")" ;;
                1)      # compopt works only inside a completion bash runs: quiet elsewhere.
                        compopt -o filenames 2>/dev/null
                        mapfile -t COMPREPLY < <(compgen -f -- "$cur") ;;
                esac ;;
        circe)
                case ${#pos[@]} in
                0)      _slctl_reply "$(_slctl_links circe)" ;;
                1)      _slctl_reply "$_slctl_circe_ops" ;;
                *)      if [ "${pos[1]}" = emulate ] && [ ${#pos[@]} -eq 2 ]; then
                                _slctl_reply "action"
                        elif [ "${pos[1]}" != sync-clocks ]; then
                                _slctl_reply "$(_slctl_devices "${pos[0]}")"
                        fi ;;
                esac ;;
        esac
        return 0
}

complete -F _slctl slctl
