// httplib's HTTP and HTTPS servers with each connection served under limits
// httplib 0.11 lacks: a deadline for a request's whole head and one for its
// whole body (httplib times out one read at a time, 5 s, so a client sending
// a byte every 3 s holds a worker for ever), a cap on connections per client
// address, and the head checked by RFC 9112 before httplib parses it
// (request_head_check.h). Everything past the head (routing, handlers,
// replies, keep-alive) is httplib's own Server::process_request.
//
// httplib calls the private virtual process_and_close_socket on a worker
// thread for each accepted connection; these classes override it.
//
// Thread safety: as httplib::Server.
#pragma once

#include <httplib.h>

#include <chrono>
#include <cstddef>
#include <functional>
#include <mutex>
#include <string>

#include "server/rest/client_connections.h"
#include "server/rest/connection_transport.h"
#include "server/rest/request_head_check.h"

namespace mm::service::rest {

// A connection's limits (RestOptions gives the defaults and why).
struct ConnectionLimits {
  RequestHeadLimits head;
  std::chrono::milliseconds header_timeout{10'000};  // a request's head, from its connection or the previous reply
  std::chrono::milliseconds body_timeout{300'000};   // a request's body, from the end of its head
  size_t max_connections_per_client = 32;
};

// What a server needs of httplib's settings to serve a connection.
struct ConnectionTimeouts {
  std::chrono::milliseconds keep_alive;  // an idle connection's wait for its next request
  std::chrono::milliseconds read, write;  // each read of a body, each write
  size_t max_requests = 5;                // on one connection (httplib's keep-alive count)
};

// The serving of connections both servers share.
class ConnectionGuard {
 public:
  explicit ConnectionGuard(ConnectionLimits limits);

  // httplib's process_request on a stream: false when the connection must end.
  using ProcessRequest = std::function<bool(httplib::Stream&, bool close_connection, bool& connection_closed)>;
  // The client's address, and its place among the address's connections
  // (empty when it has too many).
  ClientConnections::Slot admit(int socket, std::string& address);
  // Answers a connection over the cap with 429 naming the cap, and ends it.
  void refuse_over_cap(ConnectionTransport& transport, const std::string& address) const;
  // Serves requests on `transport` until the connection ends, a limit
  // refuses one, or `stopping` returns true.
  void serve(ConnectionTransport& transport, const ConnectionTimeouts& timeouts,
             const std::function<bool()>& stopping, const ProcessRequest& process) const;
  const ConnectionLimits& limits() const { return limits_; }

 private:
  ConnectionLimits limits_;
  ClientConnections clients_;
};

class GuardedHttpServer : public httplib::Server {
 public:
  explicit GuardedHttpServer(ConnectionLimits limits) : guard_(std::move(limits)) {}
  // Listens again on the bound socket with `backlog` (httplib listens with
  // 5, compiled in); call between bind_to_port and listen_after_bind.
  bool set_listen_backlog(int backlog);

 private:
  bool process_and_close_socket(socket_t sock) override;
  ConnectionGuard guard_;
};

class GuardedHttpsServer : public httplib::SSLServer {
 public:
  GuardedHttpsServer(const std::string& cert_file, const std::string& key_file, ConnectionLimits limits)
      : httplib::SSLServer(cert_file.c_str(), key_file.c_str()), guard_(std::move(limits)) {}
  bool set_listen_backlog(int backlog);

 private:
  bool process_and_close_socket(socket_t sock) override;
  ConnectionGuard guard_;
  std::mutex context_mutex_;
};

}  // namespace mm::service::rest
