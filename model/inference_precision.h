// The number format of a model's weights in inference: fp32 (as trained)
// or bf16 (half the bytes per weight, and the CPU's bf16 dot products where
// it has them; about 3 significant digits per weight). Training is always
// fp32.
#pragma once

#include <string>

namespace mm {

enum class Precision { kFp32, kBf16 };

const char* precision_name(Precision precision);  // "fp32" / "bf16"

// InputError naming `field`, the value and the accepted names.
Precision parse_precision(const std::string& name, const std::string& field);

// Whether this machine runs `precision` at speed: bf16 needs the packed
// kernels (oneDNN) and a CPU with bf16 dot products (avx512_bf16 or AMX).
bool precision_available(Precision precision);

}  // namespace mm
