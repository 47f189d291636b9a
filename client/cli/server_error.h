// How the client reports failure: a server's refusal (ServerError) is
// printed as it came and exits 1; bad local input or usage (the format
// library's InputError) exits 2, as the motion-manifold tool does.
#pragma once

#include <stdexcept>
#include <string>

namespace mm::client {

constexpr int kExitSuccess = 0;
constexpr int kExitServerError = 1;  // the server refused, or could not be reached
constexpr int kExitUsage = 2;        // bad flags or a bad local file

// A call the server refused (or that never reached it): the status code's
// name as gRPC spells it ("INVALID_ARGUMENT", "UNAVAILABLE", ...), the request
// field at fault (may be empty) and the server's message. Both protocols
// produce the same three values, so the client prints them alike.
class ServerError : public std::runtime_error {
 public:
  ServerError(std::string code, std::string field, std::string message)
      : std::runtime_error(describe(code, field, message)),
        code_(std::move(code)), field_(std::move(field)), message_(std::move(message)) {}

  const std::string& code() const { return code_; }
  const std::string& field() const { return field_; }
  // The message without the field.
  const std::string& message() const { return message_; }
  // A broken connection or a server going away: worth calling again.
  bool retryable() const { return code_ == "UNAVAILABLE"; }

 private:
  // "<CODE>: <field>: <message>", the field left out when empty.
  static std::string describe(const std::string& code, const std::string& field, const std::string& message) {
    return code + ": " + (field.empty() ? "" : field + ": ") + message;
  }

  std::string code_, field_, message_;
};

}  // namespace mm::client
