#include "server/core/service_metrics.h"

#include <prometheus/counter.h>
#include <prometheus/family.h>
#include <prometheus/gauge.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>
#include <prometheus/text_serializer.h>


namespace mm::service {
namespace {

// Latency buckets in seconds: a batch-1 decode of the default model takes
// about 25 ms on two cores, a batch of 30 about half a second.
const prometheus::Histogram::BucketBoundaries kLatencyBuckets = {0.001, 0.0025, 0.005, 0.01, 0.025, 0.05,
                                                                  0.1,   0.25,   0.5,   1,    2.5,   5, 10};
const prometheus::Histogram::BucketBoundaries kBatchBuckets = {1, 2, 4, 8, 16, 32, 64, 128};
const prometheus::Histogram::BucketBoundaries kLoadBuckets = {0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30};

}  // namespace

struct ServiceMetrics::State {
  std::shared_ptr<prometheus::Registry> registry = std::make_shared<prometheus::Registry>();
  prometheus::Family<prometheus::Counter>& requests =
      prometheus::BuildCounter()
          .Name("mm_requests_total")
          .Help("Calls answered, by operation, protocol and status code")
          .Register(*registry);
  prometheus::Family<prometheus::Counter>& errors = prometheus::BuildCounter()
                                                        .Name("mm_request_errors_total")
                                                        .Help("Calls answered with an error, by operation, "
                                                              "protocol and status code")
                                                        .Register(*registry);
  prometheus::Family<prometheus::Histogram>& latency = prometheus::BuildHistogram()
                                                           .Name("mm_request_duration_seconds")
                                                           .Help("Time in the core per call, by operation and "
                                                                 "protocol")
                                                           .Register(*registry);
  prometheus::Family<prometheus::Histogram>& batches = prometheus::BuildHistogram()
                                                           .Name("mm_batch_clips")
                                                           .Help("Clips per batch the inference executor ran, "
                                                                 "by operation")
                                                           .Register(*registry);
  prometheus::Gauge& queue_depth = prometheus::BuildGauge()
                                       .Name("mm_queue_depth")
                                       .Help("Requests waiting for the inference executor")
                                       .Register(*registry)
                                       .Add({});
  prometheus::Family<prometheus::Gauge>& jobs =
      prometheus::BuildGauge().Name("mm_jobs").Help("Training jobs by state").Register(*registry);
  prometheus::Gauge& watch_streams = prometheus::BuildGauge()
                                        .Name("mm_watch_streams")
                                        .Help("Job watch streams open (REST event streams and gRPC WatchJob)")
                                        .Register(*registry)
                                        .Add({});
  prometheus::Family<prometheus::Histogram>& model_load = prometheus::BuildHistogram()
                                                              .Name("mm_model_load_seconds")
                                                              .Help("Time to load a model, by model and outcome")
                                                              .Register(*registry);
};

ServiceMetrics::ServiceMetrics() : state_(std::make_unique<State>()) {
  for (JobState s : {JobState::kQueued, JobState::kRunning, JobState::kSucceeded, JobState::kFailed,
                     JobState::kCancelled}) {
    state_->jobs.Add({{"state", job_state_name(s)}}).Set(0);
  }
}

ServiceMetrics::~ServiceMetrics() = default;

void ServiceMetrics::observe_request(const std::string& operation, const std::string& protocol,
                                     const std::string& code, double seconds) {
  const std::map<std::string, std::string> labels = {{"operation", operation}, {"protocol", protocol}};
  state_->requests.Add({{"operation", operation}, {"protocol", protocol}, {"code", code}}).Increment();
  if (code != "OK") {
    state_->errors.Add({{"operation", operation}, {"protocol", protocol}, {"code", code}}).Increment();
  }
  state_->latency.Add(labels, kLatencyBuckets).Observe(seconds);
}

void ServiceMetrics::observe_batch(const std::string& operation, int clips) {
  state_->batches.Add({{"operation", operation}}, kBatchBuckets).Observe(clips);
}

void ServiceMetrics::set_queue_depth(int requests) { state_->queue_depth.Set(requests); }

void ServiceMetrics::set_job_counts(const std::map<JobState, int>& counts) {
  for (const auto& [state, count] : counts) state_->jobs.Add({{"state", job_state_name(state)}}).Set(count);
}

void ServiceMetrics::set_watch_streams(int open) { state_->watch_streams.Set(open); }

void ServiceMetrics::observe_model_load(const std::string& model, double seconds, bool ok) {
  state_->model_load.Add({{"model", model}, {"outcome", ok ? "ok" : "failed"}}, kLoadBuckets).Observe(seconds);
}

std::string ServiceMetrics::text() const {
  return prometheus::TextSerializer().Serialize(state_->registry->Collect());
}

}  // namespace mm::service
