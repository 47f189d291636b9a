// evaluate-gaps, evaluate-keyframes, evaluate-transitions: the gap,
// keyframe and transition benchmarks of docs/RESULTS.md
// (model/gap_evaluation.h, model/transition_evaluation.h) over recorded
// takes, as JSON and Markdown tables (scripts/gap-results.sh); join-clips:
// two clips joined by a transition (model/clip_transition.h).
#include <c10/core/InferenceMode.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "format/atomic_file.h"
#include "model/default_model.h"
#include "model/gap_evaluation.h"
#include "model/tool/cli_validators.h"
#include "model/tool/commands.h"
#include "model/tool/file_arguments.h"
#include "model/tool/motion_files.h"
#include "model/transition_evaluation.h"

namespace mm::tool {
namespace {

struct GapsOptions {
  std::string model_dir;
  std::vector<std::string> inputs;
  std::vector<int> rates;
  std::string decoder;
  GapBenchmarkOptions benchmark;
  std::vector<double> few_joints_detail, most_joints_detail;  // 3 each, when given
  std::vector<double> speed_gain_range;                       // 2, when given
  std::string out_json;
  std::string out_md;
};

// "walking_1" -> "walking": H3.6M's takes are the action and the trial.
std::string action_of(const std::string& name) {
  const auto underscore = name.rfind('_');
  return underscore == std::string::npos ? name : name.substr(0, underscore);
}

// Each input at the model's rate, named and told its action.
std::vector<GapBenchmarkTake> read_benchmark_takes(const std::vector<std::string>& inputs,
                                                   const std::vector<int>& rates, const MotionManifold& model) {
  std::vector<GapBenchmarkTake> takes;
  for (size_t i = 0; i < inputs.size(); ++i) {
    const int rate = per_input(rates, i, kDataSetRate, "--rate", inputs.size());
    GapBenchmarkTake take;
    take.name = std::filesystem::path(inputs[i]).stem().string();
    take.action = action_of(take.name);
    take.frames = motion_at_model_rate(read_input_file(inputs[i], "--input"), inputs[i], rate, model.skeleton());
    takes.push_back(std::move(take));
  }
  return takes;
}

// The tables on stdout, and the JSON and Markdown where asked.
int report(const GapBenchmarkResult& result, const std::string& out_json, const std::string& out_md) {
  std::fputs(result.markdown.c_str(), stdout);
  if (!out_json.empty()) write_file_atomically(out_json, result.json);
  if (!out_md.empty()) write_file_atomically(out_md, result.markdown);
  return kExitSuccess;
}

int run_evaluate_gaps(GapsOptions o) {
  const MotionManifold model = MotionManifold::load(o.model_dir);
  c10::InferenceMode inference;
  const std::vector<GapBenchmarkTake> takes = read_benchmark_takes(o.inputs, o.rates, model);
  o.benchmark.decoder = o.decoder.empty() ? model.default_decoder() : parse_decoder_kind(o.decoder);
  if (o.few_joints_detail.size() == 3) std::copy_n(o.few_joints_detail.begin(), 3, o.benchmark.fill.few_joints_detail.begin());
  if (o.most_joints_detail.size() == 3) std::copy_n(o.most_joints_detail.begin(), 3, o.benchmark.fill.most_joints_detail.begin());
  if (o.speed_gain_range.size() == 2) std::copy_n(o.speed_gain_range.begin(), 2, o.benchmark.fill.speed_gain_range.begin());
  const GapBenchmarkResult result = run_gap_benchmark(model, takes, o.benchmark);
  return report(result, o.out_json, o.out_md);
}

struct KeyframesOptions {
  std::string model_dir;
  std::vector<std::string> inputs;
  std::vector<int> rates;
  std::string decoder;
  KeyframeBenchmarkOptions benchmark;
  std::string out_json;
  std::string out_md;
};

int run_evaluate_keyframes(KeyframesOptions o) {
  // Loaded outside inference mode: the fitted fill differentiates through
  // the decoder (gap_code_fit.h).
  const MotionManifold model = MotionManifold::load(o.model_dir);
  c10::InferenceMode inference;
  const std::vector<GapBenchmarkTake> takes = read_benchmark_takes(o.inputs, o.rates, model);
  o.benchmark.decoder = o.decoder.empty() ? model.default_decoder() : parse_decoder_kind(o.decoder);
  const GapBenchmarkResult result = run_keyframe_benchmark(model, takes, o.benchmark);
  return report(result, o.out_json, o.out_md);
}

struct TransitionsOptions {
  std::string model_dir;
  std::vector<std::string> inputs;
  std::vector<int> rates;
  std::string decoder;
  TransitionBenchmarkOptions benchmark;
  std::string out_json;
  std::string out_md;
};

int run_evaluate_transitions(TransitionsOptions o) {
  const MotionManifold model = MotionManifold::load(o.model_dir);  // outside inference mode: see evaluate-keyframes
  c10::InferenceMode inference;
  const std::vector<GapBenchmarkTake> takes = read_benchmark_takes(o.inputs, o.rates, model);
  o.benchmark.decoder = o.decoder.empty() ? model.default_decoder() : parse_decoder_kind(o.decoder);
  const GapBenchmarkResult result = run_transition_benchmark(model, takes, o.benchmark);
  return report(result, o.out_json, o.out_md);
}

struct JoinOptions {
  std::string model_dir;
  std::string a, b, out;
  std::vector<int> rates;
  std::string decoder;
  std::string method = "generated";
  double seconds = 1.0;
};

int run_join_clips(const JoinOptions& o) {
  const MotionManifold model = MotionManifold::load(o.model_dir);  // outside inference mode: see evaluate-keyframes
  c10::InferenceMode inference;
  TransitionOptions transition;
  transition.seconds = o.seconds;
  transition.method = parse_transition_method(o.method, "--method");
  transition.decoder = o.decoder.empty() ? model.default_decoder() : parse_decoder_kind(o.decoder);
  const MotionFrames a = motion_at_model_rate(read_input_file(o.a, "--a"), o.a, per_input(o.rates, 0, kDataSetRate, "--rate", 2),
                                              model.skeleton());
  const MotionFrames b = motion_at_model_rate(read_input_file(o.b, "--b"), o.b, per_input(o.rates, 1, kDataSetRate, "--rate", 2),
                                              model.skeleton());
  const JoinedClips joined = join_clips(model, a, b, transition);
  write_motion_output(joined.frames, o.out, model.skeleton());
  std::fprintf(stderr, "joined: %lld frames at 25 Hz, the transition frames %lld to %lld (%s)\n",
               static_cast<long long>(joined.frames.frame_count()), static_cast<long long>(joined.transition_first),
               static_cast<long long>(joined.transition_last), transition_method_name(transition.method));
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
                      "fitted fill: gaps up to this long (s) are the cubic alone")
      ->capture_default_str();
  command->add_option("--few-joints-detail", options->few_joints_detail,
                      "fitted fill: the share of the manifold's movement kept in gaps of 1, 2 and 4 s of under half the "
                      "joints")
      ->expected(3);
  command->add_option("--most-joints-detail", options->most_joints_detail,
                      "fitted fill: the same for gaps of half the joints or more")
      ->expected(3);
  command->add_option("--speed-gain", options->speed_gain_range,
                      "fitted fill: the least and most gain on the manifold's movement that matches each joint's speed "
                      "to the recording's around the gap (1 1: none)")
      ->expected(2);
  command->add_flag("--speed-gain-shared", options->benchmark.fill.speed_gain_shared,
                    "fitted fill: one gain for the joints missing over the same frames (matching the sum of their "
                    "speeds) instead of one a joint");
  command->add_option("--speed-context", options->benchmark.fill.speed_context_seconds,
                      "fitted fill: seconds of recording either side of a gap whose speed the gain matches")
      ->capture_default_str();
  command->add_option("--fit-min-seconds", options->benchmark.code_fit.min_seconds,
                      "fitted fill: gaps shorter than this (s) are not fitted")
      ->capture_default_str();
  command->add_option("--fit-max-error", options->benchmark.code_fit.max_observed_error,
                      "fitted fill: a window of in-betweening whose fitted code meets its observed values worse "
                      "than this (mean squared error, normalised) lays no detail, its gaps the cubic's; inf: no bound")
      ->capture_default_str()
      ->check(positive_or_inf());
  command->add_option("--max-tangent", options->benchmark.fill.max_tangent_seconds,
                      "cubic and matched fills: the longest a border's velocity is carried into the gap (s)")
      ->capture_default_str();
  command->add_option("--fit-iterations", options->benchmark.code_fit.iterations,
                      "fitted fill: Adam steps fitting each gap window's code to the observed values (0: the encoder's)")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  command->add_option("--fit-step", options->benchmark.code_fit.learning_rate, "fitted fill: Adam's step on the code")
      ->capture_default_str();
  command->add_option("--fit-prior", options->benchmark.code_fit.prior_weight,
                      "fitted fill: weight of the prior's mean(z^2) against the observed values' mean squared error")
      ->capture_default_str();
  command->add_option("--out", options->out_json, "JSON of every configuration, method and action");
  command->add_option("--markdown", options->out_md, "the printed tables, as a file");
  command->callback([options, &action] { action = [options] { return run_evaluate_gaps(*options); }; });

  auto keys = std::make_shared<KeyframesOptions>();
  keys->model_dir = default_model_dir();
  CLI::App* keyframes = app.add_subcommand(
      "evaluate-keyframes",
      "In-betweening from sparse keyframes: each take keeps one pose every --interval seconds and every other frame "
      "is filled by slerp, cubic interpolation of the keyframes, the manifold (take denoise) as it is and the fitted "
      "fill; MPJPE, joint-angle error, speed ratio and foot skating on the frames between keyframes at 25 Hz, and the "
      "largest change of a keyframe. Prints Markdown tables; --out writes JSON.");
  keyframes->add_option("--model", keys->model_dir, "model folder (default: $MM_MODEL_DIR or the shipped model)");
  keyframes->add_option("--input", keys->inputs, "takes (motion text or BVH of the model's skeleton)")->required();
  add_rate_option(keyframes, keys->rates, kDataSetRate, "the text inputs");
  keyframes->add_option("--decoder", keys->decoder, "rotation or velocity")->check(CLI::IsMember({"rotation", "velocity"}));
  keyframes->add_option("--interval", keys->benchmark.intervals, "seconds between keyframes")->capture_default_str();
  keyframes->add_option("--take-seconds", keys->benchmark.take_seconds, "seconds of each take used (from its start)")
      ->check(CLI::Range(6.0, 3600.0))
      ->capture_default_str();
  keyframes->add_option("--fit-iterations", keys->benchmark.code_fit.iterations, "as evaluate-gaps")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  keyframes->add_option("--out", keys->out_json, "JSON of every interval, method and action");
  keyframes->add_option("--markdown", keys->out_md, "the printed tables, as a file");
  keyframes->callback([keys, &action] { action = [keys] { return run_evaluate_keyframes(*keys); }; });

  auto transitions = std::make_shared<TransitionsOptions>();
  transitions->model_dir = default_model_dir();
  CLI::App* evaluate_transitions = app.add_subcommand(
      "evaluate-transitions",
      "Transitions between clips of two takes: each take's clip joined to another take's by a transition of each "
      "--seconds length, generated by the manifold and crossfaded; border jump, foot skating and the transition's "
      "distance from the manifold's reconstructions of the takes. Prints a Markdown table; --out writes JSON.");
  evaluate_transitions->add_option("--model", transitions->model_dir, "model folder (default: $MM_MODEL_DIR or the shipped model)");
  evaluate_transitions->add_option("--input", transitions->inputs, "takes (motion text or BVH of the model's skeleton)")
      ->required();
  add_rate_option(evaluate_transitions, transitions->rates, kDataSetRate, "the text inputs");
  evaluate_transitions->add_option("--decoder", transitions->decoder, "rotation or velocity")
      ->check(CLI::IsMember({"rotation", "velocity"}));
  evaluate_transitions->add_option("--seconds", transitions->benchmark.seconds, "transition lengths (s)")
      ->check(CLI::Range(kMinTransitionSeconds, kMaxTransitionSeconds))
      ->capture_default_str();
  evaluate_transitions->add_option("--clip-seconds", transitions->benchmark.clip_seconds, "each clip's length (s)")
      ->check(CLI::Range(5.0, 60.0))
      ->capture_default_str();
  evaluate_transitions->add_option("--seed", transitions->benchmark.seed, "seed of the clips' places")->capture_default_str();
  evaluate_transitions->add_option("--out", transitions->out_json, "JSON of every length and method");
  evaluate_transitions->add_option("--markdown", transitions->out_md, "the printed table, as a file");
  evaluate_transitions->callback(
      [transitions, &action] { action = [transitions] { return run_evaluate_transitions(*transitions); }; });

  auto join = std::make_shared<JoinOptions>();
  join->model_dir = default_model_dir();
  CLI::App* join_command = app.add_subcommand(
      "join-clips",
      "Join two clips by a transition: --a's last --seconds and --b's first overlap and become the transition, "
      "generated by the manifold (it meets both clips exactly) or crossfaded. Writes the joined motion at 25 Hz "
      "(text, or BVH for a path ending in .bvh).");
  join_command->add_option("--model", join->model_dir, "model folder (default: $MM_MODEL_DIR or the shipped model)");
  join_command->add_option("--a", join->a, "the first clip (motion text or an animation file)")->required();
  join_command->add_option("--b", join->b, "the second clip")->required();
  join_command->add_option("--out", join->out, "the joined motion ('-': standard output)")->required();
  add_rate_option(join_command, join->rates, kDataSetRate, "the text inputs, --a's then --b's");
  join_command->add_option("--decoder", join->decoder, "rotation or velocity")->check(CLI::IsMember({"rotation", "velocity"}));
  join_command->add_option("--method", join->method, "generated or crossfade")
      ->check(CLI::IsMember({"generated", "crossfade"}))
      ->capture_default_str();
  join_command->add_option("--seconds", join->seconds, "the transition's length (s)")
      ->check(CLI::Range(kMinTransitionSeconds, kMaxTransitionSeconds))
      ->capture_default_str();
  join_command->callback([join, &action] { action = [join] { return run_join_clips(*join); }; });
}

}  // namespace mm::tool
