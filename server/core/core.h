// The core as the frontends see it: every operation of the service once, in
// plain C++ types (gRPC and REST translate to and from these calls and
// nothing else). ManifoldCore (engine/manifold_core.h, the LibTorch side) is the
// one the server runs; the frontends' own tests run against a fake one
// (tests/server/fake_core.h), so they build without LibTorch.
//
// Torch-free header. Thread safety: every method may be called concurrently.
// Errors are thrown as ApiError (api/api_types.h), whose code and field the
// frontends map to their status.
#pragma once

#include <atomic>
#include <functional>
#include <string>
#include <vector>

#include "server/api/api_types.h"
#include "server/core/motion_conversion.h"
#include "server/core/take_session.h"
#include "server/core/watch_streams.h"

namespace mm::service {

// A frontend's translation that depends on the model answering a call: REST
// reads application/x-bvh bodies and writes BVH replies in that model's
// skeleton (rest/bvh_translation.h). An operation given one resolves its
// model once, inside its call, and hands that model's shape to `read` right
// after (before it checks the request) and to `write` once the reply is
// complete. So the model a request is read for is the model that answers it,
// whatever is activated meanwhile, and what they throw is the call's error:
// refused while draining, counted in the metrics, mapped as the call's
// (an InputError becomes INVALID_ARGUMENT). Either may be empty. `read` fills
// in a copy of the request (its motions); the model it names is already
// chosen, so changing request.model changes nothing.
template <typename Request, typename Reply>
struct ShapedTranslation {
  std::function<void(Request& request, const ModelShape& shape)> read;
  std::function<void(const Reply& reply, const ModelShape& shape)> write;
};

// The same for a take: `read` returns the take's frames read for the model's
// shape (REST: a body of motion text in its columns or BVH of its skeleton)
// and may set request.frame_rate (a BVH body's own).
struct TakeTranslation {
  std::function<TakeChunkReader(TakeRequest& request, const ModelShape& shape)> read;
  std::function<void(const TakeSummaryReply& reply, const ModelShape& shape)> write;
};

class Core {
 public:
  virtual ~Core() = default;

  virtual bool ready() const = 0;  // a model is loaded and the core accepts calls

  // Each may be given a ShapedTranslation (above): the frontend's reading of
  // the request and writing of the reply for the model that answers.
  virtual EncodeReply encode(const CallContext& ctx, const EncodeRequest& request,
                             const ShapedTranslation<EncodeRequest, EncodeReply>& translation = {}) = 0;
  virtual MotionsReply decode(const CallContext& ctx, const DecodeRequest& request,
                              const ShapedTranslation<DecodeRequest, MotionsReply>& translation = {}) = 0;
  virtual MotionsReply sample(const CallContext& ctx, const SampleRequest& request,
                              const ShapedTranslation<SampleRequest, MotionsReply>& translation = {}) = 0;
  virtual MotionsReply interpolate(const CallContext& ctx, const InterpolateRequest& request,
                                   const ShapedTranslation<InterpolateRequest, MotionsReply>& translation = {}) = 0;
  virtual MotionsReply analogy(const CallContext& ctx, const AnalogyRequest& request,
                               const ShapedTranslation<AnalogyRequest, MotionsReply>& translation = {}) = 0;
  virtual MotionsReply denoise(const CallContext& ctx, const DenoiseRequest& request,
                               const ShapedTranslation<DenoiseRequest, MotionsReply>& translation = {}) = 0;
  // Clips a and b joined by a transition (model/clip_transition.h). Checked
  // before any work: decoder, transition_seconds (0.5 to 4), method, then
  // each clip as Encode checks a motion but of any length, from the
  // transition and 1 s more to --max-take-seconds (RESOURCE_EXHAUSTED,
  // 413, above), and the two joined making one clip of the model. The
  // generated transition's code fit (15 decoder passes forward and back on
  // one window, whatever the clips' length) runs on the inference executor.
  virtual JoinClipsReply join_clips(const CallContext& ctx, const JoinClipsRequest& request,
                                    const ShapedTranslation<JoinClipsRequest, JoinClipsReply>& translation = {}) = 0;

  // Takes (core/take_session.h): the take's frames come from `read`, or
  // from the data-root file request.path (which needs the clip-read
  // access); the reply goes to `sink` as it becomes final. The same access
  // as Encode. At most --max-take-streams run at once, beyond that
  // RESOURCE_EXHAUSTED (429) naming it; a take longer than
  // --max-take-seconds is refused (413) as its frames arrive. The call is in
  // flight (the server's drain waits for it) until it returns. With
  // translation.read the take's frames are those it reads for the model
  // that answers (a REST body), not `read`'s.
  virtual TakeSummaryReply run_take(const CallContext& ctx, TakeKind kind, const TakeRequest& request,
                                    const TakeChunkReader& read, const TakeReplySink& sink,
                                    const TakeTranslation& translation = {}) = 0;
  // A code track decoded into one motion, streamed to `sink` as run_take's.
  virtual TakeSummaryReply decode_track(
      const CallContext& ctx, const DecodeTrackRequest& request, const TakeReplySink& sink,
      const ShapedTranslation<DecodeTrackRequest, TakeSummaryReply>& translation = {}) = 0;

  virtual std::vector<ModelInfo> list_models(const CallContext& ctx) = 0;
  virtual ModelInfo describe_model(const CallContext& ctx, const std::string& name) = 0;
  // Loads `name` if needed and makes it the active model; requests in flight
  // finish on the model they started with. Needs the token.
  virtual ModelInfo activate_model(const CallContext& ctx, const std::string& name) = 0;
  // Takes model `name` out of the store (engine/model_store.h: its folder is
  // removed, calls in flight finish on it) and returns it as it was.
  // FAILED_PRECONDITION "model" for the active model and for the one the
  // server activates at start (--default-model), which it could not start
  // without. Needs the token.
  virtual ModelInfo delete_model(const CallContext& ctx, const std::string& name) = 0;

  // The motion files of the data root (core/data_root_clips.h), and one
  // window of one in the shape of model request.model ("" for the active
  // one). Need the token (or loopback) unless --public-clips.
  // FAILED_PRECONDITION without --data-root.
  virtual ListClipsReply list_clips(const CallContext& ctx) = 0;
  virtual ReadClipReply read_clip(const CallContext& ctx, const ReadClipRequest& request) = 0;
  // Writes a new motion file under the data root (a user's own mocap, to
  // train on; core/data_root_clips.h). Needs the token.
  virtual ClipFile upload_clip(const CallContext& ctx, const UploadClipRequest& request) = 0;
  // Removes a file UploadClip wrote (core/data_root_clips.h: only uploads
  // may be deleted) and returns it as it was listed. Needs the token.
  virtual ClipFile delete_clip(const CallContext& ctx, const std::string& path) = 0;

  // Needs the token. The queue is bounded per caller too
  // (--max-queued-jobs-per-caller): per token when the server has one (with
  // its one token, every caller holding it together), per IP address without.
  virtual JobInfo submit_job(const CallContext& ctx, const JobSpec& spec) = 0;
  virtual JobInfo get_job(const CallContext& ctx, const std::string& id) = 0;
  virtual std::vector<JobInfo> list_jobs(const CallContext& ctx) = 0;
  virtual JobInfo cancel_job(const CallContext& ctx, const std::string& id) = 0;  // needs the token
  // Removes a finished job's record and its folder (TrainingJobs::remove);
  // returns the record as it was. Needs the token.
  virtual JobInfo delete_job(const CallContext& ctx, const std::string& id) = 0;
  // A watch of job `id`, admitted before its stream begins (so that REST
  // answers a refusal instead of its 200): ApiError as get_job gives, or
  // RESOURCE_EXHAUSTED (429) naming --max-watch-streams or
  // --max-watch-streams-per-client when the open streams fill a cap
  // (core/watch_streams.h). The caller holds the slot until watch_job takes it.
  virtual WatchStreams::Slot begin_watch(const CallContext& ctx, const std::string& id) = 0;
  // Streams job `id` as TrainingJobs::watch does, holding `slot` (from
  // begin_watch) and giving it back when it returns. A watch lasts as long as
  // the job and does not hold the server's drain up.
  virtual void watch_job(WatchStreams::Slot slot, const std::string& id,
                         const std::function<bool(const JobInfo&)>& on_event, const std::atomic<bool>* stop) = 0;
};

}  // namespace mm::service
