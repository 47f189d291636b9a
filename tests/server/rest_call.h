// One REST call to a test server on loopback with a bearer token, checked
// against the expected status: the shared helper of the suites that drive a
// real server over REST.
#pragma once

#include <gtest/gtest.h>
#include <httplib.h>

#include <nlohmann/json.hpp>
#include <string>

namespace mm::test {

// GET, or POST of `body` ("{}" when null); returns the parsed reply, or null
// after a test failure when the server did not answer.
inline nlohmann::json rest_call(int port, const std::string& token, const std::string& method,
                                const std::string& path, const nlohmann::json& body = nlohmann::json(),
                                int expected = 200) {
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(120, 0);  // a training job's first steps on a busy machine
  const httplib::Headers headers = {{"Authorization", "Bearer " + token}};
  auto result = method == "GET" ? client.Get(path.c_str(), headers)
                                : client.Post(path.c_str(), headers, body.is_null() ? "{}" : body.dump(),
                                              "application/json");
  if (!result) {
    ADD_FAILURE() << method << " " << path << ": " << httplib::to_string(result.error());
    return nlohmann::json();
  }
  EXPECT_EQ(result->status, expected) << method << " " << path << ": " << result->body;
  return nlohmann::json::parse(result->body);
}

}  // namespace mm::test
