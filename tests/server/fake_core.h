// A stand-in for the core (server/core/core.h) that the frontends' own tests
// run the real frontends against, so that they build and run without
// LibTorch or a model: each operation records what it was given and answers
// what the test set, and refuses (INTERNAL, naming the operation) when the
// test set nothing, so that a route calling an operation it should not shows.
//
// Thread safety: the frontends call it from their own threads; a test reads
// what it recorded after the call's reply has arrived (the frontends answer
// only once the core has returned), and sets the answers before the call.
#pragma once

#include <atomic>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "server/api/api_types.h"
#include "server/core/core.h"

namespace mm::test {

[[noreturn]] inline void throw_unset(const char* operation) {
  throw service::ApiError(service::ErrorCode::kInternal, "",
                          std::string("FakeCore::") + operation + " has no answer set by this test");
}

// One operation's answer: the reply, or the refusal it throws.
template <typename Reply>
struct FakeAnswer {
  std::optional<Reply> reply;
  std::optional<service::ApiError> error;

  Reply give(const char* operation) const {
    if (error) throw *error;
    if (reply) return *reply;
    throw_unset(operation);
  }
};

class FakeCore final : public service::Core {
 public:
  // What each operation answers; unset: refused as INTERNAL.
  FakeAnswer<service::MotionsReply> decode_answer, sample_answer;
  FakeAnswer<service::TakeSummaryReply> take_answer;

  // What the last call of each was given.
  std::optional<service::DecodeRequest> decode_request;
  std::optional<service::SampleRequest> sample_request;
  std::optional<service::TakeRequest> take_request;
  std::optional<service::TakeKind> take_kind;
  bool take_body_translated = false;  // run_take was given a translation.read (a body to read)
  service::CallContext context;       // of the last call
  std::atomic<int> calls{0};          // operations called, ready() left out

  bool ready() const override { return true; }

  service::MotionsReply decode(
      const service::CallContext& ctx, const service::DecodeRequest& request,
      const service::ShapedTranslation<service::DecodeRequest, service::MotionsReply>& = {}) override {
    record(ctx);
    decode_request = request;
    return decode_answer.give("decode");
  }
  service::MotionsReply sample(
      const service::CallContext& ctx, const service::SampleRequest& request,
      const service::ShapedTranslation<service::SampleRequest, service::MotionsReply>& = {}) override {
    record(ctx);
    sample_request = request;
    return sample_answer.give("sample");
  }
  service::TakeSummaryReply run_take(const service::CallContext& ctx, service::TakeKind kind,
                                     const service::TakeRequest& request, const service::TakeChunkReader&,
                                     const service::TakeReplySink&,
                                     const service::TakeTranslation& translation = {}) override {
    record(ctx);
    take_kind = kind;
    take_request = request;
    take_body_translated = static_cast<bool>(translation.read);
    return take_answer.give("run_take");
  }

  // The rest are not set by any test: each refuses, naming itself.
  service::EncodeReply encode(const service::CallContext& ctx, const service::EncodeRequest&,
                              const service::ShapedTranslation<service::EncodeRequest, service::EncodeReply>& = {})
      override {
    unset(ctx, "encode");
  }
  service::MotionsReply interpolate(
      const service::CallContext& ctx, const service::InterpolateRequest&,
      const service::ShapedTranslation<service::InterpolateRequest, service::MotionsReply>& = {}) override {
    unset(ctx, "interpolate");
  }
  service::MotionsReply analogy(
      const service::CallContext& ctx, const service::AnalogyRequest&,
      const service::ShapedTranslation<service::AnalogyRequest, service::MotionsReply>& = {}) override {
    unset(ctx, "analogy");
  }
  service::MotionsReply denoise(
      const service::CallContext& ctx, const service::DenoiseRequest&,
      const service::ShapedTranslation<service::DenoiseRequest, service::MotionsReply>& = {}) override {
    unset(ctx, "denoise");
  }
  service::JoinClipsReply join_clips(
      const service::CallContext& ctx, const service::JoinClipsRequest&,
      const service::ShapedTranslation<service::JoinClipsRequest, service::JoinClipsReply>& = {}) override {
    unset(ctx, "join_clips");
  }
  service::TakeSummaryReply decode_track(
      const service::CallContext& ctx, const service::DecodeTrackRequest&, const service::TakeReplySink&,
      const service::ShapedTranslation<service::DecodeTrackRequest, service::TakeSummaryReply>& = {}) override {
    unset(ctx, "decode_track");
  }
  std::vector<service::ModelInfo> list_models(const service::CallContext& ctx) override {
    unset(ctx, "list_models");
  }
  service::ModelInfo describe_model(const service::CallContext& ctx, const std::string&) override {
    unset(ctx, "describe_model");
  }
  service::ModelInfo activate_model(const service::CallContext& ctx, const std::string&) override {
    unset(ctx, "activate_model");
  }
  service::ModelInfo delete_model(const service::CallContext& ctx, const std::string&) override {
    unset(ctx, "delete_model");
  }
  service::ListClipsReply list_clips(const service::CallContext& ctx) override {
    unset(ctx, "list_clips");
  }
  service::ReadClipReply read_clip(const service::CallContext& ctx, const service::ReadClipRequest&) override {
    unset(ctx, "read_clip");
  }
  service::ClipFile upload_clip(const service::CallContext& ctx, const service::UploadClipRequest&) override {
    unset(ctx, "upload_clip");
  }
  service::ClipFile delete_clip(const service::CallContext& ctx, const std::string&) override {
    unset(ctx, "delete_clip");
  }
  service::JobInfo submit_job(const service::CallContext& ctx, const service::JobSpec&) override {
    unset(ctx, "submit_job");
  }
  service::JobInfo get_job(const service::CallContext& ctx, const std::string&) override {
    unset(ctx, "get_job");
  }
  std::vector<service::JobInfo> list_jobs(const service::CallContext& ctx) override {
    unset(ctx, "list_jobs");
  }
  service::JobInfo cancel_job(const service::CallContext& ctx, const std::string&) override {
    unset(ctx, "cancel_job");
  }
  service::JobInfo delete_job(const service::CallContext& ctx, const std::string&) override {
    unset(ctx, "delete_job");
  }
  service::WatchStreams::Slot begin_watch(const service::CallContext& ctx, const std::string&) override {
    unset(ctx, "begin_watch");
  }
  void watch_job(service::WatchStreams::Slot, const std::string&, const std::function<bool(const service::JobInfo&)>&,
                 const std::atomic<bool>*) override {
    unset(service::CallContext(), "watch_job");
  }

 private:
  void record(const service::CallContext& ctx) {
    context = ctx;
    ++calls;
  }
  [[noreturn]] void unset(const service::CallContext& ctx, const char* operation) {
    record(ctx);
    throw_unset(operation);
  }
};

}  // namespace mm::test
