// --precision fp32|bf16|int8: the number format of the loaded model's
// inference weights (inference_precision.h). A loaded model multiplies in
// fp32; bf16 and int8 pack its weights again, where the CPU has bf16 dot
// products.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "model/motion_manifold.h"

namespace mm::tool {

void add_precision_option(CLI::App* command, std::string& value);

// The model at `dir`, its inference weights in `precision` ("fp32", "bf16"
// or "int8"). InputError naming --precision for an unknown value or one this
// machine cannot run.
MotionManifold load_model_at_precision(const std::string& dir, const std::string& precision);

}  // namespace mm::tool
