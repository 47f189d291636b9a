#include "model/tool/device_option.h"

#include <torch/cuda.h>

#include "format/input_error.h"

namespace mm::tool {

bool cuda_available() { return torch::cuda::is_available(); }

void add_cuda_graphs_option(CLI::App& command, bool& value) {
  command
      .add_option("--cuda-graphs", value,
                  "on a GPU, run each recurrence (forward and backward) as one CUDA graph: on or off")
      ->check(CLI::IsMember({"on", "off"}))
      ->default_str("on");
}

c10::Device parse_device(const std::string& value) {
  if (value == "cpu") return c10::kCPU;
  if (value == "cuda") {
    if (!cuda_available()) throw InputError("--device cuda: no CUDA device is available to this build of LibTorch");
    return c10::Device(c10::kCUDA, 0);
  }
  if (value == "auto") return cuda_available() ? c10::Device(c10::kCUDA, 0) : c10::Device(c10::kCPU);
  throw InputError("--device: expected cpu, cuda or auto, found \"" + value + "\"");
}

}  // namespace mm::tool
