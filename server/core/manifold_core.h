// The core of the service: every operation once, in plain C++ types, for both
// frontends (gRPC and REST translate to and from these calls and nothing
// else). It holds the model store, runs all inference on one executor that
// batches concurrent requests, records the metrics, lets in calls that
// change state (the token, or loopback without one), and hands training jobs to TrainingJobs.
//
// Torch-free header: the frontends include it without LibTorch.
// Thread safety: every method may be called concurrently.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "server/api/api_types.h"
#include "server/core/data_root_clips.h"
#include "server/core/model_precisions.h"
#include "server/core/motion_conversion.h"
#include "server/core/take_session.h"
#include "server/core/watch_streams.h"

namespace mm::service {

class ServiceMetrics;
class TrainingJobs;

// Request limits: each refusal names the limit (RESOURCE_EXHAUSTED, 413).
struct Limits {
  int max_motions = 64;       // motions of one Encode or Denoise; codes of one Decode
  int max_sample_count = 64;  // Sample's count
  int max_steps = 64;         // Interpolate's steps
  int max_denoise_iterations = 32;
};

// The inference executor's dynamic batching (as Triton's dynamic batcher):
// requests of the same model, operation and decoder are run as one batch of
// at most max_batch clips. A batch waits up to max_queue_delay_us for more
// requests only while more clients have been calling lately than it holds (a
// lone client never waits). The default is long because on two cores the 31
// clients a batch of 32 has just answered take 20 to 60 ms to call again
// (their replies are serialised on the same cores); with 20 ms, 32 clients
// got 44 clips/s in alternating half batches, with 60 ms 64 clips/s in full
// ones (docs/PERFORMANCE.md). More than max_queue_length waiting requests are
// refused (429).
struct BatchingConfig {
  int max_batch = 32;
  int max_queue_delay_us = 60000;
  int max_queue_length = 256;
  int threads = 0;  // LibTorch intra-op threads of the executor; 0: chosen by timing (core/thread_count_tuner.h)
};

struct CoreConfig {
  std::string model_store;    // folder of model folders
  std::string default_model;  // name in the store; empty: the first of h36m-dkgm-h100 or the only model
  // Calls that change state (and clip reads) need this token; empty: they
  // are taken only from loopback.
  std::string auth_token;
  bool public_clips = false;  // ListClips and ReadClip open to every caller
  // The folder of motion files ListClips and ReadClip serve (--data-root, the
  // folder training datasets lie under); empty: none.
  std::string data_root;
  int max_listed_clips = 10000;  // ListClips lists the first ones by path and says it truncated
  DataRootQuota data_root_quota;  // what uploads may add to the data root
  // The training jobs' store (--job-store): a PostgreSQL one makes the
  // replicas sharing it one deployment, with one active model and one quota
  // of the data root (core/shared_deployment.h); "" or SQLite: one server.
  std::string job_store;
  int max_loaded_models = 4;  // models kept in memory, the active one included
  ModelPrecisions precisions;  // the number format of each model's inference weights
  Limits limits;
  BatchingConfig batching;
  WatchStreamLimits watch_streams;  // open job watch streams, both protocols together
  TakeLimits takes;  // take operations (core/take_session.h)
  size_t max_take_bytes = size_t{512} << 20;  // a take read whole: a REST body, a data-root file
};

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

class ManifoldCore {
 public:
  // `metrics` and `jobs` outlive the core; `jobs` may be null (no training).
  ManifoldCore(CoreConfig config, ServiceMetrics& metrics, TrainingJobs* jobs);
  ~ManifoldCore();
  ManifoldCore(const ManifoldCore&) = delete;
  ManifoldCore& operator=(const ManifoldCore&) = delete;

  // Loads the default model and starts the executor. Throws ApiError when
  // the default cannot be loaded (the server does not start without one).
  void start();
  bool ready() const;  // a model is loaded and the core accepts calls

  // Each may be given a ShapedTranslation (above): the frontend's reading of
  // the request and writing of the reply for the model that answers.
  EncodeReply encode(const CallContext& ctx, const EncodeRequest& request,
                     const ShapedTranslation<EncodeRequest, EncodeReply>& translation = {});
  MotionsReply decode(const CallContext& ctx, const DecodeRequest& request,
                      const ShapedTranslation<DecodeRequest, MotionsReply>& translation = {});
  MotionsReply sample(const CallContext& ctx, const SampleRequest& request,
                      const ShapedTranslation<SampleRequest, MotionsReply>& translation = {});
  MotionsReply interpolate(const CallContext& ctx, const InterpolateRequest& request,
                           const ShapedTranslation<InterpolateRequest, MotionsReply>& translation = {});
  MotionsReply analogy(const CallContext& ctx, const AnalogyRequest& request,
                       const ShapedTranslation<AnalogyRequest, MotionsReply>& translation = {});
  MotionsReply denoise(const CallContext& ctx, const DenoiseRequest& request,
                       const ShapedTranslation<DenoiseRequest, MotionsReply>& translation = {});
  // Clips a and b joined by a transition (model/clip_transition.h). Checked
  // before any work: decoder, transition_seconds (0.5 to 4), method, then
  // each clip as Encode checks a motion but of any length, from the
  // transition and 1 s more to --max-take-seconds (RESOURCE_EXHAUSTED,
  // 413, above), and the two joined making one clip of the model. The
  // generated transition's code fit (15 decoder passes forward and back on
  // one window, whatever the clips' length) runs on the inference executor.
  JoinClipsReply join_clips(const CallContext& ctx, const JoinClipsRequest& request,
                            const ShapedTranslation<JoinClipsRequest, JoinClipsReply>& translation = {});

  // Takes (core/take_session.h): the take's frames come from `read`, or
  // from the data-root file request.path (which needs the clip-read
  // access); the reply goes to `sink` as it becomes final. The same access
  // as Encode. At most --max-take-streams run at once, beyond that
  // RESOURCE_EXHAUSTED (429) naming it; a take longer than
  // --max-take-seconds is refused (413) as its frames arrive. The call is in
  // flight (drain() waits for it) until it returns. With
  // translation.read the take's frames are those it reads for the model
  // that answers (a REST body), not `read`'s.
  TakeSummaryReply run_take(const CallContext& ctx, TakeKind kind, const TakeRequest& request,
                            const TakeChunkReader& read, const TakeReplySink& sink,
                            const TakeTranslation& translation = {});
  // A code track decoded into one motion, streamed to `sink` as run_take's.
  TakeSummaryReply decode_track(const CallContext& ctx, const DecodeTrackRequest& request,
                                const TakeReplySink& sink,
                                const ShapedTranslation<DecodeTrackRequest, TakeSummaryReply>& translation = {});

  std::vector<ModelInfo> list_models(const CallContext& ctx);
  ModelInfo describe_model(const CallContext& ctx, const std::string& name);
  // Loads `name` if needed and makes it the active model; requests in flight
  // finish on the model they started with. Needs the token.
  ModelInfo activate_model(const CallContext& ctx, const std::string& name);
  // Takes model `name` out of the store (core/model_store.h: its folder is
  // removed, calls in flight finish on it) and returns it as it was.
  // FAILED_PRECONDITION "model" for the active model and for the one the
  // server activates at start (--default-model), which it could not start
  // without. Needs the token.
  ModelInfo delete_model(const CallContext& ctx, const std::string& name);

  // The motion files of the data root (core/data_root_clips.h), and one
  // window of one in the shape of model request.model ("" for the active
  // one). Need the token (or loopback) unless --public-clips.
  // FAILED_PRECONDITION without --data-root.
  ListClipsReply list_clips(const CallContext& ctx);
  ReadClipReply read_clip(const CallContext& ctx, const ReadClipRequest& request);
  // Writes a new motion file under the data root (a user's own mocap, to
  // train on; core/data_root_clips.h). Needs the token.
  ClipFile upload_clip(const CallContext& ctx, const UploadClipRequest& request);
  // Removes a file UploadClip wrote (core/data_root_clips.h: only uploads
  // may be deleted) and returns it as it was listed. Needs the token.
  ClipFile delete_clip(const CallContext& ctx, const std::string& path);

  // Needs the token. The queue is bounded per caller too
  // (--max-queued-jobs-per-caller): per token when the server has one (with
  // its one token, every caller holding it together), per IP address without.
  JobInfo submit_job(const CallContext& ctx, const JobSpec& spec);
  JobInfo get_job(const CallContext& ctx, const std::string& id);
  std::vector<JobInfo> list_jobs(const CallContext& ctx);
  JobInfo cancel_job(const CallContext& ctx, const std::string& id);  // needs the token
  // Removes a finished job's record and its folder (TrainingJobs::remove);
  // returns the record as it was. Needs the token.
  JobInfo delete_job(const CallContext& ctx, const std::string& id);
  // A watch of job `id`, admitted before its stream begins (so that REST
  // answers a refusal instead of its 200): ApiError as get_job gives, or
  // RESOURCE_EXHAUSTED (429) naming --max-watch-streams or
  // --max-watch-streams-per-client when the open streams fill a cap
  // (core/watch_streams.h). The caller holds the slot until watch_job takes it.
  WatchStreams::Slot begin_watch(const CallContext& ctx, const std::string& id);
  // Streams job `id` as TrainingJobs::watch does, holding `slot` (from
  // begin_watch) and giving it back when it returns. A watch lasts as long as
  // the job and does not hold drain() up.
  void watch_job(WatchStreams::Slot slot, const std::string& id, const std::function<bool(const JobInfo&)>& on_event,
                 const std::atomic<bool>* stop);

  // Stops accepting calls (UNAVAILABLE) and waits for those in flight.
  void drain();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace mm::service
