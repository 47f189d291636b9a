#include "server/grpc/grpc_frontend.h"

#include <algorithm>
#include <climits>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/resource_quota.h>
#include <spdlog/spdlog.h>

#include "server/grpc/compression_refusal_log.h"
#include "server/grpc/manifold_service.h"

namespace mm::service {

namespace {

constexpr const char* kServiceName = "motionmanifold.v1.MotionManifold";

std::string read_pem(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  if (in) text << in.rdbuf();
  if (!in || text.str().empty()) {
    throw std::runtime_error("gRPC " + std::string(what) + " file " + path + " cannot be read or is empty");
  }
  return text.str();
}

std::shared_ptr<grpc::ServerCredentials> credentials(const GrpcOptions& options) {
  if (options.tls_cert_file.empty() && options.tls_key_file.empty()) return grpc::InsecureServerCredentials();
  if (options.tls_cert_file.empty() || options.tls_key_file.empty()) {
    throw std::runtime_error("gRPC TLS needs both a certificate and a key file (got only the " +
                             std::string(options.tls_cert_file.empty() ? "key" : "certificate") + ")");
  }
  grpc::SslServerCredentialsOptions ssl;
  ssl.pem_key_cert_pairs.push_back({read_pem(options.tls_key_file, "TLS key"),
                                    read_pem(options.tls_cert_file, "TLS certificate")});
  return grpc::SslServerCredentials(ssl);
}

std::string listen_address(const GrpcOptions& options) {
  const bool ipv6 = options.address.find(':') != std::string::npos && options.address.front() != '[';
  return (ipv6 ? "[" + options.address + "]" : options.address) + ":" + std::to_string(options.port);
}

// gRPC's arguments in milliseconds, with 0 (off) as gRPC's "unlimited".
int milliseconds_or_unlimited(int seconds) {
  if (seconds <= 0 || seconds > INT_MAX / 1000) return INT_MAX;
  return seconds * 1000;
}

// HTTP/2's stream cap: the calls plus the watch streams a client may hold
// (never more than the server's, whose threads are counted apart).
int streams_per_connection(const GrpcOptions& options) {
  return options.max_streams_per_connection +
         std::max(0, std::min(options.watch_streams_per_client, options.watch_streams));
}

// The per-connection limits of GrpcOptions as gRPC's channel arguments.
void apply_connection_limits(const GrpcOptions& options, grpc::ServerBuilder& builder) {
  if (options.max_streams_per_connection < 1 || options.max_streams_per_connection >= options.max_threads) {
    // One connection could otherwise hold every thread, and calls from
    // every other client would be refused while it does.
    throw std::runtime_error("gRPC streams per connection (--grpc-max-streams-per-connection " +
                             std::to_string(options.max_streams_per_connection) +
                             ") must be at least 1 and fewer than the gRPC threads (--grpc-threads " +
                             std::to_string(options.max_threads) + ")");
  }
  // Announced in the connection's SETTINGS; a stream opened beyond it is
  // reset with REFUSED_STREAM by the transport, before a call or a thread
  // exists for it. gRPC clients queue their calls until a stream frees.
  builder.AddChannelArgument(GRPC_ARG_MAX_CONCURRENT_STREAMS, streams_per_connection(options));

  // The server's own pings find peers that went away without closing.
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIME_MS, milliseconds_or_unlimited(options.keepalive_seconds));
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIMEOUT_MS,
                             milliseconds_or_unlimited(options.keepalive_timeout_seconds));
  // Enforcement of the client's pings: a ping that comes sooner than this
  // after the last one, with no data between, is a strike; the third gets
  // GOAWAY (ENHANCE_YOUR_CALM "too_many_pings"). Pings on a connection
  // without calls count as strikes too (KEEPALIVE_PERMIT_WITHOUT_CALLS 0).
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS,
                             milliseconds_or_unlimited(options.min_client_ping_interval_seconds));
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MAX_PING_STRIKES, 2);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 0);

  builder.AddChannelArgument(GRPC_ARG_MAX_CONNECTION_IDLE_MS,
                             milliseconds_or_unlimited(options.max_connection_idle_seconds));
  builder.AddChannelArgument(GRPC_ARG_MAX_CONNECTION_AGE_MS,
                             milliseconds_or_unlimited(options.max_connection_age_seconds));
  builder.AddChannelArgument(GRPC_ARG_MAX_CONNECTION_AGE_GRACE_MS,
                             milliseconds_or_unlimited(options.max_connection_age_grace_seconds));

  // A request naming an algorithm that is not enabled is failed from its
  // headers (grpc-encoding), before its message is read, let alone
  // inflated. Replies are never compressed either way.
  builder.SetCompressionAlgorithmSupportStatus(GRPC_COMPRESS_DEFLATE, options.accept_compressed_messages);
  builder.SetCompressionAlgorithmSupportStatus(GRPC_COMPRESS_GZIP, options.accept_compressed_messages);
}

}  // namespace

GrpcFrontend::GrpcFrontend(Core& core, GrpcOptions options) : core_(core), options_(std::move(options)) {}

GrpcFrontend::~GrpcFrontend() { shutdown(std::chrono::seconds(1)); }

void GrpcFrontend::start() {
  if (server_) throw std::runtime_error("gRPC frontend already started");
  const std::string address = listen_address(options_);
  stopping_ = false;
  service_ = std::make_unique<grpc_frontend::ManifoldService>(core_, stopping_,
                                                     std::chrono::seconds(options_.take_message_timeout_seconds));

  // Process-wide switches; they take effect for servers built after them.
  CompressionRefusalLog::install();
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();

  grpc::ServerBuilder builder;
  builder.AddListeningPort(address, credentials(options_), &port_);
  // gRPC sets SO_REUSEPORT by default: a second server on the same port
  // would start without an error and take half the connections.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  builder.RegisterService(service_.get());
  builder.SetMaxReceiveMessageSize(options_.max_message_bytes);
  builder.SetMaxSendMessageSize(options_.max_message_bytes);
  apply_connection_limits(options_, builder);
  // The synchronous server takes one thread from this quota for each of its
  // pollers and each call it serves, a WatchJob stream's for the stream's
  // life; a call that finds no thread free and no poller idle is refused
  // ("Server Threadpool Exhausted"). The quota counts calls and streams
  // together, so the core's cap on streams (which refuses a stream in
  // microseconds) plus this many more threads leaves max_threads for calls.
  // The health service is a callback service and takes none of these.
  grpc::ResourceQuota quota("motionmanifold-grpc");
  quota.SetMaxThreads(options_.max_threads + std::max(0, options_.watch_streams));
  builder.SetResourceQuota(quota);
  // One completion queue: the calls are short next to the inference they
  // wait on, and the core batches them anyway.
  builder.SetSyncServerOption(grpc::ServerBuilder::SyncServerOption::NUM_CQS, 1);
  builder.SetSyncServerOption(grpc::ServerBuilder::SyncServerOption::MIN_POLLERS, 1);
  builder.SetSyncServerOption(grpc::ServerBuilder::SyncServerOption::MAX_POLLERS, 2);

  server_ = builder.BuildAndStart();
  if (!server_ || port_ == 0) {
    server_.reset();
    port_ = 0;
    throw std::runtime_error("gRPC cannot listen on " + address + " (address in use or not available)");
  }
  set_serving(serving_);
  // gRPC refuses a compressed request with its own words ("Compression
  // algorithm 'gzip' is disabled"), which cannot name the option: the
  // operator finds it here.
  spdlog::info("gRPC: at most {} calls and {} streams a connection, keepalive ping after {} s quiet, connections closed after {} s "
               "idle or {} s old (+{} s grace); compressed requests {}",
               options_.max_streams_per_connection, streams_per_connection(options_), options_.keepalive_seconds, options_.max_connection_idle_seconds,
               options_.max_connection_age_seconds, options_.max_connection_age_grace_seconds,
               options_.accept_compressed_messages
                   ? "taken (--grpc-accept-compression: gRPC inflates each whole before checking its size)"
                   : "refused before they are inflated (--grpc-accept-compression takes them)");
  if (options_.take_message_timeout_seconds > 0) {
    spdlog::info("gRPC: a take stream waits at most {} s for each message, then ends (--grpc-take-message-timeout-seconds)",
                 options_.take_message_timeout_seconds);
  } else {
    spdlog::warn("gRPC: take streams wait for their messages without a limit (--grpc-take-message-timeout-seconds 0): "
                 "a silent client holds a thread until it goes");
  }
}

int GrpcFrontend::port() const { return port_; }

void GrpcFrontend::set_serving(bool serving) {
  serving_ = serving;
  if (!server_) return;
  if (auto* health = server_->GetHealthCheckService()) {
    health->SetServingStatus("", serving);
    health->SetServingStatus(kServiceName, serving);
  }
}

void GrpcFrontend::shutdown(std::chrono::milliseconds deadline) {
  if (!server_) return;
  set_serving(false);
  stopping_ = true;  // ends WatchJob streams, which could otherwise outlast any deadline
  server_->Shutdown(std::chrono::system_clock::now() + deadline);
  server_->Wait();
  server_.reset();
  service_.reset();
  CompressionRefusalLog::flush();
}

}  // namespace mm::service
