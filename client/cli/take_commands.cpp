// take encode | reconstruct | denoise, track decode: motions of any length
// and rate. A take file is read whole and streamed to the server in chunks
// (gRPC) or sent as the file (REST); the reply is written as it arrives
// (take_io.h).
#include <CLI/CLI.hpp>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>

#include "client/cli/commands.h"
#include "client/cli/frame_rate_text.h"
#include "client/cli/server_connection.h"
#include "client/cli/server_error.h"
#include "client/cli/take_io.h"
#include "client/cli/take_progress.h"
#include "format/input_error.h"
#include "wire/rest_json.h"

namespace mm::client {

// --json prints a reply as REST answers it, written by the same code.
using ::mm::wire::to_json;
namespace {

// The request fields a take command's options set, by the option's name:
// a refusal naming a field is shown naming the option the user typed.
const std::map<std::string, std::string> kTakeOptionOfField = {
    {"hop_seconds", "--hop"}, {"frame_rate", "--rate"}, {"frames", "--frames"},     {"decoder", "--decoder"},
    {"blend", "--blend"},     {"root", "--root"},       {"model", "--model"},       {"iterations", "--iterations"},
    {"at_model_rate", "--at-model-rate"}, {"gap_fill", "--gap-fill"}};

// Runs a command's body; a server's refusal that names a request field an
// option sets is re-thrown naming that option instead.
int naming_options(const std::function<int()>& body) {
  try {
    return body();
  } catch (const ServerError& error) {
    const auto option = kTakeOptionOfField.find(error.field());
    if (option == kTakeOptionOfField.end()) throw;
    throw ServerError(error.code(), option->second, error.message());
  }
}

// The options of every take command.
struct TakeOptions {
  TakeSource input;
  std::string model, decoder, blend, out, error_csv, root;
  double hop_seconds = 0;  // 0: the server's 3 s
  bool at_model_rate = false;
  // denoise
  bool zeros_are_missing = false, means_are_missing = false, keep_observed = false;
  int iterations = 0;
  std::string gap_fill;  // empty: the server's default, "borrowed"

  void add_to(CLI::App* command, bool transforms) {
    command->add_option("--input,--in", input.path, "take file: .txt (exponential-map text of the model's layout) or "
                                                    ".bvh (the model's skeleton, at its own frame time)")
        ->required();
    command->add_option("--rate", input.rate, "frame rate of a .txt take in Hz, 10 to 1000 (a BVH states its own)")
        ->check(CLI::Range(10.0, 1000.0))
        ->capture_default_str();
    command->add_option("--model", model, "model of the server's store (default: the active one)");
    command->add_option("--hop", hop_seconds, "seconds between window starts, 0.04 to 6 (default: 3)");
    if (!transforms) return;
    command->add_option("--decoder", decoder, "rotation or velocity (default: the model's)");
    command->add_option("--blend", blend, "how overlapping windows join: crossfade (default) or cut");
    command->add_flag("--at-model-rate", at_model_rate, "reply at the model's 25 Hz instead of the take's rate");
    command->add_option("--error-csv", error_csv, "also write each frame's error: frame,seconds,error_mm");
    command->add_option("--root", root,
                        "the reply's root path: input (the take's own, default) or generated (the model's trajectory "
                        "network, feet on the floor)");
  }

  void set_header(v1::TakeHeader& header) const {
    header.set_hop_seconds(hop_seconds);
    header.set_decoder(decoder);
    header.set_blend(blend);
    header.set_at_model_rate(at_model_rate);
    header.set_zeros_are_missing(zeros_are_missing);
    header.set_means_are_missing(means_are_missing);
    header.set_iterations(iterations);
    header.set_keep_observed(keep_observed);
    header.set_gap_fill(gap_fill);
    header.set_root(root);
  }
};

// What a take's reply was, on stdout: a line, or with --json the reply
// without its frames (the REST reply's other fields). `gap_counts`: a
// denoise keeping the observed values, whose line also says how its gaps
// were filled.
void report(const ClientSettings& settings, const std::string& out, const TakeFileWriter& written,
            const v1::TakeSummary& summary, bool gap_counts = false) {
  if (settings.json) {
    auto reply = to_json(summary);
    reply["frame_rate"] = shown_frame_rate(written.frame_rate());
    reply["frames"] = written.frames();
    print_json(reply);
  } else if (out != "-") {
    std::printf("%s: %" PRId64 " frames at %g Hz from %" PRId64 " input frames, %d windows, error mean %.2f mm, "
                "max %.2f mm%s\n",
                out.c_str(), written.frames(), shown_frame_rate(written.frame_rate()),
                static_cast<int64_t>(summary.input_frames()),
                static_cast<int>(written.windows() >= 0 ? written.windows() : summary.windows_size()),
                summary.mean_error_mm(), summary.max_error_mm(), gap_counts ? "," : "");
    if (gap_counts) {
      std::printf("  gaps: %d fitted in %d windows, %d over the server's fit limit (filled as matched)\n",
                  summary.gaps_fitted(), summary.gap_windows_fitted(), summary.gaps_over_fit_limit());
    }
  }
}

void add_take_encode(CLI::App* take, const ClientSettings& settings, Action& action) {
  auto o = std::make_shared<TakeOptions>();
  auto* command = take->add_subcommand(
      "encode", "The code track of a take: one code per 6 s window every --hop seconds, written as JSON (the REST "
                "reply's shape) for track decode");
  o->add_to(command, false);
  command->add_option("--out", o->out, "code track file (.json; - for standard output)")->required();
  command->callback([o, &settings, &action] {
    action = [o, &settings] { return naming_options([&] {
      const auto server = connect(settings.connection);
      ModelRigs rigs(*server);
      TakeUpload take = read_take(o->input, rigs, o->model, false);
      o->set_header(take.header);
      TakeProgress progress(stderr, TakeProgress::stderr_is_terminal(), "take encode " + o->input.path, 0);
      v1::CodeTrack track = server->encode_take(take);
      progress.finish();
      track.set_frame_rate(shown_frame_rate(track.frame_rate()));
      write_code_track(track, o->out);
      if (o->out != "-" && !settings.json) {
        std::printf("%s: %d windows of %g s every %g s over %" PRId64 " frames at %g Hz\n", o->out.c_str(),
                    track.windows_size(), track.window_seconds(), track.hop_seconds(),
                    static_cast<int64_t>(track.frames()), track.frame_rate());
      }
      if (settings.json && o->out != "-") print_json(to_json(track));
      return kExitSuccess;
    }); };
  });
}

void add_take_transform(CLI::App* take, const ClientSettings& settings, Action& action, TakeOperation operation) {
  const bool denoise = operation == TakeOperation::kDenoise;
  auto o = std::make_shared<TakeOptions>();
  auto* command = take->add_subcommand(
      take_operation_name(operation),
      denoise ? "A take projected onto the manifold window by window (Sec. 5.4) and joined again, at its rate and "
                "length; nan in a .txt take is a missing value, filled"
              : "A take encoded and decoded window by window and joined again, at its rate and length with its root "
                "translation, and each frame's error");
  o->add_to(command, true);
  command->add_option("--out", o->out, "the result (.txt, .bvh at the reply's rate; - for standard output)")->required();
  if (denoise) {
    command->add_flag("--zeros-are-missing", o->zeros_are_missing, "a joint-angle value of exactly 0 is missing");
    command->add_flag("--means-are-missing", o->means_are_missing, "a value equal to its training mean is missing");
    command->add_option("--iterations", o->iterations, "rounds of projecting and refilling (0: four)");
    command->add_flag("--keep-observed", o->keep_observed, "fill only the missing values");
    command->add_option("--gap-fill", o->gap_fill,
                        "with --keep-observed, how a gap is filled: borrowed (default: the take's own stretch most "
                        "like the gap's surroundings where one is like enough, of the whole body or else of the legs "
                        "and the upper body apart, else fitted), fitted (a code fitted to "
                        "a 6 s window around each gap of 0.6 s or more), matched, cubic, slerp, hold or manifold");
  }
  command->callback([o, operation, denoise, &settings, &action] {
    action = [o, operation, denoise, &settings] { return naming_options([&] {
      check_take_output(o->out, "--out");
      const auto server = connect(settings.connection);
      ModelRigs rigs(*server);
      TakeUpload take = read_take(o->input, rigs, o->model, denoise);
      o->set_header(take.header);
      TakeFileWriter writer(o->out, o->error_csv, &rigs.of(o->model).skeleton, !settings.json);
      // The reply has the take's frames, or as many at 25 Hz.
      const int64_t input_frames = take.frames.frame_count();
      const int64_t expected =
          o->at_model_rate ? static_cast<int64_t>(std::llround(input_frames * 25.0 / take.header.frame_rate()))
                           : input_frames;
      TakeProgress progress(stderr, TakeProgress::stderr_is_terminal(),
                            std::string("take ") + (denoise ? "denoise " : "reconstruct ") + o->input.path, expected);
      writer.on_frames = [&progress](int64_t frames) { progress.add(frames); };
      const v1::TakeSummary summary = server->transform_take(operation, take, writer);
      progress.finish();
      writer.finish();
      report(settings, o->out, writer, summary, denoise && o->keep_observed);
      return kExitSuccess;
    }); };
  });
}

void add_track_decode(CLI::App* track, const ClientSettings& settings, Action& action) {
  struct Options {
    std::string in, out, model, decoder, blend;
    double rate = 25;
    int64_t frames = 0;
  };
  auto o = std::make_shared<Options>();
  auto* command = track->add_subcommand(
      "decode", "A code track (as take encode writes it, edited or not) decoded into one continuous motion");
  command->add_option("--input,--in", o->in, "code track file (.json, as take encode writes it)")->required();
  command->add_option("--rate", o->rate, "frame rate of the motion, 10 to 1000 Hz")
      ->check(CLI::Range(10.0, 1000.0))
      ->capture_default_str();
  command->add_option("--frames", o->frames, "frames of the motion (default: the track's length at --rate)")
      ->check(CLI::NonNegativeNumber);
  command->add_option("--model", o->model, "model of the server's store (default: the active one)");
  command->add_option("--decoder", o->decoder, "rotation or velocity (default: the model's)");
  command->add_option("--blend", o->blend, "how overlapping windows join: crossfade (default) or cut");
  command->add_option("--out", o->out, "the motion (.txt, .bvh; - for standard output)")->required();
  command->callback([o, &settings, &action] {
    action = [o, &settings] { return naming_options([&] {
      check_take_output(o->out, "--out");
      v1::DecodeTrackRequest request;
      read_code_track(o->in, request);
      request.set_frame_rate(o->rate);
      request.set_frames(o->frames);
      request.set_decoder(o->decoder);
      request.set_blend(o->blend);
      const auto server = connect(settings.connection);
      ModelRigs rigs(*server);
      // The rig (for a BVH) of the model that will answer, asked first.
      const Skeleton* skeleton = is_animation_path(o->out) ? &rigs.of(o->model).skeleton : nullptr;
      request.set_model(rigs.pinned(o->model));
      TakeFileWriter writer(o->out, "", skeleton, !settings.json);
      TakeProgress progress(stderr, TakeProgress::stderr_is_terminal(), "track decode " + o->in, o->frames);
      writer.on_frames = [&progress](int64_t frames) { progress.add(frames); };
      const v1::TakeSummary summary = server->decode_track(request, writer);
      progress.finish();
      writer.finish();
      if (settings.json) {
        report(settings, o->out, writer, summary);
      } else if (o->out != "-") {
        std::printf("%s: %" PRId64 " frames at %g Hz from %d windows\n", o->out.c_str(), writer.frames(),
                    shown_frame_rate(writer.frame_rate()), request.windows_size());
      }
      return kExitSuccess;
    }); };
  });
}

}  // namespace

void add_take_commands(CLI::App& app, const ClientSettings& settings, Action& action) {
  auto* take = app.add_subcommand("take", "Motions of any length and rate: encode into a code track, reconstruct, "
                                          "denoise; streamed in chunks over gRPC, or the file over REST");
  take->require_subcommand(1);
  add_take_encode(take, settings, action);
  add_take_transform(take, settings, action, TakeOperation::kReconstruct);
  add_take_transform(take, settings, action, TakeOperation::kDenoise);
  auto* track = app.add_subcommand("track", "Code tracks: decode one into a motion");
  track->require_subcommand(1);
  add_track_decode(track, settings, action);
}

}  // namespace mm::client
