// motion-manifold-load: drives N concurrent clients against a running server
// for T seconds, each repeating one call (Decode, Encode or Sample) over gRPC
// or REST, and prints the throughput and the latency percentiles. Links no
// LibTorch: it measures the server, not itself.
#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "client/load/call_drivers.h"
#include "client/load/latency_stats.h"
#include "format/input_error.h"
#include "format/motion_text.h"

namespace {

using Clock = std::chrono::steady_clock;

struct ClientResult {
  std::vector<double> latencies_ms;  // of calls answered OK after the warm-up
  std::map<std::string, long> statuses;
};

}  // namespace

int main(int argc, char** argv) {
  std::signal(SIGPIPE, SIG_IGN);  // a closed connection is a failed call, not the end of the run
  CLI::App app{"motion-manifold-load: concurrent clients against a motion-manifold-server; prints throughput and "
               "latency percentiles (p50, p90, p99)"};
  std::string protocol = "grpc", host = "127.0.0.1", motion_file, json_out;
  int port = 0, clients = 1;
  double seconds = 10, warmup = 1;
  mm::client::LoadCall call;
  app.add_option("--protocol", protocol, "grpc or rest")->check(CLI::IsMember({"grpc", "rest"}))->capture_default_str();
  app.add_option("--host", host, "server address")->capture_default_str();
  app.add_option("--port", port, "the protocol's port")->required()->check(CLI::Range(1, 65535));
  app.add_option("--operation", call.operation, "decode, encode or sample")
      ->check(CLI::IsMember({"decode", "encode", "sample"}))->capture_default_str();
  app.add_option("--batch", call.batch, "codes, motions or samples per call")->check(CLI::Range(1, 4096))->capture_default_str();
  app.add_option("--model", call.model, "model to call (default: the active one)");
  app.add_option("--motion", motion_file, "encode: an H3.6M text file at 50 Hz whose first 300 frames are sent")
      ->check(CLI::ExistingFile);
  app.add_option("--clients", clients, "concurrent clients, one connection each")->check(CLI::Range(1, 1024))->capture_default_str();
  app.add_option("--seconds", seconds, "measured duration")->check(CLI::Range(0.1, 86400.0))->capture_default_str();
  app.add_option("--warmup", warmup, "seconds of calls before measuring")->check(CLI::Range(0.0, 600.0))->capture_default_str();
  app.add_option("--json", json_out, "also write the results as JSON to this file");
  CLI11_PARSE(app, argc, argv);

  if (call.operation == "encode") {
    if (motion_file.empty()) {
      std::fprintf(stderr, "--operation encode needs --motion FILE (H3.6M text at 50 Hz)\n");
      return 2;
    }
    try {
      const auto frames = mm::read_motion_text(motion_file);
      if (frames.frame_count() < 300) {
        std::fprintf(stderr, "%s: expected at least 300 frames at 50 Hz, found %lld\n", motion_file.c_str(),
                     static_cast<long long>(frames.frame_count()));
        return 2;
      }
      call.motion_frames = 300;
      call.motion_values.assign(frames.values.begin(), frames.values.begin() + 300 * frames.columns);
    } catch (const mm::InputError& e) {
      std::fprintf(stderr, "%s\n", e.what());
      return 2;
    }
  }

  std::vector<ClientResult> results(static_cast<size_t>(clients));
  std::vector<std::thread> threads;
  const auto start = Clock::now();
  const auto measure_from = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(warmup));
  const auto stop_at = measure_from + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  for (int c = 0; c < clients; ++c) {
    threads.emplace_back([&, c] {
      auto driver = protocol == "grpc"
                        ? mm::client::grpc_driver(host + ":" + std::to_string(port), call, static_cast<unsigned>(c + 1))
                        : mm::client::rest_driver(host, port, call, static_cast<unsigned>(c + 1));
      auto& result = results[static_cast<size_t>(c)];
      for (;;) {
        const auto sent = Clock::now();
        if (sent >= stop_at) break;
        const std::string status = driver->call();
        const auto answered = Clock::now();
        // Only calls sent and answered inside the measured window count.
        if (sent < measure_from || answered > stop_at) continue;
        ++result.statuses[status];
        if (status == "OK") result.latencies_ms.push_back(std::chrono::duration<double, std::milli>(answered - sent).count());
      }
    });
  }
  for (auto& t : threads) t.join();

  std::vector<double> latencies;
  std::map<std::string, long> statuses;
  for (const auto& r : results) {
    latencies.insert(latencies.end(), r.latencies_ms.begin(), r.latencies_ms.end());
    for (const auto& [status, count] : r.statuses) statuses[status] += count;
  }
  long errors = 0;
  for (const auto& [status, count] : statuses) {
    if (status != "OK") errors += count;
  }
  const auto summary = mm::client::summarize_latencies(latencies);
  const double calls_per_second = static_cast<double>(summary.calls) / seconds;
  const double clips_per_second = calls_per_second * call.batch;

  std::printf("%s %s, batch %d, %d clients, %.1f s measured after %.1f s warm-up\n", protocol.c_str(),
              call.operation.c_str(), call.batch, clients, seconds, warmup);
  std::printf("  calls ok %ld, errors %ld\n", summary.calls, errors);
  for (const auto& [status, count] : statuses) {
    if (status != "OK") std::printf("    %s: %ld\n", status.c_str(), count);
  }
  std::printf("  throughput %.2f calls/s, %.2f clips/s\n", calls_per_second, clips_per_second);
  std::printf("  latency ms: p50 %.2f  p90 %.2f  p99 %.2f  max %.2f  mean %.2f\n", summary.p50_ms, summary.p90_ms,
              summary.p99_ms, summary.max_ms, summary.mean_ms);
  if (!json_out.empty()) {
    const nlohmann::json json = {{"protocol", protocol},       {"operation", call.operation},
                                 {"batch", call.batch},        {"clients", clients},
                                 {"seconds", seconds},         {"warmup_seconds", warmup},
                                 {"calls_ok", summary.calls},  {"errors", errors},
                                 {"statuses", statuses},       {"calls_per_second", calls_per_second},
                                 {"clips_per_second", clips_per_second}, {"p50_ms", summary.p50_ms},
                                 {"p90_ms", summary.p90_ms},   {"p99_ms", summary.p99_ms},
                                 {"max_ms", summary.max_ms},   {"mean_ms", summary.mean_ms}};
    std::ofstream(json_out) << json.dump(2) << "\n";
  }
  return errors == 0 ? 0 : 1;
}
