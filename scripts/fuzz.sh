#!/bin/bash
# Builds the readers' libFuzzer targets (Clang with ASan and UBSan, -DUDVR_FUZZ=ON in
# build-fuzz/) and runs each for a fixed time, starting from its committed seed corpus
# (fuzz/corpus/<target>) and the inputs of past findings (fuzz/regressions/<target>). Exit
# status 1 when any target found a crash, a sanitizer report, a timeout, a leak, or a reader
# error that is not one clean line (fuzz/fuzz_target.h); docs/testing.md says more.
#   bash scripts/fuzz.sh [SECONDS] [TARGET...]   every target (or those named), SECONDS each (30)
#   bash scripts/fuzz.sh --list                  the targets
#   bash scripts/fuzz.sh --corpus                rewrite fuzz/corpus/ with udvr_fuzz_corpus (needs
#                                                the normal build in $UDVR_BUILD_DIR, default build)
# Environment: UDVR_FUZZ_JOBS targets at once (default 1), UDVR_FUZZ_BUILD_DIR (build-fuzz),
# UDVR_FUZZ_ARGS more libFuzzer flags (e.g. "-runs=1000000" instead of a time).
# Inputs that reach new code stay in build-fuzz/corpus/<target> (not committed; later runs start
# from them too); a finding's input is build-fuzz/findings/<target>/crash-… (or timeout-, leak-,
# oom-), its log build-fuzz/logs/<target>.log; the last lines of each log give the exec counts,
# summed up in build-fuzz/fuzz-summary.txt.
set -euo pipefail
cd "$(dirname "$0")/.."

targets_all=(raw nrrd vti model netcdf ensemble tf_json tf2_vti tf2_json npy image)
build_dir=${UDVR_FUZZ_BUILD_DIR:-build-fuzz}

if [ "${1:-}" = "--list" ]; then
    printf '%s\n' "${targets_all[@]}"
    exit 0
fi
if [ "${1:-}" = "--corpus" ]; then
    dir=${UDVR_BUILD_DIR:-build}
    cmake --build "$dir" --target udvr_fuzz_corpus -j "$(nproc)" >&2
    rm -rf fuzz/corpus
    "$dir/fuzz/udvr_fuzz_corpus" fuzz/corpus
    du -sh fuzz/corpus
    exit 0
fi

seconds=30
if [[ "${1:-}" =~ ^[0-9]+$ ]]; then
    seconds=$1
    shift
fi
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=("${targets_all[@]}")
for t in "${targets[@]}"; do
    [[ " ${targets_all[*]} " == *" $t "* ]] || {
        echo "fuzz: unknown target '$t' (--list names them)" >&2
        exit 2
    }
done
jobs=${UDVR_FUZZ_JOBS:-1}

cxx=$(command -v clang++ || command -v clang++-14 || true)
if [ -z "$cxx" ]; then
    echo "fuzz: no clang++ (Debian: apt-get install clang libclang-rt-14-dev)" >&2
    exit 2
fi
echo "== fuzz: build ($cxx, ASan + UBSan + libFuzzer) in $build_dir" >&2
start=$SECONDS
mkdir -p "$build_dir"
cmake -S . -B "$build_dir" -DUDVR_FUZZ=ON -DCMAKE_CXX_COMPILER="$cxx" \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo >"$build_dir/cmake.log" 2>&1 || {
    cat "$build_dir/cmake.log" >&2
    exit 1
}
cmake --build "$build_dir" -j "$(nproc)" --target "${targets[@]/#/udvr_fuzz_}" >&2
echo "== fuzz: built in $((SECONDS - start)) s; ${#targets[@]} targets, ${seconds} s each," \
    "$jobs at a time" >&2

symbolizer=$(command -v llvm-symbolizer || command -v llvm-symbolizer-14 || true)
# A small quarantine: less memory for every fork of the netcdf targets' HDF5 probe (127 against
# 98 executions a second with the default 256 MB).
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0:quarantine_size_mb=16}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/fuzz/lsan.supp:print_suppressions=0}
[ -z "$symbolizer" ] || export ASAN_SYMBOLIZER_PATH=$symbolizer
# Scratch files of the targets: memory, not disk, where there is /dev/shm.
if [ -z "${TMPDIR:-}" ] && [ -d /dev/shm ] && [ -w /dev/shm ]; then export TMPDIR=/dev/shm; fi

# One target: prints "target execs exec/s seconds new-units result".
run_target() {
    local t=$1
    local corpus=$build_dir/corpus/$t findings=$build_dir/findings/$t log=$build_dir/logs/$t.log
    mkdir -p "$corpus" "$findings" "$build_dir/logs"
    local seeds=(fuzz/corpus/"$t")
    [ ! -d fuzz/regressions/"$t" ] || seeds+=(fuzz/regressions/"$t")
    local dict=()
    case "$t" in
        vti | model | tf2_vti) dict=(-dict=fuzz/dicts/vtk_xml.dict) ;;
        nrrd) dict=(-dict=fuzz/dicts/nrrd.dict) ;;
        tf_json | tf2_json) dict=(-dict=fuzz/dicts/json.dict) ;;
    esac
    # netCDF-C and HDF5 leak on the error paths of most damaged files (suppressed in
    # fuzz/lsan.supp), and libFuzzer then scans the heap for leaks after each such input: 55 % of
    # the netcdf target's time. Leaks are checked by the other targets.
    case "$t" in
        netcdf | ensemble) dict+=(-detect_leaks=0) ;;
    esac
    local rc=0 t0=$SECONDS
    # shellcheck disable=SC2086
    "$build_dir/fuzz/udvr_fuzz_$t" -max_total_time="$seconds" -timeout=20 -rss_limit_mb=2560 \
        -malloc_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$findings/" \
        "${dict[@]}" ${UDVR_FUZZ_ARGS:-} "$corpus" "${seeds[@]}" >"$log" 2>&1 || rc=$?
    local execs rate units
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
    rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
    units=$(sed -n 's/^stat::new_units_added: *//p' "$log" | tail -1)
    local result=ok
    [ "$rc" -eq 0 ] || result="FAILED(exit $rc; $log)"
    printf '%-9s %10s %7s %5s %5s %s\n' "$t" "${execs:-?}" "${rate:-?}" $((SECONDS - t0)) \
        "${units:-?}" "$result"
}

summary=$build_dir/fuzz-summary.txt
printf '%-9s %10s %7s %5s %5s %s\n' target execs exec/s s new result >"$summary"
failed=0
running=0
for t in "${targets[@]}"; do
    if [ "$running" -ge "$jobs" ]; then
        wait -n || true
        running=$((running - 1))
    fi
    run_target "$t" >>"$summary" &
    running=$((running + 1))
done
wait || true
cat "$summary" >&2
if grep -q FAILED "$summary"; then
    failed=1
    for log in $(sed -n 's/.*FAILED(exit [0-9]*; \(.*\))$/\1/p' "$summary"); do
        echo "== fuzz: $log (last lines)" >&2
        grep -v '^#\|^INFO:\|^stat::' "$log" | tail -40 >&2
    done
fi
exit $failed
