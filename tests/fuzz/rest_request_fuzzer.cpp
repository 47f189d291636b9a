// libFuzzer target: one REST request into the real core, through the code
// the server runs once a request is read (RestFrontend::answer: the caller,
// the JSON / BVH / query-string translation, the core's call, the reply).
//
// An input is a request as text, the way it travels minus what httplib
// itself parses:
//   POST /v1/encode?model=h36m-dkgm-cpu      method and target, one line
//   Content-Type: application/x-bvh           headers, one a line
//                                             an empty line
//   HIERARCHY ...                             the body: the rest of the input
// The target's path and query are decoded by httplib's own functions and the
// route is matched with the server's route table and patterns; the caller is
// on loopback (127.0.0.1) with no token, so writes are let in.
// A reply of status 500, or none, aborts: every request deserves an answer
// that is not INTERNAL.
#include <httplib.h>

#include <cstddef>
#include <cstdint>
#include <regex>
#include <string>
#include <vector>

#include "server/rest/rest_frontend.h"
#include "server/rest/rest_routes.h"
#include "tests/fuzz/fuzz_service.h"

namespace {

using mm::service::rest::RouteId;

struct CompiledRoute {
  RouteId id;
  std::string method;
  std::regex pattern;
};

struct RestTarget {
  mm::service::RestFrontend frontend;
  std::vector<CompiledRoute> routes;

  RestTarget() : frontend(mm::fuzz::fuzz_service().core, mm::fuzz::fuzz_service().metrics, {}) {
    for (const auto& route : mm::service::rest::rest_routes())
      routes.push_back({route.id, route.method, std::regex(mm::service::rest::route_regex(route.path_template))});
  }
};

RestTarget& target() {
  static RestTarget* made = new RestTarget();  // left alive: the core it answers from lives until exit
  return *made;
}

// Splits off the next line (without its "\n" or "\r\n"); false at the end.
bool next_line(const std::string& input, size_t& at, std::string& line) {
  if (at >= input.size()) return false;
  size_t end = input.find('\n', at);
  if (end == std::string::npos) end = input.size();
  line = input.substr(at, end - at);
  if (!line.empty() && line.back() == '\r') line.pop_back();
  at = end + 1;
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  target();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  size_t at = 0;
  std::string line;
  // httplib answers a longer request line 414 itself, before any route.
  if (!next_line(input, at, line) || line.size() > CPPHTTPLIB_REQUEST_URI_MAX_LENGTH) return 0;
  const size_t space = line.find(' ');
  if (space == std::string::npos) return 0;

  httplib::Request request;
  request.method = line.substr(0, space);
  request.target = line.substr(space + 1);
  request.remote_addr = "127.0.0.1";
  request.remote_port = 40000;
  // As httplib's Server::parse_request_line: the path decoded, then the
  // query string parsed (and decoded) into params.
  const size_t question = request.target.find('?');
  request.path = httplib::detail::decode_url(request.target.substr(0, question), false);
  if (question != std::string::npos) httplib::detail::parse_query_text(request.target.substr(question + 1), request.params);

  while (next_line(input, at, line) && !line.empty()) {
    const size_t colon = line.find(':');
    if (colon == std::string::npos) return 0;  // httplib refuses such a header line
    const size_t value = line.find_first_not_of(" \t", colon + 1);
    request.headers.emplace(line.substr(0, colon), value == std::string::npos ? "" : line.substr(value));
  }
  const std::string body = at < input.size() ? input.substr(at) : std::string();

  RestTarget& rest = target();
  for (const CompiledRoute& route : rest.routes) {
    if (route.method != request.method || !std::regex_match(request.path, request.matches, route.pattern)) continue;
    httplib::Response response;
    rest.frontend.answer(route.id, request, body, response);
    mm::fuzz::print_answer_when_verbose(request.method + " " + request.target, response.status, response.body);
    if (response.status == 500 || response.status < 0)  // < 0: no answer at all
      mm::fuzz::report_internal_error(request.method + " " + request.path,
                                      response.status < 0 ? "no status was set" : response.body);
    return 0;
  }
  return 0;
}
