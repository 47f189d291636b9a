// evaluate-gaps: the gap benchmark of docs/RESULTS.md (model/gap_evaluation.h)
// over recorded takes, as JSON and Markdown tables (scripts/gap-results.sh).
#include <c10/core/InferenceMode.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>

#include "cli_validators.h"
#include "commands.h"
#include "default_model.h"
#include "file_arguments.h"
#include "format/atomic_file.h"
#include "gap_evaluation.h"
#include "motion_files.h"

namespace mm::tool {
namespace {

struct GapsOptions {
  std::string model_dir;
  std::vector<std::string> inputs;
  std::vector<int> rates;
  std::string decoder;
  GapBenchmarkOptions benchmark;
  std::string out_json;
  std::string out_md;
};

// "walking_1" -> "walking": H3.6M's takes are the action and the trial.
std::string action_of(const std::string& name) {
  const auto underscore = name.rfind('_');
  return underscore == std::string::npos ? name : name.substr(0, underscore);
}

int run_evaluate_gaps(GapsOptions o) {
  c10::InferenceMode inference;
  std::vector<GapBenchmarkTake> takes;
  const MotionManifold model = MotionManifold::load(o.model_dir);
  for (size_t i = 0; i < o.inputs.size(); ++i) {
    const int rate = per_input(o.rates, i, kDataSetRate, "--rate", o.inputs.size());
    GapBenchmarkTake take;
    take.name = std::filesystem::path(o.inputs[i]).stem().string();
    take.action = action_of(take.name);
    take.frames = motion_at_model_rate(read_input_file(o.inputs[i], "--input"), o.inputs[i], rate, model.skeleton());
    takes.push_back(std::move(take));
  }
  o.benchmark.decoder = o.decoder.empty() ? model.default_decoder() : parse_decoder_kind(o.decoder);
  const GapBenchmarkResult result = run_gap_benchmark(model, takes, o.benchmark);
  std::fputs(result.markdown.c_str(), stdout);
  if (!o.out_json.empty()) write_file_atomically(o.out_json, result.json);
  if (!o.out_md.empty()) write_file_atomically(o.out_md, result.markdown);
  return kExitSuccess;
}

}  // namespace

void add_gap_commands(CLI::App& app, Action& action) {
  auto options = std::make_shared<GapsOptions>();
  options->model_dir = default_model_dir();
  CLI::App* command = app.add_subcommand(
      "evaluate-gaps",
      "Fill gaps in recorded takes and measure the fills: joints made missing (NaN) for each --seconds length and "
      "--joints count at seeded places, filled by hold, slerp, cubic interpolation, the manifold (take denoise) as "
      "it is, and the manifold matched to the gap's borders; MPJPE, joint-angle error, border jump, speed ratio and "
      "foot skating on the gap frames at 25 Hz, overall and per action. Prints Markdown tables; --out writes JSON.");
  command->add_option("--model", options->model_dir, "model folder (default: $MM_MODEL_DIR or the shipped model)");
  command->add_option("--input", options->inputs, "takes (motion text or BVH of the model's skeleton)")->required();
  add_rate_option(command, options->rates, kDataSetRate, "the text inputs");
  command->add_option("--decoder", options->decoder, "rotation or velocity")->check(CLI::IsMember({"rotation", "velocity"}));
  command->add_option("--seconds", options->benchmark.gap_seconds, "gap lengths (s)")->capture_default_str();
  command->add_option("--joints", options->benchmark.joint_counts, "joints missing per gap (0: every joint)")
      ->capture_default_str();
  command->add_option("--rounds", options->benchmark.rounds, "runs of each take, each with its own gaps")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  command->add_option("--spacing", options->benchmark.spacing_seconds, "seconds at least between gaps of one run")
      ->capture_default_str();
  command->add_option("--seed", options->benchmark.seed, "seed of the gaps' places, lengths and joints")
      ->capture_default_str();
  command->add_option("--interpolate-below", options->benchmark.fill.interpolate_below_seconds,
                      "matched fill: gaps up to this long (s) are the cubic alone")
      ->capture_default_str();
  command->add_option("--full-detail-at", options->benchmark.fill.full_detail_seconds,
                      "matched fill: gaps this long (s) and longer keep full_detail of the manifold's movement")
      ->capture_default_str();
  command->add_option("--full-detail", options->benchmark.fill.full_detail,
                      "matched fill: the share of the manifold's movement long gaps keep")
      ->capture_default_str();
  command->add_option("--max-tangent", options->benchmark.fill.max_tangent_seconds,
                      "cubic and matched fills: the longest a border's velocity is carried into the gap (s)")
      ->capture_default_str();
  command->add_option("--out", options->out_json, "JSON of every configuration, method and action");
  command->add_option("--markdown", options->out_md, "the printed tables, as a file");
  command->callback([options, &action] { action = [options] { return run_evaluate_gaps(*options); }; });
}

}  // namespace mm::tool
