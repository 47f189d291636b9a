// The take rpcs of ManifoldService: the client's TakeInput stream becomes the
// core's TakeChunkReader (header first, then chunks, read as the core asks
// for frames), and the core's TakeReplySink writes the reply as it becomes
// final, frames in chunks of at most kReplyChunkFrames.
#include <algorithm>

#include "grpc/error_status.h"
#include "grpc/manifold_service.h"
#include "translation/proto_translation.h"

namespace mm::service::wire {
namespace {

// 2048 frames of 99 floats are 0.8 MB with their errors: well under gRPC's
// default 4 MB a message, whatever the client's limit.
constexpr int64_t kReplyChunkFrames = 2048;

ApiError invalid(const std::string& field, const std::string& message) {
  return ApiError(ErrorCode::kInvalidArgument, field, message);
}

template <typename Call>
grpc::Status answer_take(grpc::ServerContext* context, Call&& call) {
  try {
    call(call_context(*context));
    return grpc::Status::OK;
  } catch (const ApiError& error) {
    if (context->IsCancelled()) return grpc::Status::CANCELLED;
    return error_status(error, context);
  } catch (const std::exception& error) {
    return grpc::Status(grpc::StatusCode::INTERNAL, error.what());
  }
}

// Reads the stream's header; INVALID_ARGUMENT "header" when the stream
// starts with a chunk or ends before anything.
template <typename Stream>
TakeRequest read_header(grpc::ServerContext* context, Stream* stream) {
  v1::TakeInput first;
  if (!stream->Read(&first)) {
    throw invalid("header", context->IsCancelled() ? "the stream was cancelled before its TakeHeader"
                                                   : "the stream ended before its TakeHeader, expected the header first");
  }
  if (!first.has_header()) {
    throw invalid("header", "the stream's first message is not a TakeHeader, expected the header first, then chunks");
  }
  return to_api(first.header());
}

// The chunks after the header, one a call; the end of the client's stream
// ends the take, a cancelled call breaks it off.
template <typename Stream>
TakeChunkReader chunk_reader(grpc::ServerContext* context, Stream* stream) {
  return [context, stream](TakeChunk& chunk) {
    v1::TakeInput message;
    if (!stream->Read(&message)) {
      if (context->IsCancelled()) throw invalid("take", "the stream was cancelled before the take's end");
      return false;
    }
    if (message.has_header()) throw invalid("header", "a second TakeHeader, expected chunks after the first");
    if (!message.has_chunk()) throw invalid("chunk", "a message with neither header nor chunk");
    chunk.frames = message.chunk().frames();
    chunk.values.assign(message.chunk().values().begin(), message.chunk().values().end());
    return true;
  };
}

// Writes the reply of ReconstructTake, DenoiseTake and DecodeTrack: header,
// chunks, and (by the caller) the summary with every window.
template <typename Writer>
TakeReplySink streaming_sink(Writer* writer, int& columns, std::vector<TakeWindow>& windows) {
  TakeReplySink sink;
  const auto write = [writer](const v1::TakeOutput& message) {
    if (!writer->Write(message)) throw invalid("take", "the client has gone (the reply could not be written)");
  };
  sink.on_start = [write, &columns](const TakeReplyStart& start) {
    columns = start.columns;
    v1::TakeOutput message;
    to_wire(start, message.mutable_header());
    write(message);
  };
  sink.on_window = [&windows](const TakeWindow& window) { windows.push_back(window); };
  sink.on_frames = [write, &columns](const float* values, const float* error_mm, int64_t count) {
    for (int64_t first = 0; first < count; first += kReplyChunkFrames) {
      const int64_t frames = std::min(kReplyChunkFrames, count - first);
      v1::TakeOutput message;
      v1::FrameChunk* chunk = message.mutable_chunk();
      chunk->set_frames(static_cast<int32_t>(frames));
      chunk->mutable_values()->Add(values + first * columns, values + (first + frames) * columns);
      if (error_mm != nullptr) chunk->mutable_error_mm()->Add(error_mm + first, error_mm + first + frames);
      write(message);
    }
  };
  return sink;
}

template <typename Writer>
void write_summary(Writer* writer, const TakeSummaryReply& summary, const std::vector<TakeWindow>& windows) {
  v1::TakeOutput message;
  to_wire(summary, message.mutable_summary());
  for (const TakeWindow& window : windows) to_wire(window, message.mutable_summary()->add_windows());
  if (!writer->Write(message)) throw invalid("take", "the client has gone (the reply could not be written)");
}

grpc::Status frames_take(ManifoldCore& core, grpc::ServerContext* context, TakeKind kind,
                         grpc::ServerReaderWriter<v1::TakeOutput, v1::TakeInput>* stream) {
  return answer_take(context, [&](const CallContext& ctx) {
    const TakeRequest request = read_header(context, stream);
    int columns = 0;
    std::vector<TakeWindow> windows;
    const TakeSummaryReply summary =
        core.run_take(ctx, kind, request, chunk_reader(context, stream), streaming_sink(stream, columns, windows));
    write_summary(stream, summary, windows);
  });
}

}  // namespace

grpc::Status ManifoldService::EncodeTake(grpc::ServerContext* context, grpc::ServerReader<v1::TakeInput>* reader,
                                         v1::CodeTrack* reply) {
  return answer_take(context, [&](const CallContext& ctx) {
    const TakeRequest request = read_header(context, reader);
    TakeReplySink sink;
    sink.on_start = [reply](const TakeReplyStart& start) { to_wire(start.answered_by, reply->mutable_answered_by()); };
    sink.on_window = [reply](const TakeWindow& window) { to_wire(window, reply->add_windows()); };
    to_wire(core_.run_take(ctx, TakeKind::kEncode, request, chunk_reader(context, reader), sink), reply);
  });
}

grpc::Status ManifoldService::ReconstructTake(grpc::ServerContext* context,
                                              grpc::ServerReaderWriter<v1::TakeOutput, v1::TakeInput>* stream) {
  return frames_take(core_, context, TakeKind::kReconstruct, stream);
}

grpc::Status ManifoldService::DenoiseTake(grpc::ServerContext* context,
                                          grpc::ServerReaderWriter<v1::TakeOutput, v1::TakeInput>* stream) {
  return frames_take(core_, context, TakeKind::kDenoise, stream);
}

grpc::Status ManifoldService::DecodeTrack(grpc::ServerContext* context, const v1::DecodeTrackRequest* request,
                                          grpc::ServerWriter<v1::TakeOutput>* writer) {
  return answer_take(context, [&](const CallContext& ctx) {
    int columns = 0;
    std::vector<TakeWindow> windows;
    const TakeSummaryReply summary =
        core_.decode_track(ctx, to_api(*request), streaming_sink(writer, columns, windows));
    write_summary(writer, summary, windows);
  });
}

}  // namespace mm::service::wire
