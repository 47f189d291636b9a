// ServerConnection over gRPC: one channel, the token as `authorization`
// metadata, the refusal's field from the trailing `mm-error-field`.
#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <chrono>
#include <exception>
#include <fstream>
#include <sstream>
#include <thread>

#include "client/cli/server_connection.h"
#include "client/cli/server_error.h"
#include "format/input_error.h"
#include "motionmanifold/v1/manifold.grpc.pb.h"
#include "wire/bearer_token.h"

namespace mm::client {
namespace {

const char* code_name(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK: return "OK";
    case grpc::StatusCode::CANCELLED: return "CANCELLED";
    case grpc::StatusCode::UNKNOWN: return "UNKNOWN";
    case grpc::StatusCode::INVALID_ARGUMENT: return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED: return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND: return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS: return "ALREADY_EXISTS";
    case grpc::StatusCode::PERMISSION_DENIED: return "PERMISSION_DENIED";
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION: return "FAILED_PRECONDITION";
    case grpc::StatusCode::ABORTED: return "ABORTED";
    case grpc::StatusCode::OUT_OF_RANGE: return "OUT_OF_RANGE";
    case grpc::StatusCode::UNIMPLEMENTED: return "UNIMPLEMENTED";
    case grpc::StatusCode::INTERNAL: return "INTERNAL";
    case grpc::StatusCode::UNAVAILABLE: return "UNAVAILABLE";
    case grpc::StatusCode::DATA_LOSS: return "DATA_LOSS";
    case grpc::StatusCode::UNAUTHENTICATED: return "UNAUTHENTICATED";
    default: return "UNKNOWN";
  }
}

std::string read_file(const std::string& path, const std::string& option) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(option + " " + path + ": cannot read the file");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The take's header, then its frames in chunks of kTakeChunkFrames; stops
// early when the server has ended the call (Finish then says why).
template <typename Stream>
void send_take(Stream& stream, const TakeUpload& take) {
  v1::TakeInput message;
  *message.mutable_header() = take.header;
  message.mutable_header()->set_columns(take.frames.columns);
  if (!stream.Write(message)) return;
  const int64_t frames = take.frames.frame_count();
  for (int64_t first = 0; first < frames; first += kTakeChunkFrames) {
    const int64_t count = std::min<int64_t>(kTakeChunkFrames, frames - first);
    message.Clear();
    v1::FrameChunk* chunk = message.mutable_chunk();
    chunk->set_frames(static_cast<int32_t>(count));
    const float* values = take.frames.frame(first);
    chunk->mutable_values()->Add(values, values + count * take.frames.columns);
    if (!stream.Write(message)) return;
  }
}

// One message of a take's reply: the header and chunks to the sink, the
// summary kept. Returns whether it was the summary.
bool pass_on(const v1::TakeOutput& output, TakeReplySink& sink, v1::TakeSummary& summary) {
  switch (output.part_case()) {
    case v1::TakeOutput::kHeader: sink.header(output.header()); return false;
    case v1::TakeOutput::kChunk: sink.chunk(output.chunk()); return false;
    case v1::TakeOutput::kSummary: summary = output.summary(); return true;
    default: return false;
  }
}

class GrpcConnection : public ServerConnection {
 public:
  explicit GrpcConnection(const ConnectionOptions& options) : options_(options) {
    std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
    if (uses_tls(options)) {
      grpc::SslCredentialsOptions ssl;
      if (!options.tls_ca.empty()) ssl.pem_root_certs = read_file(options.tls_ca, "--tls-ca");
      credentials = grpc::SslCredentials(ssl);
    }
    grpc::ChannelArguments arguments;
    // Motions are ~60 KB each; a Sample of many exceeds gRPC's 4 MB default.
    arguments.SetMaxReceiveMessageSize(-1);
    arguments.SetMaxSendMessageSize(-1);
    stub_ = v1::MotionManifold::NewStub(grpc::CreateCustomChannel(options.server, credentials, arguments));
  }

  v1::EncodeReply encode(const v1::EncodeRequest& r) override { return unary(&Stub::Encode, r, v1::EncodeReply{}); }
  v1::MotionsReply decode(const v1::DecodeRequest& r) override { return unary(&Stub::Decode, r, v1::MotionsReply{}); }
  v1::MotionsReply sample(const v1::SampleRequest& r) override { return unary(&Stub::Sample, r, v1::MotionsReply{}); }
  v1::MotionsReply interpolate(const v1::InterpolateRequest& r) override {
    return unary(&Stub::Interpolate, r, v1::MotionsReply{});
  }
  v1::MotionsReply analogy(const v1::AnalogyRequest& r) override { return unary(&Stub::Analogy, r, v1::MotionsReply{}); }
  v1::MotionsReply denoise(const v1::DenoiseRequest& r) override { return unary(&Stub::Denoise, r, v1::MotionsReply{}); }
  v1::JoinClipsReply join_clips(const v1::JoinClipsRequest& r) override {
    return unary(&Stub::JoinClips, r, v1::JoinClipsReply{});
  }

  v1::ListModelsReply list_models() override {
    return unary(&Stub::ListModels, v1::ListModelsRequest{}, v1::ListModelsReply{});
  }
  v1::ModelInfo describe_model(const std::string& name) override {
    v1::DescribeModelRequest request;
    request.set_model(name);
    return unary(&Stub::DescribeModel, request, v1::ModelInfo{});
  }
  v1::ModelInfo activate_model(const std::string& name) override {
    v1::ActivateModelRequest request;
    request.set_model(name);
    return unary(&Stub::ActivateModel, request, v1::ModelInfo{});
  }
  v1::ModelInfo delete_model(const std::string& name) override {
    v1::DeleteModelRequest request;
    request.set_model(name);
    return unary(&Stub::DeleteModel, request, v1::ModelInfo{});
  }

  v1::ListClipsReply list_clips() override {
    return unary(&Stub::ListClips, v1::ListClipsRequest{}, v1::ListClipsReply{});
  }
  v1::ReadClipReply read_clip(const v1::ReadClipRequest& request) override {
    return unary(&Stub::ReadClip, request, v1::ReadClipReply{});
  }
  v1::ClipFile upload_clip(const v1::UploadClipRequest& request) override {
    return unary(&Stub::UploadClip, request, v1::ClipFile{});
  }
  v1::ClipFile delete_clip(const std::string& path) override {
    v1::DeleteClipRequest request;
    request.set_path(path);
    return unary(&Stub::DeleteClip, request, v1::ClipFile{});
  }

  v1::Job submit_job(const v1::JobSpec& spec) override {
    v1::SubmitJobRequest request;
    *request.mutable_spec() = spec;
    return unary(&Stub::SubmitJob, request, v1::Job{});
  }
  v1::Job get_job(const std::string& id) override {
    v1::GetJobRequest request;
    request.set_id(id);
    return unary(&Stub::GetJob, request, v1::Job{});
  }
  v1::ListJobsReply list_jobs() override { return unary(&Stub::ListJobs, v1::ListJobsRequest{}, v1::ListJobsReply{}); }
  v1::Job cancel_job(const std::string& id) override {
    v1::CancelJobRequest request;
    request.set_id(id);
    return unary(&Stub::CancelJob, request, v1::Job{});
  }
  v1::Job delete_job(const std::string& id) override {
    v1::DeleteJobRequest request;
    request.set_id(id);
    return unary(&Stub::DeleteJob, request, v1::Job{});
  }

  void watch_job(const std::string& id, const std::function<void(const v1::Job&)>& on_record) override {
    grpc::ClientContext context;
    prepare(context, /*deadline=*/false);
    v1::WatchJobRequest request;
    request.set_id(id);
    auto reader = stub_->WatchJob(&context, request);
    v1::Job job;
    bool final_seen = false;
    while (reader->Read(&job)) {
      on_record(job);
      if (is_final_state(job.state())) final_seen = true;
    }
    const grpc::Status status = reader->Finish();
    if (final_seen) return;
    if (!status.ok()) throw error_of(status, context);
    // The server ended the stream without a final record: it is stopping.
    throw ServerError("UNAVAILABLE", "", "the job's stream ended before the job did");
  }

  v1::CodeTrack encode_take(const TakeUpload& take) override {
    grpc::ClientContext context;
    prepare(context, /*deadline=*/false);
    v1::CodeTrack track;
    auto writer = stub_->EncodeTake(&context, &track);
    send_take(*writer, take);
    writer->WritesDone();
    const grpc::Status status = writer->Finish();
    if (!status.ok()) throw error_of(status, context);
    return track;
  }

  v1::TakeSummary transform_take(TakeOperation operation, const TakeUpload& take, TakeReplySink& sink) override {
    grpc::ClientContext context;
    prepare(context, /*deadline=*/false);
    auto stream = operation == TakeOperation::kDenoise ? stub_->DenoiseTake(&context)
                                                       : stub_->ReconstructTake(&context);
    // The reply is read while the take is still being sent: the server
    // answers frames as they are final, and a client that only wrote would
    // stall it once the reply's flow-control window filled.
    v1::TakeSummary summary;
    bool summary_seen = false;
    std::exception_ptr sink_error;
    std::thread reader([&] {
      v1::TakeOutput output;
      while (stream->Read(&output)) {
        try {
          if (pass_on(output, sink, summary)) summary_seen = true;
        } catch (...) {
          sink_error = std::current_exception();
          context.TryCancel();
          return;
        }
      }
    });
    send_take(*stream, take);
    stream->WritesDone();
    reader.join();
    const grpc::Status status = stream->Finish();
    if (sink_error) std::rethrow_exception(sink_error);
    if (!status.ok()) throw error_of(status, context);
    if (!summary_seen) throw ServerError("UNAVAILABLE", "", "the take's reply ended without its summary");
    return summary;
  }

  v1::TakeSummary decode_track(const v1::DecodeTrackRequest& request, TakeReplySink& sink) override {
    grpc::ClientContext context;
    prepare(context, /*deadline=*/false);
    auto reader = stub_->DecodeTrack(&context, request);
    v1::TakeSummary summary;
    bool summary_seen = false;
    std::exception_ptr sink_error;
    v1::TakeOutput output;
    while (reader->Read(&output)) {
      if (sink_error) continue;  // cancelled: what is left is drained
      try {
        if (pass_on(output, sink, summary)) summary_seen = true;
      } catch (...) {
        sink_error = std::current_exception();
        context.TryCancel();
      }
    }
    const grpc::Status status = reader->Finish();
    if (sink_error) std::rethrow_exception(sink_error);
    if (!status.ok()) throw error_of(status, context);
    if (!summary_seen) throw ServerError("UNAVAILABLE", "", "the track's reply ended without its summary");
    return summary;
  }

 private:
  using Stub = v1::MotionManifold::Stub;

  void prepare(grpc::ClientContext& context, bool deadline) const {
    if (deadline) {
      context.set_deadline(std::chrono::system_clock::now() +
                           std::chrono::milliseconds(static_cast<long>(options_.timeout_seconds * 1000)));
    }
    if (!options_.token.empty()) context.AddMetadata("authorization", wire::bearer_authorization(options_.token));
  }

  static ServerError error_of(const grpc::Status& status, const grpc::ClientContext& context) {
    std::string field;
    const auto& trailers = context.GetServerTrailingMetadata();
    if (const auto it = trailers.find("mm-error-field"); it != trailers.end()) {
      field.assign(it->second.data(), it->second.size());
    }
    // The status message already reads "<field>: <message>"; keep it whole
    // (the field apart only for programs) so it prints as the server wrote it.
    std::string message = status.error_message();
    if (!field.empty() && message.rfind(field + ": ", 0) == 0) message = message.substr(field.size() + 2);
    return ServerError(code_name(status.error_code()), field, message);
  }

  template <typename Request, typename Reply>
  Reply unary(grpc::Status (Stub::*method)(grpc::ClientContext*, const Request&, Reply*), const Request& request,
              Reply reply) {
    grpc::ClientContext context;
    prepare(context, /*deadline=*/true);
    const grpc::Status status = (stub_.get()->*method)(&context, request, &reply);
    if (!status.ok()) throw error_of(status, context);
    return reply;
  }

  ConnectionOptions options_;
  std::unique_ptr<Stub> stub_;
};

}  // namespace

std::unique_ptr<ServerConnection> grpc_connection(const ConnectionOptions& options) {
  return std::make_unique<GrpcConnection>(options);
}

}  // namespace mm::client
