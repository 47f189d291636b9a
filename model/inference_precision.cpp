#include "model/inference_precision.h"

#include "format/input_error.h"

#ifdef MM_HAVE_ONEDNN
#include <oneapi/dnnl/dnnl.hpp>
#endif

namespace mm {

const char* precision_name(Precision precision) {
  switch (precision) {
    case Precision::kBf16:
      return "bf16";
    case Precision::kInt8:
      return "int8";
    case Precision::kFp32:
      break;
  }
  return "fp32";
}

Precision parse_precision(const std::string& name, const std::string& field) {
  if (name == "fp32") return Precision::kFp32;
  if (name == "bf16") return Precision::kBf16;
  if (name == "int8") return Precision::kInt8;
  throw InputError(field, "unknown value \"" + name + "\", expected \"fp32\", \"bf16\" or \"int8\"");
}

Precision outside_recurrence(Precision precision) {
  return precision == Precision::kInt8 ? Precision::kBf16 : precision;
}

bool precision_available(Precision precision) {
  if (precision == Precision::kFp32) return true;
#ifdef MM_HAVE_ONEDNN
  // oneDNN reports the CPU's instruction set; bf16 dot products came with
  // AVX-512 BF16 (and AMX after it), after AVX-512 VNNI's int8 ones. Without
  // them it would emulate bf16, slower than fp32.
  const auto isa = dnnl::get_effective_cpu_isa();
  return isa == dnnl::cpu_isa::avx512_core_bf16 || isa == dnnl::cpu_isa::avx512_core_amx;
#else
  return false;
#endif
}

}  // namespace mm
