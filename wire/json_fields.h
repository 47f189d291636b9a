// Reading one JSON object of a REST body field by field, each refusal naming
// the field by its path in the body ("motions[0].values[12]",
// "from.motion.frames"), the value and what was expected. The REST messages
// (wire/rest_json.h) are read with it on both sides: the server reading a
// request, the client reading a reply.
//
// Lenient where proto3's JSON mapping is: an absent or null member reads as
// the zero value, a number may be the string "NaN", "Infinity" or
// "-Infinity", and a 64-bit integer a decimal string. Strict about what JSON
// itself can get wrong: a member of the wrong JSON type, an integer with a
// fraction or out of its type's range, and (where the reader is told to
// refuse them) a member nobody asked for.
//
// Thread safety: an ObjectReader belongs to one thread; the functions are
// pure.
#pragma once

#include <cstdint>
#include <set>
#include <stdexcept>
#include <string>

#include <google/protobuf/repeated_field.h>
#include <nlohmann/json.hpp>

#include "format/input_error.h"

namespace mm::wire {

// A field of a JSON body that cannot be read is an InputError
// (format/input_error.h) whose field() is its path in the body ("" for the
// body as a whole) and whose detail() says the value and what was expected
// ("expected a 32-bit integer, got 1.5"). The server answers it as
// INVALID_ARGUMENT naming the field; the client reports it as a reply it
// cannot read.

// What a reader does with a member it was not asked for: a request's is
// refused, so that a misspelt option ("zeros_missing") is never silently
// its default; a reply's is ignored, so that a client reads a newer server's
// reply.
enum class UnknownFields { kRefuse, kIgnore };

// "parent.key", or "key" at the top.
std::string member_path(const std::string& parent, const std::string& key);
// "parent[index]".
std::string index_path(const std::string& parent, size_t index);

// InputError "expected <expected>, got <the JSON type's name>".
InputError type_error(const std::string& path, const std::string& expected, const nlohmann::json& value);

// A JSON array of numbers appended to `out` (reserved first: the arrays of
// a motion's values are the bulk of a body). A value beyond float's range
// is read as an infinity, which the server's core refuses as it refuses any
// non-finite value.
void read_floats(const nlohmann::json& value, const std::string& path, google::protobuf::RepeatedField<float>* out);

// One JSON object: hands out its members by name, then (finish) refuses any
// member nobody asked for when told to. Every getter returns the zero value
// for an absent or null member. The reader keeps a reference to `value`.
class ObjectReader {
 public:
  // InputError when `value` is not an object.
  ObjectReader(const nlohmann::json& value, std::string path, UnknownFields unknown);

  // The member, or nullptr when absent or null; marks it as read.
  const nlohmann::json* find(const std::string& key);
  // The member's path in the body.
  std::string path(const std::string& key) const { return member_path(path_, key); }

  std::string string(const std::string& key);
  bool boolean(const std::string& key);
  int32_t int32(const std::string& key);    // a JSON number only, as proto3's JSON writes it
  int64_t int64(const std::string& key);    // a number or its decimal string
  uint64_t uint64(const std::string& key);  // a number or its decimal string
  double number(const std::string& key);    // a number, "NaN", "Infinity" or "-Infinity"
  void floats(const std::string& key, google::protobuf::RepeatedField<float>* out);
  // An embedded JSON object (a training configuration, a model's
  // provenance) as its compact text; "" when absent. `what` names the object
  // in the refusal ("the training configuration").
  std::string object_text(const std::string& key, const std::string& what);

  // Call after the last member is read: InputError for a member not read,
  // when unknown members are refused.
  void finish() const;

  UnknownFields unknown() const { return unknown_; }

 private:
  const nlohmann::json& value_;
  std::string path_;
  UnknownFields unknown_;
  std::set<std::string> known_;
};

}  // namespace mm::wire
