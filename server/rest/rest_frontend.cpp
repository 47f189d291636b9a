#include "server/rest/rest_frontend.h"

#include <httplib.h>
#include <sys/socket.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cmath>
#include <functional>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <set>
#include <stdexcept>
#include <thread>

#include "server/core/caller_identity.h"
#include "server/rest/body_for_model.h"
#include "server/rest/body_limits.h"
#include "server/rest/bvh_translation.h"
#include "server/rest/connection_stream.h"
#include "server/rest/guarded_http_server.h"
#include "server/rest/http_errors.h"
#include "server/rest/join_route.h"
#include "server/rest/json_translation.h"
#include "server/rest/openapi_document.h"
#include "server/rest/query_translation.h"
#include "server/rest/rest_routes.h"
#include "server/rest/take_routes.h"

namespace mm::service {

namespace {

using rest::RouteId;

constexpr const char* kJsonType = "application/json";
constexpr const char* kPrometheusType = "text/plain; version=0.0.4; charset=utf-8";
// An idle event stream writes an SSE comment this often: the only way to
// notice a client that went away while its job did not change (a queued
// job can wait for hours), so that its worker thread is freed.
constexpr auto kKeepAliveInterval = std::chrono::seconds(2);
// How much of a body past the limit is read and dropped at most (or the
// limit itself, if larger) before the connection is given up on.
constexpr size_t kMaxBytesDroppedPastTheLimit = 16u << 20;
// The least listen backlog: a burst of connections waits there only until
// the accepting thread takes it (it hands each to the workers' queue at once).
constexpr size_t kMinListenBacklog = 128;

// The caller as the core sees it: its Authorization headers parsed
// (core/caller_identity.h) and its IP address.
CallContext call_context(const httplib::Request& request) {
  std::vector<std::string> authorization;
  const size_t count = request.get_header_value_count("Authorization");
  for (size_t i = 0; i < count; ++i) authorization.push_back(request.get_header_value("Authorization", i));
  const BearerCredentials credentials = parse_authorization(authorization);
  return CallContext{"rest", credentials.token, credentials.problem, canonical_ip(request.remote_addr)};
}

void send_json(httplib::Response& response, int status, const std::string& body) {
  response.status = status;
  response.set_content(body, kJsonType);
}

// A reply of motions as BVH (or glTF: `format`) of the skeleton of the model
// that answered (`shape`); the file holds one motion, so a reply of several
// is 406.
void send_bvh_motion(httplib::Response& response, const MotionsReply& reply, const ModelShape& shape,
                     AnimationFormat format) {
  if (reply.motions.size() != 1) {
    const ApiError error(ErrorCode::kInvalidArgument, "",
                         std::string("Accept: ") + animation_format_media_type(format) +
                             " holds one motion and this reply has " +
                             std::to_string(reply.motions.size()) + "; ask for application/json");
    response.status = 406;
    return response.set_content(rest::error_body(error), kJsonType);
  }
  response.status = 200;
  response.set_content(rest::motions_reply_to_bvh(reply, shape, format), animation_format_media_type(format));
}

// Answers a call whose reply is motions (Decode, Sample, Interpolate,
// Analogy, Denoise): JSON, or one motion as an animation file (BVH, glTF)
// when the client's Accept names one. Such a file is of the skeleton of the
// model that answers, and so is an animation body (`body_for_model`): for
// either, the model is chosen first (Core::choose_model, on request model
// `model` for `operation`), then `run` reads the body for it and runs the
// operation on it, and the reply is written for its shape, so that an
// activation meanwhile never pairs one rig with another model. Otherwise
// `run` is given no chosen model and the operation resolves the request's.
template <typename Run>
void answer_motions(Core& core, const CallContext& context, const char* operation, const std::string& model,
                    bool body_for_model, const httplib::Request& request, httplib::Response& response, Run&& run) {
  AnimationFormat format;
  const bool file_reply = rest::names_animation(request.get_header_value("Accept"), &format);
  if (file_reply && format == AnimationFormat::kFbx) {
    // FBX is read, never written (format/fbx_animation.h says why).
    const ApiError error(ErrorCode::kInvalidArgument, "",
                         "Accept: application/octet-stream (FBX) cannot be answered: motions are written as "
                         "application/x-bvh, model/gltf-binary, model/gltf+json or application/json");
    response.status = 406;
    return response.set_content(rest::error_body(error), kJsonType);
  }
  if (!file_reply && !body_for_model) {
    return send_json(response, 200, rest::motions_reply_to_json(run(ChosenModel())));
  }
  const ChosenModel chosen = core.choose_model(context, operation, model);
  const MotionsReply reply = run(chosen);
  if (!file_reply) return send_json(response, 200, rest::motions_reply_to_json(reply));
  send_bvh_motion(response, reply, chosen.shape(), format);
}

// An encode or denoise body: JSON, or one BVH motion (Content-Type
// application/x-bvh; denoise then takes its defaults).
bool is_bvh_body(const httplib::Request& request) {
  AnimationFormat format;
  return rest::names_animation(request.get_header_value("Content-Type"), &format);
}

// The format of an animation body (is_bvh_body), BVH for any other.
AnimationFormat body_format(const httplib::Request& request) {
  AnimationFormat format = AnimationFormat::kBvh;
  rest::names_animation(request.get_header_value("Content-Type"), &format);
  return format;
}

// An animation body read as the request's one motion for the chosen model
// (a body it cannot read is the call's refusal: rest/body_for_model.h).
Motion body_motion(Core& core, const ChosenModel& chosen, const std::string& body, AnimationFormat format) {
  return rest::read_body_for_model(core, chosen, [&](const ModelShape& shape) {
    return rest::motion_from_bvh_body(body, shape, format);
  });
}

void send_error(httplib::Response& response, const ApiError& error) {
  response.status = rest::http_status(error);
  if (error.code() == ErrorCode::kUnauthenticated) response.set_header("WWW-Authenticate", "Bearer");
  response.set_content(rest::error_body(error), kJsonType);
}

// Answers `error` and closes the connection at once rather than keeping it
// alive: httplib 0.11 keeps a connection open for its keep-alive timeout (2 s,
// holding a worker) whatever the reply's Connection header says, and closes
// it at once only when a content provider fails. So the whole body is written
// by a provider that then reports failure.
void send_error_and_close(httplib::Response& response, const ApiError& error) {
  const std::string body = rest::error_body(error);
  response.status = rest::http_status(error);
  response.set_header("Connection", "close");
  response.set_content_provider(body.size(), kJsonType,
                                [body](size_t offset, size_t length, httplib::DataSink& sink) {
                                  sink.write(body.data() + offset, length);
                                  return false;  // all written: end the connection
                                });
}

// One open event stream: its place among the open watch streams (given back
// with the stream), its stop flag (read by the core's watch) and what wakes
// its keep-alive writer.
struct EventStream {
  WatchStreams::Slot slot;  // moved into the core's watch when it starts
  std::atomic<bool> stop{false};
  std::mutex mutex;
  std::condition_variable wake;
  bool finished = false;  // guarded by mutex

  void request_stop() {
    stop = true;
    std::lock_guard<std::mutex> lock(mutex);
    wake.notify_all();
  }
};

}  // namespace

struct RestFrontend::State {
  Core& core;
  ServiceMetrics& metrics;
  RestOptions options;
  std::unique_ptr<httplib::Server> server;
  std::thread serve_thread;
  std::atomic<int> port{-1};

  std::mutex streams_mutex;
  std::set<std::shared_ptr<EventStream>> streams;  // guarded by streams_mutex
  bool shutting_down = false;                      // guarded by streams_mutex

  State(Core& c, ServiceMetrics& m, RestOptions o) : core(c), metrics(m), options(std::move(o)) {}

  // `parts`: a multipart/form-data body's parts (read_body reads such a
  // body into them, not into `body`).
  void handle(RouteId route, const httplib::Request& request, const std::string& body, httplib::Response& response,
              const httplib::MultipartFormDataItems& parts = {});
  bool read_body(RouteId route, const httplib::Request& request, const httplib::ContentReader& reader,
                 std::string& body, httplib::Response& response,
                 httplib::MultipartFormDataItems* parts = nullptr) const;
  void stream_job_events(const CallContext& context, const std::string& id, httplib::Response& response);
  bool write_job_events(const std::string& id, EventStream& stream, httplib::DataSink& sink);
  void install_error_handlers();
};

// The body length the Content-Length headers declare: one whole number of
// bytes, the same in every such header; std::nullopt for anything else
// (httplib would read "-1" as 2^64 - 1 and wait for that many bytes).
std::optional<uint64_t> declared_length(const httplib::Request& request) {
  const size_t count = request.get_header_value_count("Content-Length");
  std::optional<uint64_t> length;
  for (size_t i = 0; i < count; ++i) {
    const std::string value = request.get_header_value("Content-Length", i);
    if (value.empty() || value.size() > 18 ||
        !std::all_of(value.begin(), value.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      return std::nullopt;
    }
    const uint64_t parsed = std::stoull(value);
    if (length && *length != parsed) return std::nullopt;
    length = parsed;
  }
  return length;
}

// Reads a POST body through httplib's content reader rather than letting
// httplib fill request.body: cpp-httplib 0.11 checks its payload limit only
// against Content-Length, so a chunked body would grow without bound, and it
// reads a request without Content-Length until the connection closes, where
// RFC 9112 (6.3) says such a request has no body. The declared length is
// checked against the route's limit (body_limits.h) before a byte of the
// body is read: httplib itself would first read and drop all of it, or wait
// for it until its read timeout (5 s). Answers the error and returns false
// when the body is too large or unreadable.
bool RestFrontend::State::read_body(RouteId route, const httplib::Request& request,
                                    const httplib::ContentReader& reader, std::string& body,
                                    httplib::Response& response, httplib::MultipartFormDataItems* parts) const {
  const bool has_length = request.has_header("Content-Length");
  if (!has_length && !request.has_header("Transfer-Encoding")) return true;
  const rest::BodyLimit limit =
      rest::body_limit(route, is_bvh_body(request), options.max_body_bytes, options.max_json_bytes,
                       options.max_take_bytes);
  const auto refuse = [&](const ApiError& error) {
    // What is left of the body must not be read as the next request.
    send_error_and_close(response, error);
    return false;
  };
  const std::string limit_text =
      "the limit of " + std::to_string(limit.bytes) + " bytes of " + request.method + " " + request.path + " (" +
      limit.name + ")";
  if (has_length) {
    const std::optional<uint64_t> declared = declared_length(request);
    if (!declared) {
      return refuse(ApiError(ErrorCode::kInvalidArgument, "",
                             "Content-Length \"" + request.get_header_value("Content-Length") +
                                 "\" is not a length in bytes, expected one whole number of bytes"));
    }
    if (*declared > limit.bytes) {
      return refuse(ApiError(ErrorCode::kResourceExhausted, "",
                             "the request body of " + std::to_string(*declared) +
                                 " bytes (Content-Length) exceeds " + limit_text,
                             /*too_large=*/true));
    }
  }
  // A chunked body declares no length: past the limit the rest is read and
  // dropped rather than left unread, since a client still sending would
  // otherwise meet a reset connection, not the 413. Dropping is bounded so
  // that an endless body still ends the connection.
  const size_t drop_at_most = std::max<size_t>(limit.bytes, kMaxBytesDroppedPastTheLimit);
  bool too_large = false;
  size_t dropped = 0;
  size_t received = 0;  // of every part, for a multipart body
  const auto receive = [&](const char* data, size_t length, std::string& into) {
    if (!too_large && received + length > limit.bytes) {
      too_large = true;
      body.clear();
      body.shrink_to_fit();
      if (parts != nullptr) parts->clear();
    }
    if (too_large) {
      dropped += length;
      return dropped <= drop_at_most;
    }
    received += length;
    into.append(data, length);
    return true;
  };
  bool ok = false;
  if (request.is_multipart_form_data()) {
    // httplib reads a multipart body only into parts (its plain reader
    // would call a part handler it was not given); a route that takes
    // none (parts null) reads them and drops them, and its empty body is
    // then refused as JSON.
    httplib::MultipartFormDataItems dropped_parts;
    httplib::MultipartFormDataItems& into = parts != nullptr ? *parts : dropped_parts;
    ok = reader(
        [&](const httplib::MultipartFormData& header) {
          if (too_large) return true;
          into.push_back(header);
          return true;
        },
        [&](const char* data, size_t length) {
          if (into.empty()) return false;
          return receive(data, length, into.back().content);
        });
  } else {
    ok = reader([&](const char* data, size_t length) { return receive(data, length, body); });
  }
  if (ok && !too_large) return true;
  if (too_large) {
    return refuse(ApiError(ErrorCode::kResourceExhausted, "", "the request body exceeds " + limit_text,
                           /*too_large=*/true));
  }
  const rest::ConnectionStream* stream = rest::ConnectionStream::current();
  if (stream != nullptr && stream->body_timed_out()) {
    // 408 has no ApiError code of its own; the connection ends with it.
    response.status = 408;
    response.set_header("Connection", "close");
    response.set_content(rest::error_body(rest::error_code_name_for_status(408), "",
                                          "the request body did not arrive whole within " +
                                              std::to_string(static_cast<int>(options.body_timeout_seconds)) +
                                              " s (--rest-body-timeout-seconds)"),
                         kJsonType);
    return false;
  }
  return refuse(ApiError(ErrorCode::kInvalidArgument, "", "the request body could not be read"));
}

void RestFrontend::State::handle(RouteId route, const httplib::Request& request, const std::string& body,
                                 httplib::Response& response, const httplib::MultipartFormDataItems& parts) {
  const CallContext context = call_context(request);
  try {
    switch (route) {
      case RouteId::kEncode:
        if (is_bvh_body(request)) {
          // The model first, then the body read for its skeleton.
          const ChosenModel chosen = core.choose_model(context, "encode", request.get_param_value("model"));
          EncodeRequest encode;
          encode.model = chosen.model().model;
          encode.motions.push_back(body_motion(core, chosen, body, body_format(request)));
          return send_json(response, 200, rest::encode_reply_to_json(core.encode(context, encode, chosen)));
        }
        return send_json(response, 200,
                         rest::encode_reply_to_json(core.encode(context, rest::encode_request_from_json(body))));
      case RouteId::kDecode: {
        const DecodeRequest decode = rest::decode_request_from_json(body);
        return answer_motions(core, context, "decode", decode.model, false, request, response,
                              [&](const ChosenModel& chosen) { return core.decode(context, decode, chosen); });
      }
      case RouteId::kSample: {
        const SampleRequest sample = rest::sample_request_from_json(body);
        return answer_motions(core, context, "sample", sample.model, false, request, response,
                              [&](const ChosenModel& chosen) { return core.sample(context, sample, chosen); });
      }
      case RouteId::kInterpolate: {
        const InterpolateRequest interpolate = rest::interpolate_request_from_json(body);
        return answer_motions(
            core, context, "interpolate", interpolate.model, false, request, response,
            [&](const ChosenModel& chosen) { return core.interpolate(context, interpolate, chosen); });
      }
      case RouteId::kAnalogy: {
        const AnalogyRequest analogy = rest::analogy_request_from_json(body);
        return answer_motions(core, context, "analogy", analogy.model, false, request, response,
                              [&](const ChosenModel& chosen) { return core.analogy(context, analogy, chosen); });
      }
      case RouteId::kDenoise: {
        if (is_bvh_body(request)) {
          // A BVH body takes denoise's defaults; it is read for the chosen model.
          return answer_motions(core, context, "denoise", request.get_param_value("model"), true, request, response,
                                [&](const ChosenModel& chosen) {
                                  DenoiseRequest denoise;
                                  denoise.model = chosen.model().model;
                                  denoise.motions.push_back(body_motion(core, chosen, body, body_format(request)));
                                  return core.denoise(context, denoise, chosen);
                                });
        }
        const DenoiseRequest denoise = rest::denoise_request_from_json(body);
        return answer_motions(core, context, "denoise", denoise.model, false, request, response,
                              [&](const ChosenModel& chosen) { return core.denoise(context, denoise, chosen); });
      }
      case RouteId::kJoinClips:
        return rest::answer_join(core, context, request, body, parts, response);
      case RouteId::kEncodeTake:
      case RouteId::kReconstructTake:
      case RouteId::kDenoiseTake:
      case RouteId::kDecodeTrack:
        return rest::answer_take(core, route, context, request, body, response);
      case RouteId::kListModels:
        return send_json(response, 200, rest::model_list_to_json(core.list_models(context)));
      case RouteId::kDescribeModel:
        return send_json(response, 200, rest::model_info_to_json(core.describe_model(context, request.matches[1].str())));
      case RouteId::kActivateModel:
        rest::empty_request_from_json(body);
        return send_json(response, 200, rest::model_info_to_json(core.activate_model(context, request.matches[1].str())));
      case RouteId::kDeleteModel:
        return send_json(response, 200, rest::model_info_to_json(core.delete_model(context, request.matches[1].str())));
      case RouteId::kListClips:
        return send_json(response, 200, rest::clip_list_to_json(core.list_clips(context)));
      case RouteId::kReadClip:
        return send_json(response, 200, rest::read_clip_reply_to_json(
                                            core.read_clip(context, rest::read_clip_request_from_query(request.params))));
      case RouteId::kReadClipMotion:
        return send_json(response, 200, rest::read_clip_reply_to_json(core.read_clip(
                                            context, rest::read_clip_motion_request_from_query(request.params))));
      case RouteId::kUploadClip:
        // The body is the file itself, whatever its Content-Type says.
        return send_json(response, 200, rest::clip_file_to_json(core.upload_clip(
                                            context, rest::upload_clip_request_from_query(request.params, body))));
      case RouteId::kDeleteClip:
        return send_json(response, 200, rest::clip_file_to_json(core.delete_clip(
                                            context, rest::delete_clip_path_from_query(request.params))));
      case RouteId::kSubmitJob:
        return send_json(response, 200,
                         rest::job_info_to_json(core.submit_job(context, rest::job_spec_from_json(body))));
      case RouteId::kListJobs:
        return send_json(response, 200, rest::job_list_to_json(core.list_jobs(context)));
      case RouteId::kGetJob:
        return send_json(response, 200, rest::job_info_to_json(core.get_job(context, request.matches[1].str())));
      case RouteId::kCancelJob:
        rest::empty_request_from_json(body);
        return send_json(response, 200, rest::job_info_to_json(core.cancel_job(context, request.matches[1].str())));
      case RouteId::kDeleteJob:
        return send_json(response, 200, rest::job_info_to_json(core.delete_job(context, request.matches[1].str())));
      case RouteId::kJobEvents:
        return stream_job_events(context, request.matches[1], response);
      case RouteId::kHealth:
        return send_json(response, 200, R"({"status":"alive"})");
      case RouteId::kReady:
        if (!core.ready()) throw ApiError(ErrorCode::kUnavailable, "", "not ready: no model is loaded yet, or the server is shutting down");
        return send_json(response, 200, R"({"status":"ready"})");
      case RouteId::kMetrics:
        response.status = 200;
        return response.set_content(metrics.text(), kPrometheusType);
      case RouteId::kOpenApi: {
        const std::string_view document = rest::openapi_document();
        return send_json(response, 200, std::string(document));
      }
    }
    throw ApiError(ErrorCode::kInternal, "", "route without a handler");
  } catch (const ApiError& error) {
    send_error(response, error);
  } catch (const std::exception& error) {
    send_error(response, ApiError(ErrorCode::kInternal, "", error.what()));
  }
}

void RestFrontend::State::stream_job_events(const CallContext& context, const std::string& id,
                                            httplib::Response& response) {
  // Admitted first so that an unknown job or a full server is an ordinary
  // error reply: once the stream has begun its status is sent. A client
  // refused for too many streams has its connection closed, not kept alive,
  // so that its worker is free for calls at once.
  WatchStreams::Slot slot;
  try {
    slot = core.begin_watch(context, id);
  } catch (const ApiError& error) {
    if (error.code() != ErrorCode::kResourceExhausted) throw;
    return send_error_and_close(response, error);
  }
  auto stream = std::make_shared<EventStream>();
  stream->slot = std::move(slot);
  {
    std::lock_guard<std::mutex> lock(streams_mutex);
    if (shutting_down) throw ApiError(ErrorCode::kUnavailable, "", "the server is shutting down");
    streams.insert(stream);
  }
  response.status = 200;
  response.set_header("Cache-Control", "no-cache");
  response.set_chunked_content_provider(
      "text/event-stream",
      [this, id, stream](size_t, httplib::DataSink& sink) { return write_job_events(id, *stream, sink); },
      [this, stream](bool) {
        std::lock_guard<std::mutex> lock(streams_mutex);
        streams.erase(stream);
      });
}

// Runs on the connection's worker thread until the job ends, the client
// goes away or the frontend shuts down. The core's watch blocks between
// changes; a keep-alive thread meanwhile finds a client that left.
bool RestFrontend::State::write_job_events(const std::string& id, EventStream& stream, httplib::DataSink& sink) {
  std::mutex sink_mutex;  // the sink is written from this thread and the keep-alive thread
  bool failed = false;    // guarded by sink_mutex
  auto write = [&](const std::string& text) {
    std::lock_guard<std::mutex> lock(sink_mutex);
    if (!failed && !sink.write(text.data(), text.size())) failed = true;
    if (failed) stream.stop = true;
    return !failed;
  };
  std::thread keep_alive([&] {
    std::unique_lock<std::mutex> lock(stream.mutex);
    while (!stream.finished && !stream.stop) {
      if (stream.wake.wait_for(lock, kKeepAliveInterval, [&] { return stream.finished || stream.stop.load(); }))
        break;
      lock.unlock();
      const bool ok = write(": keep-alive\n\n");
      lock.lock();
      if (!ok) break;
    }
  });
  try {
    core.watch_job(
        std::move(stream.slot), id,
        [&](const JobInfo& job) { return write("event: job\ndata: " + rest::job_info_to_json(job) + "\n\n"); },
        &stream.stop);
  } catch (const ApiError& error) {
    write("event: error\ndata: " + rest::error_body(error) + "\n\n");
  } catch (const std::exception& error) {
    write("event: error\ndata: " + rest::error_body("INTERNAL", "", error.what()) + "\n\n");
  }
  {
    std::lock_guard<std::mutex> lock(stream.mutex);
    stream.finished = true;
    stream.wake.notify_all();
  }
  keep_alive.join();
  if (failed) return false;
  sink.done();
  return true;
}

void RestFrontend::State::install_error_handlers() {
  // httplib calls the error handler for every reply of status >= 400, ours
  // included; it only fills in the replies httplib made itself (no route,
  // body too large, unreadable request), which have no body yet (ours have
  // a Content-Type even when a provider writes their body).
  httplib::Server::HandlerWithResponse on_error = [this](const httplib::Request& request,
                                                         httplib::Response& response) {
    if (!response.body.empty() || response.has_header("Content-Type")) return httplib::Server::HandlerResponse::Unhandled;
    std::string message;
    std::string field;
    switch (response.status) {
      case 404:
        message = "no route " + request.method + " " + request.path + " (the routes are listed at /v1/openapi.json)";
        break;
      case 413:
        message = "the request body exceeds the limit of " + std::to_string(options.max_body_bytes) +
                  " bytes (--max-message-bytes)";
        break;
      default:
        message = "the HTTP request was refused (status " + std::to_string(response.status) + ")";
    }
    response.set_content(rest::error_body(rest::error_code_name_for_status(response.status), field, message),
                         kJsonType);
    return httplib::Server::HandlerResponse::Handled;
  };
  server->set_error_handler(on_error);
  server->set_exception_handler([](const httplib::Request&, httplib::Response& response, std::exception_ptr error) {
    std::string message = "unexpected error";
    try {
      if (error) std::rethrow_exception(error);
    } catch (const std::exception& e) {
      message = e.what();
    } catch (...) {
    }
    send_error(response, ApiError(ErrorCode::kInternal, "", message));
  });
}

RestFrontend::RestFrontend(Core& core, ServiceMetrics& metrics, RestOptions options)
    : state_(std::make_unique<State>(core, metrics, std::move(options))) {}

RestFrontend::~RestFrontend() { shutdown(); }

void RestFrontend::start() {
  State& s = *state_;
  if (s.server) throw std::runtime_error("the REST frontend is already started");
  const bool tls = !s.options.tls_cert_file.empty() || !s.options.tls_key_file.empty();
  rest::ConnectionLimits limits;
  limits.head.max_line_bytes = s.options.max_line_bytes;
  limits.head.max_fields = s.options.max_headers;
  limits.head.max_head_bytes = s.options.max_header_bytes;
  limits.header_timeout = std::chrono::milliseconds(std::llround(s.options.header_timeout_seconds * 1000));
  limits.body_timeout = std::chrono::milliseconds(std::llround(s.options.body_timeout_seconds * 1000));
  limits.max_connections_per_client = static_cast<size_t>(std::max(1, s.options.max_connections_per_client));
  // Listens again with a backlog for a burst of connections as large as the
  // workers: httplib's compiled-in 5 overflowed under 300 connections.
  std::function<bool(int)> set_backlog;
  if (tls) {
    if (s.options.tls_cert_file.empty() || s.options.tls_key_file.empty())
      throw std::runtime_error("REST TLS needs both a certificate and a key (--tls-cert and --tls-key)");
    auto server = std::make_unique<rest::GuardedHttpsServer>(s.options.tls_cert_file, s.options.tls_key_file, limits);
    if (!server->is_valid())
      throw std::runtime_error("cannot use the TLS certificate " + s.options.tls_cert_file + " with the key " +
                               s.options.tls_key_file + " for the REST frontend");
    set_backlog = [server = server.get()](int backlog) { return server->set_listen_backlog(backlog); };
    s.server = std::move(server);
  } else {
    auto server = std::make_unique<rest::GuardedHttpServer>(limits);
    set_backlog = [server = server.get()](int backlog) { return server->set_listen_backlog(backlog); };
    s.server = std::move(server);
  }
  httplib::Server& server = *s.server;
  const size_t threads = static_cast<size_t>(std::max(1, s.options.threads) + std::max(0, s.options.watch_streams));
  server.new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
  // The largest body of any route: read_body holds each route to its own.
  server.set_payload_max_length(std::max(s.options.max_body_bytes, s.options.max_take_bytes));
  // Idle keep-alive connections hold a worker and delay shutdown by as long.
  server.set_keep_alive_timeout(2);
  // httplib writes a reply's headers and body separately: with Nagle's
  // algorithm the body then waits for the client's delayed ACK (40 ms).
  server.set_tcp_nodelay(true);
  // httplib's default sets SO_REUSEPORT, with which a second server on the
  // same port starts without an error and the kernel shares the
  // connections between the two. SO_REUSEADDR alone still lets a restarted
  // server bind while old connections linger in TIME_WAIT.
  server.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  s.install_error_handlers();
  if (!s.options.web_root.empty() && !server.set_mount_point("/", s.options.web_root))
    throw std::runtime_error("the web root " + s.options.web_root + " is not a folder (--web-root)");
  // ES modules load only with a JavaScript MIME type; say it rather than rely on httplib's table.
  server.set_file_extension_and_mimetype_mapping("js", "text/javascript");
  for (const rest::RestRoute& route : rest::rest_routes()) {
    const RouteId id = route.id;
    const std::string pattern = rest::route_regex(route.path_template);
    if (route.method == "GET") {
      server.Get(pattern, [&s, id](const httplib::Request& request, httplib::Response& response) {
        s.handle(id, request, std::string(), response);
      });
    } else if (route.method == "DELETE") {
      // A DELETE names its resource in the path or query; a body it may
      // carry is bounded as parameters are, and not read. Registered with a
      // content reader, as httplib tries those before plain handlers: the
      // catch-all 404 below would otherwise answer first.
      server.Delete(pattern, httplib::Server::HandlerWithContentReader(
                                 [&s, id](const httplib::Request& request, httplib::Response& response,
                                          const httplib::ContentReader& reader) {
                                   std::string body;
                                   if (s.read_body(id, request, reader, body, response)) {
                                     s.handle(id, request, std::string(), response);
                                   }
                                 }));
    } else {
      server.Post(pattern, httplib::Server::HandlerWithContentReader(
                               [&s, id](const httplib::Request& request, httplib::Response& response,
                                        const httplib::ContentReader& reader) {
                                 std::string body;
                                 httplib::MultipartFormDataItems parts;
                                 // Only POST /v1/join takes a multipart body (two files).
                                 if (s.read_body(id, request, reader, body, response,
                                                 id == RouteId::kJoinClips ? &parts : nullptr)) {
                                   s.handle(id, request, body, response, parts);
                                 }
                               }));
    }
  }
  // Any other request that may carry a body is answered 404 without reading
  // it: httplib would first read it whole (up to --max-message-bytes), or
  // wait for a declared one until its read timeout. Registered after the
  // routes, so they match first.
  const httplib::Server::HandlerWithContentReader no_route =
      [](const httplib::Request& request, httplib::Response& response, const httplib::ContentReader&) {
        const ApiError error(ErrorCode::kNotFound, "",
                             "no route " + request.method + " " + request.path +
                                 " (the routes are listed at /v1/openapi.json)");
        // An unread body must not be read as the next request.
        if (request.has_header("Content-Length") || request.has_header("Transfer-Encoding")) {
          send_error_and_close(response, error);
        } else {
          send_error(response, error);
        }
      };
  server.Post(".*", no_route);
  server.Put(".*", no_route);
  server.Patch(".*", no_route);
  server.Delete(".*", no_route);

  const std::string where = s.options.address + ":" + std::to_string(s.options.port);
  int port = s.options.port;
  if (port == 0) {
    port = server.bind_to_any_port(s.options.address);
    if (port <= 0) port = -1;
  } else if (!server.bind_to_port(s.options.address, port)) {
    port = -1;
  }
  if (port < 0) {
    s.server.reset();
    throw std::runtime_error("the REST frontend cannot listen on " + where + " (address in use or not available)");
  }
  if (!set_backlog(static_cast<int>(std::max<size_t>(threads, kMinListenBacklog)))) {
    s.server.reset();
    throw std::runtime_error("the REST frontend cannot listen on " + where);
  }
  s.port = port;
  s.serve_thread = std::thread([&server] { server.listen_after_bind(); });
  // httplib's stop() does nothing before the serving thread has marked the
  // server running; waiting here makes an early shutdown() reliable.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!server.is_running() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

int RestFrontend::port() const { return state_->port; }

void RestFrontend::answer(rest::RouteId route, const httplib::Request& request, const std::string& body,
                          httplib::Response& response) {
  state_->handle(route, request, body, response);
}

void RestFrontend::shutdown() {
  State& s = *state_;
  {
    std::lock_guard<std::mutex> lock(s.streams_mutex);
    s.shutting_down = true;
    for (const auto& stream : s.streams) stream->request_stop();
  }
  if (s.server) s.server->stop();
  // Joining the pool (inside listen_after_bind) lets requests in flight finish.
  if (s.serve_thread.joinable()) s.serve_thread.join();
}

}  // namespace mm::service
