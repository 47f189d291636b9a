// encode, decode, sample, interpolate, analogy, denoise, join: a request built
// from local files and flags, one call, and the reply written as motion
// files (or printed with --json). Motion files are read and written in the
// rig of the model (model_rig.h), which a request then names.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>

#include "client/cli/commands.h"
#include "client/cli/motion_io.h"
#include "client/cli/server_connection.h"
#include "client/cli/server_error.h"
#include "format/input_error.h"
#include "wire/rest_json.h"

namespace mm::client {

// --json prints a reply as REST answers it, written by the same code.
using ::mm::wire::to_json;
namespace {

// The options every inference command has.
struct ModelChoice {
  std::string model, decoder;
  bool plant_feet = false;

  void add_to(CLI::App* command, bool with_decoder) {
    command->add_option("--model", model, "model of the server's store (default: the active one)");
    if (with_decoder) {
      command->add_option("--decoder", decoder, "rotation or velocity (default: the model's)");
    }
  }
  // Decode, sample, interpolate and analogy: their motions' generated root.
  void add_plant_feet(CLI::App* command) {
    command->add_flag("--plant-feet", plant_feet,
                      "correct the generated root where a foot is planted, so that planted feet stay put");
  }
};

void add_rate(CLI::App* command, std::vector<MotionSource*> sources) {
  auto* rate = command->add_option_function<int>(
      "--rate", [sources](int value) { for (auto* s : sources) s->rate = value; },
      "frame rate of the input motions: 50 (H3.6M files, default) or 25");
  rate->check(CLI::IsMember({25, 50}));
}

// A file that is a motion (.txt, .bvh) or a code (.json), for interpolate
// and analogy.
v1::MotionOrCode motion_or_code(const MotionSource& source, ModelRigs& rigs, const std::string& model) {
  v1::MotionOrCode input;
  if (is_code_file(source.path)) {
    *input.mutable_code() = read_code(source.path);
  } else {
    *input.mutable_motion() = read_motion(source, rigs, model);
  }
  return input;
}

// Where the motions of a reply go, one file each: --out-dir and the files'
// format (--format).
struct OutputDir {
  std::string dir, type = "txt";

  void add_to(CLI::App* command, const std::string& what) {
    command->add_option("--out-dir", dir, what);
    command->add_option("--format", type, "file format of the --out-dir files: txt (exponential-map text) or bvh (BVH "
                                          "of the model's skeleton)")
        ->check(CLI::IsMember({"txt", "bvh"}))
        ->capture_default_str();
  }
};

void require_output(const ClientSettings& settings, const std::string& out, const std::string& option) {
  if (out.empty() && !settings.json) throw InputError(option + " is required (or --json to print the reply)");
  if (!out.empty() && option == "--out") check_motion_output(out, option);
}

// Writes a MotionsReply's motions (files named on stdout) or prints it.
int finish_motions(const ClientSettings& settings, const v1::MotionsReply& reply, ModelRigs& rigs,
                   const std::string& out, const OutputDir& out_dir, const std::string& stem) {
  if (!out.empty() && reply.motions_size() > 0) {
    write_motion(reply.motions(0), out, rigs, reply.answered_by().model());
    if (out != "-" && !settings.json) std::printf("%s\n", out.c_str());
  }
  if (!out_dir.dir.empty()) {
    for (const auto& path : write_numbered_motions(reply.motions(), out_dir.dir, stem, out_dir.type, rigs,
                                                   reply.answered_by().model())) {
      if (!settings.json) std::printf("%s\n", path.c_str());
    }
  }
  if (settings.json) print_json(to_json(reply));
  return kExitSuccess;
}

void add_encode(CLI::App& app, const ClientSettings& settings, Action& action) {
  struct Options {
    ModelChoice model;
    MotionSource input;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "encode", std::string("Print the code of a motion: {\"codes\": [[...]], \"model\": ...} on stdout, a code "
                            "file for decode, interpolate and analogy (and a REST Decode body as it is)"));
  command->footer(kMotionInputNote);  // once per command, in its own --help
  o->model.add_to(command, false);
  command->add_option("--input", o->input.path, "motion file (.txt or .bvh; - for standard input)")->required();
  add_rate(command, {&o->input});
  command->add_option("--start", o->input.start,
                      "first frame of the clip, in the file's own frames (a text file's rows, a BVH's frames), as "
                      "clips read's --start");
  command->callback([o, &settings, &action] {
    action = [o, &settings] {
      const auto server = connect(settings.connection);
      ModelRigs rigs(*server);
      v1::EncodeRequest request;
      *request.add_motions() = read_motion(o->input, rigs, o->model.model);
      request.set_model(rigs.pinned(o->model.model));
      const auto reply = server->encode(request);
      if (settings.json) {
        print_json(to_json(reply));
      } else {
        // One code file for the client, the tool and REST: a Decode body,
        // with the model that made the code (REST decodes with it).
        const auto& code = reply.codes(0).values();
        const nlohmann::json result = {{"codes", {std::vector<float>(code.begin(), code.end())}},
                                       {"model", reply.answered_by().model()}};
        std::printf("%s\n", result.dump().c_str());
      }
      return kExitSuccess;
    };
  });
}

void add_decode(CLI::App& app, const ClientSettings& settings, Action& action) {
  struct Options {
    ModelChoice model;
    std::vector<std::string> codes;
    std::string out;
    OutputDir out_dir;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "decode", "Decode codes (JSON files as encode prints them, or bare arrays) into motions at 25 Hz; read them "
                "back with --rate 25.");
  o->model.add_to(command, true);
  o->model.add_plant_feet(command);
  command->add_option("--code", o->codes, "code file(s) (.json; - for standard input)")->required();
  command->add_option("--out", o->out, "motion file of the first code (.txt or .bvh; - for standard output)");
  o->out_dir.add_to(command, "folder for every code's motion: decode_000.txt, ...");
  command->callback([o, &settings, &action] {
    action = [o, &settings] {
      if (o->out_dir.dir.empty()) require_output(settings, o->out, "--out");
      if (o->codes.size() > 1 && o->out_dir.dir.empty() && !o->out.empty()) {
        throw InputError("--out takes one code's motion; give --out-dir for " + std::to_string(o->codes.size()) +
                         " codes");
      }
      v1::DecodeRequest request;
      request.set_model(o->model.model);
      request.set_decoder(o->model.decoder);
      request.set_plant_feet(o->model.plant_feet);
      for (const auto& path : o->codes) *request.add_codes() = read_code(path);
      const auto server = connect(settings.connection);
      ModelRigs rigs(*server);
      const auto reply = server->decode(request);
      return finish_motions(settings, reply, rigs, o->out, o->out_dir, "decode");
    };
  });
}

void add_sample(CLI::App& app, const ClientSettings& settings, Action& action) {
  struct Options {
    ModelChoice model;
    int count = 1;
    uint64_t seed = 0;
    OutputDir out_dir;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "sample", "Draw codes from the prior N(0, I) and write their motions (25 Hz) as <out-dir>/sample_000.txt, "
                "... (or .bvh with --format bvh); the same seed, count and model give the same motions.");
  o->model.add_to(command, true);
  o->model.add_plant_feet(command);
  command->add_option("--count", o->count, "number of motions")->check(CLI::PositiveNumber)->capture_default_str();
  command->add_option("--seed", o->seed, "seed of the codes")->capture_default_str();
  o->out_dir.add_to(command, "folder for the motion files");
  command->callback([o, &settings, &action] {
    action = [o, &settings] {
      require_output(settings, o->out_dir.dir, "--out-dir");
      v1::SampleRequest request;
      request.set_model(o->model.model);
      request.set_decoder(o->model.decoder);
      request.set_plant_feet(o->model.plant_feet);
      request.set_count(o->count);
      request.set_seed(o->seed);
      const auto server = connect(settings.connection);
      ModelRigs rigs(*server);
      const auto reply = server->sample(request);
      return finish_motions(settings, reply, rigs, "", o->out_dir, "sample");
    };
  });
}

void add_interpolate(CLI::App& app, const ClientSettings& settings, Action& action) {
  struct Options {
    ModelChoice model;
    MotionSource from, to;
    int steps = 2;
    std::string method = "linear";
    OutputDir out_dir;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "interpolate", std::string("Interpolate between two motions or codes (Sec. 5.3) and write the --steps motions "
                                 "(ends included) as <out-dir>/interpolation_000.txt, ..."));
  command->footer(kMotionInputNote);  // once per command, in its own --help
  o->model.add_to(command, true);
  o->model.add_plant_feet(command);
  command->add_option("--from", o->from.path, "first motion (.txt, .bvh) or code (.json)")->required();
  command->add_option("--to", o->to.path, "last motion (.txt, .bvh) or code (.json)")->required();
  add_rate(command, {&o->from, &o->to});
  command->add_option("--start-from", o->from.start, "first frame of the clip in --from, in its own frames (rows)");
  command->add_option("--start-to", o->to.start, "first frame of the clip in --to, in its own frames (rows)");
  command->add_option("--steps", o->steps, "number of motions, both ends included")->capture_default_str();
  command->add_option("--method", o->method, "linear or spherical")->capture_default_str();
  command->add_flag_callback("--spherical", [o] { o->method = "spherical"; }, "same as --method spherical");
  o->out_dir.add_to(command, "folder for the motion files");
  command->callback([o, &settings, &action] {
    action = [o, &settings] {
      require_output(settings, o->out_dir.dir, "--out-dir");
      const auto server = connect(settings.connection);
      ModelRigs rigs(*server);
      v1::InterpolateRequest request;
      *request.mutable_from() = motion_or_code(o->from, rigs, o->model.model);
      *request.mutable_to() = motion_or_code(o->to, rigs, o->model.model);
      request.set_model(rigs.pinned(o->model.model));
      request.set_decoder(o->model.decoder);
      request.set_plant_feet(o->model.plant_feet);
      request.set_steps(o->steps);
      request.set_method(o->method);
      const auto reply = server->interpolate(request);
      return finish_motions(settings, reply, rigs, "", o->out_dir, "interpolation");
    };
  });
}

void add_analogy(CLI::App& app, const ClientSettings& settings, Action& action) {
  struct Options {
    ModelChoice model;
    MotionSource a, b, c;
    std::string out;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "analogy", std::string("Write the motion of a - b + c (Sec. 5.5): a has a feature b lacks, c receives it"));
  command->footer(kMotionInputNote);  // once per command, in its own --help
  o->model.add_to(command, true);
  o->model.add_plant_feet(command);
  command->add_option("--a", o->a.path, "motion (.txt, .bvh) or code (.json) with the feature")->required();
  command->add_option("--b", o->b.path, "motion or code without it (subtracted)")->required();
  command->add_option("--c", o->c.path, "motion or code to give it to")->required();
  add_rate(command, {&o->a, &o->b, &o->c});
  command->add_option("--start-a", o->a.start, "first frame of the clip in a, in its own frames (rows)");
  command->add_option("--start-b", o->b.start, "first frame of the clip in b, in its own frames (rows)");
  command->add_option("--start-c", o->c.start, "first frame of the clip in c, in its own frames (rows)");
  command->add_option("--out", o->out, "motion file to write (.txt or .bvh, 25 Hz; - for standard output)");
  command->callback([o, &settings, &action] {
    action = [o, &settings] {
      require_output(settings, o->out, "--out");
      const auto server = connect(settings.connection);
      ModelRigs rigs(*server);
      v1::AnalogyRequest request;
      *request.mutable_a() = motion_or_code(o->a, rigs, o->model.model);
      *request.mutable_b() = motion_or_code(o->b, rigs, o->model.model);
      *request.mutable_c() = motion_or_code(o->c, rigs, o->model.model);
      request.set_model(rigs.pinned(o->model.model));
      request.set_decoder(o->model.decoder);
      request.set_plant_feet(o->model.plant_feet);
      const auto reply = server->analogy(request);
      return finish_motions(settings, reply, rigs, o->out, {}, "analogy");
    };
  });
}

void add_denoise(CLI::App& app, const ClientSettings& settings, Action& action) {
  struct Options {
    ModelChoice model;
    MotionSource input;
    bool zeros_are_missing = false, means_are_missing = false, keep_observed = false;
    int iterations = 0;
    std::string out;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "denoise", std::string("Project a motion onto the manifold and write it decoded (Sec. 5.4); its root "
                             "translation is kept"));
  command->footer(kMotionInputNote);  // once per command, in its own --help
  o->model.add_to(command, true);
  command->add_option("--input", o->input.path, "motion file (.txt or .bvh; - for standard input)")->required();
  add_rate(command, {&o->input});
  command->add_option("--start", o->input.start,
                      "first frame of the clip, in the file's own frames (a text file's rows, a BVH's frames), as "
                      "clips read's --start");
  command->add_flag("--zeros-are-missing", o->zeros_are_missing, "a joint-angle value of exactly 0 is missing");
  command->add_flag("--means-are-missing", o->means_are_missing, "a value equal to its training mean is missing");
  command->add_option("--iterations", o->iterations, "with missing values: rounds of projecting (0: four)");
  command->add_flag("--keep-observed", o->keep_observed, "with missing values: fill only the missing ones");
  command->add_option("--out", o->out, "denoised motion file (.txt or .bvh, 25 Hz; - for standard output)");
  command->callback([o, &settings, &action] {
    action = [o, &settings] {
      require_output(settings, o->out, "--out");
      const auto server = connect(settings.connection);
      ModelRigs rigs(*server);
      v1::DenoiseRequest request;
      *request.add_motions() = read_motion(o->input, rigs, o->model.model);
      request.set_model(rigs.pinned(o->model.model));
      request.set_decoder(o->model.decoder);
      request.set_zeros_are_missing(o->zeros_are_missing);
      request.set_means_are_missing(o->means_are_missing);
      request.set_iterations(o->iterations);
      request.set_keep_observed(o->keep_observed);
      const auto reply = server->denoise(request);
      return finish_motions(settings, reply, rigs, o->out, {}, "denoise");
    };
  });
}

void add_join(CLI::App& app, const ClientSettings& settings, Action& action) {
  struct Options {
    ModelChoice model;
    MotionSource a, b;
    double seconds = 1;
    std::string method = "generated";
    std::string out;
  };
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "join", std::string("Join two clips of any length with a transition of --seconds (0.5 to 4) generated by the "
                          "manifold or crossfaded: a's frames up to its last --seconds, the transition, then b's "
                          "frames after its first --seconds, written at 25 Hz; the transition's frames on stderr"));
  command->footer(kMotionInputNote);  // once per command, in its own --help
  o->model.add_to(command, true);
  command->add_option("--a", o->a.path, "the first clip, read whole from --start-a (.txt, .bvh, .glb, .gltf, .fbx)")
      ->required();
  command->add_option("--b", o->b.path, "the second clip, read whole from --start-b")->required();
  add_rate(command, {&o->a, &o->b});
  command->add_option("--start-a", o->a.start, "first frame of clip a, in its file's own frames (rows)");
  command->add_option("--start-b", o->b.start, "first frame of clip b, in its file's own frames (rows)");
  command->add_option("--seconds", o->seconds, "the transition's length, 0.5 to 4 s")->capture_default_str();
  command->add_option("--method", o->method, "generated or crossfade")->capture_default_str();
  command->add_option("--out", o->out, "joined motion file (.txt or .bvh, 25 Hz; - for standard output)");
  command->callback([o, &settings, &action] {
    action = [o, &settings] {
      require_output(settings, o->out, "--out");
      const auto server = connect(settings.connection);
      ModelRigs rigs(*server);
      v1::JoinClipsRequest request;
      *request.mutable_a() = read_whole_motion(o->a, rigs, o->model.model);
      *request.mutable_b() = read_whole_motion(o->b, rigs, o->model.model);
      request.set_model(rigs.pinned(o->model.model));
      request.set_decoder(o->model.decoder);
      request.set_transition_seconds(o->seconds);
      request.set_method(o->method);
      const auto reply = server->join_clips(request);
      if (!o->out.empty()) {
        write_motion(reply.motion(), o->out, rigs, reply.answered_by().model());
        if (o->out != "-" && !settings.json) std::printf("%s\n", o->out.c_str());
      }
      if (settings.json) {
        print_json(to_json(reply));
      } else {
        std::fprintf(stderr, "joined: %d frames at 25 Hz, the transition frames %d to %d (%s)\n",
                     reply.motion().frames(), reply.transition_first_frame(), reply.transition_last_frame(),
                     o->method.c_str());
      }
      return kExitSuccess;
    };
  });
}

}  // namespace

void add_inference_commands(CLI::App& app, const ClientSettings& settings, Action& action) {
  add_encode(app, settings, action);
  add_decode(app, settings, action);
  add_sample(app, settings, action);
  add_interpolate(app, settings, action);
  add_analogy(app, settings, action);
  add_denoise(app, settings, action);
  add_join(app, settings, action);
}

}  // namespace mm::client
