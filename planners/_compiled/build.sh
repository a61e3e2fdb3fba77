#!/usr/bin/env bash
# Build the compiled robot-time objective against the installed OMPL wheel (`make compiled`, README.md).
#
#   PYTHON=.venv/bin/python planners/_compiled/build.sh [OMPL_SOURCE_DIR]
#
# Needs g++ (C++17), cmake >= 3.18, Eigen's headers and Python's (Debian: g++ cmake libeigen3-dev, and
# python3-dev for Debian's own Python), pip to fetch nanobind's wheel from PyPI, and OMPL's source at the
# wheel's exact version: OMPL_SOURCE_DIR (a checkout of that tag, or its unpacked release), else downloaded
# with curl from OMPL's GitHub releases. Writes _robot_time*.so and build_info.json next to this script;
# the loader (`planners._compiled.load`) refuses them once the wheel changes. Exit 2 when a prerequisite
# is missing, with what to install.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
TOOL="$HERE/../../tools/compiled_objective.py"
PYTHON="${PYTHON:-python3}"
SRC="${1:-}"

fail() { echo "make compiled: error: $*" >&2; exit 2; }

# the prerequisites, all checked before anything is fetched or built
command -v g++ >/dev/null || fail "g++ not found (Debian: apt-get install g++)"
command -v cmake >/dev/null || fail "cmake not found (Debian: apt-get install cmake)"
CMAKE_VERSION="$(cmake --version | sed -n 's/^cmake version \([0-9.]*\).*/\1/p')"
[[ "$(printf '%s\n3.18\n' "$CMAKE_VERSION" | sort -V | head -1)" == 3.18 ]] \
  || fail "cmake $CMAKE_VERSION is older than 3.18, which the build needs"
EIGEN_FOUND=""
for dir in ${Eigen3_DIR:+"$Eigen3_DIR"} /usr/share/eigen3/cmake /usr/local/share/eigen3/cmake /usr/lib/cmake/eigen3 \
           /usr/local/lib/cmake/eigen3 /usr/local/share/cmake/Eigen3; do
  [[ -f "$dir/Eigen3Config.cmake" ]] && EIGEN_FOUND="$dir" && break
done
[[ -n "$EIGEN_FOUND" ]] || fail "Eigen's headers not found (Debian: apt-get install libeigen3-dev; or set Eigen3_DIR)"
"$PYTHON" -c 'import ompl.base' 2>/dev/null || fail "$PYTHON cannot import ompl (make install first)"
"$PYTHON" -c 'import pathlib, sysconfig; assert (pathlib.Path(sysconfig.get_paths()["include"]) / "Python.h").is_file()' \
  2>/dev/null || fail "Python.h of $PYTHON not found (Debian: apt-get install python3-dev)"
[[ -n "$SRC" ]] || command -v curl >/dev/null \
  || fail "curl not found to download OMPL's source (Debian: apt-get install curl), or pass OMPL_SRC=DIR"

WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT

# the installed wheel: its version, its directory and the nanobind registry key compiled into _ompl
read -r OMPL_VERSION OMPL_DIR < <("$PYTHON" -c '
import importlib.metadata, pathlib, ompl
print(importlib.metadata.version("ompl"), pathlib.Path(ompl.__file__).parent)')
WHEEL_KEY="$("$PYTHON" "$TOOL" key "$OMPL_DIR"/_ompl*.so)"
echo "ompl $OMPL_VERSION in $OMPL_DIR, nanobind registry key $WHEEL_KEY"

# nanobind's release of that registry version (OMPL pins its nanobind as a git submodule)
case "$WHEEL_KEY" in
  v17_*) NANOBIND=2.10.2 ;;  # OMPL 2.0.0, 2.0.1 and 2.0.2: external/nanobind at v2.10.2
  *) fail "no nanobind release known for the wheel's key $WHEEL_KEY (build.sh knows v17: nanobind 2.10.2)" ;;
esac
"$PYTHON" -m pip download --quiet --no-deps "nanobind==$NANOBIND" -d "$WORK/nb" \
  || fail "could not download nanobind==$NANOBIND from PyPI (pip download)"
"$PYTHON" -m zipfile -e "$WORK"/nb/nanobind-*.whl "$WORK/nb/x"

# OMPL's headers at the wheel's exact version (the wheel ships none), with the config.h CMake would write
if [[ -z "$SRC" ]]; then
  URL="https://github.com/ompl/ompl/archive/refs/tags/$OMPL_VERSION.tar.gz"
  echo "downloading OMPL $OMPL_VERSION's source: $URL"
  curl -fsSL --retry 2 --connect-timeout 20 "$URL" -o "$WORK/ompl.tar.gz" \
    || fail "could not download $URL; pass OMPL_SRC=DIR, a checkout of OMPL's tag $OMPL_VERSION"
  tar -xzf "$WORK/ompl.tar.gz" -C "$WORK"
  SRC="$WORK/ompl-$OMPL_VERSION"
fi
[[ -f "$SRC/CMakeLists.txt" && -f "$SRC/src/ompl/config.h.in" ]] \
  || fail "$SRC is not OMPL's source (no CMakeLists.txt and src/ompl/config.h.in)"
SRC_VERSION="$(sed -n 's/^project(ompl VERSION \([0-9.]*\).*/\1/p' "$SRC/CMakeLists.txt")"
[[ "$SRC_VERSION" == "$OMPL_VERSION" ]] \
  || fail "OMPL source $SRC is version '$SRC_VERSION', the wheel is $OMPL_VERSION (check out tag $OMPL_VERSION)"
mkdir -p "$WORK/include"
cp -r "$SRC/src/ompl" "$WORK/include/"
IFS=. read -r MAJOR MINOR PATCH <<< "$OMPL_VERSION"
sed -e "s/@PROJECT_VERSION@/$OMPL_VERSION/;s/@PROJECT_VERSION_MAJOR@/$MAJOR/" \
    -e "s/@PROJECT_VERSION_MINOR@/$MINOR/;s/@PROJECT_VERSION_PATCH@/$PATCH/" \
    -e 's/#cmakedefine01 \([A-Z_]*\)/#define \1 0/' "$SRC/src/ompl/config.h.in" > "$WORK/include/ompl/config.h"

echo "compiling (about 15 s on 2 cores)"
cmake -S "$HERE" -B "$WORK/build" -DCMAKE_BUILD_TYPE=Release -DPython_EXECUTABLE="$("$PYTHON" -c 'import sys; print(sys.executable)')" \
      -Dnanobind_DIR="$WORK/nb/x/nanobind/cmake" -DEigen3_DIR="$EIGEN_FOUND" -DOMPL_INCLUDE_DIR="$WORK/include" \
      -DOMPL_LIBRARY="$OMPL_DIR/libompl.so" -DOMPL_LIBRARY_DIR="$OMPL_DIR" > "$WORK/configure.log" 2>&1 \
  || { tail -n 30 "$WORK/configure.log" >&2; fail "cmake could not configure the build (its log above)"; }
cmake --build "$WORK/build" -j 2 > "$WORK/build.log" 2>&1 \
  || { tail -n 30 "$WORK/build.log" >&2; fail "the compile failed (its log above)"; }
BUILT="$(ls "$WORK"/build/_robot_time*.so)"
BUILT_KEY="$("$PYTHON" "$TOOL" key "$BUILT")"
[[ "$BUILT_KEY" == "$WHEEL_KEY" ]] || fail "built registry key $BUILT_KEY differs from the wheel's $WHEEL_KEY"
rm -f "$HERE"/_robot_time*.so "$HERE/build_info.json"
cp "$BUILT" "$HERE/"
"$PYTHON" "$TOOL" record "$HERE/build_info.json" "$OMPL_VERSION" "$WHEEL_KEY" "$OMPL_DIR/libompl.so"
PYTHONPATH="$(dirname "$(dirname "$HERE")")${PYTHONPATH:+:$PYTHONPATH}" "$PYTHON" -c '
import sys
from planners._compiled import load
why = load()[1]
sys.exit(why or None)' || fail "the built objective does not load (the reason above)"
echo "built $(basename "$BUILT") for ompl $OMPL_VERSION ($WHEEL_KEY): planners use it (objective_impl=auto)"
