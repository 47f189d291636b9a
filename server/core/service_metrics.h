// The service's Prometheus metrics (prometheus-cpp), served as text at
// /metrics: requests, errors and latency per operation and protocol, batch
// sizes and queue depth of the inference executor, jobs per state, model load
// times and the job watch streams open. Torch-free.
// Thread safety: every method may be called concurrently.
#pragma once

#include <map>
#include <memory>
#include <string>

#include "server/api/api_types.h"

namespace mm::service {

class ServiceMetrics {
 public:
  ServiceMetrics();
  ~ServiceMetrics();
  ServiceMetrics(const ServiceMetrics&) = delete;
  ServiceMetrics& operator=(const ServiceMetrics&) = delete;

  // One finished call: `code` is "OK" or an error_code_name().
  void observe_request(const std::string& operation, const std::string& protocol, const std::string& code,
                       double seconds);
  // One batch the executor ran, in clips.
  void observe_batch(const std::string& operation, int clips);
  void set_queue_depth(int requests);
  void set_job_counts(const std::map<JobState, int>& counts);
  void set_watch_streams(int open);  // job watch streams open, both protocols
  void observe_model_load(const std::string& model, double seconds, bool ok);

  // Every metric in the Prometheus text exposition format.
  std::string text() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace mm::service
