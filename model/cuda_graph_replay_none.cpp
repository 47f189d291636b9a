// cuda_graph_replay.h for a LibTorch without CUDA: every call runs its body.
#include "cuda_graph_replay.h"

#include <atomic>

namespace mm {
namespace {
std::atomic<bool> enabled{true};
}  // namespace

std::vector<at::Tensor> run_as_cuda_graph(const std::string&, const std::vector<at::Tensor>& inputs,
                                          const TensorFunction& body) {
  return body(inputs);
}

void set_cuda_graphs_enabled(bool on) { enabled = on; }
bool cuda_graphs_enabled() { return enabled; }
bool cuda_graphs_supported() { return false; }

}  // namespace mm
