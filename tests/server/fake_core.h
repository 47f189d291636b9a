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
#include <cstdint>
#include <functional>
#include <memory>
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
  FakeAnswer<service::EncodeReply> encode_answer;
  FakeAnswer<TakeSummary> take_answer;
  // The shape of the model choose_model chooses (named as asked, version
  // kChosenVersion), or its refusal.
  FakeAnswer<service::ModelShape> choose_answer;
  static constexpr const char* kChosenVersion = "00000000c4053e11";

  // What the last call of each was given.
  std::optional<service::DecodeRequest> decode_request;
  std::optional<service::SampleRequest> sample_request;
  std::optional<service::EncodeRequest> encode_request;
  std::optional<service::TakeRequest> take_request;
  std::optional<TakeOperation> take_operation;
  int64_t take_frames_read = -1;  // the frames run_take's reader gave (-1: it was given none)
  service::CallContext context;   // of the last call
  std::atomic<int> calls{0};      // operations called, ready() left out
  // Each call in the order it came: "choose_model <operation> <name>",
  // "<operation> on chosen <name>" or "<operation> on request <model>" (an
  // operation given a chosen model or not), "refuse_body <operation> <code>".
  std::vector<std::string> steps;

  bool ready() const override { return true; }

  service::ChosenModel choose_model(const service::CallContext& ctx, const std::string& operation,
                                    const std::string& name) override {
    record(ctx);
    steps.push_back("choose_model " + operation + " " + name);
    auto choice = std::make_shared<Choice>();
    choice->operation = operation;
    return service::ChosenModel({name, kChosenVersion}, choose_answer.give("choose_model"), std::move(choice));
  }
  void refuse_body(const service::ChosenModel& chosen, const service::ApiError& error) override {
    steps.push_back("refuse_body " + choice_of(chosen).operation + " " + service::error_code_name(error.code()));
  }

  service::EncodeReply encode(const service::CallContext& ctx, const service::EncodeRequest& request,
                              const service::ChosenModel& chosen = {}) override {
    record(ctx, "encode", chosen, request.model);
    encode_request = request;
    return encode_answer.give("encode");
  }
  service::MotionsReply decode(const service::CallContext& ctx, const service::DecodeRequest& request,
                               const service::ChosenModel& chosen = {}) override {
    record(ctx, "decode", chosen, request.model);
    decode_request = request;
    return decode_answer.give("decode");
  }
  service::MotionsReply sample(const service::CallContext& ctx, const service::SampleRequest& request,
                               const service::ChosenModel& chosen = {}) override {
    record(ctx, "sample", chosen, request.model);
    sample_request = request;
    return sample_answer.give("sample");
  }
  TakeSummary run_take(const service::CallContext& ctx, TakeOperation operation,
                       const service::TakeRequest& request, const service::TakeChunkReader& read,
                       const service::TakeReplySink&, const service::ChosenModel& chosen = {}) override {
    record(ctx, service::take_call_name(operation), chosen, request.model);
    take_operation = operation;
    take_request = request;
    take_frames_read = -1;
    if (read) {
      take_frames_read = 0;
      service::TakeChunk chunk;
      while (read(chunk)) take_frames_read += chunk.frames;
    }
    return take_answer.give("run_take");
  }

  // The rest are not set by any test: each refuses, naming itself.
  service::MotionsReply interpolate(const service::CallContext& ctx, const service::InterpolateRequest&,
                                    const service::ChosenModel& = {}) override {
    unset(ctx, "interpolate");
  }
  service::MotionsReply analogy(const service::CallContext& ctx, const service::AnalogyRequest&,
                                const service::ChosenModel& = {}) override {
    unset(ctx, "analogy");
  }
  service::MotionsReply denoise(const service::CallContext& ctx, const service::DenoiseRequest&,
                                const service::ChosenModel& = {}) override {
    unset(ctx, "denoise");
  }
  service::JoinClipsReply join_clips(const service::CallContext& ctx, const service::JoinClipsRequest&,
                                     const service::ChosenModel& = {}) override {
    unset(ctx, "join_clips");
  }
  TakeSummary decode_track(const service::CallContext& ctx, const service::DecodeTrackRequest&,
                           const service::TakeReplySink&, const service::ChosenModel& = {}) override {
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
  // The hold of a model this fake chose: the operation it was chosen for.
  struct Choice final : service::ChosenModel::Hold {
    std::string operation;
  };
  static const Choice& choice_of(const service::ChosenModel& chosen) {
    const auto* choice = dynamic_cast<const Choice*>(chosen.hold());
    if (choice == nullptr) {
      throw service::ApiError(service::ErrorCode::kInternal, "", "FakeCore was given a model it did not choose");
    }
    return *choice;
  }

  void record(const service::CallContext& ctx) {
    context = ctx;
    ++calls;
  }
  // An operation's call, on the chosen model (which must have been chosen
  // for it) or on the one its request names.
  void record(const service::CallContext& ctx, const std::string& operation, const service::ChosenModel& chosen,
              const std::string& request_model) {
    record(ctx);
    if (!chosen) return steps.push_back(operation + " on request " + request_model);
    if (choice_of(chosen).operation != operation) {
      throw service::ApiError(service::ErrorCode::kInternal, "",
                              operation + " was given a model chosen for " + choice_of(chosen).operation);
    }
    steps.push_back(operation + " on chosen " + chosen.model().model);
  }
  [[noreturn]] void unset(const service::CallContext& ctx, const char* operation) {
    record(ctx);
    throw_unset(operation);
  }
};

}  // namespace mm::test
