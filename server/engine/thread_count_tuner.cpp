#include "server/engine/thread_count_tuner.h"

namespace mm::service {

namespace {

// Weight of the newest batch in a kind's recent mean: a few batches follow a
// change of load, one outlier does not flip the choice.
constexpr double kNewestWeight = 0.3;

}  // namespace

ThreadCountTuner::ThreadCountTuner(int most_threads, int explore_every)
    : most_threads_(most_threads < 1 ? 1 : most_threads),
      explore_every_(explore_every < 2 ? 2 : explore_every),
      latest_(most_threads_),
      previous_threads_(most_threads_) {}

int ThreadCountTuner::chosen(const Timings& timings) const {
  if (timings.samples[1] == 0) return most_threads_;
  return timings.seconds[1] < timings.seconds[0] ? 1 : most_threads_;
}

int ThreadCountTuner::threads_for(const std::string& kind) {
  if (most_threads_ < 2) return most_threads_;
  Timings& timings = kinds_[kind];
  int threads = chosen(timings);
  // The first batches of a kind measure the machine's default; then every
  // explore_every-th batch tries the other count, so a change of load is
  // noticed. Trying more threads takes two batches: the first pays for
  // growing the team and is not timed.
  const int phase = timings.samples[0] > 0 ? ++timings.batches % explore_every_ : -1;
  const bool explore = phase == 0 || (phase == 1 && threads == 1);
  if (explore || (timings.samples[0] > 1 && timings.samples[1] == 0)) threads = threads == 1 ? most_threads_ : 1;
  if (!explore) latest_ = chosen(timings);
  return threads;
}

void ThreadCountTuner::record(const std::string& kind, int threads, double seconds) {
  if (most_threads_ < 2) return;
  Timings& timings = kinds_[kind];
  // Batches that pay for something else are not timed: a kind's first (its
  // buffers and caches cold) and one right after the count grew (the OpenMP
  // team woken and grown: measured 48 ms for a 20 ms batch-1 decode; going
  // down to one thread cost nothing measurable). Timed, they made two
  // threads look slower than one, and one client stayed on one thread.
  const bool first_of_kind = !timings.warmed;
  timings.warmed = true;
  const bool after_growth = threads > previous_threads_;
  previous_threads_ = threads;
  if (first_of_kind || after_growth) return;
  const int slot = threads == 1 ? 1 : 0;
  timings.seconds[slot] = timings.samples[slot] == 0
                              ? seconds
                              : kNewestWeight * seconds + (1 - kNewestWeight) * timings.seconds[slot];
  ++timings.samples[slot];
  latest_ = chosen(timings);
}

}  // namespace mm::service
