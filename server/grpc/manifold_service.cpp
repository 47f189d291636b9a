#include "server/grpc/manifold_service.h"

#include <cctype>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>

#include "server/core/caller_identity.h"
#include "server/grpc/error_status.h"
#include "server/translation/proto_translation.h"

namespace mm::service::grpc_frontend {

using proto_translation::to_api;
using proto_translation::to_wire;

namespace {

// Runs one call of the core and turns what it throws into the rpc's status:
// the core's refusals by the error model, anything else as INTERNAL (a bug,
// or the machine failing, never the caller's fault).
template <typename Call>
grpc::Status answer(grpc::ServerContext* context, Call&& call) {
  try {
    call(call_context(*context));
    return grpc::Status::OK;
  } catch (const ApiError& error) {
    return error_status(error, context);
  } catch (const std::exception& error) {
    return grpc::Status(grpc::StatusCode::INTERNAL, error.what());
  }
}

// How often a WatchJob stream looks whether its client has gone or the
// server is stopping: short enough that neither waits noticeably.
constexpr auto kWatchPollInterval = std::chrono::milliseconds(50);

}  // namespace

CallContext call_context(const grpc::ServerContext& context) {
  std::vector<std::string> authorization;
  const auto range = context.client_metadata().equal_range("authorization");
  for (auto it = range.first; it != range.second; ++it) authorization.emplace_back(it->second.data(), it->second.size());
  const BearerCredentials credentials = parse_authorization(authorization);
  return CallContext{"grpc", credentials.token, credentials.problem, canonical_ip(ip_of_grpc_peer(context.peer()))};
}

grpc::Status ManifoldService::Encode(grpc::ServerContext* context, const v1::EncodeRequest* request,
                                     v1::EncodeReply* reply) {
  return answer(context, [&](const CallContext& ctx) { to_wire(core_.encode(ctx, to_api(*request)), reply); });
}

grpc::Status ManifoldService::Decode(grpc::ServerContext* context, const v1::DecodeRequest* request,
                                     v1::MotionsReply* reply) {
  return answer(context, [&](const CallContext& ctx) { to_wire(core_.decode(ctx, to_api(*request)), reply); });
}

grpc::Status ManifoldService::Sample(grpc::ServerContext* context, const v1::SampleRequest* request,
                                     v1::MotionsReply* reply) {
  return answer(context, [&](const CallContext& ctx) { to_wire(core_.sample(ctx, to_api(*request)), reply); });
}

grpc::Status ManifoldService::Interpolate(grpc::ServerContext* context, const v1::InterpolateRequest* request,
                                          v1::MotionsReply* reply) {
  return answer(context, [&](const CallContext& ctx) { to_wire(core_.interpolate(ctx, to_api(*request)), reply); });
}

grpc::Status ManifoldService::Analogy(grpc::ServerContext* context, const v1::AnalogyRequest* request,
                                      v1::MotionsReply* reply) {
  return answer(context, [&](const CallContext& ctx) { to_wire(core_.analogy(ctx, to_api(*request)), reply); });
}

grpc::Status ManifoldService::Denoise(grpc::ServerContext* context, const v1::DenoiseRequest* request,
                                      v1::MotionsReply* reply) {
  return answer(context, [&](const CallContext& ctx) { to_wire(core_.denoise(ctx, to_api(*request)), reply); });
}

grpc::Status ManifoldService::JoinClips(grpc::ServerContext* context, const v1::JoinClipsRequest* request,
                                        v1::JoinClipsReply* reply) {
  return answer(context, [&](const CallContext& ctx) { to_wire(core_.join_clips(ctx, to_api(*request)), reply); });
}

grpc::Status ManifoldService::ListModels(grpc::ServerContext* context, const v1::ListModelsRequest*,
                                         v1::ListModelsReply* reply) {
  return answer(context, [&](const CallContext& ctx) {
    for (const auto& info : core_.list_models(ctx)) to_wire(info, reply->add_models());
  });
}

grpc::Status ManifoldService::DescribeModel(grpc::ServerContext* context, const v1::DescribeModelRequest* request,
                                            v1::ModelInfo* reply) {
  return answer(context,
                [&](const CallContext& ctx) { to_wire(core_.describe_model(ctx, request->model()), reply); });
}

grpc::Status ManifoldService::ActivateModel(grpc::ServerContext* context, const v1::ActivateModelRequest* request,
                                            v1::ModelInfo* reply) {
  return answer(context,
                [&](const CallContext& ctx) { to_wire(core_.activate_model(ctx, request->model()), reply); });
}

grpc::Status ManifoldService::DeleteModel(grpc::ServerContext* context, const v1::DeleteModelRequest* request,
                                          v1::ModelInfo* reply) {
  return answer(context, [&](const CallContext& ctx) { to_wire(core_.delete_model(ctx, request->model()), reply); });
}

grpc::Status ManifoldService::ListClips(grpc::ServerContext* context, const v1::ListClipsRequest*,
                                        v1::ListClipsReply* reply) {
  return answer(context, [&](const CallContext& ctx) { to_wire(core_.list_clips(ctx), reply); });
}

grpc::Status ManifoldService::ReadClip(grpc::ServerContext* context, const v1::ReadClipRequest* request,
                                       v1::ReadClipReply* reply) {
  return answer(context, [&](const CallContext& ctx) { to_wire(core_.read_clip(ctx, to_api(*request)), reply); });
}

grpc::Status ManifoldService::UploadClip(grpc::ServerContext* context, const v1::UploadClipRequest* request,
                                         v1::ClipFile* reply) {
  return answer(context, [&](const CallContext& ctx) { to_wire(core_.upload_clip(ctx, to_api(*request)), reply); });
}

grpc::Status ManifoldService::DeleteClip(grpc::ServerContext* context, const v1::DeleteClipRequest* request,
                                         v1::ClipFile* reply) {
  return answer(context, [&](const CallContext& ctx) { to_wire(core_.delete_clip(ctx, request->path()), reply); });
}

grpc::Status ManifoldService::SubmitJob(grpc::ServerContext* context, const v1::SubmitJobRequest* request,
                                        v1::Job* reply) {
  return answer(context,
                [&](const CallContext& ctx) { to_wire(core_.submit_job(ctx, to_api(request->spec())), reply); });
}

grpc::Status ManifoldService::GetJob(grpc::ServerContext* context, const v1::GetJobRequest* request,
                                     v1::Job* reply) {
  return answer(context, [&](const CallContext& ctx) { to_wire(core_.get_job(ctx, request->id()), reply); });
}

grpc::Status ManifoldService::ListJobs(grpc::ServerContext* context, const v1::ListJobsRequest*,
                                       v1::ListJobsReply* reply) {
  return answer(context, [&](const CallContext& ctx) {
    for (const auto& info : core_.list_jobs(ctx)) to_wire(info, reply->add_jobs());
  });
}

grpc::Status ManifoldService::CancelJob(grpc::ServerContext* context, const v1::CancelJobRequest* request,
                                        v1::Job* reply) {
  return answer(context, [&](const CallContext& ctx) { to_wire(core_.cancel_job(ctx, request->id()), reply); });
}

grpc::Status ManifoldService::DeleteJob(grpc::ServerContext* context, const v1::DeleteJobRequest* request,
                                        v1::Job* reply) {
  return answer(context, [&](const CallContext& ctx) { to_wire(core_.delete_job(ctx, request->id()), reply); });
}

grpc::Status ManifoldService::WatchJob(grpc::ServerContext* context, const v1::WatchJobRequest* request,
                                       grpc::ServerWriter<v1::Job>* writer) {
  // Admitted (or refused, naming the cap) before anything is started for it:
  // a refused stream gives its thread back at once.
  WatchStreams::Slot slot;
  const auto admitted =
      answer(context, [&](const CallContext& ctx) { slot = core_.begin_watch(ctx, request->id()); });
  if (!admitted.ok()) return admitted;
  // The core's watch blocks until the job changes; a monitor turns "the
  // client has gone" (IsCancelled is thread-safe in the synchronous API) and
  // "the server is stopping" into its stop flag.
  std::atomic<bool> stop{false};
  std::mutex mutex;
  std::condition_variable wake;
  bool watch_done = false;
  std::thread monitor([&] {
    std::unique_lock<std::mutex> lock(mutex);
    while (!watch_done) {
      if (context->IsCancelled() || stopping_.load()) {
        stop = true;
        return;
      }
      wake.wait_for(lock, kWatchPollInterval);
    }
  });
  struct JoinMonitor {
    std::mutex& mutex;
    std::condition_variable& wake;
    bool& watch_done;
    std::thread& monitor;
    ~JoinMonitor() {
      {
        std::lock_guard<std::mutex> lock(mutex);
        watch_done = true;
      }
      wake.notify_all();
      monitor.join();
    }
  } join_monitor{mutex, wake, watch_done, monitor};

  bool finished = false;  // the last record written carried a terminal state
  const auto status = answer(context, [&](const CallContext&) {
    core_.watch_job(
        std::move(slot), request->id(),
        [&](const JobInfo& info) {
          finished = is_terminal(info.state);
          v1::Job job;
          to_wire(info, &job);
          return writer->Write(job);  // false: the client has gone
        },
        &stop);
  });
  if (!status.ok() || finished) return status;
  if (context->IsCancelled()) return grpc::Status::CANCELLED;
  if (stopping_.load()) {
    return grpc::Status(grpc::StatusCode::UNAVAILABLE, "the server is shutting down: watch the job again");
  }
  return grpc::Status::OK;
}

}  // namespace mm::service::grpc_frontend
