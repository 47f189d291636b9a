#include "server/engine/inference_executor.h"

#include <ATen/Parallel.h>

#include <chrono>
#include <future>

#include "model/latent_operations.h"
#include "model/usable_cpus.h"
#include "server/core/core_config.h"
#include "server/core/service_metrics.h"

#include <spdlog/spdlog.h>

namespace mm::service {

using Clock = std::chrono::steady_clock;

struct InferenceExecutor::Request {
  enum class Kind { kEncode, kDecode, kTask } kind = Kind::kTask;
  std::shared_ptr<const LoadedModel> model;
  DecoderKind decoder = DecoderKind::kRotation;
  std::vector<MotionFrames> motions;  // encode's input, decode's output
  at::Tensor codes;                   // decode's input, encode's output
  std::function<void()> task;
  int task_threads = 0;  // a task's intra-op threads; 0: the tuner's latest choice
  int clips = 0;
  std::promise<void> done;

  bool batches_with(const Request& other) const {
    return kind != Kind::kTask && kind == other.kind && model == other.model &&
           (kind == Kind::kEncode || decoder == other.decoder);
  }
  const char* operation() const { return kind == Kind::kEncode ? "encode" : kind == Kind::kDecode ? "decode" : "task"; }
};

InferenceExecutor::InferenceExecutor(const BatchingConfig& config, ServiceMetrics& metrics)
    : max_batch_(std::max(1, config.max_batch)),
      max_queue_delay_us_(std::max(0, config.max_queue_delay_us)),
      max_queue_length_(std::max(1, config.max_queue_length)),
      threads_(config.threads > 0 ? config.threads : usable_cpu_count()),
      tune_threads_(config.threads <= 0),
      tuner_(threads_),
      metrics_(metrics),
      thread_([this] { loop(); }) {}

InferenceExecutor::~InferenceExecutor() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  arrived_.notify_all();
  thread_.join();
}

namespace {
int64_t now_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(Clock::now().time_since_epoch()).count();
}
constexpr int64_t kConcurrencyWindowUs = 1000000;
}  // namespace

InferenceExecutor::Expected::Expected(InferenceExecutor& executor) : executor_(executor) {
  const int in_flight = ++executor_.expected_;
  const int64_t now = now_us();
  int64_t start = executor_.window_start_us_.load();
  if (now - start > kConcurrencyWindowUs && executor_.window_start_us_.compare_exchange_strong(start, now)) {
    executor_.previous_window_peak_.store(executor_.window_peak_.exchange(0));
  }
  int peak = executor_.window_peak_.load();
  while (in_flight > peak && !executor_.window_peak_.compare_exchange_weak(peak, in_flight)) {
  }
}

int InferenceExecutor::recent_concurrency() const {
  // A window that ended long ago says nothing about now.
  if (now_us() - window_start_us_.load() > 2 * kConcurrencyWindowUs) return 1;
  return std::max(window_peak_.load(), previous_window_peak_.load());
}

InferenceExecutor::Expected::~Expected() {
  --executor_.expected_;
  // A batch may be waiting only for this call.
  executor_.arrived_.notify_all();
}

void InferenceExecutor::enqueue(const std::shared_ptr<Request>& request) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) throw ApiError(ErrorCode::kUnavailable, "", "the server is shutting down");
    if (static_cast<int>(queue_.size()) >= max_queue_length_) {
      throw ApiError(ErrorCode::kResourceExhausted, "",
                     "the inference queue is full (max_queue_length: " + std::to_string(max_queue_length_) +
                         " requests waiting); retry later");
    }
    queue_.push_back(request);
    metrics_.set_queue_depth(static_cast<int>(queue_.size()));
  }
  arrived_.notify_all();
  request->done.get_future().get();  // rethrows the work's exception
}

at::Tensor InferenceExecutor::encode(std::shared_ptr<const LoadedModel> model, std::vector<MotionFrames> motions) {
  auto request = std::make_shared<Request>();
  request->kind = Request::Kind::kEncode;
  request->model = std::move(model);
  request->clips = static_cast<int>(motions.size());
  request->motions = std::move(motions);
  enqueue(request);
  return request->codes;
}

std::vector<MotionFrames> InferenceExecutor::decode(std::shared_ptr<const LoadedModel> model, at::Tensor codes,
                                                    DecoderKind kind) {
  auto request = std::make_shared<Request>();
  request->kind = Request::Kind::kDecode;
  request->model = std::move(model);
  request->decoder = kind;
  request->clips = static_cast<int>(codes.size(0));
  request->codes = std::move(codes);
  enqueue(request);
  return std::move(request->motions);
}

void InferenceExecutor::run(const std::function<void()>& work, int threads) {
  auto request = std::make_shared<Request>();
  request->task = work;
  request->task_threads = threads;
  request->clips = 1;
  enqueue(request);
}

std::vector<std::shared_ptr<InferenceExecutor::Request>> InferenceExecutor::next_batch(
    std::unique_lock<std::mutex>& lock) {
  std::vector<std::shared_ptr<Request>> batch{queue_.front()};
  queue_.pop_front();
  if (batch.front()->kind == Request::Kind::kTask) return batch;
  int clips = batch.front()->clips;
  const auto deadline = Clock::now() + std::chrono::microseconds(max_queue_delay_us_);
  while (clips < max_batch_) {
    // Take every waiting request that fits into this batch.
    for (auto it = queue_.begin(); it != queue_.end() && clips < max_batch_;) {
      if ((*it)->batches_with(*batch.front()) && clips + (*it)->clips <= max_batch_) {
        clips += (*it)->clips;
        batch.push_back(*it);
        it = queue_.erase(it);
      } else {
        ++it;
      }
    }
    // Wait only for calls still on their way: those in flight that are
    // neither in this batch nor already queued (for another batch).
    const int on_their_way = expected_.load() - static_cast<int>(batch.size()) - static_cast<int>(queue_.size());
    const bool more_lately = recent_concurrency() > static_cast<int>(batch.size() + queue_.size());
    if (clips >= max_batch_ || (on_their_way <= 0 && !more_lately) || Clock::now() >= deadline) break;
    arrived_.wait_until(lock, deadline);
  }
  return batch;
}

void InferenceExecutor::execute(const std::vector<std::shared_ptr<Request>>& batch) {
  const Request& first = *batch.front();
  int clips = 0;
  for (const auto& request : batch) clips += request->clips;
  if (first.kind != Request::Kind::kTask) metrics_.observe_batch(first.operation(), clips);
  // Batches of one kind take alike: the tuner compares their times.
  const std::string kind = first.kind == Request::Kind::kTask
                               ? std::string()
                               : std::string(first.operation()) + " " + first.model->name + " " + first.model->version +
                                     " " + std::to_string(static_cast<int>(first.decoder)) + " " +
                                     std::to_string(clips);
  const int threads = first.task_threads > 0 ? first.task_threads
                      : !tune_threads_       ? threads_
                      : kind.empty()         ? tuner_.latest_choice()
                                             : tuner_.threads_for(kind);
  if (threads != current_threads_) {
    at::set_num_threads(threads);
    current_threads_ = threads;
  }
  const auto started = Clock::now();
  try {
    if (first.kind == Request::Kind::kTask) {
      first.task();
    } else if (first.kind == Request::Kind::kEncode) {
      std::vector<MotionFrames> motions;
      motions.reserve(static_cast<size_t>(clips));
      for (const auto& request : batch) {
        for (auto& motion : request->motions) motions.push_back(std::move(motion));
      }
      const at::Tensor codes = encode_motions(first.model->model, motions);
      int64_t row = 0;
      for (const auto& request : batch) {
        request->codes = codes.narrow(0, row, request->clips).clone();
        row += request->clips;
      }
    } else {
      std::vector<at::Tensor> parts;
      for (const auto& request : batch) parts.push_back(request->codes);
      auto motions = decode_codes(first.model->model, at::cat(parts), first.decoder);
      size_t row = 0;
      for (const auto& request : batch) {
        request->motions.assign(std::make_move_iterator(motions.begin() + static_cast<std::ptrdiff_t>(row)),
                                std::make_move_iterator(motions.begin() +
                                                        static_cast<std::ptrdiff_t>(row + request->clips)));
        row += static_cast<size_t>(request->clips);
      }
    }
    const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
    if (!kind.empty()) tuner_.record(kind, threads, seconds);
    spdlog::debug("executor: {} of {} clips in {} requests took {:.1f} ms with {} threads", first.operation(), clips,
                  batch.size(), seconds * 1000, threads);
    for (const auto& request : batch) request->done.set_value();
  } catch (...) {
    for (const auto& request : batch) request->done.set_exception(std::current_exception());
  }
}

void InferenceExecutor::loop() {
  // The executor's thread owns the cores: LibTorch's intra-op threads are set
  // here, for the thread that runs every inference.
  at::set_num_threads(threads_);
  current_threads_ = threads_;
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    arrived_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
    if (queue_.empty()) return;  // stopping, nothing left
    auto batch = next_batch(lock);
    metrics_.set_queue_depth(static_cast<int>(queue_.size()));
    lock.unlock();
    execute(batch);
    lock.lock();
  }
}

}  // namespace mm::service
