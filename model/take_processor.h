// Takes: motions of any length and frame rate through the manifold.
//
// A TakeProcessor takes a take's frames as they arrive (a file read in
// chunks, a gRPC stream), resamples them to the model's 25 Hz
// (format/motion_resampling.h), cuts them into windows of the model's clip
// (take_windows.h: 6 s every hop, the last aligned to the take's end), runs
// the windows through the model in batches, and
// - encode: hands out each window's code with its start time (a code track);
// - reconstruct: decodes every window, joins them (take_assembly.h,
//   crossfaded on rotations), brings the result back to the take's rate and
//   length, carries the root translation over from the input (as Denoise
//   does: the model does not learn it) and gives each frame's error;
// - denoise: the same with each window projected onto the manifold
//   (Sec. 5.4, project_onto_manifold): values given as NaN (a joint missing
//   for some frames), and those DenoiseOptions names, are missing and filled
//   from the manifold; keep_observed returns the observed values as given.
//
// Memory: the processor holds the frames of the windows in one batch and the
// input frames not yet answered (about batch x hop seconds), not the take,
// so a take of an hour costs what a take of ten minutes does.
//
// decode_code_track() is the way back: a code track, edited or not, decoded
// into one continuous motion at any rate.
//
// Thread safety: a TakeProcessor is used by one thread at a time; several
// may run on one model at once (the model's inference is const). Every
// tensor operation runs inside the TorchRunner given, so the server runs
// them on its inference executor. Bad input throws InputError naming what is
// wrong (the take frame and column of a bad value, the field of a bad
// option) before the work it would cost is done; after an exception the
// processor is not used again.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "format/motion_frames.h"
#include "format/take_operation.h"
#include "format/take_summary.h"
#include "model/gap_code_fit.h"
#include "model/gap_interpolation.h"
#include "model/latent_operations.h"
#include "model/motion_manifold.h"
#include "model/take_assembly.h"
#include "model/take_windows.h"

namespace mm {

// Where a take's output root path comes from: the input's (the default:
// a reconstruction of a recorded take keeps where it went), or the model's
// trajectory network (root_trajectory.h) from the output's poses, with the
// floor followed under the last 2 s of frames (StreamingFloor: the take is
// not held whole).
enum class TakeRoot { kInput, kGenerated };
const char* take_root_name(TakeRoot root);  // "input" / "generated"
// InputError naming `field`, the value and the two names otherwise.
TakeRoot parse_take_root(const std::string& name, const std::string& field = "root");

struct TakeOptions {
  TakeOperation operation = TakeOperation::kReconstruct;
  double frame_rate = kTakeModelRate;  // Hz of the input frames, 10 to 1000 ("frame_rate")
  double hop_seconds = kDefaultHopSeconds;
  TakeBlend blend = TakeBlend::kCrossfade;
  bool at_model_rate = false;  // output at 25 Hz instead of the take's rate and length
  DecoderKind decoder = DecoderKind::kRotation;
  // Reconstruct and denoise: the output's root path. kGenerated needs a
  // model with a trajectory network (InputError naming "root" otherwise).
  TakeRoot root = TakeRoot::kInput;
  // Denoise only. NaN values are always missing there; these say what else
  // is (zeros, means: tested per value at the input's rate, where a value
  // is still exact, and then missing as a NaN is), how many rounds fill the
  // gaps, and whether the observed values are returned as given
  // (keep_observed needs neither zeros nor means: NaN are missing anyway).
  DenoiseOptions denoise;
  // Denoise with keep_observed: how each joint's gap (a run of frames where
  // it is NaN) is filled, at the output's rate (gap_interpolation.h). The
  // default, kBorrowed, lays the movement of the take's own stretch most
  // like a gap's surroundings over the cubic where one is like enough
  // (borrowed_motion.h; its frames wait for the 10 s after the gap), a
  // stretch of the whole body or else of the legs and the upper body apart
  // (gap_fill.borrow.parts is the model's skeleton's body_parts(), whatever
  // it is given), and is kFitted elsewhere. kFitted meets the observed
  // frames at both borders: the cubic
  // across the gap for short gaps and between lone keyframes (no window is
  // fitted for those), and for gaps of gap_fit.min_seconds or more the
  // movement of a code fitted to the observed values of a window centred on
  // the gap (gap_code_fit.h) laid over it; kMatched lays the
  // movement of the take's own windows instead, and is what gaps beyond
  // gap_fit.max_windows get; kManifold is the manifold's output as it is.
  // The frames of a gap are handed out once the frame after it has arrived
  // (take_gap_filler.h), and with kFitted once its window is fitted, at most
  // half a window after the gap (take_gap_fitter.h).
  GapFillOptions gap_fill;
  GapCodeFitOptions gap_fit;
  int batch_windows = 32;  // windows run through the model at once
  // The longest take accepted, seconds (0: no limit), and the name a refusal
  // gives that limit (e.g. "--max-take-seconds").
  double max_seconds = 0;
  std::string max_seconds_name = "the longest take";
};

// One window of a take and its code.
struct TakeWindowCode {
  int64_t start_frame = 0;   // 25 Hz frame of the window's start
  double start_seconds = 0;  // start_frame / 25
  std::vector<float> code;   // latent floats
};

// Where a processor's results go, in order, as soon as they are final.
struct TakeSink {
  // Each window's code (every operation).
  std::function<void(const TakeWindowCode& window)> on_window;
  // Output frames (reconstruct, denoise) at the output rate, in the model's
  // input columns, with each frame's error in mm: the mean over the
  // skeleton's joints of the distance between the output's and the input's
  // forward-kinematics positions (the input's missing values taken from the
  // output, so only observed rotations count).
  std::function<void(const MotionFrames& frames, const std::vector<float>& error_mm)> on_frames;
};

// Runs the tensor work it is given (a batch of windows, forward kinematics)
// and returns when it is done; empty: on the calling thread.
using TorchRunner = std::function<void(const std::function<void()>& work)>;

class TakeProcessor {
 public:
  // `model` outlives the processor. InputError naming the option for a bad
  // rate, hop, or denoise options; for a decoder the model lacks.
  TakeProcessor(const MotionManifold& model, TakeOptions options, TakeSink sink, TorchRunner run = {});
  ~TakeProcessor();
  TakeProcessor(const TakeProcessor&) = delete;
  TakeProcessor& operator=(const TakeProcessor&) = delete;

  // Columns of an input frame: the model's (99 for H3.6M).
  int columns() const;

  // `frames` more input frames, row-major. InputError naming the take frame
  // and column for a value that is not finite (NaN is taken as missing by
  // denoise, in joint columns only: the root translation is carried over and
  // cannot be missing), or beyond motion_text.h's bounds; and once the take
  // passes max_seconds, naming it.
  void push(const float* values, int64_t frames);
  // Ends the take: runs the windows left, hands out the rest, and returns the
  // summary (format/take_summary.h), which the server passes on as it is.
  // InputError naming the minimum when the take is shorter than one window
  // (take_window_starts).
  TakeSummary finish();

  // The most frames the processor held at once so far: input frames not yet
  // answered, the 25 Hz frames of windows not yet run, the windows of the
  // batch being run, the assembled frames not yet final, and the reply being
  // handed out. It depends on the batch, the hop and the rate, not on the
  // take's length.
  int64_t held_frames_peak() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// A whole take in memory through a processor: the codes and, for
// reconstruct and denoise, the output frames and their errors.
struct TakeResult {
  TakeSummary summary;
  std::vector<TakeWindowCode> windows;
  MotionFrames frames;
  std::vector<float> error_mm;
};
TakeResult process_take(const MotionManifold& model, const MotionFrames& take, const TakeOptions& options,
                        TorchRunner run = {});

struct CodeTrackDecoding {
  double frame_rate = kTakeModelRate;  // of the output, 10 to 1000 Hz ("frame_rate")
  // Output frames; -1 or 0: the track's length (last start + window) at
  // that rate. More frames than that hold the last pose; fewer end early.
  int64_t frames = -1;
  TakeBlend blend = TakeBlend::kCrossfade;
  DecoderKind decoder = DecoderKind::kRotation;
  int batch_windows = 32;
  double max_seconds = 0;  // as TakeOptions
  std::string max_seconds_name = "the longest take";
};

// Decodes a code track (windows in order of start, as encode gives them;
// only start_seconds and code are read) into one continuous motion: every
// code decoded to a window at its start (rounded to a 25 Hz frame), the
// windows joined as a take's are, brought to the output rate. The root
// travels as the model's trajectory network says (root_trajectory.h), in
// world layout, the floor followed under the last 2 s of frames; a model
// without one leaves it in place. Results go to sink.on_frames with an
// empty error. InputError naming "windows[i].start_seconds" (the
// first must be 0, each at or after the previous, none leaving a frame
// uncovered), "windows[i].code" (latent finite floats), "frame_rate" or
// "frames", or the length limit, before anything is decoded.
TakeSummary decode_code_track(const MotionManifold& model, const std::vector<TakeWindowCode>& track,
                              const CodeTrackDecoding& options, const TakeSink& sink, TorchRunner run = {});

}  // namespace mm
