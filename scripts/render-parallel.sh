#!/bin/bash
# Renders one image as N passes with GNU parallel, locally or on ssh hosts,
# and merges them: the result is bit-identical to a single render with the
# same --batches (each pass renders whole batches; see README).
#
# usage: scripts/render-parallel.sh N OUT.exr [--sshloginfile FILE] [--jobs-per-host J] -- REFRENDER-ARGS...
#   REFRENDER-ARGS must include --batches B with B >= N, and the scene.
#   Each host runs J passes at a time (default 1), each with its cores / J
#   threads, so a host never runs more render threads than it has cores.
#   With --sshloginfile, every host must see the same paths (shared file
#   system) and have refrender and this script at the same locations; ':' in
#   the file means this machine too (GNU parallel's syntax).
#   N and J are decimal counts (08 is 8). REFRENDER-ARGS reach refrender
#   word for word (spaces, quotes, ';' are not interpreted by any shell).
# Environment: REFRENDER (default: build/refrender beside this script's tree).
#
# Internal: `render-parallel.sh --run-pass K` is what each parallel job runs
# on its host: pass K with that host's cores / J threads. GNU parallel hands
# every job to a shell (locally and over ssh) and reads replacement strings
# ({}, {= perl =}) in its command, so no argument of the user's is written
# into that command: they go through a file (NUL-separated, in the passes'
# directory beside OUT) and the environment (--env), word for word.
set -eu

usage() { sed -n '6,15p' "$0" >&2; exit 2; }
die() { echo "render-parallel: $*" >&2; exit 2; }

# A count >= 1, read as decimal whatever zeros it starts with (the shell's
# arithmetic would read 08 as an error and 010 as 8); at most 9 digits.
count() {
    local what=$1 value=$2
    [[ $value =~ ^0*([0-9]{1,9})$ ]] && ((10#${BASH_REMATCH[1]} > 0)) ||
        die "$what: expected a count from 1 to 999999999, got '$value'"
    echo $((10#${BASH_REMATCH[1]}))
}

if [ "${1:-}" = "--run-pass" ]; then
    [[ ${2:-} =~ ^[0-9]{1,9}$ ]] || die "--run-pass: expected a pass index, got '${2:-}'"
    pass=$((10#$2))
    mapfile -d '' args < "$RP_PARTS/arguments"
    threads=$(($(nproc) / RP_PER_HOST))
    exec "$RP_REFRENDER" "${args[@]}" --quiet --threads $((threads > 0 ? threads : 1)) \
        --pass "$pass/$RP_PASSES" -o "$RP_PARTS/pass$pass.exr"
fi

here=$(cd "$(dirname "$0")/.." && pwd)
self=$here/scripts/$(basename "$0")
REFRENDER=${REFRENDER:-$here/build/refrender}
[ $# -ge 3 ] || usage
n=$(count "N (the number of passes)" "$1") out=$2
shift 2
hosts=() per_host=1
while [ $# -gt 0 ] && [ "$1" != "--" ]; do
    case $1 in
        --sshloginfile) [ $# -ge 2 ] || usage; hosts=(--sshloginfile "$2"); shift 2 ;;
        --jobs-per-host) [ $# -ge 2 ] || usage; per_host=$(count --jobs-per-host "$2"); shift 2 ;;
        *) break ;;
    esac
done
[ $# -gt 0 ] && [ "$1" = "--" ] && shift
[ $# -gt 0 ] || die "no refrender arguments (the scene and --batches B) after --"
parts=$(mktemp -d "$(dirname "$out")/.passes.XXXXXX")
trap 'rm -rf "$parts"' EXIT
printf '%s\0' "$@" > "$parts/arguments"
export RP_PARTS=$parts RP_REFRENDER=$REFRENDER RP_PER_HOST=$per_host RP_PASSES=$n
seq 0 $((n - 1)) | parallel -q --halt now,fail=1 -j "$per_host" "${hosts[@]}" \
    --env RP_PARTS --env RP_REFRENDER --env RP_PER_HOST --env RP_PASSES "$self" --run-pass
"$REFRENDER" merge "$parts"/pass*.exr -o "$out"
