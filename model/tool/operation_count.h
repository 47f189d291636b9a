// Counts the tensor operations a piece of code issues: on a GPU each is one
// kernel launch or a few, and a training step there is bound by launches, so
// the count says on any machine how a change moves that cost.
//
// Thread safety: one count at a time per process (the autograd engine runs
// CUDA backward passes on its own threads, so the count is process-wide).
#pragma once

#include <cstdint>
#include <functional>

namespace mm::tool {

// Runs `work` and returns how many ATen operators it called directly, or
// the autograd engine called for it, not counting the operators those call
// in turn. Views, allocations and conversions that copy nothing are left
// out; so are operators run inside a parallel region of another operator.
int64_t count_operations(const std::function<void()>& work);

}  // namespace mm::tool
