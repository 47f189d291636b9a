#include "model/tool/precision_option.h"

#include "format/input_error.h"

namespace mm::tool {

void add_precision_option(CLI::App* command, std::string& value) {
  command
      ->add_option("--precision", value,
                   "inference weights: fp32 (as trained), bf16 (1.6 to 1.9 times as fast where the CPU has bf16 dot "
                   "products) or int8 (the GRUs' hidden-to-gates weights in 8-bit integers, the rest bf16; "
                   "faster again at batch 1); docs/PERFORMANCE.md gives their accuracy cost")
      ->check(CLI::IsMember({"fp32", "bf16", "int8"}))
      ->capture_default_str();
}

MotionManifold load_model_at_precision(const std::string& dir, const std::string& precision) {
  const Precision wanted = parse_precision(precision, "--precision");
  if (!precision_available(wanted)) {
    throw InputError("--precision: " + precision + " needs a CPU with bf16 dot products (avx512_bf16 or AMX) and a "
                     "build with oneDNN; this one has not");
  }
  MotionManifold model = MotionManifold::load(dir);
  if (wanted != Precision::kFp32) model.pack_for_inference(wanted);
  return model;
}

}  // namespace mm::tool
