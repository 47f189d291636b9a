// Take files on the client's side: a take read whole from a motion file
// (exponential-map text of the model's layout at --rate, or BVH of the
// model's skeleton at the file's own frame time, never resampled here: the
// server resamples on rotations), a take's reply written as it arrives, and
// code track files (JSON, as POST /v1/takes:encode answers). Torch-free.
#pragma once

#include <cstdio>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "client/cli/model_rig.h"
#include "client/cli/server_connection.h"
#include "format/skeleton.h"

namespace mm::client {

// A take file and, for text, its rate (Hz; a BVH states its own).
struct TakeSource {
  std::string path;
  double rate = 50;  // the H3.6M files'
};

// Reads `source` as a take of `model` ("" the active one; its rig asked of
// `rigs`): the header names the model whose rig read it, the take's rate
// and columns; the file's bytes are kept for REST. With `missing_allowed`
// (denoise) text may hold `nan` for a missing joint value. Throws
// InputError naming the file (unreadable, malformed, a BVH of another
// skeleton, a rate outside 10 to 1000 Hz); ServerError when the model
// cannot be described.
TakeUpload read_take(const TakeSource& source, ModelRigs& rigs, const std::string& model, bool missing_allowed);

// A take's reply written as it arrives: text is streamed to a temporary
// file beside `path` (renamed over it by finish(), so no half-written file
// is ever seen; "-" streams to standard output), BVH of `skeleton` is
// written whole by finish() at the reply's rate. With a non-empty
// `error_csv`, each frame's error goes there ("frame,seconds,error_mm").
// With `whole_file_allowed` (no error CSV, no --json) a REST reply may be
// the file itself, as the server writes it for Accept: BVH or text.
// Not thread safe; used by one thread at a time.
class TakeFileWriter : public TakeReplySink {
 public:
  // `skeleton` is needed (and must outlive the writer) for a .bvh path.
  TakeFileWriter(std::string path, std::string error_csv, const Skeleton* skeleton, bool whole_file_allowed);
  ~TakeFileWriter() override;

  void header(const v1::TakeOutputHeader& header) override;
  void chunk(const v1::FrameChunk& chunk) override;
  std::string whole_file_type() const override;
  void whole_file(const std::string& bytes, int64_t frames, double frame_rate, int64_t windows) override;
  // Completes the files. Throws InputError or std::runtime_error when they
  // cannot be written.
  void finish();

  int64_t frames() const { return frames_; }
  double frame_rate() const { return header_.frame_rate(); }
  // Windows the server said it used, for a whole file; -1 otherwise.
  int64_t windows() const { return windows_; }
  // Called with each chunk's frame count as it arrives (the progress line).
  std::function<void(int64_t)> on_frames;

 private:
  std::string path_, error_csv_, temporary_;
  const Skeleton* skeleton_;
  bool bvh_ = false;
  bool whole_file_allowed_ = false, whole_ = false;
  int64_t windows_ = -1;
  v1::TakeOutputHeader header_;
  std::ofstream text_;
  MotionFrames held_;  // BVH: the frames until finish()
  std::vector<float> errors_;
  int64_t frames_ = 0;
};

// Checks before any call that `path` names a take's output (.txt, .bvh or
// "-"), so a mistyped extension fails before the server does the work.
void check_take_output(const std::string& path, const std::string& option);

// Writes a code track (to_json(CodeTrack)) to `path` ("-": standard output).
void write_code_track(const v1::CodeTrack& track, const std::string& path);

// Reads a code track file (as write_code_track writes it, or REST's reply
// to POST /v1/takes:encode) into a DecodeTrackRequest's windows. Throws
// InputError naming the file and the field at fault.
void read_code_track(const std::string& path, v1::DecodeTrackRequest& request);

// Whether `path` names an animation file: BVH, glTF (.glb, .gltf) or FBX
// (.fbx), which takes hold in the model's rig (format/animation_file.h).
bool is_animation_path(const std::string& path);

}  // namespace mm::client
