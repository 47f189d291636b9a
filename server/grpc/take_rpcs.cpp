// The take rpcs of ManifoldService: the client's TakeInput stream becomes the
// core's TakeChunkReader (header first, then chunks, read as the core asks
// for frames), and the core's TakeReplySink writes the reply as it becomes
// final, frames in chunks of at most kReplyChunkFrames. Every Read and Write
// waits under the service's message deadline (stream_message_deadlines.h),
// so a silent client holds its thread for that long at most.
#include <algorithm>

#include "server/grpc/error_status.h"
#include "server/grpc/manifold_service.h"
#include "server/translation/proto_translation.h"

namespace mm::service::grpc_frontend {

using proto_translation::to_api;
using proto_translation::to_wire;
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
// starts with a chunk or ends before anything. A header that has not come
// within the deadline ends the call (DEADLINE_EXCEEDED, sent by the
// deadline itself; what is thrown here only unwinds the handler).
template <typename Stream>
TakeRequest read_header(grpc::ServerContext* context, Stream* stream, StreamMessageDeadlines& deadlines) {
  v1::TakeInput first;
  const auto read = deadlines.wait(*context,
                                   "no TakeHeader within " + deadlines.limit_text() +
                                       " of the stream's start; a take stream sends its header first, then its chunks",
                                   [&] { return stream->Read(&first); });
  if (read.expired) throw invalid("header", "no TakeHeader within " + deadlines.limit_text());
  if (!read.ok) {
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
TakeChunkReader chunk_reader(grpc::ServerContext* context, Stream* stream, StreamMessageDeadlines& deadlines) {
  return [context, stream, &deadlines](TakeChunk& chunk) {
    v1::TakeInput message;
    const auto read = deadlines.wait(*context,
                                     "no chunk (nor the stream's end) within " + deadlines.limit_text() +
                                         " of the take's previous message",
                                     [&] { return stream->Read(&message); });
    if (read.expired) throw invalid("take", "no chunk within " + deadlines.limit_text());
    if (!read.ok) {
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
// Writes one reply message, waiting for the client to take it for at most
// the deadline.
template <typename Writer>
void write_reply(grpc::ServerContext* context, Writer* writer, StreamMessageDeadlines& deadlines,
                 const v1::TakeOutput& message) {
  const auto written = deadlines.wait(*context,
                                      "the client took no reply message within " + deadlines.limit_text() +
                                          "; read the reply while the take is sent",
                                      [&] { return writer->Write(message); });
  if (written.expired) throw invalid("take", "the client took no reply message within " + deadlines.limit_text());
  if (!written.ok) throw invalid("take", "the client has gone (the reply could not be written)");
}

template <typename Writer>
TakeReplySink streaming_sink(grpc::ServerContext* context, Writer* writer, StreamMessageDeadlines& deadlines,
                             int& columns, std::vector<TakeWindow>& windows) {
  TakeReplySink sink;
  const auto write = [context, writer, &deadlines](const v1::TakeOutput& message) {
    write_reply(context, writer, deadlines, message);
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
void write_summary(grpc::ServerContext* context, Writer* writer, StreamMessageDeadlines& deadlines,
                   const TakeSummary& summary, const std::vector<TakeWindow>& windows) {
  v1::TakeOutput message;
  to_wire(summary, message.mutable_summary());
  for (const TakeWindow& window : windows) to_wire(window, message.mutable_summary()->add_windows());
  write_reply(context, writer, deadlines, message);
}

grpc::Status frames_take(Core& core, StreamMessageDeadlines& deadlines, grpc::ServerContext* context,
                         TakeOperation operation, grpc::ServerReaderWriter<v1::TakeOutput, v1::TakeInput>* stream) {
  return answer_take(context, [&](const CallContext& ctx) {
    const TakeRequest request = read_header(context, stream, deadlines);
    int columns = 0;
    std::vector<TakeWindow> windows;
    const TakeSummary summary =
        core.run_take(ctx, operation, request, chunk_reader(context, stream, deadlines),
                      streaming_sink(context, stream, deadlines, columns, windows));
    write_summary(context, stream, deadlines, summary, windows);
  });
}

}  // namespace

grpc::Status ManifoldService::EncodeTake(grpc::ServerContext* context, grpc::ServerReader<v1::TakeInput>* reader,
                                         v1::CodeTrack* reply) {
  return answer_take(context, [&](const CallContext& ctx) {
    const TakeRequest request = read_header(context, reader, take_deadlines_);
    TakeReplySink sink;
    sink.on_start = [reply](const TakeReplyStart& start) { to_wire(start.answered_by, reply->mutable_answered_by()); };
    sink.on_window = [reply](const TakeWindow& window) { to_wire(window, reply->add_windows()); };
    to_wire(core_.run_take(ctx, TakeOperation::kEncode, request, chunk_reader(context, reader, take_deadlines_), sink),
            reply);
  });
}

grpc::Status ManifoldService::ReconstructTake(grpc::ServerContext* context,
                                              grpc::ServerReaderWriter<v1::TakeOutput, v1::TakeInput>* stream) {
  return frames_take(core_, take_deadlines_, context, TakeOperation::kReconstruct, stream);
}

grpc::Status ManifoldService::DenoiseTake(grpc::ServerContext* context,
                                          grpc::ServerReaderWriter<v1::TakeOutput, v1::TakeInput>* stream) {
  return frames_take(core_, take_deadlines_, context, TakeOperation::kDenoise, stream);
}

grpc::Status ManifoldService::DecodeTrack(grpc::ServerContext* context, const v1::DecodeTrackRequest* request,
                                          grpc::ServerWriter<v1::TakeOutput>* writer) {
  return answer_take(context, [&](const CallContext& ctx) {
    int columns = 0;
    std::vector<TakeWindow> windows;
    const TakeSummary summary =
        core_.decode_track(ctx, to_api(*request), streaming_sink(context, writer, take_deadlines_, columns, windows));
    write_summary(context, writer, take_deadlines_, summary, windows);
  });
}

}  // namespace mm::service::grpc_frontend
