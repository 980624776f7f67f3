#!/bin/sh
# Installs the Debian packages refrender needs to build, run and test.
# Idempotent: does nothing when everything is present. Uses sudo when not root.
set -eu
PACKAGES="build-essential libjson-c-dev libembree-dev libtbb-dev libopenexr-dev libopenimageio-dev
openimageio-tools python3 python3-openimageio libxml2-dev python3-numpy python3-pytest
python3-scipy python3-skimage python3-pytest-xdist python3-matplotlib parallel libassimp-dev glmark2-data
clang libclang-rt-14-dev"

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
$SUDO apt-get update -qq
# shellcheck disable=SC2086
$SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
