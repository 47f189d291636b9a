#include "server/grpc/compression_refusal_log.h"

#include <cstring>
#include <mutex>
#include <string>

#include <grpc/support/log.h>
#include <spdlog/spdlog.h>

// gRPC's own log function, which writes a line to stderr: exported by
// libgpr with C++ linkage but not declared by its public headers.
void gpr_default_log(gpr_log_func_args* args);

namespace mm::service {
namespace {

struct RefusalCount {
  std::mutex mutex;
  std::chrono::milliseconds interval{std::chrono::minutes(1)};
  bool logged_any = false;                           // under mutex
  std::chrono::steady_clock::time_point last_line;   // under mutex: when a line was last written
  long long unlogged = 0;                            // under mutex: refusals since then
};

RefusalCount& refusals() {
  // Never destroyed: gRPC may log from its threads while the process exits.
  static RefusalCount* count = new RefusalCount;
  return *count;
}

bool is_compression_refusal(const char* message) {
  return message != nullptr && std::strncmp(message, "Compression algorithm '", 23) == 0 &&
         std::strstr(message, "' is disabled") != nullptr;
}

// Under refusals().mutex.
void log_unlogged(RefusalCount& count, std::chrono::steady_clock::time_point now) {
  if (count.unlogged == 0) return;
  const double seconds = std::chrono::duration<double>(now - count.last_line).count();
  spdlog::warn("gRPC refused {} more compressed requests in the last {:.0f} s (--grpc-accept-compression takes "
               "them); one line a minute",
               count.unlogged, seconds);
  count.unlogged = 0;
  count.last_line = now;
}

void log_function(gpr_log_func_args* args) {
  if (!is_compression_refusal(args->message)) {
    gpr_default_log(args);
    return;
  }
  RefusalCount& count = refusals();
  std::lock_guard<std::mutex> lock(count.mutex);
  const auto now = std::chrono::steady_clock::now();
  if (count.logged_any && now - count.last_line < count.interval) {
    ++count.unlogged;
    return;
  }
  log_unlogged(count, now);
  spdlog::warn("gRPC refused a compressed request: {} (--grpc-accept-compression takes them; more are counted, "
               "one line a minute)",
               args->message);
  count.logged_any = true;
  count.last_line = now;
}

}  // namespace

void CompressionRefusalLog::install(std::chrono::milliseconds interval) {
  static std::once_flag installed;
  std::call_once(installed, [interval] {
    {
      std::lock_guard<std::mutex> lock(refusals().mutex);
      refusals().interval = interval;
    }
    gpr_set_log_function(log_function);
  });
}

void CompressionRefusalLog::flush() {
  RefusalCount& count = refusals();
  std::lock_guard<std::mutex> lock(count.mutex);
  log_unlogged(count, std::chrono::steady_clock::now());
}

}  // namespace mm::service
