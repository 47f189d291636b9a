#include "operator_count.h"

#include <ATen/record_function.h>

#include <atomic>
#include <cstring>
#include <vector>

namespace mm::tool {
namespace {

std::atomic<int64_t> operators{0};
// Per thread, one entry per operator being run: whether it called another.
thread_local std::vector<bool> open_operators;

// Operators that only describe memory: no kernel runs for them.
bool is_view_or_allocation(const char* name) {
  static const char* const kNames[] = {
      "aten::view",    "aten::_reshape_alias", "aten::as_strided", "aten::slice",        "aten::select",
      "aten::transpose", "aten::expand",       "aten::unsqueeze",  "aten::squeeze",      "aten::permute",
      "aten::alias",   "aten::detach",         "aten::empty",      "aten::empty_strided", "aten::resize_",
      "aten::lift_fresh", "aten::set_",        "aten::unfold",     "aten::diagonal",     "aten::_unsafe_view"};
  for (const char* view : kNames) {
    if (std::strcmp(name, view) == 0) return true;
  }
  return false;
}

std::unique_ptr<at::ObserverContext> on_start(const at::RecordFunction&) {
  if (!open_operators.empty()) open_operators.back() = true;
  open_operators.push_back(false);
  return nullptr;
}

void on_end(const at::RecordFunction& function, at::ObserverContext*) {
  if (open_operators.empty()) return;  // began before counting started
  const bool called_another = open_operators.back();
  open_operators.pop_back();
  if (!called_another && !is_view_or_allocation(function.name())) ++operators;
}

}  // namespace

int64_t count_operators(const std::function<void()>& work) {
  operators = 0;
  const auto handle =
      at::addGlobalCallback(at::RecordFunctionCallback(on_start, on_end).scopes({at::RecordScope::FUNCTION}));
  try {
    work();
  } catch (...) {
    at::removeCallback(handle);
    throw;
  }
  at::removeCallback(handle);
  return operators.load();
}

}  // namespace mm::tool
