// The number format of a model's weights in inference: fp32 (as trained),
// bf16 (half the bytes per weight, and the CPU's bf16 dot products where
// it has them; about 3 significant digits per weight) or int8 (the GRUs'
// hidden-to-gates weights, which are most of the bytes a step streams, in
// 8-bit integers with one scale per output row, multiplied with the hidden
// state quantised to 8 bits per row at each step by the CPU's integer dot
// products; every other product bf16). Training is always fp32.
#pragma once

#include <string>

namespace mm {

enum class Precision { kFp32, kBf16, kInt8 };

const char* precision_name(Precision precision);  // "fp32" / "bf16" / "int8"

// InputError naming `field`, the value and the accepted names.
Precision parse_precision(const std::string& name, const std::string& field);

// The precision of a product other than a GRU's hidden-to-gates one: int8
// covers only those (the input products' features and the output layers'
// poses and codes keep bf16's finer steps, and cost little at batch 1).
Precision outside_recurrence(Precision precision);

// Whether this machine runs `precision` at speed: bf16 and int8 need the
// packed kernels (oneDNN) and a CPU with bf16 dot products (avx512_bf16 or
// AMX; such CPUs also have the 8-bit integer dot products of AVX-512 VNNI).
bool precision_available(Precision precision);

}  // namespace mm
