// REST calls to a test server on loopback, the shared helpers of every suite
// that drives a real server over REST: a client with timeouts long enough for
// a busy machine, replies with their status, headers, body and the body
// parsed, and rest_call for the common case of a JSON call checked against
// its expected status.
#pragma once

#include <gtest/gtest.h>
#include <httplib.h>

#include <nlohmann/json.hpp>
#include <string>

namespace mm::test {

// A client of the server's REST port. The read timeout covers a training
// job's first steps, or a batch, on a machine busy with other tests.
inline httplib::Client rest_client(int port) {
  httplib::Client client("127.0.0.1", port);
  client.set_connection_timeout(10);
  client.set_read_timeout(300);
  client.set_write_timeout(300);
  return client;
}

struct Reply {
  int status = 0;  // 0: the server did not answer (a test failure is recorded)
  std::string body;
  httplib::Headers headers;
  nlohmann::json document;  // the body parsed, or null when it is not JSON

  const nlohmann::json& error() const { return document.at("error"); }
  std::string field() const { return error().at("field").get<std::string>(); }
  std::string header(const std::string& name) const {
    const auto found = headers.find(name);
    return found == headers.end() ? "" : found->second;
  }
};

inline Reply to_reply(const httplib::Result& result) {
  Reply reply;
  if (!result) {
    ADD_FAILURE() << "no HTTP answer: " << httplib::to_string(result.error());
    return reply;
  }
  reply.status = result->status;
  reply.body = result->body;
  reply.headers = result->headers;
  reply.document = nlohmann::json::parse(result->body, nullptr, false);
  if (reply.document.is_discarded()) reply.document = nullptr;
  return reply;
}

inline httplib::Headers bearer(const std::string& token) { return {{"Authorization", "Bearer " + token}}; }

inline Reply get(int port, const std::string& path, const httplib::Headers& headers = {}) {
  auto client = rest_client(port);
  return to_reply(client.Get(path.c_str(), headers));
}

// POST of a body as it is (JSON by default; a BVH file, say, with its type).
inline Reply post(int port, const std::string& path, const std::string& body, const httplib::Headers& headers = {},
                  const std::string& content_type = "application/json") {
  auto client = rest_client(port);
  return to_reply(client.Post(path.c_str(), headers, body, content_type.c_str()));
}
inline Reply post(int port, const std::string& path, const nlohmann::json& body, const httplib::Headers& headers = {}) {
  return post(port, path, body.dump(), headers);
}

inline Reply del(int port, const std::string& path, const httplib::Headers& headers = {}) {
  auto client = rest_client(port);
  return to_reply(client.Delete(path.c_str(), headers));
}

// GET, DELETE, or POST of `body` ("{}" when null), with a bearer token; the
// parsed reply, checked against the expected status (null when it is not JSON).
inline nlohmann::json rest_call(int port, const std::string& token, const std::string& method,
                                const std::string& path, const nlohmann::json& body = nlohmann::json(),
                                int expected = 200) {
  const Reply reply = method == "GET"      ? get(port, path, bearer(token))
                      : method == "DELETE" ? del(port, path, bearer(token))
                                           : post(port, path, body.is_null() ? nlohmann::json::object() : body,
                                                  bearer(token));
  if (reply.status != 0) EXPECT_EQ(reply.status, expected) << method << " " << path << ": " << reply.body;
  return reply.document;
}

}  // namespace mm::test
