// The REST API's routes: method and path, in the OpenAPI document's own
// template form ("/v1/models/{name}:activate"), each with the operation it
// stands for. The frontend registers exactly these, and a test checks them
// against openapi.json both ways.
// Thread safety: immutable data; call from any thread.
#pragma once

#include <string>
#include <vector>

namespace mm::service::rest {

enum class RouteId {
  kEncode, kDecode, kSample, kInterpolate, kAnalogy, kDenoise, kJoinClips,
  kEncodeTake, kReconstructTake, kDenoiseTake, kDecodeTrack,
  kListModels, kDescribeModel, kActivateModel, kDeleteModel,
  kListClips, kReadClip, kReadClipMotion, kUploadClip, kDeleteClip,
  kSubmitJob, kListJobs, kGetJob, kCancelJob, kDeleteJob, kJobEvents,
  kHealth, kReady, kMetrics, kOpenApi,
};

struct RestRoute {
  RouteId id;
  std::string method;         // "GET", "POST" or "DELETE"
  std::string path_template;  // OpenAPI path; {name} and {id} are path parameters
};

// Every route, in the order of the OpenAPI document.
const std::vector<RestRoute>& rest_routes();

// The regular expression (for httplib) that matches a path template: each
// {parameter} becomes one capture group of a non-empty segment without '/'
// or ':' (so "{name}:activate" splits at the colon), the rest is literal.
std::string route_regex(const std::string& path_template);

}  // namespace mm::service::rest
