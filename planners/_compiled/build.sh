#!/usr/bin/env bash
# Build the compiled robot-time objective against the installed OMPL wheel (see README.md).
#
#   PYTHON=.venv/bin/python planners/_compiled/build.sh [OMPL_SOURCE_DIR]
#
# Needs g++ (C++17), cmake >= 3.18, Eigen's headers (Debian: libeigen3-dev) and, for what it fetches,
# pip (nanobind's wheel) and curl (OMPL's source at the wheel's version, unless OMPL_SOURCE_DIR is given:
# a checkout or an unpacked release of that exact tag). Writes _robot_time*.so and build_info.json next
# to this script; the loader (`planners._compiled.load`) refuses them once the wheel changes.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
PYTHON="${PYTHON:-python3}"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT

# the installed wheel: its version, its directory and the nanobind registry key compiled into _ompl
read -r OMPL_VERSION OMPL_DIR < <("$PYTHON" -c '
import importlib.metadata, pathlib, ompl
print(importlib.metadata.version("ompl"), pathlib.Path(ompl.__file__).parent)')
WHEEL_KEY="$("$PYTHON" "$HERE/abi_key.py" "$OMPL_DIR"/_ompl*.so)"
echo "ompl $OMPL_VERSION in $OMPL_DIR, nanobind registry key $WHEEL_KEY"

# nanobind's release of that registry version (OMPL pins its nanobind as a git submodule)
case "$WHEEL_KEY" in
  v17_*) NANOBIND=2.10.2 ;;  # OMPL 2.0.0, 2.0.1 and 2.0.2's draft: external/nanobind at v2.10.2
  *) echo "build.sh: error: no nanobind release known for the wheel's key $WHEEL_KEY" >&2; exit 2 ;;
esac
"$PYTHON" -m pip download --quiet --no-deps "nanobind==$NANOBIND" -d "$WORK/nb"
"$PYTHON" -m zipfile -e "$WORK"/nb/nanobind-*.whl "$WORK/nb/x"

# OMPL's headers at the wheel's exact version (the wheel ships none), with the config.h CMake would write
SRC="${1:-}"
if [[ -z "$SRC" ]]; then
  curl -fsSL "https://github.com/ompl/ompl/archive/refs/tags/$OMPL_VERSION.tar.gz" | tar -xz -C "$WORK"
  SRC="$WORK/ompl-$OMPL_VERSION"
fi
SRC_VERSION="$(sed -n 's/^project(ompl VERSION \([0-9.]*\).*/\1/p' "$SRC/CMakeLists.txt")"
if [[ "$SRC_VERSION" != "$OMPL_VERSION" ]]; then
  echo "build.sh: error: OMPL source $SRC is version '$SRC_VERSION', the wheel is $OMPL_VERSION" >&2; exit 2
fi
mkdir -p "$WORK/include"
cp -r "$SRC/src/ompl" "$WORK/include/"
IFS=. read -r MAJOR MINOR PATCH <<< "$OMPL_VERSION"
sed -e "s/@PROJECT_VERSION@/$OMPL_VERSION/;s/@PROJECT_VERSION_MAJOR@/$MAJOR/" \
    -e "s/@PROJECT_VERSION_MINOR@/$MINOR/;s/@PROJECT_VERSION_PATCH@/$PATCH/" \
    -e 's/#cmakedefine01 \([A-Z_]*\)/#define \1 0/' "$SRC/src/ompl/config.h.in" > "$WORK/include/ompl/config.h"

cmake -S "$HERE" -B "$WORK/build" -DCMAKE_BUILD_TYPE=Release -DPython_EXECUTABLE="$("$PYTHON" -c 'import sys; print(sys.executable)')" \
      -Dnanobind_DIR="$WORK/nb/x/nanobind/cmake" -DOMPL_INCLUDE_DIR="$WORK/include" \
      -DOMPL_LIBRARY="$OMPL_DIR/libompl.so" -DOMPL_LIBRARY_DIR="$OMPL_DIR" > "$WORK/configure.log"
cmake --build "$WORK/build" -j 2 > "$WORK/build.log"
BUILT="$(ls "$WORK"/build/_robot_time*.so)"
BUILT_KEY="$("$PYTHON" "$HERE/abi_key.py" "$BUILT")"
if [[ "$BUILT_KEY" != "$WHEEL_KEY" ]]; then
  echo "build.sh: error: built registry key $BUILT_KEY differs from the wheel's $WHEEL_KEY" >&2; exit 2
fi
cp "$BUILT" "$HERE/"
"$PYTHON" "$HERE/abi_key.py" --record "$HERE/build_info.json" "$OMPL_VERSION" "$WHEEL_KEY" "$OMPL_DIR/libompl.so"
echo "built $(basename "$BUILT") for ompl $OMPL_VERSION ($WHEEL_KEY)"
