// The core of the service on LibTorch: the implementation of core/core.h's
// Core that the server (main.cpp) builds and hands to both frontends, which
// see only Core.
//
// Torch-free header (only its .cpp includes LibTorch).
// Thread safety: every method may be called concurrently.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "server/api/api_types.h"
#include "server/core/core.h"
#include "server/core/core_config.h"
#include "server/core/data_root_clips.h"
#include "server/core/motion_conversion.h"
#include "server/core/take_session.h"
#include "server/core/watch_streams.h"

namespace mm::service {

class ServiceMetrics;
class TrainingJobs;

// The core the server runs (core/core.h's Core, whose comments give each
// operation's contract): it holds the model store, runs all inference on one
// executor that batches concurrent requests, records the metrics, lets in
// calls that change state (the token, or loopback without one), and hands
// training jobs to TrainingJobs.
class ManifoldCore final : public Core {
 public:
  // `metrics` and `jobs` outlive the core; `jobs` may be null (no training).
  ManifoldCore(CoreConfig config, ServiceMetrics& metrics, TrainingJobs* jobs);
  ~ManifoldCore() override;
  ManifoldCore(const ManifoldCore&) = delete;
  ManifoldCore& operator=(const ManifoldCore&) = delete;

  // Loads the default model and starts the executor. Throws ApiError when
  // the default cannot be loaded (the server does not start without one).
  void start();
  bool ready() const override;

  ChosenModel choose_model(const CallContext& ctx, const std::string& operation, const std::string& name) override;
  void refuse_body(const ChosenModel& chosen, const ApiError& error) override;

  // The default arguments are Core's, repeated for callers holding a
  // ManifoldCore (the core's own tests).
  EncodeReply encode(const CallContext& ctx, const EncodeRequest& request, const ChosenModel& chosen = {}) override;
  MotionsReply decode(const CallContext& ctx, const DecodeRequest& request, const ChosenModel& chosen = {}) override;
  MotionsReply sample(const CallContext& ctx, const SampleRequest& request, const ChosenModel& chosen = {}) override;
  MotionsReply interpolate(const CallContext& ctx, const InterpolateRequest& request,
                           const ChosenModel& chosen = {}) override;
  MotionsReply analogy(const CallContext& ctx, const AnalogyRequest& request, const ChosenModel& chosen = {}) override;
  MotionsReply denoise(const CallContext& ctx, const DenoiseRequest& request, const ChosenModel& chosen = {}) override;
  JoinClipsReply join_clips(const CallContext& ctx, const JoinClipsRequest& request,
                            const ChosenModel& chosen = {}) override;

  TakeSummary run_take(const CallContext& ctx, TakeOperation operation, const TakeRequest& request,
                       const TakeChunkReader& read, const TakeReplySink& sink,
                       const ChosenModel& chosen = {}) override;
  TakeSummary decode_track(const CallContext& ctx, const DecodeTrackRequest& request,
                           const TakeReplySink& sink, const ChosenModel& chosen = {}) override;

  std::vector<ModelInfo> list_models(const CallContext& ctx) override;
  ModelInfo describe_model(const CallContext& ctx, const std::string& name) override;
  ModelInfo activate_model(const CallContext& ctx, const std::string& name) override;
  ModelInfo delete_model(const CallContext& ctx, const std::string& name) override;

  ListClipsReply list_clips(const CallContext& ctx) override;
  ReadClipReply read_clip(const CallContext& ctx, const ReadClipRequest& request) override;
  ClipFile upload_clip(const CallContext& ctx, const UploadClipRequest& request) override;
  ClipFile delete_clip(const CallContext& ctx, const std::string& path) override;

  JobInfo submit_job(const CallContext& ctx, const JobSpec& spec) override;
  JobInfo get_job(const CallContext& ctx, const std::string& id) override;
  std::vector<JobInfo> list_jobs(const CallContext& ctx) override;
  JobInfo cancel_job(const CallContext& ctx, const std::string& id) override;
  JobInfo delete_job(const CallContext& ctx, const std::string& id) override;
  WatchStreams::Slot begin_watch(const CallContext& ctx, const std::string& id) override;
  void watch_job(WatchStreams::Slot slot, const std::string& id, const std::function<bool(const JobInfo&)>& on_event,
                 const std::atomic<bool>* stop) override;

  // Stops accepting calls (UNAVAILABLE) and waits for those in flight.
  void drain();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace mm::service
