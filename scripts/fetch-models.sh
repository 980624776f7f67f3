#!/bin/sh
# Fetches the real scanned models from Debian packages and converts them to
# surfel PLY files in scenes/models/ (cached: existing files are kept).
#   bunny.ply      glmark2-data: /usr/share/glmark2/models/bunny.obj (installed
#                  by scripts/install-deps.sh)
#   armadillo.ply, bunny00.ply, kitten.ply
#                  libcgal-demo: data.tar.gz, fetched with 'apt-get download'
#                  and unpacked with dpkg-deb, never installed
# Nothing downloaded is committed (scenes/models/ is ignored by git). The
# unpacked CGAL data stays in scenes/models/download/ ('make clean' keeps it,
# 'make clean-models' removes it): with the models present nothing is fetched.
set -eu
cd "$(dirname "$0")/.."
BIN=${REFRENDER:-build/refrender}
OUT=scenes/models
CACHE=scenes/models/download
mkdir -p "$OUT" "$CACHE"

convert() { # convert INPUT NAME [options]: scenes/models/NAME.ply unless present
    in=$1 name=$2
    shift 2
    [ -s "$OUT/$name.ply" ] && return 0
    "$BIN" surfels "$in" -o "$OUT/$name.ply" "$@"
}

cgal_data() { # unpack the three CGAL data files into $CACHE/cgal (unless converted already)
    [ -s "$OUT/armadillo.ply" ] && [ -s "$OUT/bunny00.ply" ] && [ -s "$OUT/kitten.ply" ] && return 0
    [ -s "$CACHE/cgal/data/points_3/kitten.xyz" ] && return 0
    rm -rf "$CACHE/cgal" && mkdir -p "$CACHE/cgal"
    if ! (cd "$CACHE/cgal" && apt-get download libcgal-demo >/dev/null 2>&1); then
        SUDO=""
        [ "$(id -u)" -ne 0 ] && SUDO=sudo
        { $SUDO apt-get update -qq && (cd "$CACHE/cgal" && apt-get download libcgal-demo >/dev/null); } || {
            echo "fetch-models.sh: cannot download Debian's libcgal-demo (offline? apt's message above):" \
                 "$OUT/armadillo.ply, bunny00.ply and kitten.ply need it, and the scenes and tests that use them;" \
                 "retry online, or copy $OUT/ from a machine that has them (then nothing is fetched)" >&2
            exit 1
        }
    fi
    dpkg-deb -x "$CACHE"/cgal/libcgal-demo_*.deb "$CACHE/cgal/deb"
    tar -xzf "$CACHE/cgal/deb/usr/share/doc/libcgal-dev/data.tar.gz" -C "$CACHE/cgal" \
        data/meshes/armadillo.off data/meshes/bunny00.off data/points_3/kitten.xyz
    rm -rf "$CACHE/cgal/deb" "$CACHE"/cgal/*.deb
}

convert /usr/share/glmark2/models/bunny.obj bunny --fit 1 --checker 0.25 --color "0.85 0.8 0.7" --color2 "0.35 0.3 0.25"
cgal_data
convert "$CACHE/cgal/data/meshes/armadillo.off" armadillo --fit 1 --checker 0.2 --color "0.8 0.55 0.3" --color2 "0.3 0.2 0.15"
convert "$CACHE/cgal/data/meshes/bunny00.off" bunny00 --fit 1 --checker 0.25 --color "0.6 0.75 0.9" --color2 "0.2 0.3 0.45"
convert "$CACHE/cgal/data/points_3/kitten.xyz" kitten --fit 1 --checker 0.2 --color "0.9 0.85 0.5" --color2 "0.4 0.3 0.2"
# the bunny as a trained 2DGS model's PLY (SH degree 3), for scenes/gaussians.xml
convert /usr/share/glmark2/models/bunny.obj bunny_2dgs --fit 1 --checker 0.25 --color "0.85 0.8 0.7" \
    --color2 "0.35 0.3 0.25" --gaussians 2dgs --sh-degree 3
# and as a 3DGS model, for scenes/gaussian_semantics.xml
convert /usr/share/glmark2/models/bunny.obj bunny_3dgs --fit 1 --checker 0.25 --color "0.85 0.8 0.7" \
    --color2 "0.35 0.3 0.25" --gaussians 3dgs --sh-degree 3
