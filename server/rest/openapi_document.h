// The REST API's OpenAPI 3 document (server/rest/openapi.json), compiled into
// the binary and served verbatim at GET /v1/openapi.json.
// Thread safety: the text is immutable; call from any thread.
#pragma once

#include <string_view>

namespace mm::service::rest {

// The document's text, valid for the life of the program.
std::string_view openapi_document();

}  // namespace mm::service::rest
