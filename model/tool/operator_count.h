// Counts the tensor operators that do work while a piece of code runs: on a
// GPU each is about one kernel launch, and a training step there is bound by
// launches, so the count says on any machine how a change moves that cost.
//
// Thread safety: one count at a time per process (the autograd engine runs
// CUDA backward passes on its own threads, so the count is process-wide).
#pragma once

#include <cstdint>
#include <functional>

namespace mm::tool {

// Runs `work` and returns how many ATen operators it dispatched that call no
// other operator and are not views or allocations (view, narrow, empty, ...):
// the ones that launch a kernel.
int64_t count_operators(const std::function<void()>& work);

}  // namespace mm::tool
