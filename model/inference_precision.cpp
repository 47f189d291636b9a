#include "inference_precision.h"

#include "format/input_error.h"

#ifdef MM_HAVE_ONEDNN
#include <oneapi/dnnl/dnnl.hpp>
#endif

namespace mm {

const char* precision_name(Precision precision) { return precision == Precision::kBf16 ? "bf16" : "fp32"; }

Precision parse_precision(const std::string& name, const std::string& field) {
  if (name == "fp32") return Precision::kFp32;
  if (name == "bf16") return Precision::kBf16;
  throw InputError(field + ": unknown value \"" + name + "\", expected \"fp32\" or \"bf16\"");
}

bool precision_available(Precision precision) {
  if (precision == Precision::kFp32) return true;
#ifdef MM_HAVE_ONEDNN
  // oneDNN reports the CPU's instruction set; bf16 dot products came with
  // AVX-512 BF16 (and AMX after it). Without them it would emulate bf16,
  // slower than fp32.
  const auto isa = dnnl::get_effective_cpu_isa();
  return isa == dnnl::cpu_isa::avx512_core_bf16 || isa == dnnl::cpu_isa::avx512_core_amx;
#else
  return false;
#endif
}

}  // namespace mm
