// The --device option: "cpu", "cuda" or "auto" (CUDA when torch sees a GPU,
// else the CPU).
#pragma once

#include <c10/core/Device.h>

#include <string>

namespace mm::tool {

// Returns the device for the option's value. Throws InputError for an
// unknown value and for "cuda" when no CUDA device is available.
c10::Device parse_device(const std::string& value);

// Whether this LibTorch build sees a CUDA device.
bool cuda_available();

}  // namespace mm::tool
