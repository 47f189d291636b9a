// The REST/JSON frontend: an HTTP(S) server (cpp-httplib) that translates
// each route to one call of the core (Core) and its answer back to JSON, with
// the same error model as gRPC (http_errors.h). It validates only what JSON
// itself can get wrong (syntax, a field's type, the body's size); every
// other check is the core's. Routes: rest_routes.h and openapi.json.
//
// Thread safety: start(), port() and shutdown() may be called from any
// thread; requests are served by `threads` worker threads that call the
// core concurrently.
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "server/core/core.h"
#include "server/core/service_metrics.h"
#include "server/rest/rest_routes.h"

namespace httplib {
struct Request;
struct Response;
}  // namespace httplib

namespace mm::service {

struct RestOptions {
  std::string address = "0.0.0.0";
  int port = 8080;                   // 0: any free port (see RestFrontend::port)
  size_t max_body_bytes = 64 << 20;  // larger request bodies: 413 naming the limit
  // JSON bodies of motions or codes (body_limits.h): 64 motions of 300
  // frames x 99 values at 50 Hz are 17.0 MB with the data set's values and
  // 27.2 MB with float32 values widened to double (server/rest/README.md).
  size_t max_json_bytes = 32 << 20;
  // A take's body (POST /v1/takes:*): motion text of an hour at 50 Hz is
  // about 180 MB.
  size_t max_take_bytes = size_t{512} << 20;
  std::string tls_cert_file, tls_key_file;  // both given: HTTPS; neither: plain HTTP
  // Worker threads. Each serves one keep-alive connection at a time, so
  // clients beyond it wait for a connection to go idle (2 s): with 16, 32
  // REST clients got p99 6.3 x p50. They mostly sleep on the executor.
  int threads = 64;
  // Worker threads kept for job watch streams on top of `threads`: the
  // core's cap on open streams (--max-watch-streams), so that streams,
  // which hold a worker for their whole life, never take one that serves
  // calls. A stream refused by the cap is answered at once and its
  // connection closed.
  int watch_streams = 64;
  // Each connection's limits (guarded_http_server.h), which httplib 0.11
  // lacks: it times out one read at a time (5 s), so 300 clients sending a
  // byte every 3 s held every worker, and it reads a line of any length.
  // A request's whole head (request line and header fields), from the
  // connection's start or the previous reply: a head is a few hundred bytes,
  // sent in one packet; 10 s leaves a slow mobile link several
  // retransmissions, and bounds how long a slow client holds a worker.
  double header_timeout_seconds = 10;
  // A request's whole body, from the end of its head: the largest take
  // (--max-take-bytes, 512 MiB) needs 14 Mbit/s to arrive in 300 s, a
  // 64 MiB upload 1.8 Mbit/s; a slower link needs it raised.
  double body_timeout_seconds = 300;
  // Connections open at once from one client address: a quarter of the
  // workers (threads + watch_streams), so that one address that opens
  // connections and sends slowly leaves the other three quarters serving.
  // Behind a proxy every client has the proxy's address: raise it there
  // (to threads + watch_streams) and let the proxy cap each client.
  int max_connections_per_client = 32;
  // A request's head: RFC 9112 sets no limit; Apache and nginx take 8 kB
  // lines, and httplib refuses lines over 8192 bytes with their CRLF, so a
  // line (without its CRLF) may have 8190. A bearer token of 4096 bytes
  // fits. 200 header fields and 64 KiB in all are several times what
  // browsers and proxies send.
  size_t max_line_bytes = 8190;
  size_t max_headers = 200;
  size_t max_header_bytes = 64 << 10;
  // Folder served as static files at "/" (the web page, web/); empty: none.
  // GET requests look here before the routes, so it must hold no "v1" folder.
  std::string web_root;
};

class RestFrontend {
 public:
  // `core` and `metrics` outlive the frontend.
  RestFrontend(Core& core, ServiceMetrics& metrics, RestOptions options);
  ~RestFrontend();  // shutdown()
  RestFrontend(const RestFrontend&) = delete;
  RestFrontend& operator=(const RestFrontend&) = delete;

  // Binds the address and serves on a thread of its own. Throws
  // std::runtime_error naming the address (or the TLS files) when it cannot.
  void start();
  // The bound port (the chosen one when options.port was 0); -1 before start().
  int port() const;
  // Stops accepting connections, ends open event streams and waits for the
  // requests in flight to finish. Idempotent.
  void shutdown();

  // Answers one request of `route` whose body has been read, as the routes
  // of the started server do: the caller (request.remote_addr and its
  // Authorization headers), the translation, the core's call, and the reply
  // or refusal in `response`. Without a socket, for the fuzz targets
  // (tests/fuzz); works before start().
  void answer(rest::RouteId route, const httplib::Request& request, const std::string& body,
              httplib::Response& response);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace mm::service
