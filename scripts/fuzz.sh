#!/usr/bin/env bash
# Builds the libFuzzer harnesses of tests/fuzz with clang (ASan + UBSan) and runs each on
# its checked-in corpus for a bounded time (docs/fuzzing.md). Fails on any crash, leak,
# sanitizer report, timeout or failed check, and prints each harness's figures.
#
#   scripts/fuzz.sh [SECONDS_EACH] [HARNESS...] [HARNESS=SECONDS...]
#   scripts/fuzz.sh --build-only
#   scripts/fuzz.sh --pack [HARNESS...]
#
# Default: 15 s each, every harness (the ones named, when some are). HARNESS=SECONDS gives
# one harness its own time. --build-only builds the harnesses and runs none (the README's
# test command builds them with everything else, so that ctest only fuzzes). --pack merges
# the checked-in seeds and the grown corpus into the smallest set with the same coverage
# (libFuzzer's -merge=1) and writes it to tests/fuzz/corpus/NAME.tar.gz, which every run
# starts from.
#
# CAMLAB_FUZZ_BUILD_DIR (default build/fuzz) holds the build, the corpus each run grows
# (corpus/NAME, never the checked-in one; unpacked from NAME.tar.gz when empty) and any
# crashing input (artifacts/).
set -euo pipefail
cd "$(dirname "$0")/.."
mode=fuzz
case "${1:-}" in
  --build-only) mode=build; shift ;;
  --pack) mode=pack; shift ;;
esac
seconds=15
if [ "$mode" = fuzz ] && [ $# -gt 0 ]; then seconds="$1"; shift; fi
build_dir="${CAMLAB_FUZZ_BUILD_DIR:-build/fuzz}"
all=(api_request camera_spec scene_spec corners_vnl frame_journal capture_folder broker_protocol)
# Plain names choose the harnesses (every one when none is named); NAME=SECONDS sets a time.
harnesses=()
declare -A seconds_of
for h in "${all[@]}"; do seconds_of[$h]="$seconds"; done
for item in "$@"; do
  h="${item%%=*}"
  [ -n "${seconds_of[$h]+set}" ] || { echo "fuzz: no harness named '$h' (${all[*]})" >&2; exit 2; }
  if [ "$item" != "$h" ]; then seconds_of[$h]="${item#*=}"; else harnesses+=("$h"); fi
done
[ "${#harnesses[@]}" -gt 0 ] || harnesses=("${all[@]}")

cxx=""
for candidate in clang++ clang++-14; do
  if command -v "$candidate" >/dev/null; then cxx="$candidate"; break; fi
done
if [ -z "$cxx" ]; then
  echo "fuzz: no clang++; install clang-14 and libclang-rt-14-dev (scripts/install-deps.sh)" >&2
  exit 1
fi
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)

cmake -S tests/fuzz -B "$build_dir" -DCMAKE_CXX_COMPILER="$cxx" "${launcher[@]}" >/dev/null
targets=()
for h in "${harnesses[@]}"; do targets+=(--target "fuzz_$h"); done
build_start=$SECONDS
cmake --build "$build_dir" -j "$(nproc)" "${targets[@]}" >"$build_dir/build.log" 2>&1 ||
  { cat "$build_dir/build.log" >&2; exit 1; }
echo "fuzz: built ${#harnesses[@]} harnesses with $cxx in $((SECONDS - build_start)) s"
[ "$mode" != build ] || exit 0

mkdir -p "$build_dir/artifacts"
# The capture_folder harness writes its folders here (tmpfs when there is one), removed at exit.
scratch_base=/dev/shm
[ -d "$scratch_base" ] && [ -w "$scratch_base" ] || scratch_base="${TMPDIR:-/tmp}"
CAMLAB_FUZZ_SCRATCH=$(mktemp -d "$scratch_base/camlab-fuzz-XXXXXX")
export CAMLAB_FUZZ_SCRATCH
trap 'rm -rf "$CAMLAB_FUZZ_SCRATCH"' EXIT

if [ "$mode" = pack ]; then
  for h in "${harnesses[@]}"; do
    merged="$CAMLAB_FUZZ_SCRATCH/merged-$h"
    mkdir -p "$merged" "$build_dir/corpus/$h"
    "$build_dir/fuzz_$h" -merge=1 -timeout=10 -rss_limit_mb=2048 -max_len=16384 "$merged" \
      "tests/fuzz/corpus/$h" "$build_dir/corpus/$h" >"$build_dir/$h-merge.log" 2>&1 ||
      { tail -n 30 "$build_dir/$h-merge.log" >&2; exit 1; }
    # Reproducible bytes: sorted names, no owners or times, gzip without a name or time.
    tar -C "$merged" --sort=name --owner=0 --group=0 --numeric-owner --mtime=@0 -cf - . |
      gzip -9n >"tests/fuzz/corpus/$h.tar.gz"
    echo "fuzz: packed $(ls "$merged" | wc -l) inputs of $h into tests/fuzz/corpus/$h.tar.gz" \
      "($(stat -c %s "tests/fuzz/corpus/$h.tar.gz") bytes)"
  done
  exit 0
fi
failed=0
printf '%-16s %6s %10s %8s %6s %7s %8s  %s\n' harness seconds execs exec/s cov ft corpus result
for h in "${harnesses[@]}"; do
  seeds="tests/fuzz/corpus/$h"
  work="$build_dir/corpus/$h"
  log="$build_dir/$h.log"
  mkdir -p "$work"
  # A fresh build starts from the packed corpus (--pack), not from the seeds alone.
  if [ -f "$seeds.tar.gz" ] && [ -z "$(ls -A "$work")" ]; then
    tar -C "$work" -xzf "$seeds.tar.gz"
  fi
  status=ok
  # The grown corpus first (libFuzzer adds new inputs there), the checked-in seeds second.
  # -timeout: an input that takes 10 s is a hang; -rss_limit_mb: a blow-up is a finding.
  "$build_dir/fuzz_$h" -max_total_time="${seconds_of[$h]}" -timeout=10 -rss_limit_mb=2048 \
    -max_len=16384 -print_final_stats=1 -artifact_prefix="$build_dir/artifacts/$h-" \
    "$work" "$seeds" >"$log" 2>&1 || status=FAILED
  # The last status line: "#RUNS DONE cov: C ft: F corp: N/SIZE exec/s: E ...".
  done_line=$(grep -E "^#[0-9]+[[:space:]]+(DONE|pulse|NEW|REDUCE|INITED)" "$log" | tail -n 1 || true)
  field() { sed -nE "s/.*$1: ([0-9]+[a-zA-Z]*).*/\1/p" <<<"$done_line"; }
  execs=$(sed -nE 's/^stat::number_of_executed_units: *([0-9]+).*/\1/p' "$log")
  rate=$(sed -nE 's/^stat::average_exec_per_sec: *([0-9]+).*/\1/p' "$log")
  corpus=$(sed -nE 's/.*corp: ([0-9]+\/[0-9]+[a-zA-Z]*).*/\1/p' <<<"$done_line")
  printf '%-16s %6s %10s %8s %6s %7s %8s  %s\n' "$h" "${seconds_of[$h]}" "${execs:--}" "${rate:--}" \
    "$(field cov)" "$(field ft)" "${corpus:--}" "$status"
  if [ "$status" != ok ]; then
    failed=1
    echo "---- $log (last 60 lines):" >&2
    tail -n 60 "$log" >&2
  fi
done
[ "$failed" -eq 0 ] || { echo "fuzz: a harness failed; its input is in $build_dir/artifacts/" >&2; exit 1; }
total_s=0
for h in "${harnesses[@]}"; do total_s=$((total_s + seconds_of[$h])); done
echo "fuzz: ${#harnesses[@]} harnesses, ${total_s} s of fuzzing, no crash"
