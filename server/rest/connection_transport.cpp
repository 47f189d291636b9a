#include "server/rest/connection_transport.h"

#include <fcntl.h>
#include <openssl/err.h>
#include <poll.h>
#include <sys/socket.h>

#include <algorithm>
#include <cerrno>
#include <climits>

namespace mm::service::rest {

bool ConnectionTransport::write_all(const char* data, size_t size, Clock::time_point deadline) {
  size_t written = 0;
  while (written < size) {
    const ssize_t n = write(data + written, size - written, deadline);
    if (n <= 0) return false;
    written += static_cast<size_t>(n);
  }
  return true;
}

int ConnectionTransport::wait(bool for_writing, Clock::time_point deadline) const {
  for (;;) {
    const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) return 0;
    pollfd entry{socket_, static_cast<short>(for_writing ? POLLOUT : POLLIN), 0};
    const int ready = ::poll(&entry, 1, static_cast<int>(std::min<long long>(left, INT_MAX)));
    if (ready > 0) return 1;
    if (ready < 0 && errno != EINTR) return -1;
  }
}

bool ConnectionTransport::peer_alive() const {
  pollfd entry{socket_, POLLIN, 0};
  if (::poll(&entry, 1, 0) <= 0) return true;
  char byte;
  const ssize_t n = ::recv(socket_, &byte, 1, MSG_PEEK | MSG_DONTWAIT);
  return n > 0 || (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR));
}

ssize_t PlainTransport::read(char* data, size_t size, Clock::time_point deadline) {
  for (;;) {
    const ssize_t n = ::recv(socket_, data, size, MSG_DONTWAIT);
    if (n >= 0) return n;
    if (errno == EINTR) continue;
    if (errno != EAGAIN && errno != EWOULDBLOCK) return kFailed;
    const int ready = wait(false, deadline);
    if (ready == 0) return kTimedOut;
    if (ready < 0) return kFailed;
  }
}

ssize_t PlainTransport::write(const char* data, size_t size, Clock::time_point deadline) {
  for (;;) {
    const ssize_t n = ::send(socket_, data, size, MSG_DONTWAIT | MSG_NOSIGNAL);
    if (n >= 0) return n;
    if (errno == EINTR) continue;
    if (errno != EAGAIN && errno != EWOULDBLOCK) return kFailed;
    const int ready = wait(true, deadline);
    if (ready == 0) return kTimedOut;
    if (ready < 0) return kFailed;
  }
}

void PlainTransport::finish_sending() { ::shutdown(socket_, SHUT_WR); }

TlsTransport::TlsTransport(int socket, SSL_CTX* context, std::mutex& context_mutex) : ConnectionTransport(socket) {
  {
    std::lock_guard<std::mutex> lock(context_mutex);
    ssl_ = SSL_new(context);
  }
  if (ssl_ != nullptr) SSL_set_fd(ssl_, socket);
  // Every TLS call then returns instead of blocking, and waits in poll
  // against its deadline (ConnectionTransport::wait).
  const int flags = ::fcntl(socket, F_GETFL, 0);
  if (flags >= 0) ::fcntl(socket, F_SETFL, flags | O_NONBLOCK);
}

TlsTransport::~TlsTransport() {
  if (ssl_ != nullptr) SSL_free(ssl_);
}

bool TlsTransport::handshake(Clock::time_point deadline) {
  if (ssl_ == nullptr) return false;
  for (;;) {
    ERR_clear_error();
    const int result = SSL_accept(ssl_);
    if (result == 1) return handshaken_ = true;
    const int error = SSL_get_error(ssl_, result);
    if (error != SSL_ERROR_WANT_READ && error != SSL_ERROR_WANT_WRITE) return false;
    if (wait(error == SSL_ERROR_WANT_WRITE, deadline) <= 0) return false;
  }
}

ssize_t TlsTransport::read(char* data, size_t size, Clock::time_point deadline) {
  if (!handshaken_) return kFailed;
  for (;;) {
    ERR_clear_error();
    const int n = SSL_read(ssl_, data, static_cast<int>(std::min<size_t>(size, INT_MAX)));
    if (n > 0) return n;
    const int error = SSL_get_error(ssl_, n);
    if (error == SSL_ERROR_ZERO_RETURN) return kClosed;
    // A peer that closes the socket without TLS's close_notify.
    if (error == SSL_ERROR_SYSCALL && n == 0) return kClosed;
    if (error != SSL_ERROR_WANT_READ && error != SSL_ERROR_WANT_WRITE) return kFailed;
    const int ready = wait(error == SSL_ERROR_WANT_WRITE, deadline);
    if (ready == 0) return kTimedOut;
    if (ready < 0) return kFailed;
  }
}

ssize_t TlsTransport::write(const char* data, size_t size, Clock::time_point deadline) {
  if (!handshaken_) return kFailed;
  for (;;) {
    ERR_clear_error();
    const int n = SSL_write(ssl_, data, static_cast<int>(std::min<size_t>(size, INT_MAX)));
    if (n > 0) return n;
    const int error = SSL_get_error(ssl_, n);
    if (error != SSL_ERROR_WANT_READ && error != SSL_ERROR_WANT_WRITE) return kFailed;
    const int ready = wait(error == SSL_ERROR_WANT_WRITE, deadline);
    if (ready == 0) return kTimedOut;
    if (ready < 0) return kFailed;
  }
}

void TlsTransport::finish_sending() {
  if (handshaken_) {
    ERR_clear_error();
    SSL_shutdown(ssl_);  // close_notify, without waiting for the peer's
  }
  ::shutdown(socket_, SHUT_WR);
}

}  // namespace mm::service::rest
