// Watching a job to its end across server restarts: WatchJob again after
// UNAVAILABLE or a broken stream, with exponential backoff, until a record
// in a final state arrives. The server keeps jobs in its --state-dir and
// resumes them after a restart, so the job outlives the connection.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "client/cli/server_connection.h"

namespace mm::client {

struct WatchOptions {
  double first_backoff_seconds = 0.25;
  double max_backoff_seconds = 5;
  // Give up after this long without reaching the server (0: never).
  double give_up_after_seconds = 600;
};

// Returns the job's final record. `connect_again` makes a fresh connection
// for each attempt; `on_record` sees every record; `on_retry` is told of each
// lost connection (the error and the seconds until the next try). Throws
// the ServerError of a refusal that is not UNAVAILABLE (an unknown id), or
// the last UNAVAILABLE once give_up_after_seconds have passed without a record.
v1::Job watch_until_final(const std::string& id,
                          const std::function<std::unique_ptr<ServerConnection>()>& connect_again,
                          const std::function<void(const v1::Job&)>& on_record,
                          const std::function<void(const std::string&, double)>& on_retry,
                          const WatchOptions& options = {});

}  // namespace mm::client
