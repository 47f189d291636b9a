// The applications of Sec. 5 on a trained model: random samples (5.2),
// interpolation (5.3), denoising (5.4), analogy (5.5), and the encode/decode
// pair they are built from.
#include <c10/core/InferenceMode.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "format/atomic_file.h"
#include "format/input_error.h"
#include "format/root_path.h"
#include "model/default_model.h"
#include "model/latent_operations.h"
#include "model/tool/cli_validators.h"
#include "model/tool/commands.h"
#include "model/tool/file_arguments.h"
#include "model/tool/motion_files.h"
#include "model/tool/precision_option.h"

namespace mm::tool {
namespace {

// Options every command here shares.
struct ModelOptions {
  std::string model_dir;
  std::string decoder;  // empty: the model's default (rotation if present)
  std::string precision = "fp32";

  void add_to(CLI::App* command, bool decodes) {
    model_dir = default_model_dir();
    command->add_option("--model", model_dir, "model folder (default: $MM_MODEL_DIR or the shipped model)");
    add_precision_option(command, precision);
    if (decodes) {
      command->add_option("--decoder", decoder, "rotation or velocity (default: rotation if the model has it)")
          ->check(CLI::IsMember({"rotation", "velocity"}));
    }
  }
  DecoderKind kind(const MotionManifold& model) const {
    return decoder.empty() ? model.default_decoder() : parse_decoder_kind(decoder);
  }
};

MotionManifold load_model(const ModelOptions& o) { return load_model_at_precision(o.model_dir, o.precision); }

// A motion named on the command line and the 25 Hz window of it to use.
struct MotionArgument {
  std::string option;  // "--input", "--from", ...
  std::string path;
  int start = 0;       // first 25 Hz frame of the window
  std::string text;    // the file's bytes, once read
};

// The motions a command reads and their --rate. The files are read before the
// model loads, so that a bad path fails at once; they are parsed after, with
// the model's clip length and column count.
struct MotionInputs {
  std::vector<MotionArgument> motions;
  std::vector<int> rates;
  bool generated = false;

  explicit MotionInputs(std::vector<std::string> options) {
    for (auto& option : options) motions.push_back({std::move(option)});
  }
  // Registers --rate; `inputs` names the motions for its help.
  void add_rate_to(CLI::App* command, const std::string& inputs) {
    add_rate_option(command, rates, kDataSetRate, inputs);
    command->add_flag("--generated", generated,
                      "the motions are generated ones in world layout, as decode, sample, interpolate and analogy "
                      "write them for a model with a trajectory network: their root is brought back to the "
                      "layout's per-frame changes, which the model reads");
  }
  // Reads every file (or standard input for "-"); InputError on a bad path
  // or a --rate list of the wrong length.
  void read() {
    for (size_t i = 0; i < motions.size(); ++i) rate(i);
    std::vector<std::pair<std::string, std::string>> option_paths;
    for (const auto& m : motions) option_paths.emplace_back(m.option, m.path);
    check_one_standard_input(option_paths);
    for (auto& m : motions) m.text = read_input_file(m.path, m.option);
  }
  // The windows of the model's clip length, at 25 Hz.
  std::vector<MotionFrames> windows(const MotionManifold& model) const {
    std::vector<MotionFrames> result;
    for (size_t i = 0; i < motions.size(); ++i) {
      result.push_back(motion_window(motions[i].text, input_name(motions[i].path), model.config().frames,
                                     motions[i].start, rate(i), model.skeleton()));
      if (generated) model_root_from_world(model.skeleton(), result.back(), kRootRotationStepsPerFrame);
    }
    return result;
  }
  // The rate of motion i: --rate's value for it, or the data set's 50 Hz.
  int rate(size_t i) const { return per_input(rates, i, kDataSetRate, "--rate", motions.size()); }
};

// Writes motions as <dir>/<stem>_000.<format>, ... (format "txt" or "bvh");
// the folder was made beforehand.
int write_motions(const std::vector<MotionFrames>& motions, const std::string& dir, const std::string& stem,
                  const std::string& format, const Skeleton& skeleton) {
  for (size_t i = 0; i < motions.size(); ++i) {
    write_motion_output(motions[i], numbered_motion_path(dir, stem, static_cast<int>(i), format), skeleton);
  }
  std::printf("wrote %zu motions of %lld frames at 25 Hz: %s ... %s\n", motions.size(),
              static_cast<long long>(motions.front().frame_count()), numbered_motion_path(dir, stem, 0, format).c_str(),
              numbered_motion_path(dir, stem, static_cast<int>(motions.size()) - 1, format).c_str());
  return kExitSuccess;
}

// Writes one decoded motion to --out (a file or - for standard output) and
// says so where it does not mix with the data.
int write_motion(const MotionFrames& motion, const std::string& out, const Skeleton& skeleton) {
  write_motion_output(motion, out, skeleton);
  std::fprintf(message_stream({out}), "wrote %s (%lld frames at 25 Hz)\n",
               is_standard_stream(out) ? "standard output" : out.c_str(),
               static_cast<long long>(motion.frame_count()));
  return kExitSuccess;
}

// Mean over frames and joints of the distance between the joint positions
// (FK, millimetres) of two motions in raw frames.
double mean_joint_error_mm(const MotionManifold& model, const MotionFrames& a, const MotionFrames& b) {
  c10::InferenceMode inference;
  auto positions = [&model](const MotionFrames& m) {
    auto raw = at::from_blob(const_cast<float*>(m.values.data()), {m.frame_count(), m.columns}).to(model.device());
    return model.positions_mm(model.to_normalized(raw));
  };
  return (positions(a) - positions(b)).norm(2, -1).mean().item<double>();
}

// Codes come from the prior N(0, I): a value beyond this is no code of the
// manifold, and would overflow the decoder's arithmetic long before it.
constexpr double kMaxCodeValue = 1e3;

// A code file's text: {"codes": [[z...]]} with one code, as encode prints it
// and REST's Encode answers it (a REST Decode body as it is), or the older
// {"code": [z...]}, or a bare array of numbers. `name` is the file's name in
// messages.
at::Tensor parse_code(const std::string& text, const std::string& name, int latent) {
  nlohmann::json document;
  try {
    document = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    // Parse errors, and numbers too large for a double (1e999).
    throw InputError(name + ": not a valid code file (JSON): " + json_error_reason(e.what()));
  }
  const nlohmann::json* found = &document;
  if (document.is_object() && document.contains("codes")) {
    const auto& codes = document["codes"];
    if (!codes.is_array() || codes.size() != 1) {
      throw InputError(name + ": codes: expected an array of one code (" + std::to_string(latent) + " numbers)" +
                       (codes.is_array() ? ", found " + std::to_string(codes.size()) + " codes" : ""));
    }
    found = &codes[0];
  } else if (document.is_object() && document.contains("code")) {
    found = &document["code"];
  }
  const nlohmann::json& values = *found;
  if (!values.is_array() || values.size() != static_cast<size_t>(latent)) {
    throw InputError(name + ": code: expected an array of " + std::to_string(latent) + " numbers" +
                     (values.is_array() ? ", found " + std::to_string(values.size()) : ", found " +
                      std::string(values.type_name())));
  }
  std::vector<float> code;
  for (size_t i = 0; i < values.size(); ++i) {
    const auto& v = values[i];
    if (!v.is_number()) throw InputError(name + ": code[" + std::to_string(i) + "]: expected a number, found " + v.dump());
    const double value = v.get<double>();
    if (!(std::fabs(value) <= kMaxCodeValue)) {
      std::ostringstream bound;
      bound << kMaxCodeValue;
      throw InputError(name + ": code[" + std::to_string(i) + "]: " + v.dump() + " is out of range, expected a value within +-" +
                       bound.str() + " (codes follow the prior N(0, I))");
    }
    code.push_back(static_cast<float>(value));
  }
  return at::tensor(code).unsqueeze(0);
}

// sample and interpolate decode all their codes in one batch and hold the
// motions in memory; this bounds what one run may take.
constexpr double kDecodeMemoryBytes = 1024.0 * 1024 * 1024;

// Bytes one decoded motion needs while it is decoded: the decoder's output
// and its reversed copy (frames x pose dims, twice), the raw frames and
// their copy for the text (frames x input columns, twice), and one step's
// GRU state and gates (7 x hidden), all 4-byte floats.
double decode_bytes_per_motion(const MotionManifold& model) {
  const auto& c = model.config();
  const double floats = static_cast<double>(c.frames) * (2.0 * c.pose_dims + 2.0 * model.normalization().input_columns()) +
                        7.0 * c.hidden;
  return 4.0 * floats;
}

std::string megabytes(double bytes) {
  char text[32];
  if (bytes < 1e6) {
    std::snprintf(text, sizeof text, "%.0f kB", bytes / 1e3);
  } else if (bytes >= 1e9) {
    std::snprintf(text, sizeof text, "%.1f GB", bytes / 1e9);
  } else {
    std::snprintf(text, sizeof text, "%.1f MB", bytes / 1e6);
  }
  return text;
}

// Throws InputError naming `option`, the memory needed and `hint` (what to do
// instead) when decoding `count` motions at once would take more than
// kDecodeMemoryBytes.
void check_decode_count(const MotionManifold& model, int count, const std::string& option, const std::string& hint) {
  const double per_motion = decode_bytes_per_motion(model);
  const auto most = static_cast<long long>(kDecodeMemoryBytes / per_motion);
  if (count <= most) return;
  throw InputError(option + " " + std::to_string(count) + ": decoding " + std::to_string(count) +
                   " motions at once needs about " + megabytes(count * per_motion) + " (" + std::to_string(count) +
                   " x " + std::to_string(model.config().frames) + " frames x " +
                   std::to_string(model.normalization().input_columns()) +
                   " values, with the decoder's working memory: " + megabytes(per_motion) +
                   " a motion), more than the 1 GiB one run may use; expected at most " + std::to_string(most) + " (" + hint + ")");
}

void add_sample(CLI::App& app, Action& action) {
  struct Options {
    ModelOptions model;
    int count = 1;
    uint64_t seed = 0;
    std::string out_dir;
    std::string format = "txt";
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "sample", "Decode random codes drawn from the prior (Sec. 5.2) into sample_000.txt, ... (25 Hz; .bvh with --format bvh). One run "
                "decodes at most what fits in 1 GiB (about 5000 motions with the shipped model).");
  o->model.add_to(command, true);
  command->add_option("--count", o->count, "number of motions (run again with another --seed for more than fit in 1 GiB)")
      ->check(at_least(1))
      ->capture_default_str();
  command->add_option("--seed", o->seed, "seed of the codes")->capture_default_str();
  command->add_option("--out-dir", o->out_dir, "folder for the motion files")->required();
  command->add_option("--format", o->format, "file format of the motions: txt (H3.6M text), bvh, glb or gltf")
      ->check(CLI::IsMember({"txt", "bvh", "glb", "gltf"}))
      ->capture_default_str();
  command->callback([o, &action] {
    action = [o] {
      ensure_directory(o->out_dir, "--out-dir");
      const MotionManifold model = load_model(o->model);
      check_decode_count(model, o->count, "--count", "run again with another --seed for more");
      const auto codes = sample_codes(model, o->count, o->seed);
      return write_motions(decode_codes(model, codes, o->model.kind(model)), o->out_dir, "sample", o->format, model.skeleton());
    };
  });
}

void add_interpolate(CLI::App& app, Action& action) {
  struct Options {
    ModelOptions model;
    MotionInputs inputs{{"--from", "--to"}};
    std::string out_dir;
    std::string format = "txt";
    int steps = 5;
    bool spherical = false;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "interpolate",
      std::string("Interpolate two motions on the manifold (Sec. 5.3) into interpolation_000.txt (from) ... "
                  "interpolation_<steps-1>.txt (to), or .bvh with --format bvh. ") + kMotionRateNote);
  o->model.add_to(command, true);
  auto& from = o->inputs.motions[0];
  auto& to = o->inputs.motions[1];
  command->add_option("--from", from.path, "first motion file (- for standard input)")->required();
  command->add_option("--to", to.path, "second motion file (- for standard input)")->required();
  o->inputs.add_rate_to(command, "--from and --to (one value, or two: from,to)");
  command->add_option("--steps", o->steps, "number of motions, both ends included (>= 2)")
      ->check(at_least(2))
      ->capture_default_str();
  command->add_flag("--spherical", o->spherical, "spherical instead of linear interpolation of the codes");
  command->add_option("--start-from", from.start, "first frame of the window in --from, in its own frames (rows)");
  command->add_option("--start-to", to.start, "first frame of the window in --to, in its own frames (rows)");
  command->add_option("--out-dir", o->out_dir, "folder for the motion files")->required();
  command->add_option("--format", o->format, "file format of the motions: txt (H3.6M text), bvh, glb or gltf")
      ->check(CLI::IsMember({"txt", "bvh", "glb", "gltf"}))
      ->capture_default_str();
  command->callback([o, &action] {
    action = [o] {
      o->inputs.read();
      ensure_directory(o->out_dir, "--out-dir");
      const MotionManifold model = load_model(o->model);
      check_decode_count(model, o->steps, "--steps", "fewer steps");
      const auto codes = encode_motions(model, o->inputs.windows(model));
      const auto path = interpolate_codes(codes[0], codes[1], o->steps, o->spherical);
      return write_motions(decode_codes(model, path, o->model.kind(model)), o->out_dir, "interpolation", o->format, model.skeleton());
    };
  });
}

void add_analogy(CLI::App& app, Action& action) {
  struct Options {
    ModelOptions model;
    MotionInputs inputs{{"--a", "--b", "--c"}};
    std::string out;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "analogy", std::string("Decode z(a) - z(b) + z(c) (Sec. 5.5) into --out. ") + kMotionRateNote);
  o->model.add_to(command, true);
  auto& m = o->inputs.motions;
  command->add_option("--a", m[0].path, "motion a (- for standard input)")->required();
  command->add_option("--b", m[1].path, "motion b, subtracted (- for standard input)")->required();
  command->add_option("--c", m[2].path, "motion c (- for standard input)")->required();
  o->inputs.add_rate_to(command, "a, b and c (one value, or three: a,b,c)");
  command->add_option("--start-a", m[0].start, "first frame of the window in a, in its own frames (rows)");
  command->add_option("--start-b", m[1].start, "first frame of the window in b, in its own frames (rows)");
  command->add_option("--start-c", m[2].start, "first frame of the window in c, in its own frames (rows)");
  command->add_option("--out", o->out, "motion file to write (25 Hz; - for standard output)")->required();
  command->callback([o, &action] {
    action = [o] {
      o->inputs.read();
      check_output_file(o->out, "--out");
      const MotionManifold model = load_model(o->model);
      const auto codes = encode_motions(model, o->inputs.windows(model));
      const auto code = analogy_code(codes[0], codes[1], codes[2]).unsqueeze(0);
      return write_motion(decode_codes(model, code, o->model.kind(model))[0], o->out, model.skeleton());
    };
  });
}

void add_denoise(CLI::App& app, Action& action) {
  struct Options {
    ModelOptions model;
    MotionInputs inputs{{"--input"}};
    std::string out, corrupted_out;
    double probability = 0;
    uint64_t seed = 0;
    std::string corruption = "reference";
    DenoiseOptions denoise;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "denoise",
      std::string("Project a motion onto the manifold and decode it (Sec. 5.4), optionally after corrupting it as "
                  "in the paper (each joint-angle value dropped with a probability: to its training mean as the "
                  "paper's reference implementation does, or to zero as the paper's text says). Prints, as JSON, "
                  "the mean per-joint position error (mm) against the input (on stderr when an output is -). ") +
          kMotionRateNote);
  o->model.add_to(command, true);
  auto& input = o->inputs.motions[0];
  command->add_option("--input", input.path, "motion file (- for standard input)")->required();
  o->inputs.add_rate_to(command, "--input");
  command->add_option("--start", input.start, "first frame of the window, in the file's own frames (a text file's rows, a BVH's frames)");
  command->add_option("--out", o->out, "denoised motion file to write (25 Hz; - for standard output)")->required();
  command->add_option("--corrupt-probability", o->probability, "drop each joint-angle value with this probability first")
      ->check(CLI::Range(0.0, 1.0));
  command->add_option("--corruption", o->corruption,
                      "what a dropped value becomes: reference (its training mean, as the reference implementation "
                      "drops values) or zeroed (zero, as the paper's text says)")
      ->check(CLI::IsMember({"reference", "zeroed"}))
      ->capture_default_str();
  command->add_option("--seed", o->seed, "seed of the corruption")->capture_default_str();
  command->add_option("--corrupted-out", o->corrupted_out,
                      "also write the corrupted motion (25 Hz; - for standard output)");
  auto* zeros_are_missing = command->add_flag(
      "--zeros-are-missing", o->denoise.zeros_are_missing,
      "treat joint-angle values that are exactly zero as missing and fill them from the manifold (the zeroed "
      "corruption's dropped values)");
  command->add_flag("--means-are-missing", o->denoise.means_are_missing,
                    "treat joint-angle values exactly at their training mean as missing and fill them from the "
                    "manifold (the reference corruption's dropped values)")
      ->excludes(zeros_are_missing);
  auto* iterations = command->add_option(
      "--iterations", o->denoise.iterations,
      "with --zeros-are-missing or --means-are-missing: rounds of projecting and refilling the missing values");
  iterations->check(CLI::PositiveNumber)->capture_default_str();
  command->add_flag("--keep-observed", o->denoise.keep_observed,
                    "with --zeros-are-missing or --means-are-missing: keep the observed values and take the "
                    "manifold's only for the missing");
  command->callback([o, &action, iterations] {
    const bool missing_values = o->denoise.zeros_are_missing || o->denoise.means_are_missing;
    if (!missing_values && (o->denoise.keep_observed || iterations->count() > 0)) {
      throw CLI::ValidationError(std::string(o->denoise.keep_observed ? "--keep-observed" : "--iterations") +
                                 ": expected together with --zeros-are-missing or --means-are-missing");
    }
    action = [o] {
      o->inputs.read();
      check_output_file(o->out, "--out");
      if (!o->corrupted_out.empty()) {
        check_output_file(o->corrupted_out, "--corrupted-out");
        if (is_standard_stream(o->out) && is_standard_stream(o->corrupted_out)) {
          throw InputError("--out and --corrupted-out are both - (standard output): give one of them a file");
        }
      }
      const MotionManifold model = load_model(o->model);
      const MotionFrames clean = o->inputs.windows(model)[0];
      const MotionFrames noisy = o->probability > 0 ? corrupt_motion(clean, model.normalization(), o->probability,
                                                                     o->seed, parse_corruption(o->corruption))
                                                    : clean;
      if (!o->corrupted_out.empty()) write_motion_output(noisy, o->corrupted_out, model.skeleton());
      const MotionFrames denoised = denoise_motions(model, {noisy}, o->model.kind(model), o->denoise)[0];
      write_motion_output(denoised, o->out, model.skeleton());
      const nlohmann::json report = {
          {"input", input_name(o->inputs.motions[0].path)},
          {"rate", o->inputs.rate(0)},
          {"start", o->inputs.motions[0].start},
          {"frames", model.config().frames},
          {"corrupt_probability", o->probability},
          {"corruption", o->corruption},
          {"zeros_are_missing", o->denoise.zeros_are_missing},
          {"means_are_missing", o->denoise.means_are_missing},
          {"keep_observed", o->denoise.keep_observed},
          {"corrupted_mpjpe_mm", mean_joint_error_mm(model, noisy, clean)},
          {"denoised_mpjpe_mm", mean_joint_error_mm(model, denoised, clean)},
          {"out", o->out},
      };
      std::fprintf(message_stream({o->out, o->corrupted_out}), "%s\n", report.dump(2).c_str());
      return kExitSuccess;
    };
  });
}

void add_encode(CLI::App& app, Action& action) {
  struct Options {
    ModelOptions model;
    MotionInputs inputs{{"--input"}};
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "encode", std::string("Print the manifold code of a motion as JSON {\"codes\": [[...]]} on stdout, a code "
                            "file for decode (the client's and REST's Decode read it as it is), and which window it "
                            "encodes on stderr. ") + kMotionRateNote);
  o->model.add_to(command, false);
  auto& input = o->inputs.motions[0];
  command->add_option("--input", input.path, "motion file (- for standard input)")->required();
  o->inputs.add_rate_to(command, "--input");
  command->add_option("--start", input.start, "first frame of the window, in the file's own frames (a text file's rows, a BVH's frames)");
  command->callback([o, &action] {
    action = [o] {
      o->inputs.read();
      const MotionManifold model = load_model(o->model);
      const auto code = encode_motions(model, o->inputs.windows(model))[0].contiguous();
      // One code file for the tool, the client and REST: a Decode body.
      const nlohmann::json codes = {
          {"codes", {std::vector<float>(code.data_ptr<float>(), code.data_ptr<float>() + code.numel())}}};
      std::printf("%s\n", codes.dump().c_str());
      // Which window it is the code of, apart from the data (as every
      // command's report when its output is standard output).
      const nlohmann::json window = {{"input", input_name(o->inputs.motions[0].path)},
                                     {"rate", o->inputs.rate(0)},
                                     {"start", o->inputs.motions[0].start},
                                     {"frames", model.config().frames}};
      std::fprintf(stderr, "%s\n", window.dump().c_str());
      return kExitSuccess;
    };
  });
}

void add_decode(CLI::App& app, Action& action) {
  struct Options {
    ModelOptions model;
    std::string code, out;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "decode",
      "Decode a code (JSON as printed by encode) into a motion file at 25 Hz, the root travelling as the model's "
      "trajectory network says (world layout; a model without one stands in place: root translation zero); read it "
      "back with --rate 25.");
  o->model.add_to(command, true);
  command->add_option("--code", o->code,
                      "JSON file: {\"code\": [...]} or a bare array of the model's latent size (64), each within "
                      "+-1000 (- for standard input)")
      ->required();
  command->add_option("--out", o->out, "motion file to write (25 Hz; - for standard output)")->required();
  command->callback([o, &action] {
    action = [o] {
      const std::string text = read_input_file(o->code, "--code");
      check_output_file(o->out, "--out");
      const MotionManifold model = load_model(o->model);
      const auto code = parse_code(text, input_name(o->code), model.config().latent);
      return write_motion(decode_codes(model, code, o->model.kind(model))[0], o->out, model.skeleton());
    };
  });
}

}  // namespace

void add_manifold_commands(CLI::App& app, Action& action) {
  add_sample(app, action);
  add_interpolate(app, action);
  add_analogy(app, action);
  add_denoise(app, action);
  add_encode(app, action);
  add_decode(app, action);
}

}  // namespace mm::tool
