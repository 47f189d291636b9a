// The gRPC frontend: a gRPC server exposing motionmanifold.v1.MotionManifold
// over the core (core/core.h), with the standard health service (grpc.health.v1) and
// server reflection. A thin translator: every rpc is one call of the core
// (manifold_service.h); the core validates and the error model maps its
// refusals to status codes (error_status.h).
//
// Torch-free: includes neither LibTorch nor the model.
// Thread safety: start(), set_serving() and shutdown() may be called from any
// thread but not concurrently with each other; port() any time after start().
#pragma once

#include <atomic>
#include <chrono>
#include <memory>
#include <string>

#include "server/core/core.h"

namespace grpc {
class Server;
}

namespace mm::service {

// The frontend's own parts (manifold_service.h, take_rpcs.cpp, error_status.h,
// stream_message_deadlines.h).
namespace grpc_frontend {
class ManifoldService;
}

struct GrpcOptions {
  std::string address = "0.0.0.0";  // interface to listen on (an IPv6 address without brackets is fine)
  int port = 50051;                  // 0: a free port, see GrpcFrontend::port()
  // Largest message received or sent; gRPC refuses a larger one with
  // RESOURCE_EXHAUSTED before it reaches the core. 64 MiB holds a few
  // thousand 6 s motions.
  int max_message_bytes = 64 << 20;
  // PEM files: with both, the server speaks TLS only; with neither,
  // plaintext. One without the other is refused by start().
  std::string tls_cert_file, tls_key_file;
  // Most threads serving calls at once (gRPC's resource quota on the
  // synchronous server's pool, its pollers included); a call arriving when
  // none is free is refused with RESOURCE_EXHAUSTED by gRPC.
  int max_threads = 64;
  // Threads kept for WatchJob streams on top of max_threads: the core's cap
  // on open streams (--max-watch-streams). A stream holds its thread for its
  // whole life; the core refuses streams beyond the cap before they hold one
  // for long, so streams never take the threads of calls.
  int watch_streams = 64;

  // Limits on what one connection may hold, and for how long (seconds; 0
  // turns a time limit off).
  //
  // Calls one connection may have open at once, well below max_threads, so
  // that one client's burst waits on its own connection instead of taking
  // every thread; gRPC clients queue calls beyond it themselves. Announced
  // as HTTP/2's SETTINGS_MAX_CONCURRENT_STREAMS together with the WatchJob
  // streams one client may hold (watch_streams_per_client, the core's
  // --max-watch-streams-per-client), which have threads of their own: a
  // client watching its jobs on one channel is never queued behind them.
  int max_streams_per_connection = 16;
  int watch_streams_per_client = 8;
  // The server pings a connection quiet for this long and closes it when
  // the ping is not answered in keepalive_timeout_seconds: a peer that
  // vanished without a FIN stops holding its streams.
  int keepalive_seconds = 60;
  int keepalive_timeout_seconds = 20;
  // A client pinging more often than this without sending calls is warned
  // twice, then sent GOAWAY (keepalive enforcement): pings cost the server
  // a write each.
  int min_client_ping_interval_seconds = 30;
  // A connection without a call for this long is closed (GOAWAY).
  int max_connection_idle_seconds = 600;
  // A connection older than this is sent GOAWAY and may finish its calls
  // for max_connection_age_grace_seconds more: no connection holds its
  // share of the server for ever, and clients spread over replicas again.
  int max_connection_age_seconds = 3600;
  int max_connection_age_grace_seconds = 300;
  // Compressed request messages (gzip, deflate). Off: refused from their
  // headers, before a byte of them is inflated. On: gRPC 1.51 inflates a
  // message whole before it compares it with max_message_bytes, so one
  // message of a few MB on the wire can cost GBs of memory; only for
  // trusted clients.
  bool accept_compressed_messages = false;
  // How long a take stream (EncodeTake, ReconstructTake, DenoiseTake,
  // DecodeTrack) may wait for its next message: the header from the call's
  // start, each chunk from the one before, each reply message for the client
  // to take it. The synchronous API's reads and writes block without a limit
  // of their own, so a stream opened and left silent would hold a thread
  // (and past its header a take slot) for ever; past this the call ends
  // with DEADLINE_EXCEEDED naming the option. A message must arrive whole
  // within it: 64 MiB (--max-message-bytes) at 60 s needs 9 Mbit/s. 0: no
  // limit.
  int take_message_timeout_seconds = 60;
};

class GrpcFrontend {
 public:
  // `core` outlives the frontend.
  GrpcFrontend(Core& core, GrpcOptions options);
  ~GrpcFrontend();  // shutdown(1 s) when still serving
  GrpcFrontend(const GrpcFrontend&) = delete;
  GrpcFrontend& operator=(const GrpcFrontend&) = delete;

  // Binds and starts serving on gRPC's thread pool. Throws
  // std::runtime_error naming the address when it cannot listen there, or
  // naming the file when a TLS file cannot be read.
  void start();
  // The bound port (the chosen one when options.port is 0); 0 before start().
  int port() const;
  // The health status (SERVING / NOT_SERVING) of "" (the whole server) and
  // "motionmanifold.v1.MotionManifold". Before start() it is remembered and
  // applied at start; the default is serving.
  void set_serving(bool serving);
  // Stops accepting calls and lets those in flight finish for at most
  // `deadline`, then cancels the rest. WatchJob streams end at once with
  // UNAVAILABLE. Idempotent.
  void shutdown(std::chrono::milliseconds deadline);

 private:
  Core& core_;
  GrpcOptions options_;
  std::atomic<bool> stopping_{false};
  bool serving_ = true;
  int port_ = 0;
  std::unique_ptr<grpc_frontend::ManifoldService> service_;
  std::unique_ptr<grpc::Server> server_;
};

}  // namespace mm::service
