// jobs submit | watch | list | get | cancel | delete: training runs on the server.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>

#include "client/cli/commands.h"
#include "client/cli/job_watch.h"
#include "client/cli/progress_display.h"
#include "client/cli/server_connection.h"
#include "client/cli/server_error.h"
#include "format/input_error.h"
#include "wire/rest_json.h"

namespace mm::client {

// --json prints a reply as REST answers it, written by the same code.
using ::mm::wire::to_json;
namespace {

void print_job_line(const v1::Job& job) {
  std::printf("%-20s %-10s %-6s %s\n", job.id().c_str(), job.state().c_str(), job.spec().variant().c_str(),
              progress_text(job).c_str());
}

// Watches to the end (reconnecting), drawing progress; exit 0 only when the
// job succeeded, so that `submit --watch && next-step` chains.
int watch(const ClientSettings& settings, const std::string& id, double give_up_after) {
  const bool terminal = isatty(STDOUT_FILENO) == 1;
  ProgressDisplay display(stdout, terminal && !settings.json);
  WatchOptions options;
  options.give_up_after_seconds = give_up_after;
  const auto job = watch_until_final(
      id, [&settings] { return connect(settings.connection); },
      [&](const v1::Job& record) {
        if (settings.json) {
          std::printf("%s\n", to_json(record).dump().c_str());  // one record a line
          std::fflush(stdout);
        } else {
          display.show(record);
        }
      },
      [&](const std::string& error, double backoff) {
        display.break_line();
        std::fprintf(stderr, "connection lost (%s); watching again in %.1f s\n", error.c_str(), backoff);
      },
      options);
  display.break_line();
  if (job.state() == "succeeded") return kExitSuccess;
  std::fprintf(stderr, "error: job %s %s%s%s\n", job.id().c_str(), job.state().c_str(),
               job.error().empty() ? "" : ": ", job.error().c_str());
  return kExitServerError;
}

std::string read_config(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("--config " + path + ": cannot open the file");
  std::stringstream text;
  text << in.rdbuf();
  if (nlohmann::json::parse(text.str(), nullptr, false).is_discarded()) {
    throw InputError("--config " + path + ": not JSON");
  }
  return text.str();
}

}  // namespace

void add_job_commands(CLI::App& app, const ClientSettings& settings, Action& action) {
  auto* jobs = app.add_subcommand("jobs", "Training jobs: submit, watch, list, get, cancel, delete");
  jobs->require_subcommand(1);

  struct SubmitOptions {
    v1::JobSpec spec;
    std::string dataset, variant, config, model_name;
    int64_t iterations = 0;
    uint64_t seed = 0;
    int hidden = 0, batch = 0;
    bool watch = false;
    double give_up_after = 600;
  };
  auto s = std::make_shared<SubmitOptions>();
  auto* submit = jobs->add_subcommand("submit", "Queue a training run (needs the token); prints the job's id");
  submit->add_option("--dataset", s->dataset, "prepared .mmd file or H3.6M text tree, under the server's --data-root")
      ->required();
  submit->add_option("--variant", s->variant, "S, D, DK, DKG, DKGM (the server's default), DKGMZ or Seq2seq");
  submit->add_option("--config", s->config, "training configuration JSON file (replaces --variant)");
  submit->add_option("--iterations", s->iterations, "training iterations (default: the configuration's)");
  submit->add_option("--seed", s->seed, "the run's random seed");
  submit->add_option("--hidden", s->hidden, "GRU hidden size (default: the configuration's)");
  submit->add_option("--batch", s->batch, "clips per batch (default: the configuration's)");
  submit->add_option("--model-name", s->model_name, "name of the published model (default: job-<id>)");
  submit->add_flag("--watch", s->watch, "then watch it to the end, as jobs watch");
  submit->callback([s, &settings, &action] {
    action = [s, &settings] {
      v1::JobSpec spec;
      spec.set_dataset(s->dataset);
      spec.set_variant(s->variant);
      if (!s->config.empty()) spec.set_config_json(read_config(s->config));
      spec.set_iterations(s->iterations);
      spec.set_seed(s->seed);
      spec.set_hidden(s->hidden);
      spec.set_batch(s->batch);
      spec.set_model_name(s->model_name);
      const auto job = connect(settings.connection)->submit_job(spec);
      if (settings.json) {
        std::printf("%s\n", to_json(job).dump(s->watch ? -1 : 2).c_str());
      } else {
        std::printf("%s\n", job.id().c_str());
      }
      std::fflush(stdout);
      return s->watch ? watch(settings, job.id(), s->give_up_after) : kExitSuccess;
    };
  });

  struct WatchArgs {
    std::string id;
    double give_up_after = 600;
  };
  auto w = std::make_shared<WatchArgs>();
  auto* watch_command = jobs->add_subcommand(
      "watch", "Follow a job to its end: a progress bar on a terminal, a line per change otherwise (one JSON record "
               "a line with --json). Survives server restarts: it reconnects with backoff. Exit 0 when the job "
               "succeeded, 1 otherwise.");
  watch_command->add_option("id", w->id, "job id")->required();
  watch_command->add_option("--give-up-after", w->give_up_after,
                            "seconds without reaching the server before giving up (0: never)")
      ->capture_default_str();
  watch_command->callback([w, &settings, &action] {
    action = [w, &settings] { return watch(settings, w->id, w->give_up_after); };
  });

  jobs->add_subcommand("list", "Every job, newest first")->callback([&settings, &action] {
    action = [&settings] {
      const auto reply = connect(settings.connection)->list_jobs();
      if (settings.json) {
        print_json(to_json(reply));
      } else {
        // The columns print_job_line fills; nothing under it when there is no job.
        if (reply.jobs_size() > 0) std::printf("%-20s %-10s %-6s %s\n", "ID", "STATE", "VARIANT", "PROGRESS");
        for (const auto& job : reply.jobs()) print_job_line(job);
      }
      return kExitSuccess;
    };
  });

  auto get_id = std::make_shared<std::string>();
  auto* get = jobs->add_subcommand("get", "One job's record");
  get->add_option("id", *get_id, "job id")->required();
  get->callback([get_id, &settings, &action] {
    action = [get_id, &settings] {
      const auto job = connect(settings.connection)->get_job(*get_id);
      if (settings.json) {
        print_json(to_json(job));
      } else {
        print_job_line(job);
        // What the job trains, whole: the spec resolved at submission.
        if (!job.resolved_config_json().empty()) {
          std::printf("configuration: %s\n", to_json(job)["resolved_config"].dump().c_str());
        }
      }
      return kExitSuccess;
    };
  });

  auto cancel_id = std::make_shared<std::string>();
  auto* cancel = jobs->add_subcommand("cancel", "Cancel a queued or running job (needs the token)");
  cancel->add_option("id", *cancel_id, "job id")->required();
  cancel->callback([cancel_id, &settings, &action] {
    action = [cancel_id, &settings] {
      const auto job = connect(settings.connection)->cancel_job(*cancel_id);
      if (settings.json) {
        print_json(to_json(job));
      } else {
        print_job_line(job);
      }
      return kExitSuccess;
    };
  });

  auto delete_id = std::make_shared<std::string>();
  auto* remove = jobs->add_subcommand(
      "delete", "Remove a finished job's record and its folder on the server (log, checkpoint, run); the model it "
                "published stays (needs the token)");
  remove->add_option("id", *delete_id, "job id")->required();
  remove->callback([delete_id, &settings, &action] {
    action = [delete_id, &settings] {
      const auto job = connect(settings.connection)->delete_job(*delete_id);
      if (settings.json) {
        print_json(to_json(job));
      } else {
        std::printf("deleted job: ");
        print_job_line(job);
      }
      return kExitSuccess;
    };
  });
}

}  // namespace mm::client
