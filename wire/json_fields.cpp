#include "wire/json_fields.h"

#include <cfloat>
#include <cmath>
#include <limits>
#include <type_traits>

namespace mm::wire {

using json = nlohmann::json;

namespace {

// Reads an integer-valued JSON number (150, 150.0, 1.5e2) or, where proto3
// allows it, a decimal string; range-checked against T.
template <typename T>
T read_integer(const json& value, const std::string& path, bool strings_allowed) {
  const char* expected = std::is_signed<T>::value ? (sizeof(T) == 8 ? "a 64-bit integer" : "a 32-bit integer")
                                                   : "a non-negative 64-bit integer";
  if (value.is_number_unsigned()) {
    const uint64_t v = value.get<uint64_t>();
    if (v > static_cast<uint64_t>(std::numeric_limits<T>::max())) throw type_error(path, expected, value);
    return static_cast<T>(v);
  }
  if (value.is_number_integer()) {
    const int64_t v = value.get<int64_t>();
    if (v < static_cast<int64_t>(std::numeric_limits<T>::min()) ||
        (v > 0 && static_cast<uint64_t>(v) > static_cast<uint64_t>(std::numeric_limits<T>::max())))
      throw InputError(path, "expected " + std::string(expected) + ", got " + std::to_string(v));
    return static_cast<T>(v);
  }
  if (value.is_number_float()) {
    const double v = value.get<double>();
    // Below 2^digits, exclusive: a 64-bit max converted to double rounds up
    // to that power of two, which is itself out of range.
    if (!(std::floor(v) == v) || v < static_cast<double>(std::numeric_limits<T>::min()) ||
        v >= std::ldexp(1.0, std::numeric_limits<T>::digits))
      throw InputError(path, "expected " + std::string(expected) + ", got " + value.dump());
    return static_cast<T>(v);
  }
  if (value.is_string() && strings_allowed) {
    const std::string& text = value.get_ref<const std::string&>();
    // Digits only, with a minus sign where T is signed: stoll and stoull
    // would also take leading blanks and a plus sign, and stoull a minus
    // sign, negating the number into a huge one.
    const size_t first_digit = std::is_signed<T>::value && !text.empty() && text[0] == '-' ? 1 : 0;
    const bool digits = text.size() > first_digit &&
                        text.find_first_not_of("0123456789", first_digit) == std::string::npos;
    try {
      if (digits && std::is_signed<T>::value) {
        const long long v = std::stoll(text);
        if (v >= static_cast<long long>(std::numeric_limits<T>::min()) &&
            v <= static_cast<long long>(std::numeric_limits<T>::max()))
          return static_cast<T>(v);
      } else if (digits) {
        return static_cast<T>(std::stoull(text));
      }
    } catch (const std::out_of_range&) {
    }
    throw InputError(path,
                     "expected " + std::string(expected) + " (a number or its decimal string), got \"" + text + "\"");
  }
  throw type_error(path, expected, value);
}

double read_double(const json& value, const std::string& path) {
  if (value.is_number()) return value.get<double>();
  if (value.is_string()) {
    // proto3's JSON mapping spells the non-finite floats as strings; they
    // pass through so that the core, not the frontend, refuses them.
    const std::string& text = value.get_ref<const std::string&>();
    if (text == "NaN") return std::numeric_limits<double>::quiet_NaN();
    if (text == "Infinity") return std::numeric_limits<double>::infinity();
    if (text == "-Infinity") return -std::numeric_limits<double>::infinity();
  }
  throw type_error(path, "a number", value);
}

// A double as the nearest float. Past the midpoint between FLT_MAX and
// 2^128 it is infinite, as rounding to nearest makes it; converting a value
// outside float's range is undefined behaviour, so those are written out.
// FLT_MAX's shortest text (3.4028235e+38) is a double just above FLT_MAX,
// and reads back as FLT_MAX.
float narrowed(double v) {
  constexpr double kRoundsToInfinity = 0x1.ffffffp127;
  if (v >= kRoundsToInfinity) return std::numeric_limits<float>::infinity();
  if (v <= -kRoundsToInfinity) return -std::numeric_limits<float>::infinity();
  if (v > FLT_MAX) return FLT_MAX;
  if (v < -FLT_MAX) return -FLT_MAX;
  return static_cast<float>(v);
}

}  // namespace

std::string member_path(const std::string& parent, const std::string& key) {
  return parent.empty() ? key : parent + "." + key;
}

std::string index_path(const std::string& parent, size_t index) {
  return parent + "[" + std::to_string(index) + "]";
}

InputError type_error(const std::string& path, const std::string& expected, const json& value) {
  return InputError(path, "expected " + expected + ", got " + std::string(value.type_name()));
}

void read_floats(const json& value, const std::string& path, google::protobuf::RepeatedField<float>* out) {
  if (!value.is_array()) throw type_error(path, "an array of numbers", value);
  const auto& elements = value.get_ref<const json::array_t&>();
  out->Reserve(out->size() + static_cast<int>(elements.size()));
  for (size_t i = 0; i < elements.size(); ++i) {
    const json& element = elements[i];
    // The common case first: this loop runs for every value of every frame.
    if (element.is_number()) {
      out->AddAlreadyReserved(narrowed(element.get<double>()));
    } else {
      out->AddAlreadyReserved(narrowed(read_double(element, index_path(path, i))));
    }
  }
}

ObjectReader::ObjectReader(const json& value, std::string path, UnknownFields unknown)
    : value_(value), path_(std::move(path)), unknown_(unknown) {
  if (!value.is_object()) throw type_error(path_, "an object", value);
}

const json* ObjectReader::find(const std::string& key) {
  known_.insert(key);
  const auto it = value_.find(key);
  if (it == value_.end() || it->is_null()) return nullptr;
  return &*it;
}

std::string ObjectReader::string(const std::string& key) {
  const json* v = find(key);
  if (v == nullptr) return "";
  if (!v->is_string()) throw type_error(path(key), "a string", *v);
  return v->get<std::string>();
}

bool ObjectReader::boolean(const std::string& key) {
  const json* v = find(key);
  if (v == nullptr) return false;
  if (!v->is_boolean()) throw type_error(path(key), "a boolean (true or false)", *v);
  return v->get<bool>();
}

int32_t ObjectReader::int32(const std::string& key) {
  const json* v = find(key);
  return v == nullptr ? 0 : read_integer<int32_t>(*v, path(key), false);
}

int64_t ObjectReader::int64(const std::string& key) {
  const json* v = find(key);
  return v == nullptr ? 0 : read_integer<int64_t>(*v, path(key), true);
}

uint64_t ObjectReader::uint64(const std::string& key) {
  const json* v = find(key);
  return v == nullptr ? 0 : read_integer<uint64_t>(*v, path(key), true);
}

double ObjectReader::number(const std::string& key) {
  const json* v = find(key);
  return v == nullptr ? 0 : read_double(*v, path(key));
}

void ObjectReader::floats(const std::string& key, google::protobuf::RepeatedField<float>* out) {
  if (const json* v = find(key)) read_floats(*v, path(key), out);
}

std::string ObjectReader::object_text(const std::string& key, const std::string& what) {
  const json* v = find(key);
  if (v == nullptr) return "";
  if (!v->is_object()) throw type_error(path(key), "an object (" + what + ")", *v);
  return v->dump();
}

void ObjectReader::finish() const {
  if (unknown_ == UnknownFields::kIgnore) return;
  for (auto it = value_.begin(); it != value_.end(); ++it) {
    if (known_.count(it.key()) == 0) {
      std::string names;
      for (const auto& name : known_) names += (names.empty() ? "" : ", ") + name;
      throw InputError(path(it.key()), names.empty() ? "unknown field; this call takes no fields"
                                                     : "unknown field; expected one of: " + names);
    }
  }
}

}  // namespace mm::wire
