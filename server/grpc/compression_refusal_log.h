// CompressionRefusalLog: gRPC's own log line for each compressed request it
// refuses, kept to one line a minute. gRPC 1.51 logs "Compression algorithm
// 'gzip' is disabled." (severity ERROR) for every such call, before the
// synchronous API sees it (grpc_frontend.h, accept_compressed_messages), so
// a client sending them in a loop writes one log line each (300 refused in
// 0.1 s wrote 300 lines). Installed, the first refusal of a minute is logged
// (naming the option that would take such requests) and the others of that
// minute are counted, their number logged with the next minute's first
// refusal or at flush(). Every other gRPC log line is passed to gRPC's own
// logger unchanged.
//
// Thread safety: gRPC calls the log function from any of its threads; every
// function here may be called from any thread.
#pragma once

#include <chrono>

namespace mm::service {

class CompressionRefusalLog {
 public:
  // Makes this gRPC's log function for the process (gpr_set_log_function),
  // once: later calls change nothing. `interval` is the minute above.
  static void install(std::chrono::milliseconds interval = std::chrono::minutes(1));
  // Logs the refusals counted and not yet logged, if any (at shutdown).
  static void flush();
};

}  // namespace mm::service
