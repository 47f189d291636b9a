#include "server/rest/rest_routes.h"

namespace mm::service::rest {

const std::vector<RestRoute>& rest_routes() {
  // Colon verbs (":activate", ":cancel") follow Google's API design guide,
  // as gRPC transcoding does: the resource stays the path, the verb is not
  // a sub-resource.
  static const std::vector<RestRoute> routes = {
      {RouteId::kEncode, "POST", "/v1/encode"},
      {RouteId::kDecode, "POST", "/v1/decode"},
      {RouteId::kSample, "POST", "/v1/sample"},
      {RouteId::kInterpolate, "POST", "/v1/interpolate"},
      {RouteId::kAnalogy, "POST", "/v1/analogy"},
      {RouteId::kDenoise, "POST", "/v1/denoise"},
      {RouteId::kJoinClips, "POST", "/v1/join"},
      {RouteId::kEncodeTake, "POST", "/v1/takes:encode"},
      {RouteId::kReconstructTake, "POST", "/v1/takes:reconstruct"},
      {RouteId::kDenoiseTake, "POST", "/v1/takes:denoise"},
      {RouteId::kDecodeTrack, "POST", "/v1/tracks:decode"},
      {RouteId::kListModels, "GET", "/v1/models"},
      {RouteId::kDescribeModel, "GET", "/v1/models/{name}"},
      {RouteId::kActivateModel, "POST", "/v1/models/{name}:activate"},
      {RouteId::kDeleteModel, "DELETE", "/v1/models/{name}"},
      {RouteId::kListClips, "GET", "/v1/clips"},
      {RouteId::kReadClip, "GET", "/v1/clips/window"},
      {RouteId::kReadClipMotion, "GET", "/v1/clips/motion"},
      {RouteId::kUploadClip, "POST", "/v1/clips:upload"},
      {RouteId::kDeleteClip, "DELETE", "/v1/clips"},
      {RouteId::kSubmitJob, "POST", "/v1/jobs"},
      {RouteId::kListJobs, "GET", "/v1/jobs"},
      {RouteId::kGetJob, "GET", "/v1/jobs/{id}"},
      {RouteId::kCancelJob, "POST", "/v1/jobs/{id}:cancel"},
      {RouteId::kDeleteJob, "DELETE", "/v1/jobs/{id}"},
      {RouteId::kJobEvents, "GET", "/v1/jobs/{id}/events"},
      {RouteId::kHealth, "GET", "/healthz"},
      {RouteId::kReady, "GET", "/readyz"},
      {RouteId::kMetrics, "GET", "/metrics"},
      {RouteId::kOpenApi, "GET", "/v1/openapi.json"},
  };
  return routes;
}

std::string route_regex(const std::string& path_template) {
  std::string regex;
  for (size_t i = 0; i < path_template.size(); ++i) {
    const char c = path_template[i];
    if (c == '{') {
      const size_t close = path_template.find('}', i);
      regex += "([^/:]+)";
      i = close;
    } else if (std::string("\\^$.|?*+()[]{}").find(c) != std::string::npos) {
      regex += '\\';
      regex += c;
    } else {
      regex += c;
    }
  }
  return regex;
}

}  // namespace mm::service::rest
