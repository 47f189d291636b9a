// take-seams: how the joins between a take's windows show in its
// reconstruction (model/take_seams.h), over whole takes, as the JSON and the
// picture docs/RESULTS.md shows (scripts/take-seams.sh).
#include <c10/core/InferenceMode.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "format/atomic_file.h"
#include "model/default_model.h"
#include "model/render/error_over_time_svg.h"
#include "model/take_seams.h"
#include "model/take_windows.h"
#include "model/tool/cli_validators.h"
#include "model/tool/commands.h"
#include "model/tool/file_arguments.h"
#include "model/tool/motion_files.h"

namespace mm::tool {
namespace {

struct SeamsOptions {
  std::string model_dir;
  std::vector<std::string> inputs;
  std::vector<int> rates;
  double hop_seconds = kDefaultHopSeconds;
  std::string decoder;
  std::string out;
  std::string svg;
};

nlohmann::json transitions_json(const TransitionStatistics& s) {
  return {{"transitions", s.transitions},     {"jump_mm", s.jump_mm},           {"excess_jump_mm", s.excess_jump_mm},
          {"jerk_mm", s.jerk_mm},             {"input_jump_mm", s.input_jump_mm}, {"input_jerk_mm", s.input_jerk_mm}};
}

nlohmann::json blend_json(const BlendSeams& b) {
  return {{"seams", transitions_json(b.seams)}, {"inside", transitions_json(b.inside)},
          {"mean_error_mm", b.mean_error_mm}};
}

// Means over every take, each transition (or frame) weighing the same.
struct Pooled {
  TransitionStatistics sum;
  void add(const TransitionStatistics& s) {
    const double n = static_cast<double>(s.transitions);
    sum.transitions += s.transitions;
    sum.jump_mm += s.jump_mm * n;
    sum.excess_jump_mm += s.excess_jump_mm * n;
    sum.jerk_mm += s.jerk_mm * n;
    sum.input_jump_mm += s.input_jump_mm * n;
    sum.input_jerk_mm += s.input_jerk_mm * n;
  }
  TransitionStatistics mean() const {
    TransitionStatistics m = sum;
    const double n = std::max<double>(1, static_cast<double>(sum.transitions));
    m.jump_mm /= n;
    m.excess_jump_mm /= n;
    m.jerk_mm /= n;
    m.input_jump_mm /= n;
    m.input_jerk_mm /= n;
    return m;
  }
};

int run_take_seams(const SeamsOptions& o) {
  c10::InferenceMode inference;
  std::vector<std::string> texts;
  for (const auto& path : o.inputs) texts.push_back(read_input_file(path, "--input"));
  const MotionManifold model = MotionManifold::load(o.model_dir);
  const DecoderKind decoder = o.decoder.empty() ? model.default_decoder() : parse_decoder_kind(o.decoder);
  nlohmann::json takes = nlohmann::json::array();
  Pooled seams[2], inside[2];
  double error_sum[2] = {0, 0}, single_sum = 0;
  int64_t frame_sum = 0;
  std::printf("| take | windows | seam jump, crossfade / cut / input (mm/frame) | excess jump at seams, crossfade / cut "
              "| excess jump inside | error, take crossfade / cut / single clips (mm) |\n|---|---:|---|---|---|---|\n");
  for (size_t i = 0; i < o.inputs.size(); ++i) {
    const int rate = per_input(o.rates, i, kDataSetRate, "--rate", o.inputs.size());
    const MotionFrames take = motion_at_model_rate(texts[i], o.inputs[i], rate, model.skeleton());
    const TakeSeams s = measure_take_seams(model, take, o.inputs[i], o.hop_seconds, decoder);
    takes.push_back({{"take", s.name},
                     {"frames_25hz", s.frames},
                     {"windows", s.windows},
                     {"hop_seconds", s.hop_seconds},
                     {"crossfade", blend_json(s.crossfade)},
                     {"cut", blend_json(s.cut)},
                     {"single_clip_error_mm", s.single_clip_error_mm}});
    const BlendSeams* blends[2] = {&s.crossfade, &s.cut};
    for (int b = 0; b < 2; ++b) {
      seams[b].add(blends[b]->seams);
      inside[b].add(blends[b]->inside);
      error_sum[b] += blends[b]->mean_error_mm * static_cast<double>(s.frames);
    }
    single_sum += s.single_clip_error_mm * static_cast<double>(s.frames);
    frame_sum += s.frames;
    std::printf("| %s | %d | %.2f / %.2f / %.2f | %.2f / %.2f | %.2f / %.2f | %.1f / %.1f / %.1f |\n", o.inputs[i].c_str(),
                s.windows, s.crossfade.seams.jump_mm, s.cut.seams.jump_mm, s.cut.seams.input_jump_mm,
                s.crossfade.seams.excess_jump_mm, s.cut.seams.excess_jump_mm, s.crossfade.inside.excess_jump_mm,
                s.cut.inside.excess_jump_mm, s.crossfade.mean_error_mm, s.cut.mean_error_mm, s.single_clip_error_mm);
    if (i == 0 && !o.svg.empty()) {
      render::ErrorChartOptions chart;
      chart.frame_rate = kTakeModelRate;
      chart.title = std::filesystem::path(o.inputs[i]).stem().string() + " as one take of " +
                    std::to_string(s.windows) + " windows: per-frame error (dashed: where the cut switches windows)";
      // The cut's first frame of the next window, one after each seam's t.
      for (int64_t t : s.seam_transitions) chart.marks_seconds.push_back(static_cast<double>(t + 1) / kTakeModelRate);
      write_file_atomically(o.svg, render::render_error_over_time_svg(
                                       {{"crossfade", "#1f77b4", s.crossfade.error_mm}, {"cut", "#d62728", s.cut.error_mm}},
                                       chart));
    }
  }
  const double frames = std::max<double>(1, static_cast<double>(frame_sum));
  nlohmann::json all = {{"frames_25hz", frame_sum}, {"single_clip_error_mm", single_sum / frames}};
  const char* names[2] = {"crossfade", "cut"};
  for (int b = 0; b < 2; ++b) {
    all[names[b]] = {{"seams", transitions_json(seams[b].mean())},
                     {"inside", transitions_json(inside[b].mean())},
                     {"mean_error_mm", error_sum[b] / frames}};
  }
  const nlohmann::json document = {{"model", o.model_dir}, {"hop_seconds", o.hop_seconds}, {"all", all}, {"takes", takes}};
  if (!o.out.empty()) write_file_atomically(o.out, document.dump(2) + "\n");
  return kExitSuccess;
}

}  // namespace

void add_take_seams_command(CLI::App& app, Action& action) {
  auto options = std::make_shared<SeamsOptions>();
  options->model_dir = default_model_dir();
  CLI::App* command = app.add_subcommand(
      "take-seams",
      "Measure where a take's windows meet: each take reconstructed at 25 Hz with the windows crossfaded and cut, "
      "the jump (mm per frame) and jerk at the seams against inside the windows and against the input, and the "
      "take's error beside its windows' as single clips. Prints a Markdown table; --out writes JSON, --svg the first "
      "take's per-frame error over time.");
  command->add_option("--model", options->model_dir, "model folder (default: $MM_MODEL_DIR or the shipped model)");
  command->add_option("--input", options->inputs, "takes (motion text or BVH of the model's skeleton)")->required();
  add_rate_option(command, options->rates, kDataSetRate, "the text inputs");
  command->add_option("--hop", options->hop_seconds, "seconds between window starts")->capture_default_str();
  command->add_option("--decoder", options->decoder, "rotation or velocity")->check(CLI::IsMember({"rotation", "velocity"}));
  command->add_option("--out", options->out, "JSON of every take's measures and their pooled means");
  command->add_option("--svg", options->svg, "the first take's per-frame error over time, as SVG");
  command->callback([options, &action] { action = [options] { return run_take_seams(*options); }; });
}

}  // namespace mm::tool
