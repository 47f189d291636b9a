// The capture and replay of cuda_graph_replay.h (at::cuda::CUDAGraph).
#include <ATen/cuda/CUDAEvent.h>
#include <ATen/cuda/CUDAGraph.h>
#include <c10/cuda/CUDAFunctions.h>
#include <c10/cuda/CUDAGuard.h>
#include <c10/cuda/CUDAStream.h>

#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "model/cuda_graph_replay.h"

namespace mm {
namespace {

// One captured function for one set of input shapes on one stream: the graph
// reads `inputs` and writes `outputs`, buffers allocated for it alone.
struct Captured {
  int calls = 0;
  std::unique_ptr<at::cuda::CUDAGraph> graph;
  std::vector<at::Tensor> inputs, outputs;
  std::mutex replaying;  // one copy-in, replay, copy-out at a time
};

struct Cache {
  std::mutex lock;
  std::map<std::string, std::unique_ptr<Captured>> entries;
};

// Kept for the life of the process and never destroyed: graphs and their
// memory pools must not be torn down after the CUDA context at exit.
Cache& cache() {
  static Cache* instance = new Cache;
  return *instance;
}

std::string key_of(const std::string& name, const std::vector<at::Tensor>& inputs, const c10::cuda::CUDAStream& stream) {
  std::ostringstream key;
  key << name << "|stream " << stream.id() << " device " << static_cast<int>(stream.device_index());
  for (const auto& t : inputs) {
    key << '|';
    if (!t.defined()) {
      key << "none";
      continue;
    }
    key << t.scalar_type() << t.sizes();
  }
  return key.str();
}

// Contiguous buffers of the inputs' shapes holding their values.
std::vector<at::Tensor> buffers_like(const std::vector<at::Tensor>& inputs) {
  std::vector<at::Tensor> buffers;
  for (const auto& t : inputs) buffers.push_back(t.defined() ? t.contiguous().clone() : at::Tensor());
  return buffers;
}

void copy_into(std::vector<at::Tensor>& buffers, const std::vector<at::Tensor>& inputs) {
  for (size_t i = 0; i < inputs.size(); ++i) {
    if (inputs[i].defined()) buffers[i].copy_(inputs[i]);
  }
}

// Captures `body` on a side stream (CUDA graphs cannot be captured on the
// default stream), after one uncaptured run there: cuBLAS sets up its
// workspace for a stream on first use, which must not happen in a capture.
void capture(Captured& entry, const std::vector<at::Tensor>& inputs, const TensorFunction& body,
             const c10::cuda::CUDAStream& current) {
  entry.inputs = buffers_like(inputs);
  auto side = c10::cuda::getStreamFromPool(/*isHighPriority=*/false, current.device_index());
  at::cuda::CUDAEvent inputs_ready;
  inputs_ready.record(current);
  inputs_ready.block(side);
  {
    c10::cuda::CUDAStreamGuard on_side(side);
    body(entry.inputs);
    c10::cuda::device_synchronize();
    entry.graph = std::make_unique<at::cuda::CUDAGraph>();
    entry.graph->capture_begin();
    entry.outputs = body(entry.inputs);
    entry.graph->capture_end();
  }
  at::cuda::CUDAEvent captured;
  captured.record(side);
  captured.block(current);
}

}  // namespace

namespace detail {

std::vector<at::Tensor> replay_as_cuda_graph(const std::string& name, const std::vector<at::Tensor>& inputs,
                                             const at::Tensor& first, const TensorFunction& body) {
  c10::cuda::CUDAGuard device(first.device());
  const auto current = c10::cuda::getCurrentCUDAStream();
  Captured* entry;
  {
    std::lock_guard<std::mutex> guard(cache().lock);
    auto& slot = cache().entries[key_of(name, inputs, current)];
    if (!slot) slot = std::make_unique<Captured>();
    entry = slot.get();
  }
  std::lock_guard<std::mutex> replaying(entry->replaying);
  // The first call runs uncaptured: it warms up the allocator and the
  // libraries, and a shape seen once (an evaluation, say) costs no graph.
  if (++entry->calls == 1) return body(inputs);
  if (!entry->graph) {
    try {
      capture(*entry, inputs, body, current);
    } catch (const c10::Error& e) {
      entry->graph.reset();
      throw std::runtime_error("capturing " + name + " as a CUDA graph failed (--cuda-graphs off runs it uncaptured): " +
                               e.what_without_backtrace());
    }
  } else {
    copy_into(entry->inputs, inputs);
  }
  entry->graph->replay();
  std::vector<at::Tensor> outputs;
  for (const auto& t : entry->outputs) outputs.push_back(t.defined() ? t.clone() : at::Tensor());
  return outputs;
}

}  // namespace detail
}  // namespace mm
