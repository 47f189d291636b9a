// Which inference precision (model/inference_precision.h) each model of the
// store is loaded in: one for all, and any model named on its own.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "model/inference_precision.h"

namespace mm {

struct ModelPrecisions {
  Precision all = Precision::kFp32;
  std::map<std::string, Precision> by_model;

  Precision of(const std::string& model) const;

  // From the --precision values: "bf16" sets every model, "NAME=fp32" one.
  // InputError naming --precision and the value, for an unknown precision
  // or one this machine cannot run.
  static ModelPrecisions parse(const std::vector<std::string>& values);
};

}  // namespace mm
