#!/bin/bash
# Builds Mesquite (trilinos/mesquite, Release, static library) and the timing
# driver mq_driver next to this script, for side_by_side.sh.
#   env: MESQUITE_SRC=<checkout> (default: cloned into ./src)  MESQUITE_BUILD=<dir> (./build)
# Needs git, cmake, make and a C++ compiler; about 5 minutes on two cores.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
SRC=${MESQUITE_SRC:-$HERE/src}
BUILD=${MESQUITE_BUILD:-$HERE/build}
COMMIT=ea2fc2a76e9930e09449255d97a37ece095d72ad
if [ ! -d "$SRC" ]; then
  # meshFiles/ and demos/ hold large blobs the library does not need
  git clone --no-checkout https://github.com/trilinos/mesquite "$SRC"
  git -C "$SRC" sparse-checkout set --no-cone '/*' '!/meshFiles/' '!/demos/'
  git -C "$SRC" checkout -q "$COMMIT"
fi
# TRIBITS_EXCLUDE_FILES exists only inside a Trilinos build: skip it standalone
sed -i 's/^IF(NOT WIN32 AND NOT WIN64)$/IF(COMMAND TRIBITS_EXCLUDE_FILES AND NOT WIN32 AND NOT WIN64)/' "$SRC/CMakeLists.txt"
mkdir -p "$BUILD"
(cd "$BUILD" && cmake "$SRC" -DCMAKE_BUILD_TYPE=Release >/dev/null && make -j"$(nproc)" mesquite >/dev/null)
includes=(-I"$BUILD/src/include")
while IFS= read -r d; do includes+=(-I"$d"); done < <(find "$SRC/src" -type d)
g++ -O3 -DNDEBUG -std=c++11 "${includes[@]}" "$HERE/driver.cpp" "$BUILD/src/libmesquite.a" -o "$HERE/mq_driver"
echo "built $HERE/mq_driver"
