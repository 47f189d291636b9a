// The applications of Sec. 5 on a trained model: random samples (5.2),
// interpolation (5.3), denoising (5.4), analogy (5.5), and the encode/decode
// pair they are built from.
#include <c10/core/InferenceMode.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli_validators.h"
#include "commands.h"
#include "format/atomic_file.h"
#include "format/input_error.h"
#include "default_model.h"
#include "latent_operations.h"
#include "motion_files.h"

namespace mm::tool {
namespace {

// Options every command here shares.
struct ModelOptions {
  std::string model_dir;
  std::string decoder;  // empty: the model's default (rotation if present)

  void add_to(CLI::App* command, bool decodes) {
    model_dir = default_model_dir();
    command->add_option("--model", model_dir, "model folder (default: $MM_MODEL_DIR or the shipped model)")
        ->capture_default_str();
    if (decodes) {
      command->add_option("--decoder", decoder, "rotation or velocity (default: rotation if the model has it)")
          ->check(CLI::IsMember({"rotation", "velocity"}));
    }
  }
  DecoderKind kind(const MotionManifold& model) const {
    return decoder.empty() ? model.default_decoder() : parse_decoder_kind(decoder);
  }
};

MotionManifold load_model(const ModelOptions& o) { return MotionManifold::load(o.model_dir); }

MotionFrames read_input(const MotionManifold& model, const std::string& path, int start) {
  return read_motion_window(path, model.config().frames, start, model.normalization().input_columns());
}

int write_motions(const std::vector<MotionFrames>& motions, const std::string& dir, const std::string& stem) {
  ensure_directory(dir, "--out-dir");
  for (size_t i = 0; i < motions.size(); ++i) {
    write_motion_text_file(motions[i], numbered_motion_path(dir, stem, static_cast<int>(i)));
  }
  std::printf("wrote %zu motions of %lld frames at 25 Hz: %s ... %s\n", motions.size(),
              static_cast<long long>(motions.front().frame_count()), numbered_motion_path(dir, stem, 0).c_str(),
              numbered_motion_path(dir, stem, static_cast<int>(motions.size()) - 1).c_str());
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

// A code file: {"code": [z...]}, as encode prints, or a bare array of numbers.
at::Tensor read_code(const std::string& path, int latent) {
  nlohmann::json document;
  try {
    document = nlohmann::json::parse(read_whole_file(path));
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(path + ": not valid JSON: " + e.what());
  }
  const nlohmann::json& values = document.is_object() && document.contains("code") ? document["code"] : document;
  if (!values.is_array() || values.size() != static_cast<size_t>(latent)) {
    throw InputError(path + ": code: expected an array of " + std::to_string(latent) + " numbers" +
                     (values.is_array() ? ", found " + std::to_string(values.size()) : std::string()));
  }
  std::vector<float> code;
  for (const auto& v : values) {
    if (!v.is_number()) throw InputError(path + ": code: expected numbers, found " + v.dump());
    code.push_back(v.get<float>());
  }
  return at::tensor(code).unsqueeze(0);
}

void add_sample(CLI::App& app, Action& action) {
  struct Options {
    ModelOptions model;
    int count = 1;
    uint64_t seed = 0;
    std::string out_dir;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "sample", "Decode random codes drawn from the prior (Sec. 5.2) into sample_000.txt, ... (25 Hz).");
  o->model.add_to(command, true);
  command->add_option("--count", o->count, "number of motions")->check(at_least(1))->capture_default_str();
  command->add_option("--seed", o->seed, "seed of the codes")->capture_default_str();
  command->add_option("--out-dir", o->out_dir, "folder for the motion files")->required();
  command->callback([o, &action] {
    action = [o] {
      const MotionManifold model = load_model(o->model);
      const auto codes = sample_codes(model, o->count, o->seed);
      return write_motions(decode_codes(model, codes, o->model.kind(model)), o->out_dir, "sample");
    };
  });
}

void add_interpolate(CLI::App& app, Action& action) {
  struct Options {
    ModelOptions model;
    std::string from, to, out_dir;
    int steps = 5, start_from = 0, start_to = 0;
    bool spherical = false;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "interpolate",
      std::string("Interpolate two motions on the manifold (Sec. 5.3) into interpolation_000.txt (from) ... "
                  "interpolation_<steps-1>.txt (to). ") + kMotionRateNote);
  o->model.add_to(command, true);
  command->add_option("--from", o->from, "first motion file")->required();
  command->add_option("--to", o->to, "second motion file")->required();
  command->add_option("--steps", o->steps, "number of motions, both ends included (>= 2)")
      ->check(at_least(2))
      ->capture_default_str();
  command->add_flag("--spherical", o->spherical, "spherical instead of linear interpolation of the codes");
  command->add_option("--start-from", o->start_from, "first 25 Hz frame of the window in --from");
  command->add_option("--start-to", o->start_to, "first 25 Hz frame of the window in --to");
  command->add_option("--out-dir", o->out_dir, "folder for the motion files")->required();
  command->callback([o, &action] {
    action = [o] {
      const MotionManifold model = load_model(o->model);
      const auto codes = encode_motions(model, {read_input(model, o->from, o->start_from),
                                                read_input(model, o->to, o->start_to)});
      const auto path = interpolate_codes(codes[0], codes[1], o->steps, o->spherical);
      return write_motions(decode_codes(model, path, o->model.kind(model)), o->out_dir, "interpolation");
    };
  });
}

void add_analogy(CLI::App& app, Action& action) {
  struct Options {
    ModelOptions model;
    std::string a, b, c, out;
    int start_a = 0, start_b = 0, start_c = 0;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "analogy", std::string("Decode z(a) - z(b) + z(c) (Sec. 5.5) into --out. ") + kMotionRateNote);
  o->model.add_to(command, true);
  command->add_option("--a", o->a, "motion a")->required();
  command->add_option("--b", o->b, "motion b, subtracted")->required();
  command->add_option("--c", o->c, "motion c")->required();
  command->add_option("--start-a", o->start_a, "first 25 Hz frame of the window in a");
  command->add_option("--start-b", o->start_b, "first 25 Hz frame of the window in b");
  command->add_option("--start-c", o->start_c, "first 25 Hz frame of the window in c");
  command->add_option("--out", o->out, "motion file to write (25 Hz)")->required();
  command->callback([o, &action] {
    action = [o] {
      const MotionManifold model = load_model(o->model);
      const auto codes = encode_motions(model, {read_input(model, o->a, o->start_a), read_input(model, o->b, o->start_b),
                                                read_input(model, o->c, o->start_c)});
      const auto code = analogy_code(codes[0], codes[1], codes[2]).unsqueeze(0);
      write_motion_text_file(decode_codes(model, code, o->model.kind(model))[0], o->out);
      std::printf("wrote %s (%d frames at 25 Hz)\n", o->out.c_str(), model.config().frames);
      return kExitSuccess;
    };
  });
}

void add_denoise(CLI::App& app, Action& action) {
  struct Options {
    ModelOptions model;
    std::string input, out, corrupted_out;
    int start = 0;
    double probability = 0;
    uint64_t seed = 0;
    DenoiseOptions denoise;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "denoise",
      std::string("Project a motion onto the manifold and decode it (Sec. 5.4), optionally after corrupting it as "
                  "in the paper (each joint-angle value zeroed with a probability). Prints, as JSON, the mean "
                  "per-joint position error (mm) against the input. ") + kMotionRateNote);
  o->model.add_to(command, true);
  command->add_option("--input", o->input, "motion file")->required();
  command->add_option("--start", o->start, "first 25 Hz frame of the window");
  command->add_option("--out", o->out, "denoised motion file to write (25 Hz)")->required();
  command->add_option("--corrupt-probability", o->probability, "zero each joint-angle value with this probability first")
      ->check(CLI::Range(0.0, 1.0));
  command->add_option("--seed", o->seed, "seed of the corruption")->capture_default_str();
  command->add_option("--corrupted-out", o->corrupted_out, "also write the corrupted motion (25 Hz)");
  auto* zeros_are_missing = command->add_flag(
      "--zeros-are-missing", o->denoise.zeros_are_missing,
      "treat joint-angle values that are exactly zero as missing and fill them from the manifold");
  command->add_option("--iterations", o->denoise.iterations,
                      "with --zeros-are-missing: rounds of projecting and refilling the missing values")
      ->check(CLI::PositiveNumber)
      ->needs(zeros_are_missing)
      ->capture_default_str();
  command->add_flag("--keep-observed", o->denoise.keep_observed,
                    "with --zeros-are-missing: keep the observed values and take the manifold's only for the missing")
      ->needs(zeros_are_missing);
  command->callback([o, &action] {
    action = [o] {
      const MotionManifold model = load_model(o->model);
      const MotionFrames clean = read_input(model, o->input, o->start);
      const MotionFrames noisy =
          o->probability > 0 ? corrupt_motion(clean, model.normalization(), o->probability, o->seed) : clean;
      if (!o->corrupted_out.empty()) write_motion_text_file(noisy, o->corrupted_out);
      const MotionFrames denoised = denoise_motions(model, {noisy}, o->model.kind(model), o->denoise)[0];
      write_motion_text_file(denoised, o->out);
      const nlohmann::json report = {
          {"input", o->input},
          {"start", o->start},
          {"frames", model.config().frames},
          {"corrupt_probability", o->probability},
          {"zeros_are_missing", o->denoise.zeros_are_missing},
          {"keep_observed", o->denoise.keep_observed},
          {"corrupted_mpjpe_mm", mean_joint_error_mm(model, noisy, clean)},
          {"denoised_mpjpe_mm", mean_joint_error_mm(model, denoised, clean)},
          {"out", o->out},
      };
      std::printf("%s\n", report.dump(2).c_str());
      return kExitSuccess;
    };
  });
}

void add_encode(CLI::App& app, Action& action) {
  struct Options {
    ModelOptions model;
    std::string input;
    int start = 0;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "encode", std::string("Print the manifold code of a motion as JSON {\"code\": [...]}. ") + kMotionRateNote);
  o->model.add_to(command, false);
  command->add_option("--input", o->input, "motion file")->required();
  command->add_option("--start", o->start, "first 25 Hz frame of the window");
  command->callback([o, &action] {
    action = [o] {
      const MotionManifold model = load_model(o->model);
      const auto code = encode_motions(model, {read_input(model, o->input, o->start)})[0].contiguous();
      const nlohmann::json result = {
          {"input", o->input},
          {"start", o->start},
          {"frames", model.config().frames},
          {"code", std::vector<float>(code.data_ptr<float>(), code.data_ptr<float>() + code.numel())},
      };
      std::printf("%s\n", result.dump().c_str());
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
  auto* command = app.add_subcommand("decode", "Decode a code (JSON as printed by encode) into a motion file at 25 Hz.");
  o->model.add_to(command, true);
  command->add_option("--code", o->code, "JSON file: {\"code\": [...]} or a bare array")->required();
  command->add_option("--out", o->out, "motion file to write (25 Hz)")->required();
  command->callback([o, &action] {
    action = [o] {
      const MotionManifold model = load_model(o->model);
      const auto code = read_code(o->code, model.config().latent);
      write_motion_text_file(decode_codes(model, code, o->model.kind(model))[0], o->out);
      std::printf("wrote %s (%d frames at 25 Hz)\n", o->out.c_str(), model.config().frames);
      return kExitSuccess;
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
