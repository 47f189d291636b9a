// The bytes of one accepted REST connection, plain TCP or TLS, read and
// written against a deadline rather than per call: the guarded server
// (guarded_http_server.h) bounds a request's whole head and body by time,
// which httplib's own socket streams cannot (they time out one read only).
//
// Thread safety: a transport belongs to one connection's thread.
#pragma once

#include <openssl/ssl.h>
#include <sys/types.h>

#include <chrono>
#include <cstddef>
#include <mutex>

namespace mm::service::rest {

using Clock = std::chrono::steady_clock;

class ConnectionTransport {
 public:
  // What read() returns besides a count of bytes.
  static constexpr ssize_t kClosed = 0;     // the peer closed its side
  static constexpr ssize_t kFailed = -1;    // an error: the connection is unusable
  static constexpr ssize_t kTimedOut = -2;  // nothing arrived before the deadline

  explicit ConnectionTransport(int socket) : socket_(socket) {}
  virtual ~ConnectionTransport() = default;
  ConnectionTransport(const ConnectionTransport&) = delete;
  ConnectionTransport& operator=(const ConnectionTransport&) = delete;

  // Reads at most `size` bytes, waiting for the first until `deadline`.
  virtual ssize_t read(char* data, size_t size, Clock::time_point deadline) = 0;
  // Writes at most `size` bytes, waiting for room until `deadline`; the
  // count written, or kFailed (kTimedOut past the deadline).
  virtual ssize_t write(const char* data, size_t size, Clock::time_point deadline) = 0;
  // Ends the connection's sending side after a final reply, so that the
  // reply reaches the client before the socket is closed.
  virtual void finish_sending() = 0;

  // Writes all of `data` by `deadline`; false when it could not.
  bool write_all(const char* data, size_t size, Clock::time_point deadline);
  // Whether the peer is still there: no end of stream or error pending.
  bool peer_alive() const;
  int socket() const { return socket_; }

 protected:
  // Waits until the socket can be read (or written) or `deadline`: 1 ready,
  // 0 timed out, -1 error.
  int wait(bool for_writing, Clock::time_point deadline) const;

  int socket_;
};

// Plain TCP: recv and send without blocking, poll between them.
class PlainTransport : public ConnectionTransport {
 public:
  using ConnectionTransport::ConnectionTransport;
  ssize_t read(char* data, size_t size, Clock::time_point deadline) override;
  ssize_t write(const char* data, size_t size, Clock::time_point deadline) override;
  void finish_sending() override;
};

// TLS over a socket set non-blocking, so that the handshake, each read and
// each write wait in poll against their deadline.
class TlsTransport : public ConnectionTransport {
 public:
  // `context` outlives the transport; `context_mutex` guards SSL_new on it.
  TlsTransport(int socket, SSL_CTX* context, std::mutex& context_mutex);
  ~TlsTransport() override;

  // The TLS handshake, by `deadline`; false when it failed or was late.
  bool handshake(Clock::time_point deadline);
  SSL* ssl() const { return ssl_; }

  ssize_t read(char* data, size_t size, Clock::time_point deadline) override;
  ssize_t write(const char* data, size_t size, Clock::time_point deadline) override;
  void finish_sending() override;

 private:
  SSL* ssl_ = nullptr;
  bool handshaken_ = false;
};

}  // namespace mm::service::rest
