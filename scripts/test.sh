#!/bin/bash
# The whole test suite: installs missing packages, builds (Release), runs the GoogleTest suite
# through CTest, the Python tests, and the format check. Exit status is non-zero on any failure.
# With UDVR_TEST_ARCHES="x86-64-v3 generic" (CI sets it) it then builds and tests those CPU
# targets too, each in its own build directory (scripts/test_arch.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
build_dir=${UDVR_BUILD_DIR:-build}
export UDVR_NO_PROGRESS=1

echo "== clang-format check" >&2
files=$(git ls-files 'src/*.cpp' 'src/*.h' 'tests/*.cpp' 'bench/*.cpp' 'fuzz/*.cpp' 'fuzz/*.h' 'paraview/*.h' 'paraview/*.cxx' 2>/dev/null || true)
if [ -n "$files" ]; then
    # shellcheck disable=SC2086
    clang-format --dry-run --Werror $files
fi

echo "== ctest" >&2
(cd "$build_dir" && ctest --output-on-failure -j "$(nproc)" --timeout 600)

if [ -d python/tests ] && ls python/tests/test_*.py >/dev/null 2>&1; then
    echo "== pytest" >&2
    UDVR_BINARY="$PWD/$build_dir/udvr" /usr/bin/python3 -m pytest -q python/tests
fi

if [ -n "${UDVR_TEST_ARCHES:-}" ]; then
    echo "== other CPU targets: $UDVR_TEST_ARCHES" >&2
    bash scripts/test_arch.sh
fi
