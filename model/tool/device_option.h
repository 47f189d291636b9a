// The --device option: "cpu", "cuda" or "auto" (CUDA when torch sees a GPU,
// else the CPU).
#pragma once

#include <c10/core/Device.h>

#include <CLI/CLI.hpp>

#include <string>

namespace mm::tool {

// Returns the device for the option's value. Throws InputError for an
// unknown value and for "cuda" when no CUDA device is available.
c10::Device parse_device(const std::string& value);

// Whether this LibTorch build sees a CUDA device.
bool cuda_available();

// --cuda-graphs on|off: whether each recurrence runs as one CUDA graph on a
// GPU (cuda_graph_replay.h); off gives the uncaptured step, for comparison.
void add_cuda_graphs_option(CLI::App& command, bool& value);

}  // namespace mm::tool
