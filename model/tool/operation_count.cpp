#include "model/tool/operation_count.h"

#include <ATen/Parallel.h>
#include <ATen/record_function.h>

#include <atomic>
#include <cstring>
#include <vector>

namespace mm::tool {
namespace {

std::atomic<int64_t> operations{0};

// Per thread, one entry per operator being run.
struct OpenOperator {
  bool engine_step = false;  // the autograd engine running a backward node: counts what it calls
  bool work_below = false;   // whether anything it called did work
};
thread_local std::vector<OpenOperator> open_operators;

bool is_engine_step(const char* name) {
  static const char kPrefix[] = "autograd::engine::evaluate_function";
  return std::strncmp(name, kPrefix, sizeof(kPrefix) - 1) == 0;
}

bool named_in(const char* name, std::initializer_list<const char*> names) {
  for (const char* candidate : names) {
    if (std::strcmp(name, candidate) == 0) return true;
  }
  return false;
}

// Operators that only describe memory: no kernel runs for them.
bool does_no_work(const char* name) {
  return named_in(name, {"aten::view", "aten::_reshape_alias", "aten::as_strided", "aten::slice", "aten::select",
                         "aten::narrow", "aten::transpose", "aten::t", "aten::expand", "aten::unsqueeze",
                         "aten::squeeze", "aten::permute", "aten::alias", "aten::detach", "aten::empty",
                         "aten::empty_like", "aten::empty_strided", "aten::resize_", "aten::lift_fresh",
                         "aten::set_", "aten::unfold", "aten::diagonal", "aten::_unsafe_view", "aten::split",
                         "aten::unbind", "aten::chunk", "aten::resolve_conj", "aten::resolve_neg"});
}

// Operators that copy only when they must: they work when what they call does.
bool works_through_callees(const char* name) {
  return named_in(name, {"aten::to", "aten::contiguous", "aten::reshape", "aten::flatten"});
}

std::unique_ptr<at::ObserverContext> on_start(const at::RecordFunction& function) {
  open_operators.push_back({is_engine_step(function.name()), false});
  return nullptr;
}

void on_end(const at::RecordFunction& function, at::ObserverContext*) {
  if (open_operators.empty()) return;  // began before counting started
  const OpenOperator finished = open_operators.back();
  open_operators.pop_back();
  if (finished.engine_step) return;
  const char* name = function.name();
  const bool worked = !does_no_work(name) && (!works_through_callees(name) || finished.work_below);
  if (!open_operators.empty() && !open_operators.back().engine_step) {
    open_operators.back().work_below = open_operators.back().work_below || worked || finished.work_below;
  } else if (worked && !at::in_parallel_region()) {
    ++operations;
  }
}

}  // namespace

int64_t count_operations(const std::function<void()>& work) {
  operations = 0;
  const auto handle =
      at::addGlobalCallback(at::RecordFunctionCallback(on_start, on_end).scopes({at::RecordScope::FUNCTION}));
  try {
    work();
  } catch (...) {
    at::removeCallback(handle);
    throw;
  }
  at::removeCallback(handle);
  return operations.load();
}

}  // namespace mm::tool
