#include "server/rest/guarded_http_server.h"

#include <sys/socket.h>
#include <unistd.h>

#include "server/core/caller_identity.h"
#include "server/rest/connection_stream.h"
#include "server/rest/http_errors.h"

namespace mm::service::rest {

namespace {

// After a refusal the connection is closed; what the client still sends is
// read and dropped for up to this long (at most kMaxDrained bytes) first, so
// that the close does not reset the connection before the client has read
// the refusal (a socket closed with unread bytes sends RST). A connection
// over the per-client cap waits for nothing: hundreds of them from a slow
// client would otherwise hold the workers this long each.
constexpr auto kDrainTime = std::chrono::milliseconds(250);
constexpr size_t kMaxDrained = 1 << 20;
// How long a refusal may take to write, and a TLS handshake over the
// per-client cap, whose refusal must be sent over TLS to be read: short, so
// that connections over the cap hold a worker briefly.
constexpr auto kRefusalTime = std::chrono::seconds(1);

const char* reason_phrase(int status) {
  switch (status) {
    case 400: return "Bad Request";
    case 408: return "Request Timeout";
    case 414: return "URI Too Long";
    case 429: return "Too Many Requests";
    case 431: return "Request Header Fields Too Large";
    case 501: return "Not Implemented";
    default: return "Error";
  }
}

// Writes a JSON error reply (http_errors.h) and ends the connection: the
// bytes after a refused head cannot be trusted to start a request.
void refuse(ConnectionTransport& transport, int status, const std::string& message,
            std::chrono::milliseconds drain_time = kDrainTime) {
  const std::string body = error_body(error_code_name_for_status(status), "", message);
  const std::string reply = "HTTP/1.1 " + std::to_string(status) + " " + reason_phrase(status) +
                            "\r\nContent-Type: application/json\r\nContent-Length: " + std::to_string(body.size()) +
                            "\r\nConnection: close\r\n\r\n" + body;
  if (!transport.write_all(reply.data(), reply.size(), Clock::now() + kRefusalTime)) return;
  transport.finish_sending();
  const auto until = Clock::now() + drain_time;
  char scratch[16 << 10];
  for (size_t drained = 0; drained < kMaxDrained;) {
    const ssize_t n = transport.read(scratch, sizeof scratch, until);
    if (n <= 0) break;
    drained += static_cast<size_t>(n);
  }
}

std::string seconds_text(std::chrono::milliseconds duration) {
  std::string text = std::to_string(duration.count() / 1000.0);
  text.erase(text.find_last_not_of('0') + 1);
  if (text.back() == '.') text.pop_back();
  return text;
}

ConnectionTimeouts timeouts_of(time_t keep_alive_sec, time_t read_sec, time_t read_usec, time_t write_sec,
                               time_t write_usec, size_t max_requests) {
  using std::chrono::milliseconds;
  return ConnectionTimeouts{milliseconds(keep_alive_sec * 1000), milliseconds(read_sec * 1000 + read_usec / 1000),
                            milliseconds(write_sec * 1000 + write_usec / 1000), max_requests};
}

void close_socket(socket_t sock) {
  ::shutdown(sock, SHUT_RDWR);
  ::close(sock);
}

}  // namespace

ConnectionGuard::ConnectionGuard(ConnectionLimits limits)
    : limits_(std::move(limits)), clients_(limits_.max_connections_per_client) {}

ClientConnections::Slot ConnectionGuard::admit(int socket, std::string& address) {
  int port = 0;
  socket_address(socket, true, address, port);
  return clients_.admit(canonical_ip(address));
}

void ConnectionGuard::refuse_over_cap(ConnectionTransport& transport, const std::string& address) const {
  refuse(transport, 429,
         "this client (" + address + ") already has " + std::to_string(limits_.max_connections_per_client) +
             " REST connections open, the most one address may have (--rest-max-connections-per-client); "
             "reuse an open connection or close one",
         std::chrono::milliseconds(0));
}

void ConnectionGuard::serve(ConnectionTransport& transport, const ConnectionTimeouts& timeouts,
                            const std::function<bool()>& stopping, const ProcessRequest& process) const {
  ConnectionStream stream(transport, timeouts.read, timeouts.write);
  for (size_t served = 0; served < timeouts.max_requests; ++served) {
    // The head's deadline runs from the connection's start or the end of
    // the previous reply: a client that sends nothing is let go after the
    // keep-alive wait, as httplib did, and one that sends slowly after this.
    const Clock::time_point start = Clock::now();
    RequestHeadCheck check(limits_.head);
    HeadVerdict verdict;
    const ConnectionStream::HeadWait wait =
        stream.read_head(check, verdict, start + timeouts.keep_alive, start + limits_.header_timeout, stopping);
    if (wait == ConnectionStream::HeadWait::kIdle || wait == ConnectionStream::HeadWait::kClosed) return;
    if (wait == ConnectionStream::HeadWait::kTimedOut) {
      return refuse(transport, 408,
                    "the request's head (request line and header fields) did not arrive whole within " +
                        seconds_text(limits_.header_timeout) + " s (--rest-header-timeout-seconds)");
    }
    if (verdict.state == HeadVerdict::State::kRefused) return refuse(transport, verdict.status, verdict.message);

    stream.begin_body(verdict.head_bytes, Clock::now() + limits_.body_timeout);
    // Whether httplib read a chunked body to its end cannot be told from
    // here, nor where a body of an unreadable length ends, so the
    // connection ends after such a request.
    const bool close_connection = served + 1 == timeouts.max_requests || verdict.chunked || verdict.close_after;
    bool connection_closed = false;
    bool kept;
    {
      const ConnectionStream::Serving serving(stream);
      kept = process(stream, close_connection, connection_closed);
    }
    if (!kept || connection_closed || close_connection || stream.failed()) return;
    // A body the handler left unread must not be read as the next request.
    if (verdict.content_length && stream.body_bytes_read() < *verdict.content_length) return;
  }
}

bool GuardedHttpServer::set_listen_backlog(int backlog) { return ::listen(svr_sock_, backlog) == 0; }

bool GuardedHttpServer::process_and_close_socket(socket_t sock) {
  {
    PlainTransport transport(sock);
    std::string address;
    const ClientConnections::Slot slot = guard_.admit(sock, address);
    if (!slot) {
      guard_.refuse_over_cap(transport, address);
    } else {
      guard_.serve(transport,
                   timeouts_of(keep_alive_timeout_sec_, read_timeout_sec_, read_timeout_usec_, write_timeout_sec_,
                               write_timeout_usec_, keep_alive_max_count_),
                   [this] { return svr_sock_ == INVALID_SOCKET; },
                   [this](httplib::Stream& stream, bool close_connection, bool& connection_closed) {
                     return process_request(stream, close_connection, connection_closed, nullptr);
                   });
    }
  }
  close_socket(sock);
  return true;
}

bool GuardedHttpsServer::set_listen_backlog(int backlog) { return ::listen(svr_sock_, backlog) == 0; }

bool GuardedHttpsServer::process_and_close_socket(socket_t sock) {
  {
    TlsTransport transport(sock, ssl_context(), context_mutex_);
    std::string address;
    const ClientConnections::Slot slot = guard_.admit(sock, address);
    if (!slot) {
      // The refusal is readable only over TLS; the handshake for it is
      // given little time.
      if (transport.handshake(Clock::now() + kRefusalTime)) guard_.refuse_over_cap(transport, address);
    } else if (transport.handshake(Clock::now() + guard_.limits().header_timeout)) {
      SSL* ssl = transport.ssl();
      guard_.serve(transport,
                   timeouts_of(keep_alive_timeout_sec_, read_timeout_sec_, read_timeout_usec_, write_timeout_sec_,
                               write_timeout_usec_, keep_alive_max_count_),
                   [this] { return svr_sock_ == INVALID_SOCKET; },
                   [this, ssl](httplib::Stream& stream, bool close_connection, bool& connection_closed) {
                     return process_request(stream, close_connection, connection_closed,
                                            [ssl](httplib::Request& request) { request.ssl = ssl; });
                   });
      transport.finish_sending();
    }
  }
  close_socket(sock);
  return true;
}

}  // namespace mm::service::rest
