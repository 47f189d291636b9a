#include "server/grpc/stream_message_deadlines.h"

#include <grpc/grpc.h>
#include <grpcpp/server_context.h>

namespace mm::service::grpc_frontend {

StreamMessageDeadlines::StreamMessageDeadlines(std::chrono::milliseconds timeout, std::string option)
    : timeout_(timeout), option_(std::move(option)) {
  if (timeout_.count() > 0) watchdog_ = std::thread([this] { watch(); });
}

StreamMessageDeadlines::~StreamMessageDeadlines() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (watchdog_.joinable()) watchdog_.join();
}

std::string StreamMessageDeadlines::limit_text() const {
  const auto milliseconds = timeout_.count();
  const std::string amount = milliseconds % 1000 == 0 ? std::to_string(milliseconds / 1000)
                                                      : std::to_string(static_cast<double>(milliseconds) / 1000);
  return amount + " s (" + option_ + ")";
}

StreamMessageDeadlines::Outcome StreamMessageDeadlines::wait(grpc::ServerContext& context, std::string message,
                                                             const std::function<bool()>& step) {
  if (timeout_.count() <= 0) return Outcome{step(), false};
  uint64_t id = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    id = next_id_++;
    const bool watchdog_idle = waiting_.empty();
    // The timeout is the same for every wait, so the map's order by id is
    // its order by deadline: the watchdog only ever looks at the first.
    waiting_.emplace(id, Waiting{context.c_call(), std::chrono::steady_clock::now() + timeout_, std::move(message)});
    if (watchdog_idle) wake_.notify_one();
  }
  const bool ok = step();
  std::lock_guard<std::mutex> lock(mutex_);
  const auto entry = waiting_.find(id);
  if (entry == waiting_.end()) return Outcome{ok, true};  // the watchdog took it out: it expired
  waiting_.erase(entry);
  return Outcome{ok, false};
}

void StreamMessageDeadlines::watch() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    if (waiting_.empty()) {
      wake_.wait(lock);
      continue;
    }
    const auto first = waiting_.begin();
    if (std::chrono::steady_clock::now() < first->second.deadline) {
      wake_.wait_until(lock, first->second.deadline);
      continue;  // the first may have been taken out meanwhile
    }
    // Under the mutex: wait() cannot return, so the handler and its call
    // are alive. Cancelling from another thread is what gRPC's core allows
    // (ServerContext::TryCancel does the same, with CANCELLED); the status
    // and message reach the client, and the blocked Read or Write returns
    // false.
    grpc_call_cancel_with_status(static_cast<grpc_call*>(first->second.call), GRPC_STATUS_DEADLINE_EXCEEDED,
                                 first->second.message.c_str(), nullptr);
    waiting_.erase(first);
  }
}

}  // namespace mm::service::grpc_frontend
