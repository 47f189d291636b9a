// Runs a fixed sequence of tensor operations as one CUDA graph.
//
// A training step on a GPU is bound by kernel launches: each recurrence
// issues a few kernels per time step, 150 steps long, and the host's launch
// rate, not the GPU's arithmetic, sets the step's time. Captured once into a
// CUDA graph, a whole recurrence (forward or backward) is launched with one
// call. The captured function is replayed on fixed input and output
// buffers: the inputs are copied in, the graph runs, and the outputs are
// copied out, so that callers see ordinary fresh tensors.
//
// Off CUDA, or with graphs switched off, the function simply runs
// (cuda_graph_replay.cpp). The capture itself is cuda_graph_replay_cuda.cpp;
// a build against a LibTorch without CUDA, where no tensor is ever on CUDA,
// links cuda_graph_replay_none.cpp instead.
//
// Thread safety: any thread may call; graphs are kept per CUDA stream, and
// one replay at a time runs per graph.
#pragma once

#include <ATen/ATen.h>

#include <functional>
#include <string>
#include <vector>

namespace mm {

using TensorFunction = std::function<std::vector<at::Tensor>(const std::vector<at::Tensor>&)>;

// body(inputs); on CUDA with graphs on, from the second call with the same
// `name` and input shapes on the same stream, the replay of a graph captured
// from `body`. `body` must be a pure function of its inputs (undefined
// tensors allowed) whose every other dependency is fixed by `name`, must not
// read values back to the host, and must draw no random numbers. The
// returned tensors are copies that later calls do not overwrite.
std::vector<at::Tensor> run_as_cuda_graph(const std::string& name, const std::vector<at::Tensor>& inputs,
                                          const TensorFunction& body);

// On by default. Off: every call runs `body` directly (the uncaptured step
// that the graphs are compared and timed against).
void set_cuda_graphs_enabled(bool enabled);
bool cuda_graphs_enabled();

namespace detail {
// run_as_cuda_graph with graphs on and `first`, the first defined input, on
// CUDA.
std::vector<at::Tensor> replay_as_cuda_graph(const std::string& name, const std::vector<at::Tensor>& inputs,
                                             const at::Tensor& first, const TensorFunction& body);
}  // namespace detail

}  // namespace mm
