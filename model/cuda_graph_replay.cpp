#include "model/cuda_graph_replay.h"

#include <atomic>

namespace mm {
namespace {
std::atomic<bool> enabled{true};
}  // namespace

std::vector<at::Tensor> run_as_cuda_graph(const std::string& name, const std::vector<at::Tensor>& inputs,
                                          const TensorFunction& body) {
  for (const auto& t : inputs) {
    if (!t.defined()) continue;
    if (!enabled || !t.is_cuda()) break;
    return detail::replay_as_cuda_graph(name, inputs, t, body);
  }
  return body(inputs);
}

void set_cuda_graphs_enabled(bool on) { enabled = on; }
bool cuda_graphs_enabled() { return enabled; }

}  // namespace mm
