// The service's core API in plain C++ types: what every operation takes and
// returns, independent of the wire. The gRPC and REST frontends translate
// their messages to and from these; the core (manifold_core.h) works on them.
// Torch-free and gRPC-free, so the frontends compile quickly and the wire
// types never reach model/.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "model/training_config.h"

namespace mm::service {

// The error model, shared by both protocols (gRPC status code <-> HTTP status):
enum class ErrorCode {
  kInvalidArgument,     // INVALID_ARGUMENT    400: a field is malformed
  kNotFound,            // NOT_FOUND           404: no such model or job
  kFailedPrecondition,  // FAILED_PRECONDITION 409: the state forbids it (e.g. cancel a finished job)
  kResourceExhausted,   // RESOURCE_EXHAUSTED  413 (too large) / 429 (queue full)
  kUnauthenticated,     // UNAUTHENTICATED     401: token missing or wrong
  kUnavailable,         // UNAVAILABLE         503: no model loaded yet, or shutting down
  kInternal,            // INTERNAL            500
};
const char* error_code_name(ErrorCode code);  // "INVALID_ARGUMENT", ...

// Thrown by the core for a request it refuses. `field` names the request
// field at fault in the wire's own spelling ("motions[2].columns"; empty
// when no one field is), `message` says the value and what was expected.
// `too_large` tells a RESOURCE_EXHAUSTED for size (413) from one for load (429).
class ApiError : public std::runtime_error {
 public:
  ApiError(ErrorCode code, std::string field, const std::string& message, bool too_large = false)
      : std::runtime_error(message), code_(code), field_(std::move(field)), too_large_(too_large) {}
  ErrorCode code() const { return code_; }
  const std::string& field() const { return field_; }
  bool too_large() const { return too_large_; }

 private:
  ErrorCode code_;
  std::string field_;
  bool too_large_;
};

// Who is calling and how: the protocol labels the metrics; the bearer token
// (without "Bearer ", or why the Authorization header was not one:
// core/caller_identity.h) and the caller's address decide whether a call
// that changes state is let in.
struct CallContext {
  std::string protocol;  // "grpc" or "rest"
  std::string bearer_token;
  std::string authorization_problem;  // empty: no header, or a well-formed one
  std::string peer_ip;                // "127.0.0.1", "::1", ...; empty when unknown (not loopback)
};

// A motion on the wire: frames x columns values, row-major, at frame_rate Hz
// (25, the model's rate, or 50, taken to 25 Hz by keeping every second frame
// as the tool does) in a named layout ("h36m-expmap-99": root translation in
// mm then 32 joints x 3 exponential-map values in radians).
struct Motion {
  int frames = 0;
  int columns = 0;
  double frame_rate = 0;
  std::string layout;
  std::vector<float> values;
  // Replies only: where the root translation comes from ("generated",
  // "input" or "none") and, per frame, the planted feet (bit k: foot k of
  // the model's ModelInfo::feet).
  std::string root;
  std::vector<uint32_t> contacts;
};
constexpr const char* kH36mLayout = "h36m-expmap-99";

// A point of the manifold: `latent` floats (64 for the shipped models).
using Code = std::vector<float>;

// A motion or a code, for the operations that take either.
struct MotionOrCode {
  std::optional<Motion> motion;
  std::optional<Code> code;
};

// Which model and version answered a call.
struct AnsweredBy {
  std::string model;
  std::string version;
};

// The decoder of Decode, Sample, Interpolate, Analogy and Denoise: "rotation",
// "velocity", or empty for the model's default (rotation when it has one).
struct EncodeRequest {
  std::string model;  // empty: the active model
  std::vector<Motion> motions;
};
struct EncodeReply {
  AnsweredBy answered_by;
  std::vector<Code> codes;
};

// plant_feet (Decode, Sample, Interpolate, Analogy): correct the root so
// that planted feet stay where they were put (format/foot_contacts.h).
struct DecodeRequest {
  std::string model;
  std::vector<Code> codes;
  std::string decoder;
  bool plant_feet = false;
};
struct MotionsReply {
  AnsweredBy answered_by;
  std::vector<Motion> motions;  // at 25 Hz in the model's layout
  std::vector<Code> codes;      // the codes decoded (Sample, Interpolate, Analogy); empty otherwise
};

struct SampleRequest {
  std::string model;
  int count = 1;
  uint64_t seed = 0;  // the same seed gives the same motions
  std::string decoder;
  bool plant_feet = false;
};

struct InterpolateRequest {
  std::string model;
  MotionOrCode from, to;
  int steps = 2;  // codes from `from` to `to` inclusive
  std::string method = "linear";  // "linear" or "spherical"
  std::string decoder;
  bool plant_feet = false;
};

// a - b + c (Sec. 5.5).
struct AnalogyRequest {
  std::string model;
  MotionOrCode a, b, c;
  std::string decoder;
  bool plant_feet = false;
};

struct DenoiseRequest {
  std::string model;
  std::vector<Motion> motions;
  std::string decoder;
  // The library's DenoiseOptions (model/latent_operations.h).
  bool zeros_are_missing = false;
  bool means_are_missing = false;
  int iterations = 4;
  bool keep_observed = false;
};

// Two clips joined by a transition (model/clip_transition.h). The clips are
// motions as Encode takes them but of any frame count; the reply's motion is
// at 25 Hz, root "input".
struct JoinClipsRequest {
  std::string model;
  Motion a, b;
  double transition_seconds = 1;   // 0.5 to 4
  std::string method = "generated";  // or "crossfade"
  std::string decoder;
};
struct JoinClipsReply {
  AnsweredBy answered_by;
  Motion motion;
  int transition_first_frame = 0, transition_last_frame = 0;  // in `motion`, both included
};

struct ModelInfo {
  std::string name;     // the folder's name in the store
  std::string version;  // content hash of its manifest and .pt files, 16 hex digits
  bool active = false;
  bool loaded = false;
  std::string variant;  // "DKGM", ...
  int hidden = 0, latent = 0, frames = 0, columns = 0;
  double frame_rate = 25;
  std::string layout;
  std::vector<std::string> decoders;
  double load_seconds = 0;  // of its latest load; 0 when not loaded
  std::string precision = "fp32";  // of its inference weights, as --precision sets it for this model
  bool trajectory = false;         // it has a root trajectory network: its motions travel
  std::vector<std::string> feet;   // its skeleton's feet, in the order of Motion::contacts' bits
  // Describe only: the manifest's provenance and the evaluation, JSON text
  // ("{}" when absent), and the model card (Markdown, empty when absent).
  std::string provenance_json = "{}";
  std::string evaluation_json = "{}";
  std::string model_card;
  // Describe only: the skeleton of its motions, the manifest's JSON text
  // (format/skeleton.h: joints, offsets, and the BVH layout of a rig learnt
  // from BVH files; "{}" when absent), so that a client converts BVH itself.
  std::string skeleton_json = "{}";
};

// Clips of the data root (--data-root): the motion files a client may pick
// on the server instead of uploading one.
struct ClipFile {
  std::string path;    // relative to the data root, '/' separators
  std::string format;  // "h36m-text" (*.txt, 99 values a line at 50 Hz) or "bvh" (*.bvh)
  int64_t size_bytes = 0;
  bool uploaded = false;  // written by UploadClip, so DeleteClip may remove it
};
struct ListClipsReply {
  std::vector<ClipFile> clips;  // sorted by path
  bool truncated = false;       // the root holds more files than the server lists
};

struct UploadClipRequest {
  std::string path;     // the new file, relative to the data root, '/' separators
  std::string content;  // its bytes: H3.6M text (*.txt) or BVH (*.bvh)
};

struct ReadClipRequest {
  std::string model;  // whose clip length and skeleton; empty: the active model
  std::string path;   // relative to the data root (as ListClips gives it), or absolute under it
  int64_t start = 0;  // the window's first frame, in the file's own frames
  // The whole file at its own rate instead of one window (start must be 0),
  // bounded by the longest take (core/data_root_clips.h).
  bool whole = false;
};
struct ReadClipReply {
  std::string path;  // relative to the data root
  std::string format;
  int64_t start = 0;
  int64_t file_frames = 0;       // frames of the file at its own rate
  double file_frame_rate = 0;    // Hz: 50 for H3.6M text, 1 / frame time for BVH
  int64_t last_start = 0;        // the largest start that still gives a full window
  Motion motion;                 // the window: the model's clip length at 25 Hz
};

// Training jobs.
enum class JobState { kQueued, kRunning, kSucceeded, kFailed, kCancelled };
const char* job_state_name(JobState state);  // "queued", "running", ...
bool is_terminal(JobState state);

struct JobSpec {
  // A prepared dataset file (.mmd) or an H3.6M-layout text tree
  // (S*/<action>_<n>.txt), relative to the configured data root.
  std::string dataset;
  std::string variant = "DKGM";  // S, D, DK, DKG, DKGM, DKGMZ, Seq2seq
  std::string config_json;       // optional training configuration (JSON text); replaces variant
  int64_t iterations = 0;        // 0: the configuration's
  uint64_t seed = 0;
  int hidden = 0;                // 0: the configuration's
  int batch = 0;                 // 0: the configuration's
  std::string model_name;        // the published model's name; empty: "job-<id>"
};

struct JobProgress {
  int64_t iteration = 0;
  int64_t total = 0;
  std::map<std::string, double> losses;  // every loss term of the latest report
  double iterations_per_second = 0;
  double eta_seconds = 0;
};

struct JobInfo {
  std::string id;
  JobSpec spec;
  // The training configuration the spec resolved to at submission, whole:
  // what the run trains. Absent only in a record stored before
  // configurations were resolved whose spec no longer resolves.
  std::optional<ResolvedTrainConfig> resolved_config;
  // Its JSON text (to_json_text), as the wire shows it; "" when absent. The
  // jobs set the two together (set_resolved_config, jobs/job_record_json.h).
  std::string resolved_config_json;
  JobState state = JobState::kQueued;
  JobProgress progress;
  std::string error;            // why a failed job failed
  std::string published_model;  // the model a succeeded job published
  double created_at = 0, started_at = 0, finished_at = 0;  // Unix seconds; 0 = not yet
  int resumes = 0;  // times it was resumed from a checkpoint after a restart
};

}  // namespace mm::service
