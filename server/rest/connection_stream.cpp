#include "server/rest/connection_stream.h"

#include <netdb.h>
#include <sys/socket.h>

#include <algorithm>
#include <cstring>

namespace mm::service::rest {

namespace {

// What one read from the transport asks for: a head is a few hundred bytes,
// and a body larger than this is read straight into httplib's buffer.
constexpr size_t kReadChunk = 16 << 10;
// How often a wait for a head looks whether the server is stopping.
constexpr auto kStopPoll = std::chrono::milliseconds(100);

thread_local const ConnectionStream* current_stream = nullptr;

}  // namespace

void socket_address(int socket, bool peer, std::string& ip, int& port) {
  sockaddr_storage address{};
  socklen_t length = sizeof address;
  const int got = peer ? ::getpeername(socket, reinterpret_cast<sockaddr*>(&address), &length)
                       : ::getsockname(socket, reinterpret_cast<sockaddr*>(&address), &length);
  if (got != 0) return;
  char host[NI_MAXHOST], service[NI_MAXSERV];
  if (::getnameinfo(reinterpret_cast<sockaddr*>(&address), length, host, sizeof host, service, sizeof service,
                    NI_NUMERICHOST | NI_NUMERICSERV) != 0) {
    return;
  }
  ip = host;
  port = std::atoi(service);
}

ConnectionStream::ConnectionStream(ConnectionTransport& transport, std::chrono::milliseconds read_timeout,
                                   std::chrono::milliseconds write_timeout)
    : transport_(transport), read_timeout_(read_timeout), write_timeout_(write_timeout) {
  socket_address(transport.socket(), true, remote_ip_, remote_port_);
  socket_address(transport.socket(), false, local_ip_, local_port_);
}

ConnectionStream::HeadWait ConnectionStream::read_head(RequestHeadCheck& check, HeadVerdict& verdict,
                                                       Clock::time_point idle_deadline,
                                                       Clock::time_point head_deadline,
                                                       const std::function<bool()>& stopping) {
  // What the previous request left unread begins this one.
  buffer_.erase(0, position_);
  position_ = 0;
  verdict = check.advance(buffer_);
  char chunk[kReadChunk];
  while (verdict.state == HeadVerdict::State::kNeedMore) {
    if (stopping()) return HeadWait::kClosed;
    const Clock::time_point deadline = buffer_.empty() ? std::min(idle_deadline, head_deadline) : head_deadline;
    const Clock::time_point now = Clock::now();
    if (now >= deadline) return buffer_.empty() ? HeadWait::kIdle : HeadWait::kTimedOut;
    const ssize_t n = transport_.read(chunk, sizeof chunk, std::min(deadline, now + kStopPoll));
    if (n == ConnectionTransport::kTimedOut) continue;
    if (n <= 0) return HeadWait::kClosed;
    buffer_.append(chunk, static_cast<size_t>(n));
    verdict = check.advance(buffer_);
  }
  return HeadWait::kChecked;
}

void ConnectionStream::begin_body(size_t head_bytes, Clock::time_point deadline) {
  head_left_ = head_bytes;
  body_read_ = 0;
  body_deadline_ = deadline;
}

const ConnectionStream* ConnectionStream::current() { return current_stream; }

ConnectionStream::Serving::Serving(const ConnectionStream& stream) { current_stream = &stream; }
ConnectionStream::Serving::~Serving() { current_stream = nullptr; }

bool ConnectionStream::is_readable() const {
  // read() waits for itself, against the body's deadline.
  return !read_failed_;
}

bool ConnectionStream::is_writable() const { return !write_failed_ && transport_.peer_alive(); }

ssize_t ConnectionStream::read(char* ptr, size_t size) {
  if (read_failed_) return -1;
  size_t n = 0;
  if (position_ < buffer_.size()) {
    n = std::min(size, buffer_.size() - position_);
    std::memcpy(ptr, buffer_.data() + position_, n);
    position_ += n;
  } else {
    buffer_.clear();
    position_ = 0;
    // Only a body is read from the socket here: a head is buffered whole
    // by read_head() before httplib reads it.
    const Clock::time_point now = Clock::now();
    if (now >= body_deadline_) {
      body_timed_out_ = read_failed_ = true;
      return -1;
    }
    const Clock::time_point deadline = std::min(body_deadline_, now + read_timeout_);
    ssize_t got;
    if (size >= kReadChunk) {
      got = transport_.read(ptr, size, deadline);
    } else {
      char chunk[kReadChunk];
      got = transport_.read(chunk, sizeof chunk, deadline);
      if (got > 0) {
        buffer_.assign(chunk, static_cast<size_t>(got));
        position_ = std::min(size, buffer_.size());
        std::memcpy(ptr, buffer_.data(), position_);
        got = static_cast<ssize_t>(position_);
      }
    }
    if (got == ConnectionTransport::kTimedOut) {
      body_timed_out_ = Clock::now() >= body_deadline_;
      read_failed_ = true;
      return -1;
    }
    if (got < 0) {
      read_failed_ = true;
      return -1;
    }
    if (got == 0) return 0;
    n = static_cast<size_t>(got);
  }
  const size_t from_head = std::min(n, head_left_);
  head_left_ -= from_head;
  body_read_ += n - from_head;
  return static_cast<ssize_t>(n);
}

ssize_t ConnectionStream::write(const char* ptr, size_t size) {
  if (write_failed_) return -1;
  const ssize_t n = transport_.write(ptr, size, Clock::now() + write_timeout_);
  if (n < 0) {
    write_failed_ = true;
    return -1;
  }
  return n;
}

void ConnectionStream::get_remote_ip_and_port(std::string& ip, int& port) const {
  ip = remote_ip_;
  port = remote_port_;
}

void ConnectionStream::get_local_ip_and_port(std::string& ip, int& port) const {
  ip = local_ip_;
  port = local_port_;
}

}  // namespace mm::service::rest
