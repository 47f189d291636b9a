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

// Documents that nest arrays and objects deeper than this are refused before
// they are parsed: printing or comparing one recurses once per level, and a
// few hundred thousand levels overflow a thread's stack. Every document of
// this project nests a few levels.
constexpr int kMaxJsonDepth = 64;

// The deepest nesting of arrays and objects in `text` (0 for a number or a
// string), counted over its brackets outside strings; for text that is not
// JSON, a number that means nothing.
int json_nesting_depth(const std::string& text);

// The document in `text`; throws InputError "<source>: not valid JSON: ..."
// on a syntax error, or "<source>: nests deeper than ..." past kMaxJsonDepth.
// Any JSON value is accepted: the caller checks its shape.
nlohmann::json parse_json_text(const std::string& text, const std::string& source);

}  // namespace mm
