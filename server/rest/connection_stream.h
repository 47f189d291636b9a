// One REST connection as httplib reads and writes it (httplib::Stream), over
// a ConnectionTransport, with a buffer that holds each request's head whole
// before httplib sees it: the head is read against one deadline and checked
// (request_head_check.h) first, then httplib parses it from the buffer, and
// reads the body through read() against the body's own deadline. Bytes past
// a request (a pipelined next one) stay buffered for the next head.
//
// Thread safety: belongs to one connection's thread.
#pragma once

#include <httplib.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

#include "server/rest/connection_transport.h"
#include "server/rest/request_head_check.h"

namespace mm::service::rest {

class ConnectionStream : public httplib::Stream {
 public:
  // `read_timeout` bounds each read of a body besides the body's deadline,
  // `write_timeout` each write (httplib's own per-call timeouts).
  ConnectionStream(ConnectionTransport& transport, std::chrono::milliseconds read_timeout,
                   std::chrono::milliseconds write_timeout);

  // How waiting for a request's head ended.
  enum class HeadWait {
    kChecked,   // the head arrived whole, or was refused: `check`'s verdict says which
    kIdle,      // no byte of a request by the idle deadline: a keep-alive connection left unused
    kTimedOut,  // part of a head, but not all of it, by the head deadline
    kClosed,    // the peer closed, the connection failed, or `stopping` said so
  };
  // Reads the next request's head: its first byte by `idle_deadline` (or
  // `head_deadline`, if sooner), all of it by `head_deadline`, each arrival
  // given to `check`. `stopping` is asked between waits of at most 100 ms.
  HeadWait read_head(RequestHeadCheck& check, HeadVerdict& verdict, Clock::time_point idle_deadline,
                     Clock::time_point head_deadline, const std::function<bool()>& stopping);
  // Starts the body of the request whose head was just read (`head_bytes`
  // long): it must arrive whole by `deadline`.
  void begin_body(size_t head_bytes, Clock::time_point deadline);
  // Body bytes httplib has read since begin_body().
  uint64_t body_bytes_read() const { return body_read_; }
  // Whether a read or write failed, or the body's deadline passed: the
  // connection must not serve another request.
  bool failed() const { return read_failed_ || write_failed_; }
  bool body_timed_out() const { return body_timed_out_; }

  // The stream whose request this thread is serving (null outside one), for
  // a handler to tell a body that came too slowly from one that broke off.
  static const ConnectionStream* current();

  // httplib::Stream
  bool is_readable() const override;
  bool is_writable() const override;
  ssize_t read(char* ptr, size_t size) override;
  ssize_t write(const char* ptr, size_t size) override;
  void get_remote_ip_and_port(std::string& ip, int& port) const override;
  void get_local_ip_and_port(std::string& ip, int& port) const override;
  socket_t socket() const override { return transport_.socket(); }

  // Marks this stream as the thread's current() while it lives.
  class Serving {
   public:
    explicit Serving(const ConnectionStream& stream);
    ~Serving();
    Serving(const Serving&) = delete;
    Serving& operator=(const Serving&) = delete;
  };

 private:
  ConnectionTransport& transport_;
  std::chrono::milliseconds read_timeout_, write_timeout_;
  std::string buffer_;  // received, from the current request's first byte (before read_head: any byte)
  size_t position_ = 0;  // the first byte of buffer_ httplib has not read
  size_t head_left_ = 0;  // head bytes httplib has not read yet
  uint64_t body_read_ = 0;
  Clock::time_point body_deadline_ = Clock::time_point::max();
  bool read_failed_ = false;   // later reads fail too; a reply may still be written
  bool write_failed_ = false;
  bool body_timed_out_ = false;
  std::string remote_ip_, local_ip_;
  int remote_port_ = 0, local_port_ = 0;
};

// The numeric address and port of a socket's peer (`peer`) or its own end.
void socket_address(int socket, bool peer, std::string& ip, int& port);

}  // namespace mm::service::rest
