// Latency statistics of a load run: percentiles by the nearest-rank method
// over every call's latency, in milliseconds. Plain value type.
#pragma once

#include <vector>

namespace mm::client {

struct LatencySummary {
  long calls = 0;
  double p50_ms = 0, p90_ms = 0, p99_ms = 0, max_ms = 0, mean_ms = 0;
};

// Summary of `latencies_ms` (sorted or not); all zero for none.
LatencySummary summarize_latencies(std::vector<double> latencies_ms);

// The nearest-rank percentile (0 < p <= 100) of sorted values.
double percentile_of_sorted(const std::vector<double>& sorted, double p);

}  // namespace mm::client
