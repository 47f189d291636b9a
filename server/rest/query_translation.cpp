#include "server/rest/query_translation.h"

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

// A number (frame_rate, hop_seconds): "nan" and "inf" pass, so that the
// core refuses them naming the field and the value.
double real(const QueryParameters& parameters, const std::string& name, double fallback) {
  const auto found = parameters.find(name);
  if (found == parameters.end()) return fallback;
  const std::string& value = found->second;
  char* end = nullptr;
  const double parsed = std::strtod(value.c_str(), &end);
  if (value.empty() || end != value.c_str() + value.size() || value.find_first_of(" \t") != std::string::npos) {
    throw invalid(name, "expected a number, got \"" + value + "\"");
  }
  return parsed;
}

bool boolean(const QueryParameters& parameters, const std::string& name) {
  const std::string value = text(parameters, name);
  if (value.empty() || value == "false") return false;
  if (value == "true") return true;
  throw invalid(name, "expected true or false, got \"" + value + "\"");
}

}  // namespace

TakeRequest take_request_from_query(const QueryParameters& parameters, bool denoise, bool bvh_body) {
  std::set<std::string> known = {"model", "frame_rate", "hop_seconds", "blend", "decoder", "at_model_rate", "path", "root"};
  if (denoise) known.insert({"zeros_are_missing", "means_are_missing", "iterations", "keep_observed", "gap_fill"});
  check_known_and_single(parameters, known);
  TakeRequest request;
  request.model = text(parameters, "model");
  if (bvh_body && parameters.count("frame_rate")) {
    throw invalid("frame_rate", "a BVH body's rate is its Frame Time; frame_rate is for motion text only");
  }
  // Motion text without a rate: the H3.6M files' 50 Hz. 0 for a path: the
  // core takes the file's own (a BVH's Frame Time, 50 Hz for text).
  const bool has_path = parameters.count("path") > 0;
  request.frame_rate = real(parameters, "frame_rate", has_path ? 0.0 : 50.0);
  request.hop_seconds = real(parameters, "hop_seconds", 0.0);
  request.blend = text(parameters, "blend");
  request.decoder = text(parameters, "decoder");
  request.at_model_rate = boolean(parameters, "at_model_rate");
  request.path = text(parameters, "path");
  request.root = text(parameters, "root");
  if (has_path && request.path.empty()) throw invalid("path", "path is empty, expected a file under the data root");
  if (denoise) {
    request.zeros_are_missing = boolean(parameters, "zeros_are_missing");
    request.means_are_missing = boolean(parameters, "means_are_missing");
    const int64_t iterations = integer(parameters, "iterations");
    if (iterations < 0 || iterations > 1000000) {
      throw invalid("iterations", "expected 0 (four) to 1000000, got " + std::to_string(iterations));
    }
    request.iterations = static_cast<int>(iterations);
    request.keep_observed = boolean(parameters, "keep_observed");
    // Its name and its place (keep_observed only) are the core's to check,
    // so that REST refuses it as gRPC does.
    request.gap_fill = text(parameters, "gap_fill");
  }
  return request;
}

ReadClipRequest read_clip_request_from_query(const QueryParameters& parameters) {
  check_known_and_single(parameters, {"model", "path", "start"});
  ReadClipRequest request;
  request.model = text(parameters, "model");
  request.path = text(parameters, "path");
  request.start = integer(parameters, "start");
  return request;
}

ReadClipRequest read_clip_motion_request_from_query(const QueryParameters& parameters) {
  // No start: the whole file begins at its first frame.
  check_known_and_single(parameters, {"model", "path"});
  ReadClipRequest request;
  request.model = text(parameters, "model");
  request.path = text(parameters, "path");
  request.whole = true;
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
