// The one executor that owns the cores for inference. Every LibTorch call of
// the service runs on its single thread with as many intra-op threads as
// there are cores, instead of one call per connection thread with OpenMP
// threads of every call spinning on the same cores (16 concurrent calls on
// two cores took 18.9 s where one after the other took 24 ms each).
//
// Concurrent encodes, and concurrent decodes, of the same model and decoder
// are run as one batch (as Triton's dynamic batcher): the executor takes the
// first waiting request, then waits up to max_queue_delay_us for more of the
// same kind while other calls are on their way or while fewer requests are
// in the batch than were in flight together lately (clients answered by the
// last batch are about to call again: waiting for them turns two alternating
// half batches into one full one), up to max_batch clips. A lone client
// never waits. More than max_queue_length waiting requests are
// refused with RESOURCE_EXHAUSTED (429).
//
// Thread safety: every method may be called from any thread; each blocks
// until its work is done and rethrows what the work threw.
#pragma once

#include <ATen/ATen.h>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "server/engine/model_store.h"
#include "server/engine/thread_count_tuner.h"

namespace mm::service {

class ServiceMetrics;
struct BatchingConfig;

class InferenceExecutor {
 public:
  InferenceExecutor(const BatchingConfig& config, ServiceMetrics& metrics);
  ~InferenceExecutor();  // finishes the queue, then stops
  InferenceExecutor(const InferenceExecutor&) = delete;
  InferenceExecutor& operator=(const InferenceExecutor&) = delete;

  // Codes (n, latent) of motions already checked for the model (25 Hz, its
  // clip length and columns).
  at::Tensor encode(std::shared_ptr<const LoadedModel> model, std::vector<MotionFrames> motions);
  // Motions (25 Hz) of codes (n, latent) through one decoder.
  std::vector<MotionFrames> decode(std::shared_ptr<const LoadedModel> model, at::Tensor codes, DecoderKind kind);
  // Any other work (denoising), alone, with `threads` LibTorch intra-op
  // threads (0: as many as the latest batch chose). One thread suits a chain
  // of small sequential ops, such as a code fit's GRU steps forward and back
  // (JoinClips): beside a busy neighbour two threads spent 34 s of CPU on a
  // fit that took 14 s on one, waiting for each other.
  void run(const std::function<void()>& work, int threads = 0);

  // Announces a call that will reach the executor soon, so that a batch
  // waits for it (within max_queue_delay_us) rather than running without it.
  // The core holds one for each call in flight.
  class Expected {
   public:
    explicit Expected(InferenceExecutor& executor);
    ~Expected();
    Expected(const Expected&) = delete;
    Expected& operator=(const Expected&) = delete;

   private:
    InferenceExecutor& executor_;
  };

 private:
  struct Request;
  void enqueue(const std::shared_ptr<Request>& request);
  void loop();
  std::vector<std::shared_ptr<Request>> next_batch(std::unique_lock<std::mutex>& lock);
  void execute(const std::vector<std::shared_ptr<Request>>& batch);

  const int max_batch_, max_queue_delay_us_, max_queue_length_, threads_;
  // Chooses between threads_ and one thread by timing batches, unless the
  // operator fixed the count (--threads); the executor's thread owns it.
  const bool tune_threads_;
  ThreadCountTuner tuner_;
  int current_threads_ = 0;
  ServiceMetrics& metrics_;
  std::mutex mutex_;
  std::condition_variable arrived_;
  std::deque<std::shared_ptr<Request>> queue_;
  std::atomic<int> expected_{0};  // calls in flight that have not reached the queue or are in it
  // The most calls in flight at once in the current and the previous window
  // of about a second: how many clients are calling lately.
  std::atomic<int> window_peak_{0}, previous_window_peak_{0};
  std::atomic<int64_t> window_start_us_{0};
  int recent_concurrency() const;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace mm::service
