// The core as the frontends see it: every operation of the service once, in
// plain C++ types (gRPC and REST translate to and from these calls and
// nothing else). ManifoldCore (engine/manifold_core.h, the LibTorch side) is the
// one the server runs; the frontends' own tests run against a fake one
// (tests/server/fake_core.h), so they build without LibTorch. The core
// never reads or writes a frontend's formats: a frontend whose body or reply
// depends on the model that answers chooses that model first (ChosenModel,
// below), reads the body for it, runs the operation on it and writes the
// reply for it, each step its own.
//
// Torch-free header. Thread safety: every method may be called concurrently.
// Errors are thrown as ApiError (api/api_types.h), whose code and field the
// frontends map to their status.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "server/api/api_types.h"
#include "server/core/motion_conversion.h"
#include "server/core/take_session.h"
#include "server/core/watch_streams.h"

namespace mm::service {

// The model one call runs on, chosen before the call's body is read
// (Core::choose_model), for a frontend whose body or reply depends on it:
// REST reads an application/x-bvh body and writes a BVH reply in that
// model's skeleton, a take's motion text in its columns. The frontend reads
// what it needs (model(), shape()) and hands the handle to the operation,
// which runs on exactly the model held here, whatever is activated meanwhile.
//
// The handle is the call begun: choose_model admitted it (its refusals
// counted as the operation's), the call is in flight until the handle goes
// (the server's drain waits for it, the reply's writing included), and its
// outcome is counted once: by the operation it is given to, or by
// Core::refuse_body when the frontend cannot read the body for its shape.
// A handle let go with neither (the frontend failed otherwise) ends its call
// counted as INTERNAL. One handle, one call: it cannot be copied, and an
// operation given one whose call has ended refuses it (INTERNAL). Not
// synchronised: one thread uses a handle at a time.
//
// A default-constructed handle holds no model: an operation given it
// resolves its request's `model` itself (gRPC, and REST's JSON calls).
class ChosenModel {
 public:
  // What the core keeps for the call (the model loaded, the call's
  // admission); opaque to the frontends.
  class Hold {
   public:
    virtual ~Hold() = default;
  };

  ChosenModel() = default;
  ChosenModel(AnsweredBy model, ModelShape shape, std::shared_ptr<Hold> hold)
      : model_(std::move(model)), shape_(std::move(shape)), hold_(std::move(hold)) {}
  ChosenModel(ChosenModel&&) = default;
  ChosenModel& operator=(ChosenModel&&) = default;
  ChosenModel(const ChosenModel&) = delete;
  ChosenModel& operator=(const ChosenModel&) = delete;

  explicit operator bool() const { return hold_ != nullptr; }
  const AnsweredBy& model() const { return model_; }  // its name and version, as the reply's answered_by
  const ModelShape& shape() const { return shape_; }  // what a body is read and a reply written for
  Hold* hold() const { return hold_.get(); }          // for the core that chose it

 private:
  AnsweredBy model_;
  ModelShape shape_;
  std::shared_ptr<Hold> hold_;
};

class Core {
 public:
  virtual ~Core() = default;

  virtual bool ready() const = 0;  // a model is loaded and the core accepts calls

  // Begins a call of `operation` on model `name` ("" for the active one)
  // for a frontend that must know the model before it reads the call's body
  // or writes its reply (ChosenModel, above). `operation` is the name the
  // metrics count the call by, one of "encode", "decode", "sample",
  // "interpolate", "analogy", "denoise", "join_clips", "encode_take",
  // "reconstruct_take", "denoise_take" (take_call_name) and "decode_track";
  // the handle must then be given to that operation. Refused as the
  // operation would be, before any body is read, and counted as its call:
  // UNAVAILABLE while the server is not accepting calls (drain), for a take
  // RESOURCE_EXHAUSTED when --max-take-streams are running, NOT_FOUND for an
  // unknown model, FAILED_PRECONDITION for one that cannot be loaded.
  virtual ChosenModel choose_model(const CallContext& ctx, const std::string& operation,
                                   const std::string& name) = 0;
  // Ends the call of `chosen` with `error`, the frontend's refusal of a body
  // it could not read for the chosen model's shape (INVALID_ARGUMENT naming
  // the body's line): counted as the call's outcome, as an operation's
  // refusal is. The frontend then answers `error`; `chosen` runs no
  // operation after. Nothing is counted for a call that has ended already.
  virtual void refuse_body(const ChosenModel& chosen, const ApiError& error) = 0;

  // Each runs on `chosen`'s model when given one (choose_model, for the same
  // operation; the request's `model` is then not read), otherwise on the
  // model its request names.
  virtual EncodeReply encode(const CallContext& ctx, const EncodeRequest& request,
                             const ChosenModel& chosen = {}) = 0;
  virtual MotionsReply decode(const CallContext& ctx, const DecodeRequest& request,
                              const ChosenModel& chosen = {}) = 0;
  virtual MotionsReply sample(const CallContext& ctx, const SampleRequest& request,
                              const ChosenModel& chosen = {}) = 0;
  virtual MotionsReply interpolate(const CallContext& ctx, const InterpolateRequest& request,
                                   const ChosenModel& chosen = {}) = 0;
  virtual MotionsReply analogy(const CallContext& ctx, const AnalogyRequest& request,
                               const ChosenModel& chosen = {}) = 0;
  virtual MotionsReply denoise(const CallContext& ctx, const DenoiseRequest& request,
                               const ChosenModel& chosen = {}) = 0;
  // Clips a and b joined by a transition (model/clip_transition.h). Checked
  // before any work: decoder, transition_seconds (0.5 to 4), method, then
  // each clip as Encode checks a motion but of any length, from the
  // transition and 1 s more to --max-take-seconds (RESOURCE_EXHAUSTED,
  // 413, above), and the two joined making one clip of the model. The
  // generated transition's code fit (15 decoder passes forward and back on
  // one window, whatever the clips' length) runs on the inference executor.
  virtual JoinClipsReply join_clips(const CallContext& ctx, const JoinClipsRequest& request,
                                    const ChosenModel& chosen = {}) = 0;

  // Takes (core/take_session.h): the take's frames come from `read` (gRPC's
  // stream, or a REST body the frontend read for `chosen`'s model), or from
  // the data-root file request.path (which needs the clip-read access); the
  // reply goes to `sink` as it becomes final. The same access as Encode. At
  // most --max-take-streams run at once, beyond that RESOURCE_EXHAUSTED
  // (429) naming it (a chosen model's call holds its place from
  // choose_model); a take longer than --max-take-seconds is refused (413) as
  // its frames arrive. The call is in flight (the server's drain waits for
  // it) until it returns.
  virtual TakeSummary run_take(const CallContext& ctx, TakeOperation operation, const TakeRequest& request,
                               const TakeChunkReader& read, const TakeReplySink& sink,
                               const ChosenModel& chosen = {}) = 0;
  // A code track decoded into one motion, streamed to `sink` as run_take's.
  virtual TakeSummary decode_track(const CallContext& ctx, const DecodeTrackRequest& request,
                                   const TakeReplySink& sink, const ChosenModel& chosen = {}) = 0;

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
