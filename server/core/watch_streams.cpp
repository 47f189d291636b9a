#include "server/core/watch_streams.h"

#include <map>
#include <mutex>

#include "server/api/api_types.h"
#include "server/core/caller_identity.h"

namespace mm::service {

struct WatchStreams::State {
  explicit State(WatchStreamLimits l) : limits(l) {}
  const WatchStreamLimits limits;
  mutable std::mutex mutex;
  int open = 0;                          // guarded by mutex
  std::map<std::string, int> by_client;  // guarded by mutex; no client with 0
};

WatchStreams::Slot::Slot(std::shared_ptr<State> state, std::string client)
    : state_(std::move(state)), client_(std::move(client)) {}

WatchStreams::Slot::~Slot() { release(); }

WatchStreams::Slot::Slot(Slot&& other) noexcept
    : state_(std::move(other.state_)), client_(std::move(other.client_)) {
  other.state_.reset();
}

WatchStreams::Slot& WatchStreams::Slot::operator=(Slot&& other) noexcept {
  if (this != &other) {
    release();
    state_ = std::move(other.state_);
    client_ = std::move(other.client_);
    other.state_.reset();
  }
  return *this;
}

void WatchStreams::Slot::release() {
  if (!state_) return;
  {
    std::lock_guard<std::mutex> lock(state_->mutex);
    --state_->open;
    const auto found = state_->by_client.find(client_);
    if (found != state_->by_client.end() && --found->second == 0) state_->by_client.erase(found);
  }
  state_.reset();
}

WatchStreams::WatchStreams(WatchStreamLimits limits) : state_(std::make_shared<State>(limits)) {}

WatchStreams::~WatchStreams() = default;

WatchStreams::Slot WatchStreams::admit(const std::string& ip) {
  const std::string client = canonical_ip(ip);
  State& s = *state_;
  std::lock_guard<std::mutex> lock(s.mutex);
  // The total first: when the server is full, that is what a caller can
  // wait out, whoever holds the streams.
  if (s.open >= s.limits.max_streams) {
    throw ApiError(ErrorCode::kResourceExhausted, "",
                   "too many job watch streams: " + std::to_string(s.open) + " are open, at most " +
                       std::to_string(s.limits.max_streams) +
                       " at once (the server's --max-watch-streams); watch again later, or poll the job instead");
  }
  const auto found = s.by_client.find(client);
  const int of_client = found == s.by_client.end() ? 0 : found->second;
  if (of_client >= s.limits.max_streams_per_client) {
    throw ApiError(ErrorCode::kResourceExhausted, "",
                   "too many job watch streams from " + (client.empty() ? std::string("an unknown address") : client) +
                       ": " + std::to_string(of_client) + " are open, at most " +
                       std::to_string(s.limits.max_streams_per_client) +
                       " per client address (the server's --max-watch-streams-per-client); close one first");
  }
  ++s.open;
  ++s.by_client[client];
  return Slot(state_, client);
}

int WatchStreams::open() const {
  std::lock_guard<std::mutex> lock(state_->mutex);
  return state_->open;
}

}  // namespace mm::service
