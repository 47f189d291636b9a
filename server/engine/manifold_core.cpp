#include "server/engine/manifold_core.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <condition_variable>
#include <cstring>
#include <filesystem>
#include <iterator>
#include <mutex>
#include <optional>
#include <thread>

#include "format/foot_contacts.h"
#include "format/input_error.h"
#include "model/clip_transition.h"
#include "model/latent_operations.h"
#include "server/core/caller_identity.h"
#include "server/core/data_root_clips.h"
#include "server/core/motion_conversion.h"
#include "server/core/service_metrics.h"
#include "server/engine/inference_executor.h"
#include "server/engine/model_store.h"
#include "server/engine/shared_deployment.h"
#include "server/engine/take_operations.h"
#include "server/jobs/training_jobs.h"

namespace mm::service {
namespace {

const char* const kShippedDefault = "h36m-dkgm-h100";

ApiError invalid(const std::string& field, const std::string& message) {
  return ApiError(ErrorCode::kInvalidArgument, field, message);
}

// A count field within [1, limit]; above the limit is too large (413) and
// names the server option that sets it.
void check_count(int value, int minimum, int limit, const std::string& field, const std::string& option) {
  if (value < minimum) {
    throw invalid(field, "expected at least " + std::to_string(minimum) + ", found " + std::to_string(value));
  }
  if (value > limit) {
    throw ApiError(ErrorCode::kResourceExhausted, field,
                   "at most " + std::to_string(limit) + " allowed (the server's " + option + "), found " +
                       std::to_string(value),
                   true);
  }
}

at::Tensor codes_tensor(const std::vector<Code>& codes, int latent) {
  auto tensor = at::empty({static_cast<int64_t>(codes.size()), latent}, at::kFloat);
  for (size_t i = 0; i < codes.size(); ++i) {
    std::memcpy(tensor[static_cast<int64_t>(i)].data_ptr<float>(), codes[i].data(), sizeof(float) * latent);
  }
  return tensor;
}

std::vector<Code> to_codes(const at::Tensor& tensor) {
  const auto codes = tensor.to(at::kFloat).contiguous();
  std::vector<Code> result(static_cast<size_t>(codes.size(0)));
  for (size_t i = 0; i < result.size(); ++i) {
    const float* row = codes.data_ptr<float>() + static_cast<int64_t>(i) * codes.size(1);
    result[i].assign(row, row + codes.size(1));
  }
  return result;
}

}  // namespace

struct ManifoldCore::State {
  State(CoreConfig c, ServiceMetrics& m, TrainingJobs* j)
      : config(std::move(c)), metrics(m), jobs(j), store(config.model_store, m, config.max_loaded_models, config.precisions), executor(config.batching, m),
        watch_streams(config.watch_streams) {}

  CoreConfig config;
  std::string default_model;  // activated at start(): the next start needs it
  ServiceMetrics& metrics;
  TrainingJobs* jobs;
  ModelStore store;
  InferenceExecutor executor;
  WatchStreams watch_streams;

  std::mutex takes_mutex;
  int takes_running = 0;  // guarded by takes_mutex

  std::atomic<bool> accepting{false};
  std::mutex calls_mutex;
  std::condition_variable calls_done;
  int calls_in_flight = 0;

  // Keeps the job gauges current without the metrics knowing the jobs.
  std::atomic<bool> stopping{false};
  std::thread job_gauges;

  // Last, so destroyed first: its thread follows the shared record into `store`.
  std::unique_ptr<SharedDeployment> deployment;

  DecoderKind decoder_for(const LoadedModel& model, const std::string& name) const {
    DecoderKind kind;
    if (name.empty()) return model.model.default_decoder();
    if (name == "rotation") {
      kind = DecoderKind::kRotation;
    } else if (name == "velocity") {
      kind = DecoderKind::kVelocity;
    } else {
      throw invalid("decoder", "expected \"rotation\", \"velocity\" or empty (the model's default), found \"" +
                                   name + "\"");
    }
    if (!model.model.has_decoder(kind)) {
      throw invalid("decoder", "model \"" + model.name + "\" has no " + name + " decoder; it has " +
                                   decoder_name(model.model.default_decoder()));
    }
    return kind;
  }

  // Lets in a call that changes state, or reads the data root's files
  // (`what` says which, for the refusal). With a token configured the caller
  // must send it, from anywhere. Without one only callers on loopback are let
  // in: a server that listens on 0.0.0.0 without a token (as scripts/serve.sh
  // starts it) is then never writable from the network, and local use (the
  // tool's scripts, a page opened on the same machine) needs no secret.
  void require_access(const CallContext& ctx, const std::string& what) const {
    const std::string refusal = authorization_refusal(ctx.authorization_problem, !config.auth_token.empty());
    if (!refusal.empty()) throw ApiError(ErrorCode::kUnauthenticated, "authorization", refusal);
    if (config.auth_token.empty()) {
      if (is_loopback_ip(ctx.peer_ip)) return;
      throw ApiError(ErrorCode::kUnauthenticated, "authorization",
                     "this server has no token, so " + what + " is taken only from loopback, and this call came from " +
                         (ctx.peer_ip.empty() ? std::string("an unknown address") : ctx.peer_ip) +
                         ": start the server with --auth-token-file FILE and send Authorization: Bearer <token>");
    }
    if (ctx.bearer_token.empty()) {
      throw ApiError(ErrorCode::kUnauthenticated, "authorization",
                     what + " needs the server's bearer token (Authorization: Bearer <token>)");
    }
    if (!tokens_equal(ctx.bearer_token, config.auth_token)) {
      throw ApiError(ErrorCode::kUnauthenticated, "authorization", "the bearer token is not the server's");
    }
  }
  void require_token(const CallContext& ctx) const { require_access(ctx, "a call that changes the server's state"); }
  // Clips are the operator's data (H3.6M's licence forbids redistributing
  // it): read like a write unless the operator made them public.
  void require_clip_reader(const CallContext& ctx) const {
    if (!config.public_clips) require_access(ctx, "reading the data root's clips (--public-clips opens them)");
  }

  // A place among the take operations running at once, given back when the
  // returned guard goes.
  std::shared_ptr<void> admit_take() {
    std::lock_guard<std::mutex> lock(takes_mutex);
    if (takes_running >= config.takes.max_streams) {
      throw ApiError(ErrorCode::kResourceExhausted, "",
                     std::to_string(takes_running) + " take operations are running, the most the server runs at "
                     "once (--max-take-streams " + std::to_string(config.takes.max_streams) +
                     "); try again when one has finished");
    }
    ++takes_running;
    return std::shared_ptr<void>(nullptr, [this](void*) {
      std::lock_guard<std::mutex> lock(takes_mutex);
      --takes_running;
    });
  }
  TakeBounds take_bounds() const { return {config.takes, config.limits.max_denoise_iterations}; }
  TorchRunner take_runner() {
    return [this](const std::function<void()>& work) { executor.run(work); };
  }

  TrainingJobs& training() const {
    if (jobs == nullptr) {
      throw ApiError(ErrorCode::kFailedPrecondition, "", "this server runs no training jobs (started without --state-dir)");
    }
    return *jobs;
  }

  // The code of a motion or a code given for `field` ("from", "a", ...).
  at::Tensor latent_of(const std::shared_ptr<const LoadedModel>& model, const MotionOrCode& input,
                       const std::string& field) {
    if (input.motion.has_value() == input.code.has_value()) {
      throw invalid(field, "expected exactly one of motion or code, found " +
                               std::string(input.motion ? "both" : "neither"));
    }
    if (input.code) {
      check_code(*input.code, model->shape, field + ".code");
      return codes_tensor({*input.code}, model->shape.latent)[0];
    }
    auto frames = to_model_frames(*input.motion, model->shape, field + ".motion");
    return executor.encode(model, {std::move(frames)})[0];
  }

  // The motions of `codes`, and the codes themselves when the reply carries
  // them (Sample, Interpolate, Analogy: not Decode, whose codes are the
  // caller's own).
  // With plant_feet, the root path is corrected so that planted feet stay
  // put (format/foot_contacts.h).
  MotionsReply decode_reply(const std::shared_ptr<const LoadedModel>& model, const at::Tensor& codes,
                            DecoderKind kind, bool plant_feet_too, bool with_codes = true) {
    MotionsReply reply;
    reply.answered_by = {model->name, model->version};
    const std::string root = model->model.has_trajectory() ? "generated" : "none";
    auto motions = executor.decode(model, codes, kind);
    if (plant_feet_too) plant_feet_of_each(model->shape.skeleton, motions, 25);
    for (const auto& motion : motions) reply.motions.push_back(to_api_motion(motion, model->shape, root));
    if (with_codes) reply.codes = to_codes(codes);
    return reply;
  }

  // One call from its admission to its outcome: admitted only while the
  // core accepts calls (else UNAVAILABLE, counted), in flight for drain()
  // until it goes, its outcome counted once in the metrics. An operation
  // begins its own, or runs on the one choose_model began (the hold of the
  // ChosenModel it hands out, with the model chosen and a take's place).
  class Call final : public ChosenModel::Hold {
   public:
    Call(State& state, std::string operation, const CallContext& ctx)
        : state_(state), operation_(std::move(operation)), protocol_(ctx.protocol) {
      std::lock_guard<std::mutex> lock(state_.calls_mutex);
      if (!state_.accepting) {
        count(ErrorCode::kUnavailable);
        throw ApiError(ErrorCode::kUnavailable, "", "the server is not accepting calls (starting or shutting down)");
      }
      ++state_.calls_in_flight;
    }
    Call(const Call&) = delete;
    Call& operator=(const Call&) = delete;
    // A chosen model's call let go without an outcome: its frontend failed
    // between choose_model and the operation (core.h).
    ~Call() override {
      if (!counted_) count(ErrorCode::kInternal);
      std::lock_guard<std::mutex> lock(state_.calls_mutex);
      if (--state_.calls_in_flight == 0) state_.calls_done.notify_all();
    }

    const std::string& operation() const { return operation_; }
    bool counted() const { return counted_; }
    bool of(const State& state) const { return &state_ == &state; }
    void count_ok() { count("OK"); }
    void count(ErrorCode code) { count(error_code_name(code)); }

    // Counts the exception being handled as the call's outcome and throws
    // it as the error model's ApiError: the library's own input errors
    // (which the checks should pre-empt) as INVALID_ARGUMENT, anything
    // unexpected as INTERNAL.
    [[noreturn]] void fail() {
      try {
        throw;
      } catch (const ApiError& e) {
        count(e.code());
        throw;
      } catch (const InputError& e) {
        count(ErrorCode::kInvalidArgument);
        throw ApiError(ErrorCode::kInvalidArgument, "", e.what());
      } catch (const std::exception& e) {
        count(ErrorCode::kInternal);
        std::string what = e.what();
        spdlog::error("{} failed: {}", operation_, what);
        throw ApiError(ErrorCode::kInternal, "", what.substr(0, what.find('\n')));
      }
    }

    std::shared_ptr<const LoadedModel> model;  // chosen by choose_model
    std::shared_ptr<void> take_slot;           // a take's place, admitted by choose_model

   private:
    void count(const char* code) {
      counted_ = true;
      state_.metrics.observe_request(operation_, protocol_, code,
                                     std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count());
    }

    State& state_;
    const std::string operation_;
    const std::string protocol_;
    const std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
    bool counted_ = false;  // a call is used by one frontend thread at a time
  };

  // The call `chosen` began for `operation`; INTERNAL (a frontend's
  // mistake) for one chosen by another core, for another operation, or
  // whose call has ended.
  Call& chosen_call(const ChosenModel& chosen, const std::string& operation) const {
    auto* call = dynamic_cast<Call*>(chosen.hold());
    if (call == nullptr || !call->of(*this)) {
      throw ApiError(ErrorCode::kInternal, "", operation + " was given a model that this core did not choose");
    }
    if (call->operation() != operation) {
      throw ApiError(ErrorCode::kInternal, "",
                     operation + " was given a model chosen for " + call->operation() + " (choose_model)");
    }
    if (call->counted()) {
      throw ApiError(ErrorCode::kInternal, "", operation + " was given a chosen model whose call has ended");
    }
    return *call;
  }
  // The model a call runs on: `chosen`'s (checked by call()), else the one
  // the request names.
  std::shared_ptr<const LoadedModel> model_for(const ChosenModel& chosen, const std::string& name) {
    if (chosen) return static_cast<const Call*>(chosen.hold())->model;
    return store.get(name);
  }
  // A take's place: the one choose_model admitted, else one admitted now.
  std::shared_ptr<void> take_slot_for(const ChosenModel& chosen) {
    if (chosen) return static_cast<const Call*>(chosen.hold())->take_slot;
    return admit_take();
  }

  // Runs one call (Call, above) on `chosen`'s or its own: counts its
  // outcome and maps its errors.
  template <typename Work>
  auto call(const char* operation, const CallContext& ctx, Work&& work) -> decltype(work()) {
    return call(operation, ctx, false, ChosenModel(), std::forward<Work>(work));
  }
  // `inference`: the call reaches the executor, which may wait for it to
  // join a batch (announced only now, not while a chosen model's body was
  // read).
  template <typename Work>
  auto call(const char* operation, const CallContext& ctx, bool inference, const ChosenModel& chosen, Work&& work)
      -> decltype(work()) {
    std::optional<Call> own;
    Call& begun = chosen ? chosen_call(chosen, operation) : own.emplace(*this, operation, ctx);
    std::optional<InferenceExecutor::Expected> expected;
    if (inference) expected.emplace(executor);
    try {
      auto result = work();
      begun.count_ok();
      return result;
    } catch (...) {
      begun.fail();
    }
  }
};

ManifoldCore::ManifoldCore(CoreConfig config, ServiceMetrics& metrics, TrainingJobs* jobs)
    : state_(std::make_unique<State>(std::move(config), metrics, jobs)) {}

ManifoldCore::~ManifoldCore() {
  state_->stopping = true;
  if (state_->job_gauges.joinable()) state_->job_gauges.join();
}

void ManifoldCore::start() {
  std::string name = state_->config.default_model;
  if (name.empty()) {
    const auto models = state_->store.list();
    for (const auto& model : models) {
      if (model.name == kShippedDefault) name = model.name;
    }
    if (name.empty() && models.size() == 1) name = models.front().name;
    if (name.empty()) {
      throw ApiError(ErrorCode::kFailedPrecondition, "default_model",
                     "the model store " + state_->config.model_store + " has " + std::to_string(models.size()) +
                         " models and none is named " + kShippedDefault + ": name the default with --default-model");
    }
  }
  state_->store.remove_deleted_leftovers();
  // What uploads a crash interrupted left: nothing else would ever remove it.
  if (!state_->config.data_root.empty()) sweep_upload_leftovers(state_->config.data_root);
  const auto model = state_->store.activate(name);
  state_->default_model = name;
  spdlog::info("model {} (version {}) active, loaded in {:.2f} s", model->name, model->version, model->load_seconds);
  state_->deployment = join_deployment(state_->config.job_store, state_->store, state_->config.data_root_quota);
  state_->accepting = true;
  if (state_->jobs) {
    state_->job_gauges = std::thread([state = state_.get()] {
      while (!state->stopping) {
        try {
          state->metrics.set_job_counts(state->jobs->counts());
          state->metrics.set_watch_streams(state->watch_streams.open());
        } catch (const std::exception& e) {
          spdlog::debug("job gauges not updated: {}", e.what());
        }
        for (int i = 0; i < 10 && !state->stopping; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
      }
    });
  }
}

bool ManifoldCore::ready() const { return state_->accepting; }

namespace {

// The operations a model is chosen for (Core::choose_model), as the metrics
// name them; whether each is a take, which holds a place among those running.
bool chooses_a_model(const std::string& operation, bool* take) {
  static const char* const kCalls[] = {"encode", "decode", "sample", "interpolate", "analogy", "denoise", "join_clips"};
  static const char* const kTakes[] = {"encode_take", "reconstruct_take", "denoise_take", "decode_track"};
  *take = std::find(std::begin(kTakes), std::end(kTakes), operation) != std::end(kTakes);
  return *take || std::find(std::begin(kCalls), std::end(kCalls), operation) != std::end(kCalls);
}

}  // namespace

ChosenModel ManifoldCore::choose_model(const CallContext& ctx, const std::string& operation,
                                       const std::string& name) {
  bool take = false;
  if (!chooses_a_model(operation, &take)) {
    throw ApiError(ErrorCode::kInternal, "", "no operation \"" + operation + "\" runs on a chosen model");
  }
  // Refused and counted as the operation's call would be, in its order:
  // the core accepting, a take's place, the model.
  auto call = std::make_shared<State::Call>(*state_, operation, ctx);
  try {
    if (take) call->take_slot = state_->admit_take();
    call->model = state_->store.get(name);
  } catch (...) {
    call->fail();
  }
  const LoadedModel& model = *call->model;
  return ChosenModel({model.name, model.version}, model.shape, std::move(call));
}

void ManifoldCore::refuse_body(const ChosenModel& chosen, const ApiError& error) {
  auto* call = dynamic_cast<State::Call*>(chosen.hold());
  if (call == nullptr || !call->of(*state_)) {
    throw ApiError(ErrorCode::kInternal, "", "refuse_body was given a model that this core did not choose");
  }
  if (!call->counted()) call->count(error.code());
}

EncodeReply ManifoldCore::encode(const CallContext& ctx, const EncodeRequest& request,
                                 const ChosenModel& chosen) {
  return state_->call("encode", ctx, true, chosen, [&] {
    const auto model = state_->model_for(chosen, request.model);
    check_count(static_cast<int>(request.motions.size()), 1, state_->config.limits.max_motions, "motions",
                "max_motions");
    std::vector<MotionFrames> frames;
    for (size_t i = 0; i < request.motions.size(); ++i) {
      frames.push_back(to_model_frames(request.motions[i], model->shape, "motions[" + std::to_string(i) + "]"));
    }
    EncodeReply reply;
    reply.codes = to_codes(state_->executor.encode(model, std::move(frames)));
    reply.answered_by = {model->name, model->version};
    return reply;
  });
}

MotionsReply ManifoldCore::decode(const CallContext& ctx, const DecodeRequest& request,
                                  const ChosenModel& chosen) {
  return state_->call("decode", ctx, true, chosen, [&] {
    const auto model = state_->model_for(chosen, request.model);
    const DecoderKind kind = state_->decoder_for(*model, request.decoder);
    check_count(static_cast<int>(request.codes.size()), 1, state_->config.limits.max_motions, "codes",
                "max_motions");
    for (size_t i = 0; i < request.codes.size(); ++i) {
      check_code(request.codes[i], model->shape, "codes[" + std::to_string(i) + "]");
    }
    return state_->decode_reply(model, codes_tensor(request.codes, model->shape.latent), kind, request.plant_feet,
                                /*with_codes=*/false);
  });
}

MotionsReply ManifoldCore::sample(const CallContext& ctx, const SampleRequest& request,
                                  const ChosenModel& chosen) {
  return state_->call("sample", ctx, true, chosen, [&] {
    const auto model = state_->model_for(chosen, request.model);
    const DecoderKind kind = state_->decoder_for(*model, request.decoder);
    check_count(request.count, 1, state_->config.limits.max_sample_count, "count", "max_sample_count");
    return state_->decode_reply(model, sample_codes(model->model, request.count, request.seed), kind,
                                request.plant_feet);
  });
}

MotionsReply ManifoldCore::interpolate(const CallContext& ctx, const InterpolateRequest& request,
                                       const ChosenModel& chosen) {
  return state_->call("interpolate", ctx, true, chosen, [&] {
    const auto model = state_->model_for(chosen, request.model);
    const DecoderKind kind = state_->decoder_for(*model, request.decoder);
    check_count(request.steps, 2, state_->config.limits.max_steps, "steps", "max_steps");
    if (request.method != "linear" && request.method != "spherical" && !request.method.empty()) {
      throw invalid("method", "expected \"linear\" or \"spherical\", found \"" + request.method + "\"");
    }
    const auto from = state_->latent_of(model, request.from, "from");
    const auto to = state_->latent_of(model, request.to, "to");
    const auto codes = interpolate_codes(from, to, request.steps, request.method == "spherical");
    return state_->decode_reply(model, codes, kind, request.plant_feet);
  });
}

MotionsReply ManifoldCore::analogy(const CallContext& ctx, const AnalogyRequest& request,
                                   const ChosenModel& chosen) {
  return state_->call("analogy", ctx, true, chosen, [&] {
    const auto model = state_->model_for(chosen, request.model);
    const DecoderKind kind = state_->decoder_for(*model, request.decoder);
    const auto a = state_->latent_of(model, request.a, "a");
    const auto b = state_->latent_of(model, request.b, "b");
    const auto c = state_->latent_of(model, request.c, "c");
    return state_->decode_reply(model, analogy_code(a, b, c).unsqueeze(0), kind, request.plant_feet);
  });
}

MotionsReply ManifoldCore::denoise(const CallContext& ctx, const DenoiseRequest& request,
                                   const ChosenModel& chosen) {
  return state_->call("denoise", ctx, true, chosen, [&] {
    const auto model = state_->model_for(chosen, request.model);
    const DecoderKind kind = state_->decoder_for(*model, request.decoder);
    check_count(static_cast<int>(request.motions.size()), 1, state_->config.limits.max_motions, "motions",
                "max_motions");
    check_count(request.iterations, 1, state_->config.limits.max_denoise_iterations, "iterations",
                "max_denoise_iterations");
    if (request.zeros_are_missing && request.means_are_missing) {
      throw invalid("means_are_missing", "expected either zeros_are_missing or means_are_missing, found both");
    }
    if (request.keep_observed && !request.zeros_are_missing && !request.means_are_missing) {
      throw invalid("keep_observed", "expected together with zeros_are_missing or means_are_missing (without "
                                     "missing values every value is observed)");
    }
    std::vector<MotionFrames> frames;
    for (size_t i = 0; i < request.motions.size(); ++i) {
      frames.push_back(to_model_frames(request.motions[i], model->shape, "motions[" + std::to_string(i) + "]"));
    }
    DenoiseOptions options;
    options.zeros_are_missing = request.zeros_are_missing;
    options.means_are_missing = request.means_are_missing;
    options.iterations = request.iterations;
    options.keep_observed = request.keep_observed;
    std::vector<MotionFrames> denoised;
    state_->executor.run([&] { denoised = denoise_motions(model->model, frames, kind, options); });
    MotionsReply reply;
    reply.answered_by = {model->name, model->version};
    for (const auto& motion : denoised) reply.motions.push_back(to_api_motion(motion, model->shape, "input"));
    return reply;
  });
}

JoinClipsReply ManifoldCore::join_clips(const CallContext& ctx, const JoinClipsRequest& request,
                                       const ChosenModel& chosen) {
  return state_->call("join_clips", ctx, true, chosen, [&] {
    const auto model = state_->model_for(chosen, request.model);
    TransitionOptions options;
    options.decoder = state_->decoder_for(*model, request.decoder);
    const double seconds = request.transition_seconds;
    if (!(seconds >= kMinTransitionSeconds && seconds <= kMaxTransitionSeconds)) {
      char found[32];
      std::snprintf(found, sizeof found, "%g", seconds);
      throw invalid("transition_seconds", "expected 0.5 to 4 (s), found " + std::string(found));
    }
    options.seconds = seconds;
    if (request.method != "generated" && request.method != "crossfade") {
      throw invalid("method", "expected \"generated\" or \"crossfade\", found \"" + request.method + "\"");
    }
    options.method = parse_transition_method(request.method, "method");
    // As the library counts them (clip_transition.h): n transition frames
    // at 25 Hz, and a second of each clip beside them for the fit to see.
    constexpr double kModelRate = 25;
    const auto n = static_cast<int64_t>(std::lround(seconds * kModelRate));
    const auto shortest = n + static_cast<int64_t>(kModelRate);
    const auto longest = static_cast<int64_t>(state_->config.takes.max_seconds * kModelRate);
    const std::string why = "the transition's " + std::to_string(n) + " frames and 1 s more";
    for (const auto& [clip, name] : {std::pair<const Motion*, const char*>{&request.a, "a"}, {&request.b, "b"}}) {
      if (clip->frames == 0 && clip->values.empty() && clip->layout.empty()) {
        throw invalid(name, "expected a motion (frames, columns, frame_rate, layout, values), found none");
      }
    }
    const MotionFrames a =
        clip_to_model_frames(request.a, model->shape, "a", shortest, why, longest, "--max-take-seconds");
    const MotionFrames b =
        clip_to_model_frames(request.b, model->shape, "b", shortest, why, longest, "--max-take-seconds");
    const int64_t joined_frames = a.frame_count() + b.frame_count() - n;
    if (joined_frames < model->shape.frames) {
      throw invalid("b.frames", "expected a and b to make at least " + std::to_string(model->shape.frames) +
                                    " frames at 25 Hz joined (one clip of the model, which the transition is "
                                    "fitted in), found " + std::to_string(a.frame_count()) + " + " +
                                    std::to_string(b.frame_count()) + " less the transition's " + std::to_string(n) +
                                    " = " + std::to_string(joined_frames));
    }
    JoinedClips joined;
    // One intra-op thread: the fit is a chain of small sequential ops
    // (inference_executor.h says what two threads cost).
    state_->executor.run([&] { joined = ::mm::join_clips(model->model, a, b, options); }, /*threads=*/1);
    JoinClipsReply reply;
    reply.answered_by = {model->name, model->version};
    reply.motion = to_api_motion(joined.frames, model->shape, "input");
    reply.transition_first_frame = static_cast<int>(joined.transition_first);
    reply.transition_last_frame = static_cast<int>(joined.transition_last);
    return reply;
  });
}

TakeSummary ManifoldCore::run_take(const CallContext& ctx, TakeOperation operation, const TakeRequest& request,
                                   const TakeChunkReader& read, const TakeReplySink& sink,
                                   const ChosenModel& chosen) {
  // Not announced to the executor as inference: a take spends most of its
  // time waiting for its frames, and batches must not wait for it.
  return state_->call(take_call_name(operation), ctx, false, chosen, [&] {
    const auto slot = state_->take_slot_for(chosen);
    const auto model = state_->model_for(chosen, request.model);
    const DecoderKind decoder = state_->decoder_for(*model, request.decoder);
    if (request.path.empty()) {
      return run_take_on_model(*model, decoder, operation, request, read, sink, state_->take_runner(),
                               state_->take_bounds());
    }
    state_->require_clip_reader(ctx);
    auto file = std::make_shared<const TakeFile>(read_take_file(state_->config.data_root, request.path, model->shape,
                                                                request.frame_rate, operation == TakeOperation::kDenoise,
                                                                state_->config.max_take_bytes));
    TakeRequest from_file = request;
    from_file.frame_rate = file->frame_rate;
    return run_take_on_model(*model, decoder, operation, from_file, take_file_reader(file), sink, state_->take_runner(),
                             state_->take_bounds());
  });
}

TakeSummary ManifoldCore::decode_track(const CallContext& ctx, const DecodeTrackRequest& request,
                                       const TakeReplySink& sink, const ChosenModel& chosen) {
  return state_->call("decode_track", ctx, false, chosen, [&] {
    const auto slot = state_->take_slot_for(chosen);
    const auto model = state_->model_for(chosen, request.model);
    const DecoderKind decoder = state_->decoder_for(*model, request.decoder);
    return decode_track_on_model(*model, decoder, request, sink, state_->take_runner(), state_->take_bounds());
  });
}

std::vector<ModelInfo> ManifoldCore::list_models(const CallContext& ctx) {
  return state_->call("list_models", ctx, [&] { return state_->store.list(); });
}

ModelInfo ManifoldCore::describe_model(const CallContext& ctx, const std::string& name) {
  return state_->call("describe_model", ctx, [&] {
    if (name.empty()) return state_->store.describe(state_->store.active()->name);
    return state_->store.describe(name);
  });
}

ModelInfo ManifoldCore::activate_model(const CallContext& ctx, const std::string& name) {
  return state_->call("activate_model", ctx, [&] {
    state_->require_token(ctx);
    try {
      const auto model = state_->store.activate(name);
      spdlog::info("model {} (version {}) active", model->name, model->version);
    } catch (const ApiError& e) {
      spdlog::warn("activating model {} failed, the active model stays: {}", name, e.what());
      throw;
    }
    return state_->store.describe(name);
  });
}

ModelInfo ManifoldCore::delete_model(const CallContext& ctx, const std::string& name) {
  return state_->call("delete_model", ctx, [&] {
    state_->require_token(ctx);
    if (name == state_->default_model) {
      throw ApiError(ErrorCode::kFailedPrecondition, "model",
                     "model \"" + name + "\" is the one this server activates at start (--default-model), which it "
                     "could not start without; expected another model");
    }
    auto model = state_->store.remove(name);
    spdlog::info("model {} (version {}) deleted", model.name, model.version);
    return model;
  });
}

ListClipsReply ManifoldCore::list_clips(const CallContext& ctx) {
  return state_->call("list_clips", ctx, [&] {
    state_->require_clip_reader(ctx);
    return list_data_root_clips(state_->config.data_root, state_->config.max_listed_clips);
  });
}

ReadClipReply ManifoldCore::read_clip(const CallContext& ctx, const ReadClipRequest& request) {
  return state_->call("read_clip", ctx, [&] {
    state_->require_clip_reader(ctx);
    const auto model = state_->store.get(request.model);
    return read_data_root_clip(state_->config.data_root, request, model->shape,
                               {state_->config.takes.max_seconds, state_->config.max_reply_bytes});
  });
}

ClipFile ManifoldCore::upload_clip(const CallContext& ctx, const UploadClipRequest& request) {
  return state_->call("upload_clip", ctx, [&] {
    state_->require_token(ctx);
    return write_data_root_clip(state_->config.data_root, request, state_->config.data_root_quota);
  });
}

ClipFile ManifoldCore::delete_clip(const CallContext& ctx, const std::string& path) {
  return state_->call("delete_clip", ctx, [&] {
    state_->require_token(ctx);
    auto clip = delete_data_root_clip(state_->config.data_root, path);
    spdlog::info("uploaded clip {} deleted", clip.path);
    return clip;
  });
}

JobInfo ManifoldCore::submit_job(const CallContext& ctx, const JobSpec& spec) {
  return state_->call("submit_job", ctx, [&] {
    state_->require_token(ctx);
    // Whose queue it joins: the token's when there is one (one token: every
    // caller holding it), else the address's (loopback only, then).
    const std::string submitter = state_->config.auth_token.empty() ? "ip:" + ctx.peer_ip : "token";
    auto job = state_->training().submit(spec, submitter);
    spdlog::info("job {} queued: {} on {}", job.id, spec.variant, spec.dataset);
    return job;
  });
}

JobInfo ManifoldCore::get_job(const CallContext& ctx, const std::string& id) {
  return state_->call("get_job", ctx, [&] { return state_->training().get(id); });
}

std::vector<JobInfo> ManifoldCore::list_jobs(const CallContext& ctx) {
  return state_->call("list_jobs", ctx, [&] { return state_->training().list(); });
}

JobInfo ManifoldCore::cancel_job(const CallContext& ctx, const std::string& id) {
  return state_->call("cancel_job", ctx, [&] {
    state_->require_token(ctx);
    return state_->training().cancel(id);
  });
}

JobInfo ManifoldCore::delete_job(const CallContext& ctx, const std::string& id) {
  return state_->call("delete_job", ctx, [&] {
    state_->require_token(ctx);
    return state_->training().remove(id);
  });
}

WatchStreams::Slot ManifoldCore::begin_watch(const CallContext& ctx, const std::string& id) {
  // A watch lasts as long as the job: it is not an inference call and must
  // not hold drain() up, so it is counted as a call only while it starts.
  return state_->call("watch_job", ctx, [&] {
    state_->training().get(id);
    return state_->watch_streams.admit(ctx.peer_ip);
  });
}

void ManifoldCore::watch_job(WatchStreams::Slot slot, const std::string& id,
                             const std::function<bool(const JobInfo&)>& on_event, const std::atomic<bool>* stop) {
  if (!slot.held()) throw ApiError(ErrorCode::kInternal, "", "a job watch without a slot (begin_watch first)");
  state_->training().watch(id, on_event, stop);
}

void ManifoldCore::drain() {
  std::unique_lock<std::mutex> lock(state_->calls_mutex);
  state_->accepting = false;
  state_->calls_done.wait(lock, [this] { return state_->calls_in_flight == 0; });
}

}  // namespace mm::service
