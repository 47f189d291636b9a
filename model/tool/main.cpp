// motion-manifold: prepare H3.6M, train a motion manifold, evaluate it, and
// use it (sampling, interpolation, analogy, denoising; Sec. 5 of the paper).
//
// Exit codes: 0 success, 2 bad usage or bad input, 1 other failures, 130
// training cancelled by SIGINT/SIGTERM. No exception leaves main().
#include <ATen/Parallel.h>
#include <c10/util/Exception.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <thread>

#include "format/input_error.h"
#include "model/heap_reuse.h"
#include "model/tool/commands.h"
#include "model/usable_cpus.h"

namespace {

std::string join_command_line(int argc, char** argv) {
  std::string line;
  for (int i = 0; i < argc; ++i) {
    if (i > 0) line += ' ';
    line += argv[i];
  }
  return line;
}

int run(int argc, char** argv) {
  using namespace mm::tool;
  mm::keep_freed_memory_for_reuse();
  // LibTorch starts with one intra-op thread here; the GRU's matrix products
  // want every core, unless OMP_NUM_THREADS bounds them: OpenMP threads spin,
  // so two runs that each take every core slow each other many times over.
  const char* bound = std::getenv("OMP_NUM_THREADS");
  const int threads = bound != nullptr ? std::atoi(bound) : mm::usable_cpu_count();
  if (threads > 0) at::set_num_threads(threads);

  const std::string command_line = join_command_line(argc, argv);
  CLI::App app{
      "motion-manifold " MM_VERSION ": human motion manifolds with sequential networks (Jang & Lee, "
      "\"Constructing Human Motion Manifold with Sequential Networks\", Computer Graphics Forum 2020).\n"
      "Prepare H3.6M, train, evaluate, and sample / interpolate / denoise / make analogies on the manifold."};
  app.set_version_flag("--version", "motion-manifold " MM_VERSION);
  app.require_subcommand(1);
  Action action;
  add_prepare_command(app, action);
  add_train_commands(app, action, command_line);
  add_evaluate_command(app, action);
  add_manifold_commands(app, action);
  add_bench_command(app, action);
  add_render_commands(app, action);
  add_take_commands(app, action);
  add_take_seams_command(app, action);
  add_gap_commands(app, action);
  add_trajectory_commands(app, action);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help
    std::fprintf(stderr, "error: %s\nRun with --help for more information.\n", e.what());
    return kExitUsage;
  }
  if (!action) {
    std::fprintf(stderr, "error: no command given\n");
    return kExitUsage;
  }
  return action();
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const mm::InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return mm::tool::kExitUsage;
  } catch (const c10::Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what_without_backtrace());
    return mm::tool::kExitFailure;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return mm::tool::kExitFailure;
  } catch (...) {
    std::fprintf(stderr, "error: unknown failure\n");
    return mm::tool::kExitFailure;
  }
}
