// StreamMessageDeadlines: a deadline on each message a synchronous gRPC
// stream waits for. The synchronous API's Read and Write block until the
// message has come (or gone) or the call ends, and offer no timeout of their
// own: a client that opens a take stream and sends nothing, or sends its
// header and then nothing, would hold one of the server's gRPC threads (and,
// past the header, a take slot) for ever. Here each such wait is registered
// with one watchdog thread, which cancels a call still waiting when its
// deadline passes, with DEADLINE_EXCEEDED and a message naming the option
// that sets it; the cancellation ends the blocked Read or Write (it returns
// false), and the handler's thread is free again.
//
// Only the waits are timed: the time the server spends on a message between
// two of them never counts, so a take that takes an hour to compute is never
// cut, and one that sends a message every second is never cut either.
//
// Thread safety: wait() may be called from every handler thread at once.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>

namespace grpc {
class ServerContext;
}

namespace mm::service::grpc_frontend {

class StreamMessageDeadlines {
 public:
  // Each wait may last `timeout`, which `option` sets (limit_text() names
  // both). A zero timeout turns the deadlines off (no thread is started and
  // wait() only runs its step).
  StreamMessageDeadlines(std::chrono::milliseconds timeout, std::string option);
  // Stops the watchdog. Every wait() must have returned (the gRPC server
  // has been shut down and waited for).
  ~StreamMessageDeadlines();
  StreamMessageDeadlines(const StreamMessageDeadlines&) = delete;
  StreamMessageDeadlines& operator=(const StreamMessageDeadlines&) = delete;

  // What one wait ended with.
  struct Outcome {
    bool ok = false;       // what `step` returned: false when the stream ended or the call was cancelled
    bool expired = false;  // the deadline passed first and cancelled the call
  };

  // Runs `step` (one blocking Read or Write on `context`'s stream) under a
  // deadline of the timeout from now. When it passes before `step` returns,
  // the call is cancelled with DEADLINE_EXCEEDED and `message`, which the
  // client receives as the call's status, and `step` returns false.
  // `context` is the running handler's (valid until wait() returns).
  Outcome wait(grpc::ServerContext& context, std::string message, const std::function<bool()>& step);

  // "N s (<option>)": how a message names this limit.
  std::string limit_text() const;

 private:
  struct Waiting {
    void* call;  // grpc_call*, valid while the entry is in waiting_
    std::chrono::steady_clock::time_point deadline;
    std::string message;
  };

  void watch();

  const std::chrono::milliseconds timeout_;
  const std::string option_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::map<uint64_t, Waiting> waiting_;  // under mutex_; by registration, so by deadline too
  uint64_t next_id_ = 0;                 // under mutex_
  bool stopping_ = false;                // under mutex_
  std::thread watchdog_;
};

}  // namespace mm::service::grpc_frontend
