#!/bin/sh
# Renders one image as N passes with GNU parallel, locally or on ssh hosts,
# and merges them: the result is bit-identical to a single render with the
# same --batches (each pass renders whole batches; see README).
#
# usage: scripts/render-parallel.sh N OUT.exr [--sshloginfile FILE] -- REFRENDER-ARGS...
#   REFRENDER-ARGS must include --batches B with B >= N, and the scene.
#   With --sshloginfile, every host must see the same paths (shared file
#   system) and have refrender at the same location; ':' in the file means
#   this machine too (GNU parallel's syntax).
# Environment: REFRENDER (default: build/refrender beside this script's tree).
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
REFRENDER=${REFRENDER:-$here/build/refrender}
[ $# -ge 3 ] || { sed -n '5,12p' "$0" >&2; exit 2; }
n=$1 out=$2
shift 2
hosts=""
if [ "$1" = "--sshloginfile" ]; then
    hosts="--sshloginfile $2"
    shift 2
fi
[ "$1" = "--" ] && shift
parts=$(mktemp -d "$(dirname "$out")/.passes.XXXXXX")
trap 'rm -rf "$parts"' EXIT
# shellcheck disable=SC2086
seq 0 $((n - 1)) | parallel --halt now,fail=1 $hosts \
    "$REFRENDER" "$@" --quiet --pass {}/"$n" -o "$parts/pass{}.exr"
"$REFRENDER" merge "$parts"/pass*.exr -o "$out"
