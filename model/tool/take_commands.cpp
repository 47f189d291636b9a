// Takes: motions of any length and frame rate through the manifold
// (take_processor.h): encode into a code track, reconstruct, denoise (NaN
// values missing), and decode a code track back into one motion.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "format/bvh_file.h"
#include "format/input_error.h"
#include "format/motion_mirror.h"
#include "format/motion_resampling.h"
#include "format/motion_text.h"
#include "format/skeleton_bvh.h"
#include "model/default_model.h"
#include "model/take_processor.h"
#include "model/take_windows.h"
#include "model/tool/commands.h"
#include "model/tool/file_arguments.h"
#include "model/tool/motion_files.h"
#include "model/tool/precision_option.h"
#include "model/tool/take_progress_line.h"

namespace mm::tool {
namespace {

const char* const kTakeNote =
    "A take is a motion of any length (at least one window: 6 s) and frame rate (10 to 1000 Hz): an H3.6M "
    "exponential-map text file at --rate (default 50, the data set's), or a BVH file of the model's skeleton at its "
    "own frame time (--rate does not apply). It is cut into the model's 6 s windows every --hop seconds, the last "
    "aligned to the take's end.";

// The options of a take's model, its windows and how they are joined.
struct TakeArguments {
  std::string model_dir = default_model_dir();
  std::string decoder;  // empty: the model's default
  std::string blend = "crossfade";
  std::string precision = "fp32";

  void add_to(CLI::App* command, bool decodes) {
    command->add_option("--model", model_dir, "model folder (default: $MM_MODEL_DIR or the shipped model)");
    add_precision_option(command, precision);
    if (!decodes) return;
    command->add_option("--decoder", decoder, "rotation or velocity (default: rotation if the model has it)")
        ->check(CLI::IsMember({"rotation", "velocity"}));
    command->add_option("--blend", blend,
                        "how overlapping windows are joined: crossfade (slerp of the rotations across the overlap) "
                        "or cut (at the overlap's middle)")
        ->check(CLI::IsMember({"crossfade", "cut"}))
        ->capture_default_str();
  }
  DecoderKind kind(const MotionManifold& model) const {
    return decoder.empty() ? model.default_decoder() : parse_decoder_kind(decoder);
  }
};

// A take read from --input: its frames and rate.
struct TakeInput {
  MotionFrames frames;
  double rate = 0;
};

TakeInput read_take(const std::string& path, double text_rate, bool nan_is_missing, const Skeleton& skeleton) {
  const std::string text = read_input_file(path, "--input");
  const std::string name = input_name(path);
  if (is_animation_input(path, text)) {
    const BvhFile file = parse_animation_input(text, name, skeleton);
    return {skeleton_motion_from_bvh_at_file_rate(skeleton, file, name), bvh_frame_rate(file)};
  }
  return {parse_motion_text_buffer(text.data(), text.size(), name, skeleton_motion_columns(skeleton), nan_is_missing),
          text_rate};
}

// BVH of the skeleton's own layout at `rate` for a path ending in .bvh,
// else motion text; "-" is standard output.
void write_take(const MotionFrames& frames, double rate, const std::string& path, const Skeleton& skeleton) {
  if (is_animation_path(path)) {
    write_output_file(path, animation_output_bytes(skeleton_motion_to_bvh(skeleton, bvh_layout_of(skeleton), frames, rate), path, skeleton));
    return;
  }
  std::ostringstream text;
  write_motion_text(frames, text);
  write_output_file(path, text.str());
}

void write_error_csv(const std::vector<float>& error_mm, double rate, const std::string& path) {
  std::string text = "frame,seconds,error_mm\n";
  char line[64];
  for (size_t f = 0; f < error_mm.size(); ++f) {
    std::snprintf(line, sizeof line, "%zu,%.6f,%.3f\n", f, f / rate, error_mm[f]);
    text += line;
  }
  write_output_file(path, text);
}

nlohmann::json summary_json(const TakeSummary& s, bool encodes) {
  nlohmann::json summary = {{"input_frames", s.input_frames}, {"input_rate", s.input_rate},
                            {"model_frames", s.model_frames}, {"windows", s.windows},
                            {"hop_seconds", s.hop_seconds}};
  if (encodes) return summary;
  summary["frames"] = s.output_frames;
  summary["frame_rate"] = s.output_rate;
  summary["mean_error_mm"] = s.mean_error_mm;
  summary["max_error_mm"] = s.max_error_mm;
  if (s.gap_windows_fitted > 0 || s.gaps_over_fit_limit > 0) {
    summary["gap_windows_fitted"] = s.gap_windows_fitted;
    summary["gaps_fitted"] = s.gaps_fitted;
    summary["gaps_over_fit_limit"] = s.gaps_over_fit_limit;
  }
  return summary;
}

nlohmann::json track_json(const TakeResult& result, int window_frames) {
  nlohmann::json windows = nlohmann::json::array();
  for (const auto& w : result.windows) {
    windows.push_back({{"start_seconds", w.start_seconds}, {"start_frame", w.start_frame}, {"code", w.code}});
  }
  return {{"frames", result.summary.input_frames},
          {"frame_rate", result.summary.input_rate},
          {"window_seconds", window_frames / kTakeModelRate},
          {"hop_seconds", result.summary.hop_seconds},
          {"windows", std::move(windows)}};
}

// A code track's windows from JSON as take encode writes it (only
// windows[i].start_seconds and windows[i].code are read). `name` is the
// file's name in messages.
std::vector<TakeWindowCode> parse_track(const std::string& text, const std::string& name) {
  nlohmann::json document;
  try {
    document = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(name + ": not a valid code track (JSON): " + json_error_reason(e.what()));
  }
  if (!document.is_object() || !document.contains("windows") || !document["windows"].is_array()) {
    throw InputError(name + ": windows: expected an array of {\"start_seconds\", \"code\"} as take encode writes");
  }
  std::vector<TakeWindowCode> track;
  const auto& windows = document["windows"];
  for (size_t i = 0; i < windows.size(); ++i) {
    const std::string field = name + ": windows[" + std::to_string(i) + "]";
    const auto& w = windows[i];
    if (!w.is_object() || !w.contains("start_seconds") || !w["start_seconds"].is_number()) {
      throw InputError(field + ".start_seconds", "expected a number");
    }
    if (!w.contains("code") || !w["code"].is_array()) throw InputError(field + ".code", "expected an array of numbers");
    TakeWindowCode window;
    window.start_seconds = w["start_seconds"].get<double>();
    for (size_t k = 0; k < w["code"].size(); ++k) {
      const auto& v = w["code"][k];
      if (!v.is_number()) throw InputError(field + ".code[" + std::to_string(k) + "]: expected a number, found " + v.dump());
      window.code.push_back(v.get<float>());
    }
    track.push_back(std::move(window));
  }
  return track;
}

void add_take_operation(CLI::App* take, Action& action, TakeOperation operation) {
  struct Options {
    TakeArguments model;
    std::string input, out, error_csv;
    double rate = kDataSetRate;
    double hop = kDefaultHopSeconds;
    bool at_model_rate = false;
    std::string root = "input";
    DenoiseOptions denoise;
    std::string gap_fill = "borrowed";
    bool gap_fill_given = false;
  };
  auto o = std::make_shared<Options>();
  const bool encodes = operation == TakeOperation::kEncode;
  const bool denoises = operation == TakeOperation::kDenoise;
  std::string description =
      encodes ? "Encode a take into a code track: each window's start and code, as JSON ({\"windows\": "
                "[{\"start_seconds\", \"start_frame\", \"code\"}, ...]}), for take decode. "
      : denoises
          ? "Denoise a take: every window projected onto the manifold (Sec. 5.4), values given as nan (and those "
            "--zeros-are-missing or --means-are-missing names) missing and filled from the manifold; the windows "
            "joined, at the take's rate and length, root translation the input's (or --root generated). "
          : "Reconstruct a take: every window encoded and decoded, the windows joined, at the take's rate and "
            "length (or 25 Hz with --at-model-rate), root translation the input's (or --root generated). ";
  if (!encodes) {
    description += "Prints a summary as JSON (mean and largest per-frame error: the mean distance of the joints "
                   "from the input's, mm). ";
  }
  auto* command = take->add_subcommand(take_operation_name(operation), description + kTakeNote);
  o->model.add_to(command, !encodes);
  command->add_option("--input,--in", o->input, "the take: motion text or BVH (- for standard input)")->required();
  command->add_option("--rate", o->rate, "frame rate of a text take, Hz (10 to 1000)")->capture_default_str();
  command->add_option("--hop", o->hop, "seconds between window starts (0.04 to 6)")->capture_default_str();
  command
      ->add_option("--out", o->out,
                   encodes ? "code track to write (JSON; - for standard output)"
                           : "motion to write: BVH of the model's skeleton at the reply's rate for a name ending in "
                             ".bvh, else motion text (- for standard output)")
      ->required();
  if (!encodes) {
    command->add_flag("--at-model-rate", o->at_model_rate, "reply at the model's 25 Hz instead of the take's rate");
    command->add_option("--error-csv", o->error_csv, "also write each frame's error: frame,seconds,error_mm");
    command
        ->add_option("--root", o->root,
                     "the output's root path: input (the take's own) or generated (the model's trajectory "
                     "network, feet on the floor)")
        ->capture_default_str();
  }
  if (denoises) {
    auto* zeros = command->add_flag("--zeros-are-missing", o->denoise.zeros_are_missing,
                                    "also treat joint-angle values that are exactly zero as missing");
    command->add_flag("--means-are-missing", o->denoise.means_are_missing,
                      "also treat joint-angle values exactly at their training mean as missing")
        ->excludes(zeros);
    command->add_option("--iterations", o->denoise.iterations,
                        "rounds of projecting and refilling the missing values")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    command->add_flag("--keep-observed", o->denoise.keep_observed,
                      "keep the observed values as given and take the manifold's only where values are missing");
    command
        ->add_option("--gap-fill", o->gap_fill,
                     "with --keep-observed, how a gap (a run of frames where a joint is nan) is filled: borrowed "
                     "(the movement of the take's own stretch most like the gap's surroundings, within 60 s before "
                     "and 10 s after it, laid over the cubic where one is like enough, else for the legs and the "
                     "upper body apart, fitted elsewhere), fitted (a "
                     "code fitted to the observed frames of a 6 s window centred on each gap of 0.6 s or more, its "
                     "movement laid over a cubic that meets both borders; at most 20 windows a take, later gaps "
                     "matched), matched (the take's own windows' movement over the cubic), cubic, slerp, hold or "
                     "manifold (the model's output as it is)")
        ->capture_default_str()
        ->each([o](const std::string&) { o->gap_fill_given = true; });
  }
  command->callback([o, &action, operation, encodes] {
    action = [o, operation, encodes] {
      check_output_file(o->out, "--out");
      if (!o->error_csv.empty()) {
        check_output_file(o->error_csv, "--error-csv");
        if (is_standard_stream(o->out) && is_standard_stream(o->error_csv)) {
          throw InputError("--out and --error-csv are both - (standard output): give one of them a file");
        }
      }
      check_take_rate(o->rate, "--rate");
      const MotionManifold model = load_model_at_precision(o->model.model_dir, o->model.precision);
      try {
        take_windowing(model.config().frames, o->hop);
      } catch (const InputError& e) {
        throw InputError("--hop", e.detail());
      }
      const TakeInput take = read_take(o->input, o->rate, operation == TakeOperation::kDenoise, model.skeleton());
      TakeOptions options;
      options.operation = operation;
      options.frame_rate = take.rate;
      options.hop_seconds = o->hop;
      options.blend = parse_take_blend(o->model.blend);
      options.at_model_rate = o->at_model_rate;
      options.decoder = o->model.kind(model);
      options.denoise = o->denoise;
      options.gap_fill.method = parse_gap_method(o->gap_fill, "--gap-fill");
      if (o->gap_fill_given && !o->denoise.keep_observed) {
        throw InputError("--gap-fill: applies with --keep-observed only (without it every value is the manifold's), "
                         "found --gap-fill " + o->gap_fill + " alone");
      }
      options.root = parse_take_root(o->root, "--root");
      TakeResult result;
      try {
        // process_take's work, with each window counted on a terminal.
        const int64_t model_frames = resampled_frame_count(take.frames.frame_count(), take.rate, kTakeModelRate);
        const int window_frames = model.config().frames;
        const int64_t windows =
            model_frames >= window_frames
                ? static_cast<int64_t>(take_window_starts(model_frames, take_windowing(window_frames, o->hop)).size())
                : 0;
        const std::string what = std::string("take ") + take_operation_name(operation) + " " + input_name(o->input);
        TakeProgressLine progress(stderr, what, windows);
        result.frames.columns = take.frames.columns;
        TakeSink sink;
        sink.on_window = [&](const TakeWindowCode& window) {
          result.windows.push_back(window);
          progress.window_done();
        };
        sink.on_frames = [&result](const MotionFrames& frames, const std::vector<float>& error_mm) {
          result.frames.values.insert(result.frames.values.end(), frames.values.begin(), frames.values.end());
          result.error_mm.insert(result.error_mm.end(), error_mm.begin(), error_mm.end());
        };
        TakeProcessor processor(model, options, std::move(sink));
        processor.push(take.frames.values.data(), take.frames.frame_count());
        result.summary = processor.finish();
      } catch (const InputError& e) {
        throw InputError(input_name(o->input) + ": " + e.what());  // what is left to refuse is the take's
      }
      std::FILE* messages = message_stream({o->out, o->error_csv});
      if (encodes) {
        write_output_file(o->out, track_json(result, model.config().frames).dump() + "\n");
      } else {
        write_take(result.frames, result.summary.output_rate, o->out, model.skeleton());
        if (!o->error_csv.empty()) write_error_csv(result.error_mm, result.summary.output_rate, o->error_csv);
      }
      nlohmann::json report = summary_json(result.summary, encodes);
      report["input"] = input_name(o->input);
      report["out"] = o->out;
      std::fprintf(messages, "%s\n", report.dump(2).c_str());
      return kExitSuccess;
    };
  });
}

void add_take_decode(CLI::App* take, Action& action) {
  struct Options {
    TakeArguments model;
    std::string track, out;
    double rate = kTakeModelRate;
    int64_t frames = -1;
  };
  auto o = std::make_shared<Options>();
  auto* command = take->add_subcommand(
      "decode",
      "Decode a code track (as take encode writes it, edited or not) into one continuous motion: every code decoded "
      "to a 6 s window at its start, the windows joined, at --rate. The root does not move (the model has no root "
      "translation).");
  o->model.add_to(command, true);
  // --input as in the client's track decode and every other command; --track as before.
  command->add_option("--input,--track", o->track, "code track (JSON; - for standard input)")->required();
  command->add_option("--rate", o->rate, "frame rate of the motion, Hz (10 to 1000)")->capture_default_str();
  command->add_option("--frames", o->frames, "frames to write (default: the track's length at --rate)");
  command
      ->add_option("--out", o->out,
                   "motion to write: BVH of the model's skeleton at --rate for a name ending in .bvh, else motion "
                   "text (- for standard output)")
      ->required();
  command->callback([o, &action] {
    action = [o] {
      const std::string text = read_input_file(o->track, "--input");
      check_output_file(o->out, "--out");
      check_take_rate(o->rate, "--rate");
      if (o->frames < -1 || o->frames == 0) {
        throw InputError("--frames: expected a number of frames (at least 1), found " + std::to_string(o->frames));
      }
      const auto track = parse_track(text, input_name(o->track));
      const MotionManifold model = load_model_at_precision(o->model.model_dir, o->model.precision);
      CodeTrackDecoding options;
      options.frame_rate = o->rate;
      options.frames = o->frames;
      options.blend = parse_take_blend(o->model.blend);
      options.decoder = o->model.kind(model);
      MotionFrames motion;
      motion.columns = model.normalization().input_columns();
      TakeSink sink;
      sink.on_frames = [&motion](const MotionFrames& frames, const std::vector<float>&) {
        motion.values.insert(motion.values.end(), frames.values.begin(), frames.values.end());
      };
      TakeSummary summary;
      try {
        summary = decode_code_track(model, track, options, sink);
      } catch (const InputError& e) {
        throw InputError(input_name(o->track) + ": " + e.what());
      }
      write_take(motion, o->rate, o->out, model.skeleton());
      std::fprintf(message_stream({o->out}), "wrote %s (%lld frames at %g Hz from %d windows)\n",
                   is_standard_stream(o->out) ? "standard output" : o->out.c_str(),
                   static_cast<long long>(summary.output_frames), o->rate, summary.windows);
      return kExitSuccess;
    };
  });
}

// take resample: a motion brought to another rate on rotations, as takes are
// (format/motion_resampling.h), e.g. to give a take the rate of another tool.
void add_take_resample(CLI::App* take, Action& action) {
  struct Options {
    TakeArguments model;
    std::string input, out;
    double rate = kDataSetRate, to = kTakeModelRate;
  };
  auto o = std::make_shared<Options>();
  auto* command = take->add_subcommand(
      "resample",
      "Bring a motion to another frame rate as takes are: every joint's rotation slerped between the two nearest "
      "frames, the root's position interpolated linearly. Covers the input's duration (a frame every 1/--to s up "
      "to its last frame's time).");
  o->model.add_to(command, false);
  command->add_option("--input", o->input, "motion text at --rate, or BVH of the model's skeleton (- for standard input)")
      ->required();
  command->add_option("--rate", o->rate, "frame rate of a text input, Hz")->capture_default_str();
  command->add_option("--to", o->to, "frame rate to write, Hz (10 to 1000)")->required();
  command->add_option("--out", o->out, "BVH for a name ending in .bvh, else motion text (- for standard output)")
      ->required();
  command->callback([o, &action] {
    action = [o] {
      check_take_rate(o->rate, "--rate");
      check_take_rate(o->to, "--to");
      check_output_file(o->out, "--out");
      const MotionManifold model = load_model_at_precision(o->model.model_dir, o->model.precision);
      const TakeInput in = read_take(o->input, o->rate, false, model.skeleton());
      const MotionFrames out = resample_motion(in.frames, in.rate, o->to);
      write_take(out, o->to, o->out, model.skeleton());
      std::fprintf(message_stream({o->out}), "wrote %s (%lld frames at %g Hz from %lld at %g Hz)\n",
                   is_standard_stream(o->out) ? "standard output" : o->out.c_str(),
                   static_cast<long long>(out.frame_count()), o->to, static_cast<long long>(in.frames.frame_count()),
                   in.rate);
      return kExitSuccess;
    };
  });
}

// take mirror: a motion's mirror image, left and right swapped
// (format/motion_mirror.h), e.g. to see whether the manifold turns both
// ways (docs/RESULTS.md, "Motions that travel").
void add_take_mirror(CLI::App* take, Action& action) {
  struct Options {
    TakeArguments model;
    std::string input, out;
    double rate = kDataSetRate;
  };
  auto o = std::make_shared<Options>();
  auto* command = take->add_subcommand(
      "mirror",
      "Mirror a motion: left and right swapped as in a mirror (each joint takes its twin's rotation reflected "
      "across the body's plane; the root turns and moves sideways the other way), at the input's rate and length. "
      "Needs a skeleton that is its own mirror image (H3.6M's is).");
  o->model.add_to(command, false);
  command->add_option("--input", o->input, "motion text at --rate, or BVH of the model's skeleton (- for standard input)")
      ->required();
  command->add_option("--rate", o->rate, "frame rate of a text input, Hz")->capture_default_str();
  command->add_option("--out", o->out, "BVH for a name ending in .bvh, else motion text (- for standard output)")
      ->required();
  command->callback([o, &action] {
    action = [o] {
      check_take_rate(o->rate, "--rate");
      check_output_file(o->out, "--out");
      const MotionManifold model = load_model_at_precision(o->model.model_dir, o->model.precision);
      const TakeInput in = read_take(o->input, o->rate, false, model.skeleton());
      const MotionFrames out = mirrored(motion_mirror(model.skeleton()), in.frames);
      write_take(out, in.rate, o->out, model.skeleton());
      std::fprintf(message_stream({o->out}), "wrote %s (%lld frames at %g Hz, mirrored)\n",
                   is_standard_stream(o->out) ? "standard output" : o->out.c_str(),
                   static_cast<long long>(out.frame_count()), in.rate);
      return kExitSuccess;
    };
  });
}

}  // namespace

void add_take_commands(CLI::App& app, Action& action) {
  auto* take = app.add_subcommand("take", "Takes: motions of any length and frame rate (encode, reconstruct, "
                                          "denoise, decode, resample, mirror).");
  take->require_subcommand(1);
  add_take_operation(take, action, TakeOperation::kEncode);
  add_take_operation(take, action, TakeOperation::kReconstruct);
  add_take_operation(take, action, TakeOperation::kDenoise);
  add_take_decode(take, action);
  add_take_resample(take, action);
  add_take_mirror(take, action);
}

}  // namespace mm::tool
