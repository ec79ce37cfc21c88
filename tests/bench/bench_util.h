#pragma once
// What every C++ benchmark prints (../shared/BENCHMARKS.md): one RESULT line per measured variant, with the
// same quantile rule everywhere.
//   RESULT bench=<name> variant=<variant> n=<samples> p50_us=.. p99_us=.. p999_us=.. max_us=..[ k=v...]
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

namespace dca::bench {

/// The q-quantile (0..1) of ascending samples: the sample at rank floor(q * n), clamped to the last; 0 for none.
inline double quantile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return 0;
  const auto i = static_cast<std::size_t>(q * static_cast<double>(sorted.size()));
  return sorted[std::min(sorted.size() - 1, i)];
}

/// Sorts the samples (microseconds) and prints their RESULT line with `digits` decimals, then `extra` (which
/// starts with a space: " rtf=2.1"); flushed at once. Prints nothing when there are no samples.
inline void result(std::string_view bench, std::string_view variant, std::vector<double>& us,
                   std::string_view extra = "", int digits = 1) {
  if (us.empty()) return;
  std::sort(us.begin(), us.end());
  std::printf("RESULT bench=%.*s variant=%.*s n=%zu p50_us=%.*f p99_us=%.*f p999_us=%.*f max_us=%.*f%.*s\n",
              static_cast<int>(bench.size()), bench.data(), static_cast<int>(variant.size()), variant.data(),
              us.size(), digits, quantile(us, 0.5), digits, quantile(us, 0.99), digits, quantile(us, 0.999), digits,
              us.back(), static_cast<int>(extra.size()), extra.data());
  std::fflush(stdout);
}

/// result() for per-call samples of nanoseconds' size: 4 decimals, and the median in ns (" p50_ns=37.4").
inline void result_ns(std::string_view bench, std::string_view variant, std::vector<double>& us) {
  std::sort(us.begin(), us.end());
  char extra[48];
  std::snprintf(extra, sizeof extra, " p50_ns=%.1f", quantile(us, 0.5) * 1000);
  result(bench, variant, us, extra, 4);
}

/// A path in $TMPDIR (else /tmp) that is this process's own: <temp>/<stem>-<pid>. The benchmark removes it.
inline std::string temp_path(std::string_view stem) {
  const char* tmp = std::getenv("TMPDIR");
  return std::string(tmp != nullptr && tmp[0] != '\0' ? tmp : "/tmp") + "/" + std::string(stem) + "-" +
         std::to_string(::getpid());
}

}  // namespace dca::bench
