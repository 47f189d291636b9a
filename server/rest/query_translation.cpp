#include "rest/query_translation.h"

#include <cerrno>
#include <cstdlib>
#include <set>

namespace mm::service::rest {
namespace {

ApiError invalid(const std::string& parameter, const std::string& message) {
  return ApiError(ErrorCode::kInvalidArgument, parameter, message);
}

void check_known_and_single(const QueryParameters& parameters, const std::set<std::string>& known) {
  for (auto it = parameters.begin(); it != parameters.end(); it = parameters.upper_bound(it->first)) {
    if (!known.count(it->first)) {
      std::string names;
      for (const auto& name : known) names += (names.empty() ? "" : ", ") + name;
      throw invalid(it->first, "unknown query parameter \"" + it->first + "\", expected " + names);
    }
    if (parameters.count(it->first) > 1) {
      throw invalid(it->first, "query parameter \"" + it->first + "\" is given " +
                                   std::to_string(parameters.count(it->first)) + " times, expected once");
    }
  }
}

std::string text(const QueryParameters& parameters, const std::string& name) {
  const auto found = parameters.find(name);
  return found == parameters.end() ? std::string() : found->second;
}

int64_t integer(const QueryParameters& parameters, const std::string& name) {
  const auto found = parameters.find(name);
  if (found == parameters.end()) return 0;
  const std::string& value = found->second;
  errno = 0;
  char* end = nullptr;
  const long long parsed = std::strtoll(value.c_str(), &end, 10);
  // strtoll also takes leading blanks and a plus sign: digits only.
  const size_t first_digit = !value.empty() && value[0] == '-' ? 1 : 0;
  const bool digits = value.size() > first_digit && value.find_first_not_of("0123456789", first_digit) == std::string::npos;
  if (!digits || end != value.c_str() + value.size() || errno == ERANGE) {
    throw invalid(name, "expected a 64-bit integer, got \"" + value + "\"");
  }
  return parsed;
}

}  // namespace

ReadClipRequest read_clip_request_from_query(const QueryParameters& parameters) {
  check_known_and_single(parameters, {"model", "path", "start"});
  ReadClipRequest request;
  request.model = text(parameters, "model");
  request.path = text(parameters, "path");
  request.start = integer(parameters, "start");
  return request;
}

UploadClipRequest upload_clip_request_from_query(const QueryParameters& parameters, std::string content) {
  check_known_and_single(parameters, {"path"});
  UploadClipRequest request;
  request.path = text(parameters, "path");
  request.content = std::move(content);
  return request;
}

std::string delete_clip_path_from_query(const QueryParameters& parameters) {
  check_known_and_single(parameters, {"path"});
  return text(parameters, "path");
}

}  // namespace mm::service::rest
