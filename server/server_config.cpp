#include "server/server_config.h"

#include <CLI/CLI.hpp>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <thread>
#include <vector>

#include "format/input_error.h"
#include "server/jobs/job_spec_check.h"

namespace mm::service {
namespace {

// The tool that runs training jobs: beside the server when installed, in the
// build tree when run from there, else on PATH.
std::string default_tool_path() {
  std::error_code error;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    const auto beside = self.parent_path() / "motion-manifold";
    if (std::filesystem::is_regular_file(beside, error)) return beside.string();
  }
#ifdef MM_BUILD_TOOL
  if (std::filesystem::is_regular_file(MM_BUILD_TOOL, error)) return MM_BUILD_TOOL;
#endif
  return "motion-manifold";
}

}  // namespace

int parse_server_config(int argc, char** argv, ServerConfig& config) {
  CLI::App app{"motion-manifold-server " MM_VERSION
               ": serves trained motion manifolds (Jang & Lee, CGF 2020) over gRPC and REST and runs training jobs.\n"
               "Every option can also be set in the --config file or by the environment variable in brackets (a flag wins over the file, the file over the environment)."};
  app.set_config("--config", "", "configuration file (TOML or INI: key = value, keys as the long options)");
  app.set_version_flag("--version", "motion-manifold-server " MM_VERSION);
  app.get_formatter()->column_width(40);

  config.core.model_store = MM_SOURCE_DIR "/models";
  config.jobs.tool_path = default_tool_path();
  config.rest.web_root = MM_SOURCE_DIR "/web";
  std::string address = "0.0.0.0", token_file;

  // The path defaults are this build's source and build tree: described,
  // not shown, since --help is read on other machines too.
  app.add_option("--model-store", config.core.model_store, "folder of model folders (default: models/ of the source tree)")
      ->envname("MM_MODEL_STORE");
  app.add_option("--default-model", config.core.default_model,
                 "model to activate at start (default: h36m-dkgm-h100, or the store's only model)")
      ->envname("MM_DEFAULT_MODEL");
  app.add_option("--address", address, "address both frontends listen on")->envname("MM_ADDRESS")->capture_default_str();
  app.add_option("--grpc-port", config.grpc.port, "gRPC port (0: any free port)")
      ->envname("MM_GRPC_PORT")->capture_default_str()->check(CLI::Range(0, 65535));
  app.add_option("--rest-port", config.rest.port, "REST port (0: any free port)")
      ->envname("MM_REST_PORT")->capture_default_str()->check(CLI::Range(0, 65535));
  app.add_option("--auth-token", config.core.auth_token,
                 "bearer token required on calls that change state (submit, cancel, activate, upload, delete) and on "
                 "clip reads; empty: those calls are taken only from loopback")
      ->envname("MM_AUTH_TOKEN");
  app.add_flag("--public-clips", config.core.public_clips,
               "ListClips and ReadClip open to every caller, without the token (default: they need it, or loopback)")
      ->envname("MM_PUBLIC_CLIPS");
  app.add_option("--auth-token-file", token_file, "file holding the bearer token (first line)")
      ->envname("MM_AUTH_TOKEN_FILE")->check(CLI::ExistingFile);
  app.add_option("--tls-cert", config.grpc.tls_cert_file, "PEM certificate: serve gRPC and REST over TLS")
      ->envname("MM_TLS_CERT")->check(CLI::ExistingFile);
  app.add_option("--tls-key", config.grpc.tls_key_file, "PEM private key of --tls-cert")
      ->envname("MM_TLS_KEY")->check(CLI::ExistingFile);

  int max_message_bytes = config.grpc.max_message_bytes;
  app.add_option("--max-message-bytes", max_message_bytes, "largest gRPC message and REST body, in bytes")
      ->envname("MM_MAX_MESSAGE_BYTES")->capture_default_str()->check(CLI::Range(1024, 1 << 30));
  app.add_option("--max-json-bytes", config.rest.max_json_bytes,
                 "largest REST JSON body of motions or codes, in bytes (refused by its declared length; files and "
                 "BVH bodies go up to --max-message-bytes)")
      ->envname("MM_MAX_JSON_BYTES")->capture_default_str()->check(CLI::Range(size_t{1024}, size_t{1} << 30));
  app.add_option("--max-motions", config.core.limits.max_motions,
                 "motions of one Encode or Denoise, codes of one Decode")
      ->envname("MM_MAX_MOTIONS")->capture_default_str()->check(CLI::Range(1, 4096));
  app.add_option("--max-sample-count", config.core.limits.max_sample_count, "Sample's largest count")
      ->envname("MM_MAX_SAMPLE_COUNT")->capture_default_str()->check(CLI::Range(1, 4096));
  app.add_option("--max-steps", config.core.limits.max_steps, "Interpolate's most steps")
      ->envname("MM_MAX_STEPS")->capture_default_str()->check(CLI::Range(2, 4096));
  app.add_option("--max-denoise-iterations", config.core.limits.max_denoise_iterations,
                 "Denoise's most rounds")
      ->envname("MM_MAX_DENOISE_ITERATIONS")->capture_default_str()->check(CLI::Range(1, 1000));
  app.add_option("--max-batch", config.core.batching.max_batch, "most clips the executor runs as one batch")
      ->envname("MM_MAX_BATCH")->capture_default_str()->check(CLI::Range(1, 4096));
  app.add_option("--max-queue-delay-us", config.core.batching.max_queue_delay_us,
                 "how long a batch waits for more requests, in microseconds")
      ->envname("MM_MAX_QUEUE_DELAY_US")->capture_default_str()->check(CLI::Range(0, 1000000));
  app.add_option("--max-queue-length", config.core.batching.max_queue_length,
                 "requests waiting for the executor beyond which calls are refused (429)")
      ->envname("MM_MAX_QUEUE_LENGTH")->capture_default_str()->check(CLI::Range(1, 1000000));
  app.add_option("--threads", config.core.batching.threads, "LibTorch threads of the executor (0: chosen by timing batches, the CPUs this process may use (affinity, cgroup CPU quota) or one)")
      ->envname("MM_THREADS")->capture_default_str()->check(CLI::Range(0, 1024));
  app.add_option("--rest-threads", config.rest.threads,
                 "REST worker threads: keep-alive connections served at once")
      ->envname("MM_REST_THREADS")->capture_default_str()->check(CLI::Range(1, 4096));
  // REST's limits on each connection (RestOptions says why each default).
  app.add_option("--rest-header-timeout-seconds", config.rest.header_timeout_seconds,
                 "a REST request's whole head (request line and headers) must arrive within this, from its "
                 "connection's start or the previous reply; else 408 and the connection is closed")
      ->envname("MM_REST_HEADER_TIMEOUT_SECONDS")->capture_default_str()->check(CLI::Range(0.1, 3600.0));
  app.add_option("--rest-body-timeout-seconds", config.rest.body_timeout_seconds,
                 "a REST request's whole body must arrive within this, from the end of its head; else 408 and the "
                 "connection is closed")
      ->envname("MM_REST_BODY_TIMEOUT_SECONDS")->capture_default_str()->check(CLI::Range(0.1, 86400.0));
  app.add_option("--rest-max-connections-per-client", config.rest.max_connections_per_client,
                 "REST connections open at once from one client address; more are answered 429 and closed (behind "
                 "a proxy every client has the proxy's address)")
      ->envname("MM_REST_MAX_CONNECTIONS_PER_CLIENT")->capture_default_str()->check(CLI::Range(1, 65536));
  app.add_option("--rest-max-line-bytes", config.rest.max_line_bytes,
                 "longest REST request line (else 414) or header line (else 431), without its CRLF")
      ->envname("MM_REST_MAX_LINE_BYTES")->capture_default_str()->check(CLI::Range(size_t{256}, size_t{8190}));
  app.add_option("--rest-max-headers", config.rest.max_headers, "most header fields of a REST request (else 431)")
      ->envname("MM_REST_MAX_HEADERS")->capture_default_str()->check(CLI::Range(size_t{8}, size_t{10000}));
  app.add_option("--rest-max-header-bytes", config.rest.max_header_bytes,
                 "largest REST request head, request line and header fields together (else 431)")
      ->envname("MM_REST_MAX_HEADER_BYTES")->capture_default_str()
      ->check(CLI::Range(size_t{1024}, size_t{1} << 20));
  auto* web_root = app.add_option("--web-root", config.rest.web_root,
                 "folder of the web page served at / over REST (default: web/ of the source tree, none when it is "
                 "absent; empty: no page)")
      ->envname("MM_WEB_ROOT");
  app.add_option("--grpc-threads", config.grpc.max_threads, "gRPC threads: calls served at once")
      ->envname("MM_GRPC_THREADS")->capture_default_str()->check(CLI::Range(2, 4096));
  // gRPC's limits on one connection (GrpcOptions says why each is set).
  app.add_option("--grpc-max-streams-per-connection", config.grpc.max_streams_per_connection,
                 "gRPC calls one connection may have open at once, fewer than --grpc-threads so that one client "
                 "cannot take every thread; HTTP/2's MAX_CONCURRENT_STREAMS is this plus "
                 "--max-watch-streams-per-client")
      ->envname("MM_GRPC_MAX_STREAMS_PER_CONNECTION")->capture_default_str()->check(CLI::Range(1, 4095));
  app.add_option("--grpc-keepalive-seconds", config.grpc.keepalive_seconds,
                 "the server pings a gRPC connection quiet this long (0: never)")
      ->envname("MM_GRPC_KEEPALIVE_SECONDS")->capture_default_str()->check(CLI::Range(0, 86400));
  app.add_option("--grpc-keepalive-timeout-seconds", config.grpc.keepalive_timeout_seconds,
                 "a gRPC connection whose peer does not answer the server's ping in this long is closed")
      ->envname("MM_GRPC_KEEPALIVE_TIMEOUT_SECONDS")->capture_default_str()->check(CLI::Range(1, 3600));
  app.add_option("--grpc-min-ping-interval-seconds", config.grpc.min_client_ping_interval_seconds,
                 "a gRPC client pinging more often than this without calls gets GOAWAY after two warnings")
      ->envname("MM_GRPC_MIN_PING_INTERVAL_SECONDS")->capture_default_str()->check(CLI::Range(1, 86400));
  app.add_option("--grpc-max-connection-idle-seconds", config.grpc.max_connection_idle_seconds,
                 "a gRPC connection without a call this long is closed (0: never)")
      ->envname("MM_GRPC_MAX_CONNECTION_IDLE_SECONDS")->capture_default_str()->check(CLI::Range(0, 2000000));
  app.add_option("--grpc-max-connection-age-seconds", config.grpc.max_connection_age_seconds,
                 "a gRPC connection this old is sent GOAWAY: the client reconnects (0: never)")
      ->envname("MM_GRPC_MAX_CONNECTION_AGE_SECONDS")->capture_default_str()->check(CLI::Range(0, 2000000));
  app.add_option("--grpc-max-connection-age-grace-seconds", config.grpc.max_connection_age_grace_seconds,
                 "calls on a gRPC connection past its age may go on this long before they are cancelled (0: "
                 "until they end)")
      ->envname("MM_GRPC_MAX_CONNECTION_AGE_GRACE_SECONDS")->capture_default_str()->check(CLI::Range(0, 2000000));
  app.add_flag("--grpc-accept-compression", config.grpc.accept_compressed_messages,
               "take gzip- and deflate-compressed gRPC requests (default: refused from their headers); gRPC 1.51 "
               "inflates a message whole before checking --max-message-bytes, so a few MB sent can cost GBs: "
               "trusted clients only")
      ->envname("MM_GRPC_ACCEPT_COMPRESSION");
  app.add_option("--grpc-take-message-timeout-seconds", config.grpc.take_message_timeout_seconds,
                 "a gRPC take stream's next message must arrive whole within this: its TakeHeader from the call's "
                 "start, each chunk from the message before, and each reply message must be taken by the client; "
                 "else the call ends with DEADLINE_EXCEEDED (0: no limit)")
      ->envname("MM_GRPC_TAKE_MESSAGE_TIMEOUT_SECONDS")->capture_default_str()->check(CLI::Range(0, 86400));
  app.add_option("--max-watch-streams", config.core.watch_streams.max_streams,
                 "job watch streams (REST events, gRPC WatchJob) open at once, both protocols together; more are "
                 "refused (429, RESOURCE_EXHAUSTED), and each frontend keeps this many workers for them besides "
                 "--rest-threads and --grpc-threads")
      ->envname("MM_MAX_WATCH_STREAMS")->capture_default_str()->check(CLI::Range(1, 4096));
  app.add_option("--max-watch-streams-per-client", config.core.watch_streams.max_streams_per_client,
                 "job watch streams open at once from one client address")
      ->envname("MM_MAX_WATCH_STREAMS_PER_CLIENT")->capture_default_str()->check(CLI::Range(1, 4096));
  app.add_option("--max-take-seconds", config.core.takes.max_seconds,
                 "the longest take (EncodeTake, ReconstructTake, DenoiseTake, DecodeTrack's reply), in seconds; "
                 "refused as its frames arrive (413, RESOURCE_EXHAUSTED)")
      ->envname("MM_MAX_TAKE_SECONDS")->capture_default_str()->check(CLI::Range(6.0, 1e6));
  app.add_option("--max-take-streams", config.core.takes.max_streams,
                 "take operations running at once, both protocols together; more are refused (429, "
                 "RESOURCE_EXHAUSTED)")
      ->envname("MM_MAX_TAKE_STREAMS")->capture_default_str()->check(CLI::Range(1, 4096));
  app.add_option("--max-take-gap-fits", config.core.takes.max_gap_fits,
                 "windows a DenoiseTake with keep_observed fits to its gaps (gap_fill \"fitted\": each about 15 "
                 "decoder passes forward and back); the gaps of later windows are filled as gap_fill \"matched\" "
                 "and the take's summary counts them (0: no limit)")
      ->envname("MM_MAX_TAKE_GAP_FITS")->capture_default_str()->check(CLI::Range(0, 1000000));
  app.add_option("--max-take-bytes", config.core.max_take_bytes,
                 "largest take sent whole, in bytes: a REST body of /v1/takes:* (refused by its declared length, "
                 "413) or a data-root file named by path=")
      ->envname("MM_MAX_TAKE_BYTES")->capture_default_str()->check(CLI::Range(size_t{1024}, size_t{1} << 34));
  app.add_option("--max-loaded-models", config.core.max_loaded_models, "models kept in memory")
      ->envname("MM_MAX_LOADED_MODELS")->capture_default_str()->check(CLI::Range(1, 64));

  app.add_option("--state-dir", config.jobs.state_dir,
                 "folder of the job database and job runs; empty: no training jobs")
      ->envname("MM_STATE_DIR");
  app.add_option("--data-root", config.jobs.data_root,
                 "folder every training dataset must lie under, whose motion files clients may also list and read "
                 "(ListClips, ReadClip)")
      ->envname("MM_DATA_ROOT");
  app.add_option("--tool", config.jobs.tool_path,
                 "the motion-manifold executable that trains (default: beside the server, else the build tree's)")
      ->envname("MM_TOOL");
  app.add_option("--training-threads", config.jobs.training_threads,
                 "threads of a training job (it runs at the lowest CPU priority)")
      ->envname("MM_TRAINING_THREADS")->capture_default_str()->check(CLI::Range(1, 1024));
  app.add_option_function<std::string>(
         "--training-priority",
         [&config](const std::string& priority) { config.jobs.training_at_lowest_priority = priority == "idle"; },
         "CPU priority of a training job: idle (SCHED_IDLE and nice 19, so that it only takes a core serving leaves "
         "idle, and waits while calls keep the cores busy) or normal (the server's own, for a replica that only "
         "trains)")
      ->envname("MM_TRAINING_PRIORITY")->default_str("idle")->check(CLI::IsMember({"idle", "normal"}));
  app.add_option("--checkpoint-every", config.jobs.checkpoint_every, "iterations between a job's checkpoints")
      ->envname("MM_CHECKPOINT_EVERY")->capture_default_str()->check(CLI::Range(1, 1000000));
  app.add_option("--max-queued-jobs", config.jobs.max_queued, "queued jobs beyond which submissions are refused")
      ->envname("MM_MAX_QUEUED_JOBS")->capture_default_str()->check(CLI::Range(1, 100000));
  app.add_option("--max-queued-jobs-per-caller", config.jobs.max_queued_per_submitter,
                 "queued jobs of one caller beyond which its submissions are refused: per token with --auth-token "
                 "(every holder of the one token together), else per IP address")
      ->envname("MM_MAX_QUEUED_JOBS_PER_CALLER")->capture_default_str()->check(CLI::Range(1, 100000));
  app.add_option("--max-job-iterations", config.jobs.max_iterations,
                 "most iterations a job may train (its own, its configuration's or its variant's)")
      ->envname("MM_MAX_JOB_ITERATIONS")->capture_default_str()->check(CLI::Range(int64_t{1}, kMaxJobIterations));
  app.add_option("--max-job-seconds", config.jobs.max_seconds,
                 "a job's most wall time on the server running it, in seconds; past it the job is stopped (its "
                 "checkpoint kept) and fails (0: no limit)")
      ->envname("MM_MAX_JOB_SECONDS")->capture_default_str()->check(CLI::Range(0.0, 1e9));
  app.add_option("--max-upload-bytes", config.core.data_root_quota.max_upload_bytes,
                 "largest file UploadClip writes, in bytes (a REST body is also bounded by --max-message-bytes)")
      ->envname("MM_MAX_UPLOAD_BYTES")->capture_default_str()->check(CLI::Range(int64_t{1}, int64_t{1} << 40));
  app.add_option("--max-data-root-bytes", config.core.data_root_quota.max_root_bytes,
                 "bytes the data root may hold, its files together, beyond which uploads are refused")
      ->envname("MM_MAX_DATA_ROOT_BYTES")->capture_default_str()->check(CLI::Range(int64_t{0}, int64_t{1} << 50));
  app.add_option("--max-data-root-files", config.core.data_root_quota.max_root_files,
                 "files the data root may hold beyond which uploads are refused")
      ->envname("MM_MAX_DATA_ROOT_FILES")->capture_default_str()->check(CLI::Range(int64_t{0}, int64_t{1} << 40));
  app.add_option("--job-store", config.jobs.job_store,
                 "where job records live: empty for SQLite in --state-dir, or a postgresql:// URI shared by "
                 "several replicas (which must then share --state-dir and --model-store)")
      ->envname("MM_JOB_STORE");
  app.add_option("--job-lease-seconds", config.jobs.lease_seconds,
                 "how long a dead replica's running job waits before another replica takes it over (PostgreSQL)")
      ->envname("MM_JOB_LEASE_SECONDS")->capture_default_str()->check(CLI::Range(1.0, 3600.0));

  std::vector<std::string> precisions;
  app.add_option("--precision", precisions,
                 "inference weights: fp32 (as trained), bf16 or int8 (faster where the CPU has bf16 dot products; "
                 "docs/PERFORMANCE.md gives their accuracy cost), for every model, or NAME=PRECISION for one "
                 "(repeatable)")
      ->envname("MM_PRECISION");
  app.add_option("--ready-file", config.ready_file,
                 "written once serving: JSON with the bound ports and the pid (for scripts and tests)")
      ->envname("MM_READY_FILE");
  app.add_option("--log-level", config.log_level, "trace, debug, info, warn, error")
      ->envname("MM_LOG_LEVEL")->capture_default_str()
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
  app.add_option("--log-format", config.log_format, "text, or json (one object a line)")
      ->envname("MM_LOG_FORMAT")->capture_default_str()->check(CLI::IsMember({"text", "json"}));

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    config.core.precisions = ModelPrecisions::parse(precisions);
  } catch (const InputError& e) {
    std::cerr << e.what() << "\n";
    return 2;
  }
  if (config.grpc.tls_cert_file.empty() != config.grpc.tls_key_file.empty()) {
    std::cerr << "--tls-cert and --tls-key go together\n";
    return 2;
  }
  if (config.grpc.max_streams_per_connection >= config.grpc.max_threads) {
    std::cerr << "--grpc-max-streams-per-connection (" << config.grpc.max_streams_per_connection
              << ") must be fewer than --grpc-threads (" << config.grpc.max_threads
              << "): one connection could otherwise take every gRPC thread\n";
    return 2;
  }
  if (!token_file.empty()) {
    std::ifstream in(token_file);
    std::getline(in, config.core.auth_token);
  }
  if (!config.jobs.state_dir.empty() && config.jobs.data_root.empty()) {
    std::cerr << "--state-dir needs --data-root: the folder that training datasets must lie under\n";
    return 2;
  }
  config.grpc.address = config.rest.address = address;
  config.grpc.max_message_bytes = max_message_bytes;
  config.core.max_reply_bytes = static_cast<size_t>(max_message_bytes);
  config.rest.max_body_bytes = static_cast<size_t>(max_message_bytes);
  config.rest.max_take_bytes = config.core.max_take_bytes;
  config.rest.tls_cert_file = config.grpc.tls_cert_file;
  config.rest.tls_key_file = config.grpc.tls_key_file;
  config.jobs.model_store = config.core.model_store;
  config.rest.watch_streams = config.grpc.watch_streams = config.core.watch_streams.max_streams;
  config.grpc.watch_streams_per_client = config.core.watch_streams.max_streams_per_client;
  config.core.data_root = config.jobs.data_root;
  config.core.job_store = config.jobs.job_store;
  // An installation without the source tree has no page unless it names one;
  // a --web-root given that is not a folder stops the server at start.
  if (web_root->count() == 0 && !std::filesystem::is_directory(config.rest.web_root)) config.rest.web_root.clear();
  return -1;
}

}  // namespace mm::service
