// Pictures for reports and for checking a model by eye: `render` draws
// motions as rows of stick figures (mm_render's pose strip over forward
// kinematics), `plot-log` draws the loss curves of a training log.
#include <ATen/ATen.h>
#include <c10/core/InferenceMode.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "format/atomic_file.h"
#include "format/bvh_file.h"
#include "format/input_error.h"
#include "format/motion_frames.h"
#include "model/forward_kinematics.h"
#include "model/render/loss_curve_svg.h"
#include "model/render/pose_strip_svg.h"
#include "model/tool/cli_validators.h"
#include "model/tool/commands.h"
#include "model/tool/file_arguments.h"
#include "model/tool/motion_files.h"

namespace mm::tool {
namespace {

constexpr double kOutputRate = 25.0;  // Hz of every drawn row
constexpr int kDefaultPoses = 6;

struct RenderOptions {
  std::vector<std::string> inputs, labels;
  std::vector<int64_t> frames;
  std::vector<int> rates, starts, lengths;
  std::string title, out;
  double azimuth_deg = 90;
  bool center_poses = false;
};

// The 25 Hz window of input `i` that its row shows.
MotionFrames read_row_motion(const RenderOptions& o, size_t i) {
  const std::string path = input_name(o.inputs[i]);
  const int rate = per_input(o.rates, i, kModelRate, "--rate", o.inputs.size());
  const int start = per_input(o.starts, i, 0, "--start", o.inputs.size());
  const int length = per_input(o.lengths, i, -1, "--length", o.inputs.size());
  const std::string text = read_input_file(o.inputs[i], "--input");
  const MotionFrames whole = motion_at_model_rate(text, path, rate);
  // --start counts the file's own frames (rows at --rate, a BVH's frames), as
  // everywhere else; the window and --length are at 25 Hz.
  const double file_rate = is_bvh_input(path, text) ? 1.0 / parse_bvh_text(text, path).frame_time_s : rate;
  const int64_t first = std::llround(start * kModelRate / file_rate);
  const int64_t available = whole.frame_count() - first;
  if (available <= 0) {
    throw InputError(path + ": --start " + std::to_string(start) + " is past the end: the file has " +
                     std::to_string(whole.frame_count()) + " frames at 25 Hz");
  }
  MotionFrames motion;
  motion.columns = whole.columns;
  motion.values.assign(whole.frame(first), whole.frame(first) + available * whole.columns);
  const int64_t count = length < 0 ? available : length;
  if (count > available) {
    throw InputError(path + ": too short for --start " + std::to_string(start) + " --length " +
                     std::to_string(length) + ": it has " + std::to_string(available) + " frames at 25 Hz");
  }
  MotionFrames window;
  window.columns = motion.columns;
  window.values.assign(motion.frame(0), motion.frame(0) + count * motion.columns);
  return window;
}

std::vector<float> joint_positions_mm(const ForwardKinematics& fk, const MotionFrames& motion) {
  c10::InferenceMode inference;
  const at::Tensor frames =
      at::from_blob(const_cast<float*>(motion.values.data()), {motion.frame_count(), motion.columns}, at::kFloat);
  const at::Tensor positions = fk.positions(frames).to(at::kFloat).contiguous();
  return std::vector<float>(positions.data_ptr<float>(), positions.data_ptr<float>() + positions.numel());
}

// kDefaultPoses frames spread over [0, frames): 0, n/5, 2n/5, ..., n-1.
std::vector<int64_t> spread_frames(int64_t frames) {
  std::vector<int64_t> indices;
  for (int i = 0; i < kDefaultPoses; ++i) {
    const int64_t f = std::min(frames - 1, i * frames / (kDefaultPoses - 1));
    if (indices.empty() || indices.back() != f) indices.push_back(f);
  }
  return indices;
}

int run_render(const RenderOptions& o) {
  if (!o.labels.empty() && o.labels.size() != o.inputs.size()) {
    throw InputError("--label: expected one per --input (" + std::to_string(o.inputs.size()) + "), found " +
                     std::to_string(o.labels.size()));
  }
  std::vector<std::pair<std::string, std::string>> option_paths;
  for (const auto& input : o.inputs) option_paths.emplace_back("--input", input);
  check_one_standard_input(option_paths);
  check_output_file(o.out, "--out");
  const Skeleton skeleton = Skeleton::h36m();
  const ForwardKinematics fk(skeleton);
  std::vector<render::PoseRow> rows;
  int64_t shortest = INT64_MAX;
  for (size_t i = 0; i < o.inputs.size(); ++i) {
    const MotionFrames motion = read_row_motion(o, i);
    render::PoseRow row;
    row.label = o.labels.empty() ? std::filesystem::path(input_name(o.inputs[i])).stem().string() : o.labels[i];
    row.frames = motion.frame_count();
    row.positions_mm = joint_positions_mm(fk, motion);
    shortest = std::min(shortest, row.frames);
    rows.push_back(std::move(row));
  }
  render::StripOptions strip;
  strip.frame_indices = o.frames.empty() ? spread_frames(shortest) : o.frames;
  strip.frame_rate = kOutputRate;
  strip.title = o.title;
  strip.center_poses = o.center_poses;
  strip.view_azimuth_deg = o.azimuth_deg;
  write_output_file(o.out, render::render_pose_strip_svg(skeleton, rows, strip));
  std::fprintf(message_stream({o.out}), "wrote %s: %zu rows x %zu poses\n", o.out.c_str(), rows.size(),
               strip.frame_indices.size());
  return kExitSuccess;
}

void add_render(CLI::App& app, Action& action) {
  auto o = std::make_shared<RenderOptions>();
  auto* command = app.add_subcommand(
      "render",
      "Draw motions as an SVG picture: one row of stick figures (side view by default, y up) per --input, at the "
      "chosen frames, with one scale for all rows. Inputs are H3.6M exponential-map text files; rows are drawn "
      "at 25 Hz, so give --rate 50 for raw data set files (every second frame is kept) and 25 (the default) for "
      "files the model wrote. --rate, --start and --length take one value for all inputs or one per input.");
  command->add_option("--input", o->inputs, "motion file (repeat for more rows; - for standard input)")->required();
  command->add_option("--label", o->labels, "row label, one per --input (default: the file names)");
  command->add_option("--frames", o->frames,
                      "25 Hz frames to draw, within the window, comma-separated (default: 6 spread over the "
                      "shortest row, e.g. 0,30,60,90,120,149 for 150 frames)")
      ->delimiter(',');
  add_rate_option(command, o->rates, kModelRate, "the input files");
  command->add_option("--start", o->starts, "first frame of the window, in the file's own frames (rows at --rate; default 0)")
      ->check(at_least(0))
      ->delimiter(',');
  command->add_option("--length", o->lengths, "frames in the window at 25 Hz (default: to the end)")
      ->check(at_least(1))
      ->delimiter(',');
  command->add_option("--title", o->title, "title above the rows");
  command->add_option("--azimuth", o->azimuth_deg,
                      "view direction in degrees around the vertical: 90 side view (forward to the right), 0 front "
                      "view, between: oblique")
      ->capture_default_str();
  command->add_flag("--center-poses", o->center_poses,
                    "centre each pose on its own horizontal extent instead of on its root joint");
  command->add_option("--out", o->out, "SVG file to write (- for standard output)")->required();
  command->callback([o, &action] { action = [o] { return run_render(*o); }; });
}

void add_plot_log(CLI::App& app, Action& action) {
  struct Options {
    std::string log, out, title;
    std::vector<std::string> columns;
    int smooth = 1;
    bool log_scale = false;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "plot-log", "Plot the loss terms of a training log (train_log.csv, written by train) as an SVG chart, one "
                  "panel per term over iterations.");
  command->add_option("--log", o->log, "training log (CSV with an iteration column)")->required();
  command->add_option("--columns", o->columns,
                      "columns to plot, comma-separated, e.g. L_ang,L_pos,L_M,L_W,L_G,L_D (default: every column "
                      "but iteration and learning_rate)")
      ->delimiter(',');
  command->add_option("--smooth", o->smooth, "moving-average window in logged points (1: raw values)")
      ->check(at_least(1))
      ->capture_default_str();
  command->add_flag("--log-scale", o->log_scale, "logarithmic y axes (values <= 0 are left out)");
  command->add_option("--title", o->title, "title above the panels (default: the log's path)");
  command->add_option("--out", o->out, "SVG file to write (- for standard output)")->required();
  command->callback([o, &action] {
    action = [o] {
      check_input_file(o->log, "--log");
      check_output_file(o->out, "--out");
      const render::LossLog log = render::read_loss_log(o->log);
      std::vector<std::string> columns = o->columns;
      if (columns.empty()) {
        for (const auto& c : log.columns) {
          if (c != "iteration" && c != "learning_rate") columns.push_back(c);
        }
      }
      render::CurveOptions curves;
      curves.smooth_window = o->smooth;
      curves.log_scale = o->log_scale;
      curves.title = o->title.empty() ? o->log : o->title;
      write_output_file(o->out, render::render_loss_curves_svg(log, columns, curves));
      std::fprintf(message_stream({o->out}), "wrote %s: %zu panels over %zu logged iterations\n", o->out.c_str(), columns.size(),
                  log.rows.size());
      return kExitSuccess;
    };
  });
}

}  // namespace

void add_render_commands(CLI::App& app, Action& action) {
  add_render(app, action);
  add_plot_log(app, action);
}

}  // namespace mm::tool
