// ServerConnection over REST/JSON (server/rest/README.md): one keep-alive
// httplib client, the token as `Authorization: Bearer`, refusals from the
// JSON error body, WatchJob as the job's Server-Sent Events.
#include <httplib.h>

#include "client/cli/server_connection.h"
#include "client/cli/server_error.h"
#include "format/input_error.h"
#include "wire/bearer_token.h"
#include "wire/rest_error.h"
#include "wire/rest_json.h"

namespace mm::client {
namespace {

using json = nlohmann::json;
using ::mm::wire::to_json;

// A reply's body read into its message by the code the server wrote it with
// (fields this client does not know ignored); a field it cannot read is a
// reply it cannot use.
template <typename Message>
Message reply_message(const json& body) {
  Message message;
  try {
    ::mm::wire::from_json(body, message);
  } catch (const InputError& error) {
    throw ServerError("INTERNAL", "", std::string("the server's reply cannot be read: ") + error.what());
  }
  return message;
}

// The gRPC code of an HTTP status, for bodies that are not the server's
// JSON error (a proxy's page, say).
std::string code_of_http_status(int status) {
  switch (status) {
    case 400: return "INVALID_ARGUMENT";
    case 401: return "UNAUTHENTICATED";
    case 403: return "PERMISSION_DENIED";
    case 404: return "NOT_FOUND";
    case 409: return "FAILED_PRECONDITION";
    case 413: case 429: return "RESOURCE_EXHAUSTED";
    case 502: case 503: case 504: return "UNAVAILABLE";
    default: return "INTERNAL";
  }
}

ServerError error_of_response(int status, const std::string& body) {
  if (const auto error = wire::rest_error_from_body(body, code_of_http_status(status))) {
    return ServerError(error->code, error->field, error->message);
  }
  return ServerError(code_of_http_status(status), "", "HTTP " + std::to_string(status) + ": " + body);
}

// Path parameters never hold '/' or ':' on the server's side; escape what
// a user typed anyway so that it reaches the server as one segment. Query
// values are escaped the same way (a data-root path's '/' included).
std::string segment(const std::string& value) {
  static const char* hex = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : value) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') {
      out += static_cast<char>(c);
    } else {
      out += '%';
      out += hex[c >> 4];
      out += hex[c & 15];
    }
  }
  return out;
}

// A number as a query value (JSON's shortest form that reads back the same).
std::string number(double value) { return json(value).dump(); }

// The query of a take route (server/rest/README.md): the header's fields,
// those left at their defaults left out; the rate only for text, since a
// BVH states its own.
std::string take_query(const v1::TakeHeader& h, bool bvh) {
  std::string query;
  const auto add = [&query](const std::string& name, const std::string& value) {
    query += (query.empty() ? "?" : "&") + name + "=" + segment(value);
  };
  if (!h.model().empty()) add("model", h.model());
  if (!bvh) add("frame_rate", number(h.frame_rate()));
  if (h.hop_seconds() > 0) add("hop_seconds", number(h.hop_seconds()));
  if (!h.blend().empty()) add("blend", h.blend());
  if (!h.decoder().empty()) add("decoder", h.decoder());
  if (h.at_model_rate()) add("at_model_rate", "true");
  if (h.zeros_are_missing()) add("zeros_are_missing", "true");
  if (h.means_are_missing()) add("means_are_missing", "true");
  if (h.iterations() > 0) add("iterations", std::to_string(h.iterations()));
  if (h.keep_observed()) add("keep_observed", "true");
  if (!h.gap_fill().empty()) add("gap_fill", h.gap_fill());
  if (!h.root().empty()) add("root", h.root());
  return query;
}

// A take's JSON reply passed on as its gRPC stream would be.
v1::TakeSummary pass_on_take_reply(const json& body, TakeReplySink& sink) {
  auto reply = reply_message<::mm::wire::TakeReply>(body);
  sink.header(reply.header);
  sink.chunk(reply.frames);
  return std::move(reply.summary);
}

// A take's reply as the file the sink asked for, its summary from the
// X-Take-* headers (no window codes: those come only with JSON).
v1::TakeSummary pass_on_whole_file(const httplib::Response& response, int64_t input_frames, TakeReplySink& sink) {
  const auto number = [&response](const char* name) {
    const std::string value = response.get_header_value(name);
    if (value.empty()) throw std::runtime_error(std::string("the take's reply lacks its ") + name + " header");
    return std::stod(value);
  };
  v1::TakeSummary summary;
  summary.set_frames(static_cast<int64_t>(number("X-Take-Frames")));
  summary.set_input_frames(input_frames);
  summary.set_mean_error_mm(number("X-Take-Mean-Error-Mm"));
  summary.set_max_error_mm(number("X-Take-Max-Error-Mm"));
  // The gap fill's counts: absent (0) from a server older than them.
  const auto count = [&response](const char* name) {
    const std::string value = response.get_header_value(name);
    return value.empty() ? 0 : std::stoi(value);
  };
  summary.set_gap_windows_fitted(count("X-Take-Gap-Windows-Fitted"));
  summary.set_gaps_fitted(count("X-Take-Gaps-Fitted"));
  summary.set_gaps_over_fit_limit(count("X-Take-Gaps-Over-Fit-Limit"));
  sink.whole_file(response.body, summary.frames(), number("X-Take-Frame-Rate"),
                  static_cast<int64_t>(number("X-Take-Windows")));
  return summary;
}

class RestConnection : public ServerConnection {
 public:
  explicit RestConnection(const ConnectionOptions& options) : options_(options), client_(base_url(options)) {
    if (!client_.is_valid()) throw InputError("--rest-url " + options.rest_url + ": not a valid http(s) URL");
    const auto timeout = static_cast<time_t>(options.timeout_seconds);
    client_.set_connection_timeout(10, 0);
    client_.set_read_timeout(timeout, 0);
    client_.set_write_timeout(timeout, 0);
    client_.set_keep_alive(true);
    client_.set_tcp_nodelay(true);
#ifdef CPPHTTPLIB_OPENSSL_SUPPORT
    if (!options.tls_ca.empty()) client_.set_ca_cert_path(options.tls_ca.c_str());
#endif
    if (!options.token.empty()) {
      client_.set_default_headers({{"Authorization", wire::bearer_authorization(options.token)}});
    }
  }

  v1::EncodeReply encode(const v1::EncodeRequest& r) override {
    return reply_message<v1::EncodeReply>(post("/v1/encode", to_json(r)));
  }
  v1::MotionsReply decode(const v1::DecodeRequest& r) override {
    return reply_message<v1::MotionsReply>(post("/v1/decode", to_json(r)));
  }
  v1::MotionsReply sample(const v1::SampleRequest& r) override {
    return reply_message<v1::MotionsReply>(post("/v1/sample", to_json(r)));
  }
  v1::MotionsReply interpolate(const v1::InterpolateRequest& r) override {
    return reply_message<v1::MotionsReply>(post("/v1/interpolate", to_json(r)));
  }
  v1::MotionsReply analogy(const v1::AnalogyRequest& r) override {
    return reply_message<v1::MotionsReply>(post("/v1/analogy", to_json(r)));
  }
  v1::MotionsReply denoise(const v1::DenoiseRequest& r) override {
    return reply_message<v1::MotionsReply>(post("/v1/denoise", to_json(r)));
  }
  v1::JoinClipsReply join_clips(const v1::JoinClipsRequest& r) override {
    return reply_message<v1::JoinClipsReply>(post("/v1/join", to_json(r)));
  }

  v1::ListModelsReply list_models() override { return reply_message<v1::ListModelsReply>(get("/v1/models")); }
  v1::ModelInfo describe_model(const std::string& name) override {
    // REST names the model in the path; the active one is found in the list.
    if (name.empty()) {
      // Held here: a range-for over a member of the temporary reply would
      // read it after its destruction.
      const v1::ListModelsReply listed = list_models();
      for (const auto& model : listed.models()) {
        if (model.active()) return reply_message<v1::ModelInfo>(get("/v1/models/" + segment(model.name())));
      }
      throw ServerError("UNAVAILABLE", "model", "the server has no active model");
    }
    return reply_message<v1::ModelInfo>(get("/v1/models/" + segment(name)));
  }
  v1::ModelInfo activate_model(const std::string& name) override {
    return reply_message<v1::ModelInfo>(post("/v1/models/" + segment(name) + ":activate", json::object()));
  }
  v1::ModelInfo delete_model(const std::string& name) override {
    return reply_message<v1::ModelInfo>(del("/v1/models/" + segment(name)));
  }

  v1::ListClipsReply list_clips() override { return reply_message<v1::ListClipsReply>(get("/v1/clips")); }
  v1::ReadClipReply read_clip(const v1::ReadClipRequest& request) override {
    std::string query = "?path=" + segment(request.path());
    // A whole read has no start: one given is sent, for the server to refuse as gRPC's is.
    if (!request.whole() || request.start() != 0) query += "&start=" + std::to_string(request.start());
    if (!request.model().empty()) query += "&model=" + segment(request.model());
    return reply_message<v1::ReadClipReply>(get((request.whole() ? "/v1/clips/motion" : "/v1/clips/window") + query));
  }
  v1::ClipFile upload_clip(const v1::UploadClipRequest& request) override {
    return reply_message<v1::ClipFile>(reply_of(client_.Post(
        ("/v1/clips:upload?path=" + segment(request.path())).c_str(), request.content(), "application/octet-stream")));
  }
  v1::ClipFile delete_clip(const std::string& path) override {
    return reply_message<v1::ClipFile>(del("/v1/clips?path=" + segment(path)));
  }

  v1::Job submit_job(const v1::JobSpec& spec) override {
    return reply_message<v1::Job>(post("/v1/jobs", to_json(spec)));
  }
  v1::Job get_job(const std::string& id) override { return reply_message<v1::Job>(get("/v1/jobs/" + segment(id))); }
  v1::ListJobsReply list_jobs() override { return reply_message<v1::ListJobsReply>(get("/v1/jobs")); }
  v1::Job cancel_job(const std::string& id) override {
    return reply_message<v1::Job>(post("/v1/jobs/" + segment(id) + ":cancel", json::object()));
  }
  v1::Job delete_job(const std::string& id) override {
    return reply_message<v1::Job>(del("/v1/jobs/" + segment(id)));
  }

  void watch_job(const std::string& id, const std::function<void(const v1::Job&)>& on_record) override {
    int status = 0;
    std::string pending, error_body;
    bool final_seen = false;
    // One event is "event: job\ndata: <JSON>\n\n"; comments (": keep-alive")
    // only prove the connection alive.
    const auto on_event = [&](const std::string& event) {
      std::string data;
      size_t start = 0;
      while (start < event.size()) {
        size_t end = event.find('\n', start);
        if (end == std::string::npos) end = event.size();
        const std::string line = event.substr(start, end - start);
        if (line.rfind("data:", 0) == 0) data += line.substr(line.size() > 5 && line[5] == ' ' ? 6 : 5);
        start = end + 1;
      }
      if (data.empty()) return;
      const v1::Job job = reply_message<v1::Job>(json::parse(data));
      on_record(job);
      if (is_final_state(job.state())) final_seen = true;
    };
    httplib::Client stream_client(base_url(options_));
    stream_client.set_connection_timeout(10, 0);
    stream_client.set_read_timeout(60, 0);  // the server writes a keep-alive every 2 s
#ifdef CPPHTTPLIB_OPENSSL_SUPPORT
    if (!options_.tls_ca.empty()) stream_client.set_ca_cert_path(options_.tls_ca.c_str());
#endif
    const auto result = stream_client.Get(
        ("/v1/jobs/" + segment(id) + "/events").c_str(), httplib::Headers{{"Accept", "text/event-stream"}},
        [&](const httplib::Response& response) {
          status = response.status;
          return true;
        },
        [&](const char* data, size_t length) {
          if (status != 200) {
            error_body.append(data, length);
            return true;
          }
          pending.append(data, length);
          for (size_t end; (end = pending.find("\n\n")) != std::string::npos;) {
            const std::string event = pending.substr(0, end);
            pending.erase(0, end + 2);
            on_event(event);
          }
          return true;
        });
    if (final_seen) return;
    if (status != 0 && status != 200) throw error_of_response(status, error_body);
    if (!result) throw unreachable(result.error());
    throw ServerError("UNAVAILABLE", "", "the job's event stream ended before the job did");
  }

  v1::CodeTrack encode_take(const TakeUpload& take) override {
    return reply_message<v1::CodeTrack>(post_take("/v1/takes:encode", take));
  }
  v1::TakeSummary transform_take(TakeOperation operation, const TakeUpload& take, TakeReplySink& sink) override {
    const char* route = operation == TakeOperation::kDenoise ? "/v1/takes:denoise" : "/v1/takes:reconstruct";
    const std::string type = sink.whole_file_type();
    if (type.empty()) return pass_on_take_reply(post_take(route, take), sink);
    const auto result = take_response(route, take, type);
    return pass_on_whole_file(checked(result), take.frames.frame_count(), sink);
  }
  v1::TakeSummary decode_track(const v1::DecodeTrackRequest& request, TakeReplySink& sink) override {
    const std::string type = sink.whole_file_type();
    if (type.empty()) return pass_on_take_reply(post("/v1/tracks:decode", to_json(request)), sink);
    const auto result = client_.Post("/v1/tracks:decode", httplib::Headers{{"Accept", type}},
                                     ::mm::wire::body_text(to_json(request)), "application/json");
    return pass_on_whole_file(checked(result), 0, sink);
  }

 private:
  static std::string base_url(const ConnectionOptions& options) {
    std::string url = options.rest_url;
    while (!url.empty() && url.back() == '/') url.pop_back();
    // --tls turns a bare http URL into https, as it turns TLS on for gRPC.
    if (uses_tls(options) && url.rfind("http://", 0) == 0) url = "https://" + url.substr(7);
    if (url.find("://") == std::string::npos) url = (uses_tls(options) ? "https://" : "http://") + url;
    return url;
  }

  ServerError unreachable(httplib::Error error) const {
    return ServerError("UNAVAILABLE", "", options_.rest_url + ": " + httplib::to_string(error));
  }

  json reply_of(const httplib::Result& result) const {
    if (!result) throw unreachable(result.error());
    if (result->status != 200) throw error_of_response(result->status, result->body);
    return json::parse(result->body);
  }

  json get(const std::string& path) { return reply_of(client_.Get(path.c_str())); }
  json del(const std::string& path) { return reply_of(client_.Delete(path.c_str())); }
  // `body`: a request as wire/rest_json.h writes it (json or FloatJson).
  template <typename Document>
  json post(const std::string& path, const Document& body) {
    return reply_of(client_.Post(path.c_str(), ::mm::wire::body_text(body), "application/json"));
  }

  // The take's file as the body, as the client read it; the reply as JSON.
  json post_take(const std::string& route, const TakeUpload& take) {
    return reply_of(take_response(route, take, "application/json"));
  }
  // The same, the reply as `accept` asks.
  httplib::Result take_response(const std::string& route, const TakeUpload& take, const std::string& accept) {
    const std::string path = route + take_query(take.header, take.bvh);
    return client_.Post(path.c_str(), httplib::Headers{{"Accept", accept}}, take.file_bytes,
                        take.bvh ? "application/x-bvh" : "text/plain");
  }
  // A successful response, or the refusal thrown.
  const httplib::Response& checked(const httplib::Result& result) const {
    if (!result) throw unreachable(result.error());
    if (result->status != 200) throw error_of_response(result->status, result->body);
    return *result;
  }

  ConnectionOptions options_;
  httplib::Client client_;
};

}  // namespace

std::unique_ptr<ServerConnection> rest_connection(const ConnectionOptions& options) {
  return std::make_unique<RestConnection>(options);
}

}  // namespace mm::client
