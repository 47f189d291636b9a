#include "wire/rest_error.h"

#include <nlohmann/json.hpp>

namespace mm::wire {

std::string rest_error_body(const RestError& error) {
  const nlohmann::json body = {{"error", {{"code", error.code}, {"field", error.field}, {"message", error.message}}}};
  return body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::optional<RestError> rest_error_from_body(const std::string& body, const std::string& code_if_absent) {
  const auto parsed = nlohmann::json::parse(body, nullptr, false);
  if (parsed.is_discarded() || !parsed.is_object() || !parsed.contains("error") || !parsed["error"].is_object()) {
    return std::nullopt;
  }
  const auto& e = parsed["error"];
  return RestError{e.value("code", code_if_absent), e.value("field", ""), e.value("message", "")};
}

}  // namespace mm::wire
