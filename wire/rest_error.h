// The body of every REST refusal,
//   {"error": {"code": "INVALID_ARGUMENT", "field": "motions[0].columns", "message": "..."}}
// written by the server (server/rest/http_errors.cpp) and read by the client
// (client/cli/rest_connection.cpp) from this one definition.
//
// Thread safety: pure functions; call from any thread.
#pragma once

#include <optional>
#include <string>

namespace mm::wire {

// A refusal as REST carries it: the gRPC code's name, the request field it
// names ("" for the request as a whole) and the message.
struct RestError {
  std::string code;
  std::string field;
  std::string message;
};

// The JSON error body (one line, no trailing newline). Bytes of the message
// that are not UTF-8 (a message may quote the request) are replaced by
// U+FFFD rather than fail to answer.
std::string rest_error_body(const RestError& error);

// The refusal in a reply's body; nullopt when the body is not such an object
// (a proxy's page, say). An absent "code" is `code_if_absent`, an absent
// "field" or "message" "". Throws nlohmann::json::type_error when one of
// them is not a string.
std::optional<RestError> rest_error_from_body(const std::string& body, const std::string& code_if_absent);

}  // namespace mm::wire
