// How large a request body each route takes: what its largest legitimate
// request needs, so that a body beyond it is refused by its declared length
// (Content-Length) before a byte of it is read, and a chunked one as soon as
// it grows past the limit. Parsing JSON costs several times its size in
// memory (a 50 MB body took 218 MiB), so JSON bodies have a limit of their
// own below --max-message-bytes, which stays the bound for files (uploads,
// BVH bodies) and the outer bound for every body.
//
// Thread safety: pure functions; call from any thread.
#pragma once

#include <cstddef>
#include <string>

#include "server/rest/rest_routes.h"

namespace mm::service::rest {

// The most a body of parameters only takes (Sample, SubmitJob, activation,
// cancel): a training configuration is a few kB.
constexpr size_t kMaxParametersBodyBytes = size_t{1} << 20;

// A route's body limit and the name a refusal gives it.
struct BodyLimit {
  size_t bytes = 0;
  std::string name;  // "--max-json-bytes", "--max-message-bytes", ...
};

// The limit of a body of `route`: uploads and BVH bodies (`bvh_body`) take
// up to `max_message_bytes`; JSON bodies of motions or codes (Encode,
// Decode, Interpolate, Analogy, Denoise) up to `max_json_bytes`; bodies of
// parameters up to kMaxParametersBodyBytes; none more than
// `max_message_bytes`; a take (POST /v1/takes:*, motion text or BVH) up to
// `max_take_bytes`, its own bound (a take of an hour is larger than any
// other body). A route not named here has the outer bound.
BodyLimit body_limit(RouteId route, bool bvh_body, size_t max_message_bytes, size_t max_json_bytes,
                     size_t max_take_bytes);

}  // namespace mm::service::rest
