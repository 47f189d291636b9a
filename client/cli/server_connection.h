// A connection to a motion-manifold-server: one method per rpc of
// proto/motionmanifold/v1/manifold.proto, taking and returning the proto's
// messages whatever the protocol, so that the commands are written once.
// Implementations: gRPC (grpc_connection.cpp) and REST (rest_connection.cpp).
// Every method returns the reply on success and throws ServerError on a
// refusal or a broken connection. Not thread safe: one per thread.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "client/cli/connection_options.h"
#include "format/motion_frames.h"
#include "format/take_operation.h"
#include "motionmanifold/v1/manifold.pb.h"

namespace mm::client {

namespace v1 = motionmanifold::v1;

// A take to send (take_io.h reads one): what to do with it, its frames in the
// model's layout for gRPC, and the file itself for REST's body, which the
// server reads as the client did (text at header.frame_rate, or BVH at its
// own Frame Time).
struct TakeUpload {
  v1::TakeHeader header;
  MotionFrames frames;
  std::string file_bytes;
  bool bvh = false;
};

// Where a take's reply goes as it arrives: its header once, then its frames
// chunk by chunk (each with its frames' errors, empty for DecodeTrack).
class TakeReplySink {
 public:
  virtual ~TakeReplySink() = default;
  virtual void header(const v1::TakeOutputHeader& header) = 0;
  virtual void chunk(const v1::FrameChunk& chunk) = 0;

  // REST only: the media type of a file this sink takes whole, as the
  // server writes it for that Accept ("application/x-bvh", "text/plain"),
  // instead of frames; empty: frames (the JSON reply, with each frame's
  // error and every window's code).
  virtual std::string whole_file_type() const { return ""; }
  // That file, with the frames and rate the server gave beside it.
  virtual void whole_file(const std::string& bytes, int64_t frames, double frame_rate, int64_t windows) {
    (void)bytes, (void)frames, (void)frame_rate, (void)windows;
  }
};

class ServerConnection {
 public:
  virtual ~ServerConnection() = default;

  virtual v1::EncodeReply encode(const v1::EncodeRequest& request) = 0;
  virtual v1::MotionsReply decode(const v1::DecodeRequest& request) = 0;
  virtual v1::MotionsReply sample(const v1::SampleRequest& request) = 0;
  virtual v1::MotionsReply interpolate(const v1::InterpolateRequest& request) = 0;
  virtual v1::MotionsReply analogy(const v1::AnalogyRequest& request) = 0;
  virtual v1::MotionsReply denoise(const v1::DenoiseRequest& request) = 0;
  virtual v1::JoinClipsReply join_clips(const v1::JoinClipsRequest& request) = 0;

  virtual v1::ListModelsReply list_models() = 0;
  // Empty name: the active model.
  virtual v1::ModelInfo describe_model(const std::string& name) = 0;
  virtual v1::ModelInfo activate_model(const std::string& name) = 0;
  virtual v1::ModelInfo delete_model(const std::string& name) = 0;  // the model as it was

  virtual v1::ListClipsReply list_clips() = 0;
  virtual v1::ReadClipReply read_clip(const v1::ReadClipRequest& request) = 0;
  virtual v1::ClipFile upload_clip(const v1::UploadClipRequest& request) = 0;
  virtual v1::ClipFile delete_clip(const std::string& path) = 0;  // the file as it was listed

  virtual v1::Job submit_job(const v1::JobSpec& spec) = 0;
  virtual v1::Job get_job(const std::string& id) = 0;
  virtual v1::ListJobsReply list_jobs() = 0;
  virtual v1::Job cancel_job(const std::string& id) = 0;
  virtual v1::Job delete_job(const std::string& id) = 0;  // the record as it was
  // Calls `on_record` with the job's record now and after every change, and
  // returns when a record in a final state has been passed on. Throws
  // ServerError when refused, and with code UNAVAILABLE when the stream ends
  // before the job does (the server stopped): the caller may watch again.
  virtual void watch_job(const std::string& id, const std::function<void(const v1::Job&)>& on_record) = 0;

  // Takes. Frames go to the server in chunks of at most kTakeChunkFrames
  // (gRPC) or as the file's body (REST); the reply's frames are passed to
  // `sink` as they arrive and its summary (every window's code included) is
  // returned. No deadline: a take may be an hour long.
  virtual v1::CodeTrack encode_take(const TakeUpload& take) = 0;
  // operation: kReconstruct or kDenoise (encode_take answers a code track).
  virtual v1::TakeSummary transform_take(TakeOperation operation, const TakeUpload& take, TakeReplySink& sink) = 0;
  virtual v1::TakeSummary decode_track(const v1::DecodeTrackRequest& request, TakeReplySink& sink) = 0;
};

// Frames a chunk of a take's request stream: 2048 x 99 floats is 0.8 MB,
// well under gRPC's 4 MB message limit.
constexpr int kTakeChunkFrames = 2048;

// The connection `options` ask for (REST with options.rest, else gRPC).
// Throws InputError when a local file it needs (the CA) cannot be read.
std::unique_ptr<ServerConnection> connect(const ConnectionOptions& options);

std::unique_ptr<ServerConnection> grpc_connection(const ConnectionOptions& options);
std::unique_ptr<ServerConnection> rest_connection(const ConnectionOptions& options);

// Whether a job state is final ("succeeded", "failed", "cancelled").
bool is_final_state(const std::string& state);

}  // namespace mm::client
