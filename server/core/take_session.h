// Takes in the core: motions of any length and frame rate (model/
// take_processor.h) encoded into a code track, reconstructed or denoised,
// and code tracks decoded, for both frontends in plain types.
//
// One streaming shape serves both protocols: the frontend hands the core a
// TakeChunkReader that yields the take's frames chunk by chunk (gRPC: the
// messages of the client's stream as they arrive; REST: the parsed body) and
// a TakeReplySink that takes the reply as it becomes final (gRPC writes it
// on, REST gathers it). The core holds at most a batch of windows, never the
// take (ManifoldCore::run_take). The operation ends with the model's
// TakeSummary (format/take_summary.h), passed on as the model gave it.
//
// Torch-free and wire-free: the frontends include it.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "format/animation_file.h"
#include "format/motion_frames.h"
#include "format/skeleton.h"
#include "format/take_operation.h"
#include "format/take_summary.h"
#include "server/api/api_types.h"

namespace mm::service {

// The name a take operation's calls are counted and logged under:
// "encode_take", "reconstruct_take", "denoise_take" (metrics).
const char* take_call_name(TakeOperation operation);

// The server's bounds on takes (server options of the same names).
struct TakeLimits {
  double max_seconds = 7200;  // --max-take-seconds: the longest take, and DecodeTrack's reply
  int max_streams = 4;        // --max-take-streams: take operations running at once, server-wide
  // --max-take-gap-fits: windows a DenoiseTake with keep_observed and the
  // fitted fill fits to its gaps (each about 15 decoder passes forward and
  // back); the gaps of later windows get the matched fill (0: no limit).
  int max_gap_fits = 20;
};

// What a take operation is asked to do (the wire's TakeHeader).
struct TakeRequest {
  std::string model;        // empty: the active model
  double frame_rate = 0;    // Hz of the frames, 10 to 1000
  int columns = 0;          // values a frame; 0: the model's
  std::string layout;       // empty: the model's
  std::string decoder;      // "rotation", "velocity", empty: the model's default
  double hop_seconds = 0;   // 0: 3
  std::string blend;        // "crossfade" (empty) or "cut"
  bool at_model_rate = false;
  // Denoise only, as DenoiseRequest's.
  bool zeros_are_missing = false;
  bool means_are_missing = false;
  int iterations = 0;  // 0: four
  bool keep_observed = false;
  // With keep_observed, how a gap is filled (model/gap_interpolation.h):
  // "borrowed" (empty means this), "fitted", "matched", "cubic", "slerp",
  // "hold" or "manifold".
  std::string gap_fill;
  // Reconstruct and denoise: the reply's root path, "input" (empty) or
  // "generated" (the model's trajectory network).
  std::string root;
  // A file under the data root as the take instead of the reader's frames:
  // motion text at frame_rate (0: 50 Hz, the H3.6M files') or BVH at its own
  // Frame Time. Needs the clip-read access.
  std::string path;
};

// Consecutive frames of a take, row-major.
struct TakeChunk {
  int64_t frames = 0;
  std::vector<float> values;
};
// Fills `chunk` with the take's next frames and returns true, or returns
// false at the take's end. May throw ApiError (the stream broke off).
using TakeChunkReader = std::function<bool(TakeChunk& chunk)>;

// One window's code: its start in seconds (a multiple of 0.04 s) and as a
// frame of the take at the take's own rate (rounded).
struct TakeWindow {
  double start_seconds = 0;
  int64_t start_frame = 0;
  Code code;
};

// What the reply's frames are, known before the first of them.
struct TakeReplyStart {
  AnsweredBy answered_by;
  double frame_rate = 0;
  int columns = 0;
  std::string layout;
  int64_t input_frames = 0;  // 0 for DecodeTrack and while a stream's frames still arrive
};

// Where the reply goes, in order: start once (before anything else), then
// windows and frames as they are final (frames: `count` x columns values and
// `count` errors in mm, none for DecodeTrack). A callback may throw to stop
// the operation (the client has gone).
struct TakeReplySink {
  std::function<void(const TakeReplyStart& start)> on_start;
  std::function<void(const TakeWindow& window)> on_window;
  std::function<void(const float* values, const float* error_mm, int64_t count)> on_frames;
};

struct DecodeTrackRequest {
  std::string model;
  std::vector<TakeWindow> windows;  // start_frame is not read
  double frame_rate = 0;            // 0: 25
  int64_t frames = 0;               // 0: the track's length
  std::string decoder;
  std::string blend;
};

// A take sent whole (a REST body, a data-root file), parsed: motion text of
// `columns` values a line at `frame_rate`, `nan` accepted in joint columns
// when `allow_nan` (denoise); or BVH of `skeleton` at its own Frame Time.
// INVALID_ARGUMENT naming `field` ("body", "path") with the parser's message.
struct TakeFile {
  MotionFrames frames;
  double frame_rate = 0;
};
TakeFile take_from_text(const std::string& data, const std::string& source, const std::string& field, int columns,
                        double frame_rate, bool allow_nan);
// BVH, or glTF or FBX by `format` (format/animation_file.h), in the unit of
// the skeleton's rig.
TakeFile take_from_bvh(const std::string& data, const std::string& source, const std::string& field,
                       const Skeleton& skeleton, AnimationFormat format = AnimationFormat::kBvh);
// A reader handing out `take`'s frames in chunks of at most `chunk_frames`.
TakeChunkReader take_file_reader(std::shared_ptr<const TakeFile> take, int64_t chunk_frames = 2048);

}  // namespace mm::service
