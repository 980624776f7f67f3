#!/bin/sh
# Installs the Debian packages refrender needs to build, run and test.
# Idempotent: does nothing when everything is present. Uses sudo when not root.
#
# usage: scripts/install-deps.sh [--cluster]
#   --cluster  also Debian's slurm-wlm and munge, for 'make test-cluster'
#              (a throwaway single-node Slurm the test starts itself). They
#              are daemons, so not in the default set: installing them
#              starts nothing here (policy-rc.d refuses service starts).
set -eu
# python3-venv, python3-pip: tests/test_python_package.py installs the refrender Python package
# (python/) into a fresh venv with pip, as the README shows
PACKAGES="build-essential libjson-c-dev libembree-dev libtbb-dev libopenexr-dev libopenimageio-dev
openimageio-tools python3 python3-openimageio libxml2-dev libpng-dev python3-numpy python3-pytest
python3-scipy python3-skimage python3-pytest-xdist python3-matplotlib parallel libassimp-dev glmark2-data
clang libclang-rt-14-dev colmap python3-venv python3-pip"
CLUSTER_PACKAGES="slurm-wlm munge"

cluster=0
case "${1:-}" in
    "") ;;
    --cluster) cluster=1 ;;
    -h|--help) sed -n '2,9p' "$0"; exit 0 ;;
    *) echo "install-deps: unknown option '$1' (try --help)" >&2; exit 2 ;;
esac
[ "$cluster" -eq 1 ] && PACKAGES="$PACKAGES $CLUSTER_PACKAGES"

missing=""
for p in $PACKAGES; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
        missing="$missing $p"
    fi
done
[ -z "$missing" ] && exit 0

echo "install-deps: installing$missing" >&2
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null 2>&1 || { echo "install-deps: need root or sudo to install:$missing" >&2; exit 1; }
    SUDO=sudo
fi
export DEBIAN_FRONTEND=noninteractive
# The cluster packages' maintainer scripts would start munge and slurmd as
# system services; the test runs its own daemons, so service starts are
# refused while they install (exit 101: "action forbidden by policy").
policy=""
if [ "$cluster" -eq 1 ] && [ ! -e /usr/sbin/policy-rc.d ]; then
    policy=/usr/sbin/policy-rc.d
    printf '#!/bin/sh\nexit 101\n' | $SUDO tee "$policy" >/dev/null
    $SUDO chmod 755 "$policy"
    trap '$SUDO rm -f "$policy"' EXIT
fi
$SUDO apt-get update -qq
# shellcheck disable=SC2086
$SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
