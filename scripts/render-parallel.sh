#!/bin/sh
# Renders one image as N passes with GNU parallel, locally or on ssh hosts,
# and merges them: the result is bit-identical to a single render with the
# same --batches (each pass renders whole batches; see README).
#
# usage: scripts/render-parallel.sh N OUT.exr [--sshloginfile FILE] [--jobs-per-host J] -- REFRENDER-ARGS...
#   REFRENDER-ARGS must include --batches B with B >= N, and the scene.
#   Each host runs J passes at a time (default 1), each with its cores / J
#   threads, so a host never runs more render threads than it has cores.
#   With --sshloginfile, every host must see the same paths (shared file
#   system) and have refrender at the same location; ':' in the file means
#   this machine too (GNU parallel's syntax).
# Environment: REFRENDER (default: build/refrender beside this script's tree).
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
REFRENDER=${REFRENDER:-$here/build/refrender}
[ $# -ge 3 ] || { sed -n '5,14p' "$0" >&2; exit 2; }
n=$1 out=$2
shift 2
hosts="" per_host=1
while [ $# -gt 0 ] && [ "$1" != "--" ]; do
    case $1 in
        --sshloginfile) hosts="--sshloginfile $2"; shift 2 ;;
        --jobs-per-host)
            case $2 in ""|*[!0-9]*|0) echo "render-parallel: --jobs-per-host: expected a count, got '$2'" >&2; exit 2 ;; esac
            per_host=$2; shift 2 ;;
        *) break ;;
    esac
done
[ "$1" = "--" ] && shift
parts=$(mktemp -d "$(dirname "$out")/.passes.XXXXXX")
trap 'rm -rf "$parts"' EXIT
# The thread count is worked out on the host that runs the pass (GNU
# parallel hands the command to a shell there): its own cores / J.
# shellcheck disable=SC2086,SC2016
seq 0 $((n - 1)) | parallel --halt now,fail=1 -j "$per_host" $hosts \
    "$REFRENDER" "$@" --quiet --threads '$(( $(nproc) / '"$per_host"' > 0 ? $(nproc) / '"$per_host"' : 1 ))' \
    --pass {}/"$n" -o "$parts/pass{}.exr"
"$REFRENDER" merge "$parts"/pass*.exr -o "$out"
