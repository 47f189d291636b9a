// The rpc handlers of motionmanifold.v1.MotionManifold: each translates its
// request to the core API's types, calls the one Core method with
// the call_context() below, and translates the reply or the refusal
// (error_status.h) back. No validation of its own: the core validates, once
// for both protocols.
//
// Thread safety: the handlers run concurrently on gRPC's synchronous thread
// pool; the service holds no state of its own beyond the core's reference,
// the stopping flag and the take streams' message deadlines.
#pragma once

#include <atomic>
#include <chrono>

#include "motionmanifold/v1/manifold.grpc.pb.h"
#include "server/core/core.h"
#include "server/grpc/stream_message_deadlines.h"

namespace mm::service::grpc_frontend {

namespace v1 = ::motionmanifold::v1;

// The caller as the core sees it: its authorization metadata parsed
// (core/caller_identity.h) and its IP address.
CallContext call_context(const grpc::ServerContext& context);

class ManifoldService final : public v1::MotionManifold::Service {
 public:
  // `core` and `stopping` outlive the service. While `stopping` is true,
  // WatchJob streams end with UNAVAILABLE (the client watches again after
  // the restart) so that a shutdown never waits on a job that trains for an
  // hour. A take stream's next message (the header, each chunk, each reply
  // message the client must take) may keep its call waiting for at most
  // `take_message_timeout` (0: for ever), after which the call ends with
  // DEADLINE_EXCEEDED naming --grpc-take-message-timeout-seconds. The
  // service must outlive every call (gRPC's server shut down and waited for).
  ManifoldService(Core& core, const std::atomic<bool>& stopping,
                  std::chrono::milliseconds take_message_timeout)
      : core_(core), stopping_(stopping), take_deadlines_(take_message_timeout, "--grpc-take-message-timeout-seconds") {}

  grpc::Status Encode(grpc::ServerContext* context, const v1::EncodeRequest* request, v1::EncodeReply* reply) override;
  grpc::Status Decode(grpc::ServerContext* context, const v1::DecodeRequest* request,
                      v1::MotionsReply* reply) override;
  grpc::Status Sample(grpc::ServerContext* context, const v1::SampleRequest* request,
                      v1::MotionsReply* reply) override;
  grpc::Status Interpolate(grpc::ServerContext* context, const v1::InterpolateRequest* request,
                           v1::MotionsReply* reply) override;
  grpc::Status Analogy(grpc::ServerContext* context, const v1::AnalogyRequest* request,
                       v1::MotionsReply* reply) override;
  grpc::Status Denoise(grpc::ServerContext* context, const v1::DenoiseRequest* request,
                       v1::MotionsReply* reply) override;
  grpc::Status JoinClips(grpc::ServerContext* context, const v1::JoinClipsRequest* request,
                         v1::JoinClipsReply* reply) override;

  // Takes (grpc/take_rpcs.cpp): the client's stream read as the take
  // arrives, the reply written as it becomes final.
  grpc::Status EncodeTake(grpc::ServerContext* context, grpc::ServerReader<v1::TakeInput>* reader,
                          v1::CodeTrack* reply) override;
  grpc::Status ReconstructTake(grpc::ServerContext* context,
                               grpc::ServerReaderWriter<v1::TakeOutput, v1::TakeInput>* stream) override;
  grpc::Status DenoiseTake(grpc::ServerContext* context,
                           grpc::ServerReaderWriter<v1::TakeOutput, v1::TakeInput>* stream) override;
  grpc::Status DecodeTrack(grpc::ServerContext* context, const v1::DecodeTrackRequest* request,
                           grpc::ServerWriter<v1::TakeOutput>* writer) override;

  grpc::Status ListModels(grpc::ServerContext* context, const v1::ListModelsRequest* request,
                          v1::ListModelsReply* reply) override;
  grpc::Status DescribeModel(grpc::ServerContext* context, const v1::DescribeModelRequest* request,
                             v1::ModelInfo* reply) override;
  grpc::Status ActivateModel(grpc::ServerContext* context, const v1::ActivateModelRequest* request,
                             v1::ModelInfo* reply) override;
  grpc::Status DeleteModel(grpc::ServerContext* context, const v1::DeleteModelRequest* request,
                           v1::ModelInfo* reply) override;

  grpc::Status ListClips(grpc::ServerContext* context, const v1::ListClipsRequest* request,
                         v1::ListClipsReply* reply) override;
  grpc::Status ReadClip(grpc::ServerContext* context, const v1::ReadClipRequest* request,
                        v1::ReadClipReply* reply) override;
  grpc::Status UploadClip(grpc::ServerContext* context, const v1::UploadClipRequest* request,
                          v1::ClipFile* reply) override;
  grpc::Status DeleteClip(grpc::ServerContext* context, const v1::DeleteClipRequest* request,
                          v1::ClipFile* reply) override;

  grpc::Status SubmitJob(grpc::ServerContext* context, const v1::SubmitJobRequest* request, v1::Job* reply) override;
  grpc::Status GetJob(grpc::ServerContext* context, const v1::GetJobRequest* request, v1::Job* reply) override;
  grpc::Status ListJobs(grpc::ServerContext* context, const v1::ListJobsRequest* request,
                        v1::ListJobsReply* reply) override;
  grpc::Status CancelJob(grpc::ServerContext* context, const v1::CancelJobRequest* request, v1::Job* reply) override;
  grpc::Status DeleteJob(grpc::ServerContext* context, const v1::DeleteJobRequest* request, v1::Job* reply) override;
  grpc::Status WatchJob(grpc::ServerContext* context, const v1::WatchJobRequest* request,
                        grpc::ServerWriter<v1::Job>* writer) override;

 private:
  Core& core_;
  const std::atomic<bool>& stopping_;
  StreamMessageDeadlines take_deadlines_;
};

}  // namespace mm::service::grpc_frontend
