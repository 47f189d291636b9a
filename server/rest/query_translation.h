// The query string of a route -> the core's plain types, for the routes
// that take their request there (GET /v1/clips/window: a read names a file
// and a frame, and a GET can be bookmarked, cached and linked from the page;
// POST /v1/clips:upload, whose body is the file itself; DELETE /v1/clips). Strict as the JSON bodies are: an unknown parameter, one given
// twice, or a value that is not of its type is INVALID_ARGUMENT naming the
// parameter. Values in range are the core's to check.
//
// Thread safety: pure functions; call from any thread.
#pragma once

#include <map>
#include <string>

#include "core/api_types.h"

namespace mm::service::rest {

// The decoded query parameters, as httplib gives them.
using QueryParameters = std::multimap<std::string, std::string>;

// ?path=<relative path>&start=<integer, default 0>&model=<name, default the active model>
ReadClipRequest read_clip_request_from_query(const QueryParameters& parameters);

// ?path=<relative path of the new file>, and the body as its content.
UploadClipRequest upload_clip_request_from_query(const QueryParameters& parameters, std::string content);

// ?path=<relative path of an uploaded file> (DELETE /v1/clips): the path.
std::string delete_clip_path_from_query(const QueryParameters& parameters);

}  // namespace mm::service::rest
