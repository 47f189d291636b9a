#include "server/core/model_precisions.h"

#include "format/input_error.h"

namespace mm {

Precision ModelPrecisions::of(const std::string& model) const {
  const auto found = by_model.find(model);
  return found == by_model.end() ? all : found->second;
}

ModelPrecisions ModelPrecisions::parse(const std::vector<std::string>& values) {
  ModelPrecisions result;
  for (const auto& value : values) {
    const auto equals = value.find('=');
    const std::string name = equals == std::string::npos ? value : value.substr(equals + 1);
    const Precision precision = parse_precision(name, "--precision \"" + value + "\"");
    if (!precision_available(precision)) {
      throw InputError("--precision \"" + value + "\": " + name + " needs a CPU with bf16 dot products (avx512_bf16 "
                       "or AMX) and a build with oneDNN; this one has not");
    }
    if (equals == std::string::npos) {
      result.all = precision;
    } else {
      result.by_model[value.substr(0, equals)] = precision;
    }
  }
  return result;
}

}  // namespace mm
