// motion-manifold-server: the long-running service. Wires the core (models,
// executor, metrics), the training jobs and the two frontends, then waits for
// SIGTERM or SIGINT: it stops accepting calls, lets those in flight finish,
// checkpoints the running training job (it resumes at the next start) and
// exits 0.
#include <malloc.h>
#include <signal.h>
#include <unistd.h>

#include <spdlog/pattern_formatter.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>

#include "server/core/caller_identity.h"
#include "server/core/service_metrics.h"
#include "server/engine/manifold_core.h"
#include "server/grpc/grpc_frontend.h"
#include "server/jobs/training_jobs.h"
#include "server/rest/rest_frontend.h"
#include "server/server_config.h"

namespace {

using namespace mm::service;

// %* in a log pattern: the message as a JSON string body (quotes, backslashes
// and control characters escaped), so that --log-format json writes one
// valid JSON object a line.
class JsonEscapedMessage : public spdlog::custom_flag_formatter {
 public:
  void format(const spdlog::details::log_msg& message, const std::tm&, spdlog::memory_buf_t& out) override {
    const std::string escaped = nlohmann::json(std::string(message.payload.data(), message.payload.size())).dump();
    out.append(escaped.data() + 1, escaped.data() + escaped.size() - 1);  // without the quotes
  }
  std::unique_ptr<custom_flag_formatter> clone() const override { return std::make_unique<JsonEscapedMessage>(); }
};

void configure_logging(const ServerConfig& config) {
  spdlog::set_level(spdlog::level::from_str(config.log_level));
  if (config.log_format == "json") {
    auto formatter = std::make_unique<spdlog::pattern_formatter>();
    formatter->add_flag<JsonEscapedMessage>('*').set_pattern(
        R"({"time":"%Y-%m-%dT%H:%M:%S.%e%z","level":"%l","pid":%P,"thread":%t,"message":"%*"})");
    spdlog::set_formatter(std::move(formatter));
  } else {
    spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e%z %l %v");
  }
}

// Written atomically (temporary file, then rename): a reader sees all of it or nothing.
void write_ready_file(const std::string& path, int grpc_port, int rest_port) {
  const nlohmann::json ready = {{"grpc_port", grpc_port}, {"rest_port", rest_port}, {"pid", getpid()}};
  const std::string temporary = path + ".tmp";
  std::ofstream(temporary) << ready.dump() << "\n";
  std::filesystem::rename(temporary, path);
}

// Says at start what a listener beyond loopback exposes: without a token
// the network may read and call but not change state; without TLS the token
// and the motions cross the network in the clear.
void warn_when_exposed(const ServerConfig& config) {
  if (!listens_beyond_loopback(config.grpc.address) && !listens_beyond_loopback(config.rest.address)) return;
  const bool tls = !config.grpc.tls_cert_file.empty();
  if (config.core.auth_token.empty()) {
    spdlog::warn("listening beyond loopback ({}) without a token: calls that change state{} are refused except from "
                 "loopback; give --auth-token-file FILE to allow them from the network",
                 config.grpc.address, config.core.public_clips ? "" : " and clip reads");
  }
  if (!tls) {
    spdlog::warn("listening beyond loopback ({}) without TLS: {}motions travel unencrypted; give --tls-cert and "
                 "--tls-key, or listen on 127.0.0.1 behind a proxy that terminates TLS",
                 config.grpc.address, config.core.auth_token.empty() ? "" : "the bearer token and ");
  }
}

}  // namespace

int main(int argc, char** argv) {
  ServerConfig config;
  if (const int code = parse_server_config(argc, argv, config); code >= 0) return code;
  configure_logging(config);

  // Every thread started from here on inherits the blocked set, so the
  // signals reach only sigwait below.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  signal(SIGPIPE, SIG_IGN);  // a client that hangs up is not a reason to die
  // A take's buffers are megabytes, allocated on whichever connection
  // thread serves it. glibc raises its mmap threshold after such a block
  // is freed, and later ones then stay in that thread's arena: the peak
  // grew by about 25 MiB with every take. A fixed threshold keeps large
  // blocks mapped apart, given back to the system when freed.
  mallopt(M_MMAP_THRESHOLD, 1 << 20);

  try {
    ServiceMetrics metrics;
    std::unique_ptr<TrainingJobs> jobs;
    if (!config.jobs.state_dir.empty()) {
      jobs = std::make_unique<TrainingJobs>(config.jobs, [](const std::string& name) {
        spdlog::info("training job published model {}", name);
      });
    }
    ManifoldCore core(config.core, metrics, jobs.get());
    if (jobs) jobs->start();  // before the core, whose metrics read the jobs
    core.start();

    GrpcFrontend grpc(core, config.grpc);
    grpc.start();
    grpc.set_serving(true);
    RestFrontend rest(core, metrics, config.rest);
    rest.start();
    spdlog::info("serving gRPC on {}:{} and REST on {}:{}{}", config.grpc.address, grpc.port(), config.rest.address,
                 rest.port(), config.grpc.tls_cert_file.empty() ? "" : " (TLS)");
    warn_when_exposed(config);
    if (!config.ready_file.empty()) write_ready_file(config.ready_file, grpc.port(), rest.port());

    int signal_number = 0;
    sigwait(&stop_signals, &signal_number);
    spdlog::info("{}: stopping: draining calls in flight", strsignal(signal_number));
    grpc.set_serving(false);
    core.drain();
    grpc.shutdown(std::chrono::seconds(10));
    rest.shutdown();
    if (jobs) jobs->shutdown();
    spdlog::info("stopped");
    return 0;
  } catch (const ApiError& e) {
    spdlog::critical("cannot start: {}{}{}", e.field(), e.field().empty() ? "" : ": ", e.what());
    return 1;
  } catch (const std::exception& e) {
    spdlog::critical("cannot start: {}", e.what());
    return 1;
  }
}
