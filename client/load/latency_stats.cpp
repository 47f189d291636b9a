#include "client/load/latency_stats.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace mm::client {

double percentile_of_sorted(const std::vector<double>& sorted, double p) {
  if (sorted.empty()) return 0;
  const auto rank = static_cast<size_t>(std::ceil(p / 100.0 * static_cast<double>(sorted.size())));
  return sorted[std::min(sorted.size(), std::max<size_t>(rank, 1)) - 1];
}

LatencySummary summarize_latencies(std::vector<double> latencies_ms) {
  LatencySummary summary;
  if (latencies_ms.empty()) return summary;
  std::sort(latencies_ms.begin(), latencies_ms.end());
  summary.calls = static_cast<long>(latencies_ms.size());
  summary.p50_ms = percentile_of_sorted(latencies_ms, 50);
  summary.p90_ms = percentile_of_sorted(latencies_ms, 90);
  summary.p99_ms = percentile_of_sorted(latencies_ms, 99);
  summary.max_ms = latencies_ms.back();
  summary.mean_ms = std::accumulate(latencies_ms.begin(), latencies_ms.end(), 0.0) / static_cast<double>(summary.calls);
  return summary;
}

}  // namespace mm::client
