#include "client/cli/job_watch.h"

#include <algorithm>
#include <chrono>
#include <thread>

#include "client/cli/server_error.h"

namespace mm::client {

v1::Job watch_until_final(const std::string& id,
                          const std::function<std::unique_ptr<ServerConnection>()>& connect_again,
                          const std::function<void(const v1::Job&)>& on_record,
                          const std::function<void(const std::string&, double)>& on_retry,
                          const WatchOptions& options) {
  using Clock = std::chrono::steady_clock;
  v1::Job last;
  double backoff = options.first_backoff_seconds;
  auto last_contact = Clock::now();
  for (;;) {
    try {
      auto connection = connect_again();
      connection->watch_job(id, [&](const v1::Job& job) {
        last = job;
        // Any record proves the server back: the next loss starts afresh.
        backoff = options.first_backoff_seconds;
        last_contact = Clock::now();
        on_record(job);
      });
      return last;
    } catch (const ServerError& e) {
      if (!e.retryable()) throw;
      const double waited = std::chrono::duration<double>(Clock::now() - last_contact).count();
      if (options.give_up_after_seconds > 0 && waited > options.give_up_after_seconds) throw;
      on_retry(e.what(), backoff);
      std::this_thread::sleep_for(std::chrono::duration<double>(backoff));
      backoff = std::min(options.max_backoff_seconds, backoff * 2);
    }
  }
}

}  // namespace mm::client
