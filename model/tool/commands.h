// The subcommands of the motion-manifold tool, one group per file. Each
// add_* function registers its subcommand(s) on the application; when one of
// them is parsed, its callback stores in `action` the work to run, which
// main() then calls and whose result is the process exit code.
//
// Errors: commands throw InputError for bad input (exit 2) and anything else
// for internal failures (exit 1); main() maps them, so nothing escapes.
#pragma once

#include <functional>
#include <string>

namespace CLI {
class App;
}

namespace mm::tool {

// Exit codes of the tool.
constexpr int kExitSuccess = 0;
constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;       // bad usage or InputError
constexpr int kExitCancelled = 130; // SIGINT / SIGTERM during training

using Action = std::function<int()>;

void add_prepare_command(CLI::App& app, Action& action);
// `command_line` is recorded in the exported model's provenance; it must
// outlive the parsed action.
void add_train_commands(CLI::App& app, Action& action, const std::string& command_line);
void add_evaluate_command(CLI::App& app, Action& action);
// sample, interpolate, analogy, denoise, encode, decode (Sec. 5).
void add_manifold_commands(CLI::App& app, Action& action);
void add_bench_command(CLI::App& app, Action& action);
// render (pose strips of motions) and plot-log (loss curves), as SVG.
void add_render_commands(CLI::App& app, Action& action);
// take encode|reconstruct|denoise|decode: motions of any length and rate.
void add_take_commands(CLI::App& app, Action& action);
// take-seams: where a take's windows meet, measured (model/take_seams.h).
void add_take_seams_command(CLI::App& app, Action& action);
// train-trajectory and evaluate-trajectory: the root path of generated motion.
void add_trajectory_commands(CLI::App& app, Action& action);
// evaluate-gaps: gaps in recorded takes filled and measured (model/gap_evaluation.h).
void add_gap_commands(CLI::App& app, Action& action);

}  // namespace mm::tool
