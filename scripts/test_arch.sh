#!/bin/bash
# Builds and tests udvr for other CPU targets (CMake's UDVR_ARCH), each in its own Release build
# directory build-arch-<v3|v4|generic|native>: only udvr, udvr_test and the Python module (no
# benchmarks), then CTest and the Python reference tests with that build's binary and module.
#   bash scripts/test_arch.sh x86-64-v3 generic     (default: the targets in $UDVR_TEST_ARCHES)
# A target this CPU cannot run is skipped with a message. Needs the packages of scripts/setup.sh.
set -euo pipefail
cd "$(dirname "$0")/.."

arches=("$@")
if [ ${#arches[@]} -eq 0 ]; then
    read -r -a arches <<<"${UDVR_TEST_ARCHES:-}"
fi
if [ ${#arches[@]} -eq 0 ]; then
    echo "test_arch: no CPU targets given (arguments or UDVR_TEST_ARCHES)" >&2
    exit 2
fi
jobs=$(nproc)
export UDVR_NO_PROGRESS=1

# The /proc/cpuinfo flags each x86-64 level needs (x86-64-v4 = v3 + the AVX-512 ones).
v3_flags="avx avx2 bmi1 bmi2 f16c fma abm movbe xsave"
v4_flags="$v3_flags avx512f avx512bw avx512cd avx512dq avx512vl"
cpu_flags=" $(grep -m1 '^flags' /proc/cpuinfo 2>/dev/null | cut -d: -f2) "

# Prints why this machine cannot run `arch` (nothing when it can).
cannot_run() {
    local need=""
    case "$1" in
        native | generic) return 0 ;;
        x86-64-v3) need=$v3_flags ;;
        x86-64-v4) need=$v4_flags ;;
    esac
    case "$(uname -m)" in
        x86_64 | amd64) ;;
        *)
            echo "not an x86-64 machine ($(uname -m))"
            return 0
            ;;
    esac
    local missing=""
    for f in $need; do
        [[ "$cpu_flags" == *" $f "* ]] || missing="$missing $f"
    done
    [ -z "$missing" ] || echo "the CPU lacks$missing"
}

for arch in "${arches[@]}"; do
    case "$arch" in
        native | x86-64-v4 | x86-64-v3 | generic) ;;
        *)
            echo "test_arch: unknown CPU target '$arch' (native, x86-64-v4, x86-64-v3, generic)" >&2
            exit 2
            ;;
    esac
done

# The vector instruction set of the main build (-march=native), from `udvr --version`: a target
# whose lanes would be the same code path (x86-64-v3 on a CPU with AVX2 but no AVX-512) is
# already tested by scripts/test.sh's ctest and pytest, and is skipped (~8 min of CI on 2 cores).
main_binary=${UDVR_BUILD_DIR:-build}/udvr
main_isa=""
if [ -x "$main_binary" ]; then
    main_isa=$("$main_binary" --version 2>/dev/null | sed -n 's/.*(target native: \([^,]*\),.*/\1/p')
fi
# The vector instruction set a target compiles to (util/build_info.h's UDVR_BUILD_ISA).
isa_of() {
    case "$1" in
        x86-64-v4) echo "AVX-512" ;;
        x86-64-v3) echo "AVX2+FMA" ;;
        *) echo "" ;;
    esac
}

for arch in "${arches[@]}"; do
    if [ -n "$main_isa" ] && [ "$(isa_of "$arch")" = "$main_isa" ] && [ -z "${UDVR_TEST_SAME_ISA:-}" ]; then
        echo "== arch $arch: skipped: the main build ($main_binary, -march=native) already runs its $main_isa lanes (UDVR_TEST_SAME_ISA=1 builds it anyway)" >&2
        continue
    fi
    why=$(cannot_run "$arch")
    if [ -n "$why" ]; then
        echo "== arch $arch: skipped: $why" >&2
        continue
    fi
    dir=build-arch-${arch#x86-64-}
    echo "== arch $arch: configure and build in $dir (-j$jobs)" >&2
    start=$SECONDS
    # The baseline build also goes without MPI (-DUDVR_MPI=OFF), as where MPI is not installed.
    mpi=()
    [ "$arch" != generic ] || mpi=(-DUDVR_MPI=OFF)
    cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=Release -DUDVR_ARCH="$arch" \
        -DUDVR_WERROR="${UDVR_WERROR:-OFF}" -DUDVR_BUILD_TESTS=ON -DUDVR_BUILD_BENCH=OFF \
        -DUDVR_PARAVIEW=OFF "${mpi[@]}" >&2
    targets=(udvr udvr_test udvr_core_only_test)
    python_module=no
    if grep -q '/udvr_python\.dir$' "$dir/CMakeFiles/TargetDirectories.txt"; then
        targets+=(udvr_python)
        python_module=yes
    fi
    # ctest replays the fuzz corpora with this driver (fuzz/CMakeLists.txt).
    if grep -q '/udvr_fuzz_replay\.dir$' "$dir/CMakeFiles/TargetDirectories.txt"; then
        targets+=(udvr_fuzz_replay)
    fi
    cmake --build "$dir" -j "$jobs" --target "${targets[@]}" >&2
    built=$SECONDS
    echo "== arch $arch: $("$dir/udvr" --version); built in $((built - start)) s" >&2

    echo "== arch $arch: ctest" >&2
    (cd "$dir" && ctest --output-on-failure -j "$jobs" --timeout 600)
    if [ $python_module = no ]; then
        echo "== arch $arch: pytest skipped: no Python module (pybind11 not found)" >&2
    else
        echo "== arch $arch: pytest (reference render and probe)" >&2
        UDVR_BUILD_DIR="$PWD/$dir" UDVR_BINARY="$PWD/$dir/udvr" /usr/bin/python3 -m pytest -q \
            python/tests/test_reference_render.py python/tests/test_reference_probe.py \
            python/tests/test_reference2d_cli.py python/tests/test_reference_bivariate.py \
            python/tests/test_build_info.py python/tests/test_quantile_levels.py
    fi
    echo "== arch $arch: passed (build $((built - start)) s, tests $((SECONDS - built)) s)" >&2
done
