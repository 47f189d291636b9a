// Parsing a JSON document that a person or another program wrote (a model's
// manifest, a training configuration, a skeleton, normalisation statistics):
// a syntax error becomes an InputError that names where the text came from.
//
// Only for code that links nlohmann_json itself: mm_format's other public
// headers keep JSON out of their interface.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace mm {

// The document in `text`; throws InputError "<source>: not valid JSON: ..."
// on a syntax error. Any JSON value is accepted: the caller checks its shape.
nlohmann::json parse_json_text(const std::string& text, const std::string& source);

}  // namespace mm
