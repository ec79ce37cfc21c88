#!/usr/bin/env bash
# A fresh build's wall time and CPU, file by file against a unity build (docs/build.md, "Unity builds"), alternated
# A B A B, each in a new build directory with no compiler cache (BENCHMARKS.md format):
#   RESULT bench=build_<target> variant=file_by_file n=.. p50_us=.. max_us=.. cpu_s=..   (the baseline)
#   RESULT bench=build_<target> variant=unity n=.. p50_us=.. max_us=.. cpu_s=.. wall_vs_file_by_file=..
# p50_us and max_us: the build's wall time (configure not included); cpu_s: the median user + system CPU of the
# compiler and linker processes.
#   tests/bench/build_bench.sh [DCA]   (DCA is ignored: tests/bench/run passes it)
# DCA_BENCH_TARGET: the target (default dca_demo, what scripts/demo builds; `all` with tests is CI's build),
# DCA_BENCH_ROUNDS: the rounds (default 2). A round of dca_demo is about 8 minutes on 2 cores.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
target="${DCA_BENCH_TARGET:-dca_demo}"
rounds="${DCA_BENCH_ROUNDS:-2}"
tests=OFF
[ "$target" = dca_demo ] || tests=ON
work="$(mktemp -d "${TMPDIR:-/tmp}/dca_build_bench_XXXXXX")"
trap 'rm -rf "$work"' EXIT

declare -A wall cpu
one() {  # variant unity(ON|OFF): a fresh configure and build; appends its wall (us) and CPU (s)
  local dir="$work/$1" t0 t1 c0 c1
  rm -rf "$dir"
  cmake -S "$root" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDCA_SANITIZE=OFF -DDCA_BUILD_TESTS="$tests" \
        -DDCA_BUILD_BENCH=OFF -DDCA_WERROR=ON -DCMAKE_UNITY_BUILD="$2" >"$work/$1.log" 2>&1
  c0=$(awk '{ print $14 + $15 + $16 + $17 }' /proc/$$/stat)
  t0=$(date +%s%N)
  cmake --build "$dir" -j "$(nproc)" --target "$target" >>"$work/$1.log" 2>&1 || { tail -30 "$work/$1.log" >&2; exit 1; }
  t1=$(date +%s%N)
  c1=$(awk '{ print $14 + $15 + $16 + $17 }' /proc/$$/stat)  # (children's ticks once waited for)
  wall[$1]+="$(( (t1 - t0) / 1000 )) "
  cpu[$1]+="$(awk -v a="$c0" -v b="$c1" -v hz="$(getconf CLK_TCK)" 'BEGIN { printf "%.1f", (b - a) / hz }') "
  echo "build_bench: $target $1 round done: $(( (t1 - t0) / 1000000 )) ms" >&2
  rm -rf "$dir"
}
median() { tr ' ' '\n' | sed '/^$/d' | sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }
maxof() { tr ' ' '\n' | sed '/^$/d' | sort -g | tail -1; }

for _ in $(seq 1 "$rounds"); do
  one file_by_file OFF
  one unity ON
done
base=$(median <<<"${wall[file_by_file]}")
for v in file_by_file unity; do
  p50=$(median <<<"${wall[$v]}")
  line="RESULT bench=build_$target variant=$v n=$rounds p50_us=$p50 max_us=$(maxof <<<"${wall[$v]}")"
  line+=" cpu_s=$(median <<<"${cpu[$v]}")"
  [ "$v" = file_by_file ] || line+=" wall_vs_file_by_file=$(awk -v a="$p50" -v b="$base" 'BEGIN { printf "%.2f", a / b }')"
  echo "$line"
done
