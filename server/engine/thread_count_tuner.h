// Chooses the executor's LibTorch thread count batch by batch, by timing
// both: all the CPUs the process may use, or one. On an idle machine all
// are faster; beside another busy process (a build, a second service, the
// machine's other tenant) threads that meet at every parallel region wait
// for the one that shares its core, and one thread is faster by 2x
// (docs/PERFORMANCE.md, "Under CPU contention"). Nothing the process can
// read says which case it is in, so it measures: batches of the same kind
// (operation, model and clip count) are timed with the count chosen so far,
// and every explore_every-th one with the other, and the count whose recent
// batches were faster is kept. A kind's first batch and a batch that pays
// for growing the thread team are not timed.
//
// Torch-free. Thread safety: none; the executor's one thread owns it.
#pragma once

#include <map>
#include <string>

namespace mm::service {

class ThreadCountTuner {
 public:
  // `most_threads` < 2: always that many (nothing to choose).
  explicit ThreadCountTuner(int most_threads, int explore_every = 24);

  // The thread count to run the next batch of `kind` with.
  int threads_for(const std::string& kind);
  // How long that batch took with `threads` threads.
  void record(const std::string& kind, int threads, double seconds);
  // The count chosen most lately, for work that has no kind of its own.
  int latest_choice() const { return latest_; }

 private:
  struct Timings {
    double seconds[2] = {0, 0};  // recent mean with most_threads_ [0] and 1 thread [1]
    int samples[2] = {0, 0};
    int batches = 0;
    bool warmed = false;  // its first batch ran
  };
  int chosen(const Timings& timings) const;

  int most_threads_;
  int explore_every_;
  int latest_;
  int previous_threads_;  // the count of the last batch recorded, of any kind
  std::map<std::string, Timings> kinds_;
};

}  // namespace mm::service
