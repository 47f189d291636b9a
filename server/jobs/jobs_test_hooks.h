// Hooks that let a test act at a chosen point of a job's life, as another
// replica sharing the database would; the server passes none. Given to
// TrainingJobs' second constructor, never part of JobsConfig.
#pragma once

#include <functional>
#include <string>

namespace mm::service {

struct JobsTestHooks {
  // Called on the worker thread between putting a finished job's model in
  // place and committing its record; tests write another replica's cancel
  // there.
  std::function<void(const std::string& job_id)> before_publication_commit;
  // Called in cancel() between reading the job's record and committing the
  // cancel; tests finish the job there as another replica would.
  std::function<void(const std::string& job_id)> before_cancel_commit;
};

}  // namespace mm::service
