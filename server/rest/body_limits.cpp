#include "server/rest/body_limits.h"

namespace mm::service::rest {

BodyLimit body_limit(RouteId route, bool bvh_body, size_t max_message_bytes, size_t max_json_bytes,
                     size_t max_take_bytes) {
  const BodyLimit outer{max_message_bytes, "--max-message-bytes"};
  // The smaller of a route's own limit and the outer one, named as the one that binds.
  const auto within_outer = [&](BodyLimit own) { return own.bytes < outer.bytes ? own : outer; };
  switch (route) {
    case RouteId::kUploadClip:
      return outer;
    case RouteId::kEncode:
    case RouteId::kDenoise:
      if (bvh_body) return outer;
      return within_outer({max_json_bytes, "--max-json-bytes"});
    case RouteId::kEncodeTake:
    case RouteId::kReconstructTake:
    case RouteId::kDenoiseTake:
      return {max_take_bytes, "--max-take-bytes"};
    case RouteId::kDecode:
    case RouteId::kDecodeTrack:
    case RouteId::kInterpolate:
    case RouteId::kAnalogy:
    case RouteId::kJoinClips:  // JSON, or two files in a multipart/form-data body
      return within_outer({max_json_bytes, "--max-json-bytes"});
    case RouteId::kSample:
    case RouteId::kSubmitJob:
    case RouteId::kActivateModel:
    case RouteId::kCancelJob:
    case RouteId::kDeleteModel:
    case RouteId::kDeleteJob:
    case RouteId::kDeleteClip:
      return within_outer({kMaxParametersBodyBytes, "a body of parameters only"});
    default:
      return outer;
  }
}

}  // namespace mm::service::rest
