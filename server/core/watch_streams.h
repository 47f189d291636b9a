// The open job watch streams (REST's event streams and gRPC's WatchJob), both
// frontends counted together: at most `max_streams` in all and
// `max_streams_per_client` from one client address. A stream holds a slot
// for its whole life, which can be hours for a queued job, so streams are
// bounded apart from calls: each frontend keeps as many workers for streams
// as this cap on top of those serving calls (RestOptions::watch_streams,
// GrpcOptions::watch_streams), and a stream refused here is answered at once.
//
// Torch-free and wire-free. Thread safety: every method may be called
// concurrently; a Slot may be given back from any thread.
#pragma once

#include <memory>
#include <string>

namespace mm::service {

// The defaults: 64 streams cost 64 idle workers per frontend (threads,
// hardly any memory: docs/PERFORMANCE.md); 8 per address is more than a
// browser opens to one host over HTTP/1.1 (6 connections) and keeps one
// client to an eighth of the total.
struct WatchStreamLimits {
  int max_streams = 64;            // --max-watch-streams
  int max_streams_per_client = 8;  // --max-watch-streams-per-client
};

class WatchStreams {
  struct State;

 public:
  // One stream's place among the open ones, given back when the Slot is
  // destroyed (or assigned over). Move-only; an empty Slot holds nothing. It
  // may outlive the WatchStreams that gave it.
  class Slot {
   public:
    Slot() = default;
    ~Slot();
    Slot(Slot&& other) noexcept;
    Slot& operator=(Slot&& other) noexcept;
    Slot(const Slot&) = delete;
    Slot& operator=(const Slot&) = delete;
    bool held() const { return state_ != nullptr; }

   private:
    friend class WatchStreams;
    Slot(std::shared_ptr<State> state, std::string client);
    void release();
    std::shared_ptr<State> state_;
    std::string client_;
  };

  explicit WatchStreams(WatchStreamLimits limits);
  ~WatchStreams();

  // A slot for a new stream of the client at `ip` (an IPv4-mapped IPv6
  // address counts as its IPv4 address; "" when unknown, which all unknown
  // callers share). Throws ApiError RESOURCE_EXHAUSTED
  // (429, not too_large) naming the cap that is full, its value and its
  // option when `max_streams` streams, or `max_streams_per_client` of this
  // client's, are open.
  Slot admit(const std::string& ip);

  int open() const;  // streams holding a slot now

 private:
  std::shared_ptr<State> state_;
};

}  // namespace mm::service
