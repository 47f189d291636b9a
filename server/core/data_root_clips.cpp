#include "server/core/data_root_clips.h"

#include "format/animation_file.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "format/bvh_file.h"
#include "format/input_error.h"
#include "format/motion_text.h"
#include "format/motion_text_rows.h"
#include "format/rig_folder_dataset.h"
#include "format/skeleton_bvh.h"
#include "server/api/data_root_path.h"
#include "server/jobs/upload_reservations.h"

namespace mm::service {
namespace {

namespace fs = std::filesystem;

// Larger files are refused before they are read: a window needs a few MB of
// any real motion file, and a request must not make the server read gigabytes.
constexpr uintmax_t kMaxClipFileBytes = uintmax_t{256} << 20;

// The hidden folder that marks which files of the root were uploaded: an
// empty file at the same relative path for each.
constexpr const char* kUploadMarks = ".uploads";

fs::path upload_mark(const fs::path& root, const fs::path& file) {
  return root / kUploadMarks / file.lexically_relative(root);
}

// 50 Hz text rows per frame at the model's 25 Hz.
constexpr int64_t kTextRowsPerModelFrame = 2;

ApiError invalid(const std::string& field, const std::string& message) {
  return ApiError(ErrorCode::kInvalidArgument, field, message);
}

std::string quoted(const std::string& value) {
  return nlohmann::json(value).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string decimal(double value, const char* format = "%g") {
  char text[32];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

// The format a file's extension names; empty for neither.
std::string clip_format(const fs::path& path) {
  std::string extension = path.extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (extension == ".txt") return kH36mTextFormat;
  if (extension == ".bvh") return kBvhFormat;
  if (extension == ".glb" || extension == ".gltf") return kGltfFormat;
  if (extension == ".fbx") return kFbxFormat;
  return "";
}

fs::path data_root_folder(const std::string& data_root) {
  if (data_root.empty()) {
    throw ApiError(ErrorCode::kFailedPrecondition, "",
                   "this server was started without --data-root: it has no folder of clips to list, read or write");
  }
  const fs::path root = canonical_data_root(data_root);
  std::error_code error;
  if (!fs::is_directory(root, error)) {
    throw ApiError(ErrorCode::kFailedPrecondition, "", "the data root (--data-root) " + data_root + " is not a folder");
  }
  return root;
}

void check_start(int64_t start, int64_t last_start, const std::string& window) {
  if (start < 0) {
    throw invalid("start", "start " + std::to_string(start) + " is negative, expected 0 to " +
                               std::to_string(last_start) + " (" + window + ")");
  }
  if (start > last_start) {
    throw invalid("start", "start " + std::to_string(start) + " is past the last full window, expected 0 to " +
                               std::to_string(last_start) + " (" + window + ")");
  }
}

std::string read_whole_file(const fs::path& path, uintmax_t size, const std::string& relative) {
  std::ifstream in(path, std::ios::binary);
  std::string data(static_cast<size_t>(size), '\0');
  if (!in || !in.read(data.data(), static_cast<std::streamsize>(size))) {
    throw invalid("path", relative + ": the file cannot be read");
  }
  return data;
}

// Every second row from `start`, as Encode takes a 50 Hz motion to 25 Hz.
// The rows are counted first (at most kMaxMotionTextRows) and only the
// window's are parsed.
void read_text_window(const std::string& data, const std::string& relative, const ModelShape& shape,
                      int64_t start, ReadClipReply& reply) {
  const int64_t window_rows = kTextRowsPerModelFrame * shape.frames;
  reply.file_frames = count_motion_text_rows(data.data(), data.size(), relative, kH36mColumns);
  reply.file_frame_rate = kH36mFrameRate;
  reply.last_start = reply.file_frames - window_rows;
  const std::string window = relative + " has " + std::to_string(reply.file_frames) + " frames at 50 Hz and a window takes " +
                             std::to_string(window_rows) + " of them, " + std::to_string(shape.frames) +
                             " at the model's 25 Hz";
  if (reply.last_start < 0) {
    throw invalid("path", relative + " is shorter than one window: it has " + std::to_string(reply.file_frames) +
                              " frames at 50 Hz, expected at least " + std::to_string(window_rows) + " (" +
                              std::to_string(shape.frames) + " at the model's 25 Hz)");
  }
  check_start(start, reply.last_start, window);
  const MotionFrames rows = parse_motion_text_rows(data.data(), data.size(), relative, kH36mColumns, start, window_rows,
                                                   /*nan_is_missing=*/true);
  Motion& motion = reply.motion;
  motion.frames = shape.frames;
  motion.columns = rows.columns;
  motion.frame_rate = 25;
  motion.layout = layout_name(rows.columns);
  motion.values.reserve(static_cast<size_t>(shape.frames) * rows.columns);
  for (int64_t k = 0; k < shape.frames; ++k) {
    const float* row = rows.frame(kTextRowsPerModelFrame * k);
    motion.values.insert(motion.values.end(), row, row + rows.columns);
  }
}

// Resampled from `start` to 25 Hz; in the model's skeleton when the file is
// of its hierarchy, else in the file's own. The file's declared length is
// bounded (the longest take, checked before its frames are read) and only
// the window's frames are resampled.
void read_bvh_window(const std::string& data, const std::string& relative, const ModelShape& shape, int64_t start,
                     ReadClipReply& reply) {
  // glTF and FBX in the unit of the model's rig (its length unit told below
  // for another rig's).
  AnimationFormat animation = AnimationFormat::kBvh;
  animation_format_of_path(relative, &animation);
  const BvhFile file = parse_animation_file(data.data(), data.size(), animation, relative,
                                            bvh_layout_of(shape.skeleton).millimetres_per_unit);
  Skeleton skeleton = shape.skeleton;
  std::string layout = shape.layout;
  try {
    match_bvh_to_skeleton(shape.skeleton, file, relative);
  } catch (const InputError&) {
    double millimetres_per_unit = 1;
    try {
      millimetres_per_unit = detect_bvh_millimetres_per_unit(file, relative);
    } catch (const InputError&) {
      throw invalid("path", relative + " is a BVH of another skeleton than the model's whose length unit cannot be "
                                       "told: its rest pose is no person 0.5 to 3 m tall in mm, cm or m");
    }
    skeleton = bvh_skeleton(file, fs::path(relative).stem().string(), millimetres_per_unit);
    layout = "expmap-" + std::to_string(skeleton_motion_columns(skeleton));
  }

  const int64_t frames = file.frame_count();
  reply.file_frames = frames;
  reply.file_frame_rate = bvh_frame_rate(file);
  const std::string rate = decimal(reply.file_frame_rate);
  if (bvh_imported_frame_count(frames, file.frame_time_s) < shape.frames) {
    throw invalid("path", relative + " is shorter than one window: its " + std::to_string(frames) + " frames at " +
                              rate + " Hz last " + decimal((frames - 1) * file.frame_time_s, "%.2f") +
                              " s, expected at least " + decimal((shape.frames - 1) / kBvhImportRate, "%.2f") +
                              " s (" + std::to_string(shape.frames) + " frames at 25 Hz)");
  }
  // The last start from which the import still makes a full window: the
  // estimate from the durations, then moved to the importer's own count
  // (bvh_imported_frame_count), so that the two agree to the last frame.
  int64_t last = frames - 1 -
                 static_cast<int64_t>(std::ceil((shape.frames - 1) / (kBvhImportRate * file.frame_time_s)));
  last = std::clamp<int64_t>(last, 0, frames - 1);
  while (last > 0 && bvh_imported_frame_count(frames - last, file.frame_time_s) < shape.frames) --last;
  while (last + 1 < frames && bvh_imported_frame_count(frames - last - 1, file.frame_time_s) >= shape.frames) ++last;
  reply.last_start = last;
  check_start(start, last,
              relative + " has " + std::to_string(frames) + " frames at " + rate + " Hz and a window is " +
                  std::to_string(shape.frames) + " frames at 25 Hz");

  // Only the window's frames are resampled, not the whole file.
  MotionFrames motion = skeleton_motion_window_from_bvh(skeleton, file, relative, start, shape.frames);

  reply.motion.frames = shape.frames;
  reply.motion.columns = motion.columns;
  reply.motion.frame_rate = kBvhImportRate;
  reply.motion.layout = layout;
  reply.motion.values = std::move(motion.values);
}

// A whole read is as long as a take may be: refused, naming the file's
// length and the limit, when its last frame lies past it (as TakeProcessor
// counts a take's length, so that what is read here a take of the same file
// accepts), or when its values would not fit one gRPC message.
void check_whole_length(int64_t frames, double frame_rate, int columns, const WholeReadLimits& limits,
                        const std::string& relative) {
  const double last_seconds = static_cast<double>(frames - 1) / frame_rate;
  if (limits.max_seconds > 0 && last_seconds > limits.max_seconds) {
    throw invalid("path", relative + " is " + std::to_string(frames) + " frames at " + decimal(frame_rate) +
                              " Hz, its last at " + decimal(last_seconds, "%.2f") +
                              " s, longer than the longest take (--max-take-seconds " + decimal(limits.max_seconds) +
                              " s)");
  }
  const double bytes = static_cast<double>(frames) * columns * sizeof(float);
  if (limits.max_bytes > 0 && bytes > static_cast<double>(limits.max_bytes)) {
    throw invalid("path", relative + " is " + std::to_string(frames) + " frames of " + std::to_string(columns) +
                              " values, " + decimal(bytes / (1 << 20), "%.1f") +
                              " MiB read whole, more than one reply may carry (--max-message-bytes " +
                              std::to_string(limits.max_bytes) + "): read it by windows or as a take");
  }
}

// Every row at 50 Hz; counted and bounded before any is parsed.
void read_text_whole(const std::string& data, const std::string& relative, const WholeReadLimits& limits,
                     ReadClipReply& reply) {
  reply.file_frames = count_motion_text_rows(data.data(), data.size(), relative, kH36mColumns);
  reply.file_frame_rate = kH36mFrameRate;
  check_whole_length(reply.file_frames, kH36mFrameRate, kH36mColumns, limits, relative);
  MotionFrames rows = parse_motion_text_rows(data.data(), data.size(), relative, kH36mColumns, 0, reply.file_frames,
                                             /*nan_is_missing=*/true);
  reply.motion.frames = reply.file_frames;
  reply.motion.columns = rows.columns;
  reply.motion.frame_rate = kH36mFrameRate;
  reply.motion.layout = layout_name(rows.columns);
  reply.motion.values = std::move(rows.values);
}

// Every frame at the file's rate in the model's skeleton, as a take reads
// the file; the declared length is bounded before the frames are converted.
void read_bvh_whole(const std::string& data, const std::string& relative, const ModelShape& shape,
                    const WholeReadLimits& limits, ReadClipReply& reply) {
  AnimationFormat animation = AnimationFormat::kBvh;
  animation_format_of_path(relative, &animation);
  const BvhFile file = parse_animation_file(data.data(), data.size(), animation, relative,
                                            bvh_layout_of(shape.skeleton).millimetres_per_unit);
  reply.file_frames = file.frame_count();
  reply.file_frame_rate = bvh_frame_rate(file);
  check_whole_length(reply.file_frames, reply.file_frame_rate, shape.columns, limits, relative);
  MotionFrames frames = skeleton_motion_from_bvh_at_file_rate(shape.skeleton, file, relative);
  reply.motion.frames = frames.frame_count();
  reply.motion.columns = frames.columns;
  reply.motion.frame_rate = reply.file_frame_rate;
  reply.motion.layout = shape.layout;
  reply.motion.values = std::move(frames.values);
}

}  // namespace

ListClipsReply list_data_root_clips(const std::string& data_root, int max_clips) {
  const fs::path root = data_root_folder(data_root);
  ListClipsReply reply;
  std::error_code error, ignored;
  // Links to folders are not followed (the iterator's default): one could
  // lead out of the root, or round in a cycle.
  fs::recursive_directory_iterator it(root, fs::directory_options::skip_permission_denied, error), end;
  for (; !error && it != end; it.increment(error)) {
    const fs::path& path = it->path();
    if (path.filename().string().rfind('.', 0) == 0) {
      if (it->is_directory(ignored)) it.disable_recursion_pending();
      continue;
    }
    // A name no client could ask ReadClip for is not listed.
    const std::string relative = path.lexically_relative(root).generic_string();
    if (first_control_character(relative)) continue;
    fs::path target = path;
    if (it->is_symlink(ignored)) {
      const auto resolved = resolve_under_data_root(root, relative, "path");
      if (!resolved) continue;  // a link out of the root is not a clip of it
      target = *resolved;
    }
    const std::string format = clip_format(target);
    if (format.empty() || !fs::is_regular_file(target, ignored)) continue;
    ClipFile clip;
    clip.path = relative;
    clip.format = format;
    clip.size_bytes = static_cast<int64_t>(fs::file_size(target, ignored));
    clip.uploaded = fs::exists(upload_mark(root, target), ignored);
    reply.clips.push_back(std::move(clip));
  }
  if (error) {
    throw ApiError(ErrorCode::kInternal, "", "the data root cannot be read: " + error.message());
  }
  std::sort(reply.clips.begin(), reply.clips.end(),
            [](const ClipFile& a, const ClipFile& b) { return a.path < b.path; });
  if (static_cast<int64_t>(reply.clips.size()) > max_clips) {
    reply.clips.resize(static_cast<size_t>(std::max(0, max_clips)));
    reply.truncated = true;
  }
  return reply;
}

ReadClipReply read_data_root_clip(const std::string& data_root, const ReadClipRequest& request,
                                  const ModelShape& shape, const WholeReadLimits& whole_limits) {
  const fs::path root = data_root_folder(data_root);
  if (request.whole && request.start != 0) {
    throw invalid("start", "start " + std::to_string(request.start) +
                               " with whole, expected 0: a whole read begins at the file's first frame");
  }
  if (request.path.empty()) {
    throw invalid("path", "path is empty, expected a .txt or .bvh file under the data root (as ListClips names it)");
  }
  const auto resolved = resolve_under_data_root(root, request.path, "path");
  if (!resolved) {
    throw invalid("path", "path " + quoted(request.path) +
                              " lies outside the data root, expected a file under it (as ListClips names it)");
  }
  std::error_code error;
  if (!fs::exists(*resolved, error)) {
    throw ApiError(ErrorCode::kNotFound, "path",
                   "path " + quoted(request.path) + " names no file under the data root (ListClips names them)");
  }
  if (!fs::is_regular_file(*resolved, error)) {
    throw invalid("path", "path " + quoted(request.path) + " is a folder, expected a .txt or .bvh file");
  }
  const std::string format = clip_format(*resolved);
  if (format.empty()) {
    throw invalid("path", "path " + quoted(request.path) +
                              " is neither H3.6M text (.txt) nor BVH, glTF or FBX (.bvh, .glb, .gltf, .fbx), "
                              "expected one of them");
  }
  const uintmax_t size = fs::file_size(*resolved, error);
  if (error) throw invalid("path", "path " + quoted(request.path) + " cannot be read: " + error.message());
  if (size > kMaxClipFileBytes) {
    throw ApiError(ErrorCode::kResourceExhausted, "path",
                   "path " + quoted(request.path) + " is " + std::to_string(size) + " bytes, more than the " +
                       std::to_string(kMaxClipFileBytes) + " a clip file may have",
                   /*too_large=*/true);
  }

  ReadClipReply reply;
  reply.path = resolved->lexically_relative(root).generic_string();
  reply.format = format;
  reply.start = request.start;
  const std::string data = read_whole_file(*resolved, size, reply.path);
  try {
    if (request.whole && format == kH36mTextFormat) {
      read_text_whole(data, reply.path, whole_limits, reply);
    } else if (request.whole) {
      read_bvh_whole(data, reply.path, shape, whole_limits, reply);
    } else if (format == kH36mTextFormat) {
      read_text_window(data, reply.path, shape, request.start, reply);
    } else {
      read_bvh_window(data, reply.path, shape, request.start, reply);
    }
  } catch (const InputError& e) {
    throw invalid("path", e.what());
  }
  return reply;
}

namespace {

// The path an upload names, checked for its form: relative, '/'-separated
// components that are neither empty nor hidden (which also rules out `.`
// and `..`), a clip's extension.
void check_upload_path(const std::string& path) {
  const auto refuse = [&](const std::string& why) {
    throw invalid("path", "path " + quoted(path) + " " + why);
  };
  if (path.empty()) refuse("is empty, expected a file's path relative to the data root (\"mine/walk_01.bvh\")");
  if (path.size() > 1024) refuse("is longer than 1024 characters");
  if (path.front() == '/') refuse("is absolute, expected a path relative to the data root");
  size_t begin = 0;
  while (begin <= path.size()) {
    const size_t end = std::min(path.find('/', begin), path.size());
    const std::string component = path.substr(begin, end - begin);
    if (component.empty()) refuse("has an empty component, expected names separated by single '/'");
    if (component.front() == '.') refuse("has a component starting with '.' (" + quoted(component) + "), which names hidden or parent folders");
    // The file is first written under a longer temporary name in the same
    // folder, and a name past the file system's 255 bytes fails only there.
    if (component.size() > kMaxUploadedNameBytes) {
      refuse("has a component of " + std::to_string(component.size()) + " bytes, expected at most " +
             std::to_string(kMaxUploadedNameBytes));
    }
    begin = end + 1;
  }
  if (clip_format(fs::path(path)).empty()) {
    refuse("has neither extension .txt (H3.6M text) nor .bvh, .glb, .gltf or .fbx (an animation file)");
  }
}

// The content parsed as its format says; INVALID_ARGUMENT "content" naming
// the file and the parser's message otherwise.
void check_upload_content(const std::string& content, const std::string& format, const std::string& path) {
  if (content.empty()) throw invalid("content", path + ": the content is empty, expected a motion file");
  try {
    if (format != kH36mTextFormat) {
      AnimationFormat animation = AnimationFormat::kBvh;
      animation_format_of_path(path, &animation);
      parse_animation_file(content, animation, path, 0);  // its length bounded before its frames are read
    } else {
      count_motion_text_rows(content.data(), content.size(), path, kH36mColumns);  // before any value is parsed
      parse_motion_text_buffer(content.data(), content.size(), path);
    }
  } catch (const InputError& error) {
    throw invalid("content", error.what());
  }
}

ApiError over_quota(const std::string& message) {
  return ApiError(ErrorCode::kResourceExhausted, "content", message, /*too_large=*/true);
}

void check_upload_size(const std::string& path, int64_t size, const DataRootQuota& quota) {
  if (size > quota.max_upload_bytes) {
    throw over_quota(path + ": " + std::to_string(size) + " bytes, more than the " +
                     std::to_string(quota.max_upload_bytes) + " an uploaded file may have (--max-upload-bytes)");
  }
}

// What the root would hold with the upload (and with what other replicas'
// uploads in flight have reserved), against the quota; each refusal names
// the quota, the use and the option.
void check_root_quota(const fs::path& root, const std::string& path, int64_t size, const DataRootQuota& quota,
                      const UploadReservations::Reserved& reserved = {}) {
  const DataRootUse use = data_root_use(root.string());
  const std::string in_flight =
      reserved.files == 0 ? ""
                          : " (and uploads in flight on the replicas " + std::to_string(reserved.bytes) + " more)";
  if (use.bytes + reserved.bytes + size > quota.max_root_bytes) {
    throw over_quota(path + ": the data root holds " + std::to_string(use.bytes) + " bytes" + in_flight + ", and " +
                     std::to_string(size) + " more would pass its quota of " + std::to_string(quota.max_root_bytes) +
                     " bytes (--max-data-root-bytes); delete uploads (DeleteClip) to make room");
  }
  if (use.files + reserved.files + 1 > quota.max_root_files) {
    throw over_quota(path + ": the data root holds " + std::to_string(use.files) + " files" +
                     (reserved.files == 0 ? "" : " (and uploads in flight on the replicas " +
                                                     std::to_string(reserved.files) + " more)") +
                     ", its quota (--max-data-root-files " + std::to_string(quota.max_root_files) +
                     "); delete uploads (DeleteClip) to make room");
  }
}

// A reservation of quota.shared, given back when the upload ends, written
// or not. A release that fails (the database gone) is only logged: the
// reservation lapses by itself (UploadReservations::kReservationSeconds).
class Reservation {
 public:
  Reservation() = default;
  Reservation(std::shared_ptr<UploadReservations> shared, int64_t id) : shared_(std::move(shared)), id_(id) {}
  Reservation(const Reservation&) = delete;
  Reservation& operator=(Reservation&& other) noexcept {
    std::swap(shared_, other.shared_);
    std::swap(id_, other.id_);
    return *this;
  }
  ~Reservation() {
    if (!shared_) return;
    try {
      shared_->release(id_);
    } catch (const std::exception& e) {
      spdlog::warn("an upload's quota reservation {} was not given back ({}); it lapses in {} s", id_, e.what(),
                   UploadReservations::kReservationSeconds);
    }
  }

 private:
  std::shared_ptr<UploadReservations> shared_;
  int64_t id_ = 0;
};

// The temporary names of write_data_root_clip: ".<clip>.upload.<pid>.<n>",
// and earlier versions' ".<clip>.upload.<pid>.<n>.tmp.<pid>.<n>" (theirs
// went through write_file_atomically, which adds the second part).
constexpr const char* kUploadInfix = ".upload.";
constexpr const char* kLegacySuffix = ".tmp.";

bool all_digits(const std::string& text) {
  return !text.empty() && std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// "<digits>.<digits>" exactly.
bool counted_pair(const std::string& text) {
  const size_t dot = text.find('.');
  return dot != std::string::npos && all_digits(text.substr(0, dot)) && all_digits(text.substr(dot + 1));
}

enum class TemporaryKind { kNone, kLocked, kLegacy };

TemporaryKind upload_temporary_kind(const std::string& name) {
  if (name.size() < 2 || name.front() != '.') return TemporaryKind::kNone;
  const size_t infix = name.find(kUploadInfix, 1);
  if (infix == std::string::npos || infix < 2) return TemporaryKind::kNone;
  // The clip's own name: what an upload may name (no dot first, an extension).
  const std::string clip = name.substr(1, infix - 1);
  if (clip.front() == '.' || clip_format(fs::path(clip)).empty()) return TemporaryKind::kNone;
  const std::string rest = name.substr(infix + std::strlen(kUploadInfix));
  if (counted_pair(rest)) return TemporaryKind::kLocked;
  const size_t legacy = rest.find(kLegacySuffix);
  if (legacy != std::string::npos && counted_pair(rest.substr(0, legacy)) &&
      counted_pair(rest.substr(legacy + std::strlen(kLegacySuffix)))) {
    return TemporaryKind::kLegacy;
  }
  return TemporaryKind::kNone;
}

// Earlier versions' temporary files carry no lock: one unchanged this long
// has no writer (an upload is written from memory in seconds).
constexpr auto kLegacyLeftoverAge = std::chrono::minutes(10);

// Removes `path` when no process holds its lock (see sweep_upload_leftovers)
// or, for a legacy name, when it is old enough; adds its size to `bytes`.
// The lock is taken on the file and the name is checked to still be that
// file before the unlink, so a writer that creates its file between the two
// (it locks it at once, and checks after locking that its file still has a
// name) never loses it.
bool remove_abandoned(const fs::path& path, TemporaryKind kind, int64_t& bytes) {
  int fd = ::open(path.c_str(), O_RDWR | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0 && errno == EACCES) fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return false;
  bool removed = false;
  struct stat held {}, named {};
  if (::flock(fd, LOCK_EX | LOCK_NB) == 0 && ::fstat(fd, &held) == 0 && ::lstat(path.c_str(), &named) == 0 &&
      S_ISREG(named.st_mode) && held.st_dev == named.st_dev && held.st_ino == named.st_ino) {
    const bool old_enough =
        kind == TemporaryKind::kLocked ||
        std::chrono::system_clock::now() - std::chrono::system_clock::from_time_t(named.st_mtime) > kLegacyLeftoverAge;
    if (old_enough && ::unlink(path.c_str()) == 0) {
      removed = true;
      bytes += static_cast<int64_t>(named.st_size);
    }
  }
  ::close(fd);  // drops the lock
  return removed;
}

// The staged file of one upload, created and locked (exclusive flock, held
// until close) before a byte is written: the lock is what tells the sweep
// at a replica's start that a live process still writes it. Its own name
// for each upload, so that two of the same path never share it.
class StagedUpload {
 public:
  explicit StagedUpload(const fs::path& target) {
    static std::atomic<uint64_t> uploads{0};
    // A sweep elsewhere may take the lock in the instant between our
    // create and our lock and unlink the file: it then has no name, and we
    // start again under another.
    for (int attempt = 0; attempt < 3 && fd_ < 0; ++attempt) {
      path_ = target.parent_path() / ("." + target.filename().string() + kUploadInfix + std::to_string(::getpid()) +
                                      "." + std::to_string(uploads++));
      const int fd = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
      if (fd < 0) {
        if (errno == EEXIST) continue;
        throw std::runtime_error("cannot create " + path_.filename().string() + ": " + std::strerror(errno));
      }
      int locked;
      do locked = ::flock(fd, LOCK_EX);
      while (locked != 0 && errno == EINTR);
      struct stat status {};
      if (locked != 0 || ::fstat(fd, &status) != 0) {
        const int saved = errno;
        ::unlink(path_.c_str());
        ::close(fd);
        throw std::runtime_error("cannot lock " + path_.filename().string() + ": " + std::strerror(saved));
      }
      if (status.st_nlink == 0) {
        ::close(fd);
        continue;
      }
      fd_ = fd;
    }
    if (fd_ < 0) throw std::runtime_error("no temporary name could be created beside the file");
  }
  ~StagedUpload() {
    // Whether linked into place or not, the temporary name goes; the lock
    // is held until then, so a sweep never sees it unlocked.
    ::unlink(path_.c_str());
    ::close(fd_);
  }
  StagedUpload(const StagedUpload&) = delete;
  StagedUpload& operator=(const StagedUpload&) = delete;

  void write(const std::string& content) {
    const char* data = content.data();
    size_t left = content.size();
    while (left > 0) {
      const ssize_t written = ::write(fd_, data, left);
      if (written < 0 && errno == EINTR) continue;
      if (written <= 0) throw std::runtime_error(std::string("writing failed: ") + std::strerror(errno));
      data += written;
      left -= static_cast<size_t>(written);
    }
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
  int fd_ = -1;
};

}  // namespace

DataRootUse data_root_use(const std::string& data_root) {
  DataRootUse use;
  std::error_code error, ignored;
  fs::recursive_directory_iterator it(data_root, fs::directory_options::skip_permission_denied, error), end;
  for (; !error && it != end; it.increment(error)) {
    if (it.depth() == 0 && it->path().filename() == kUploadMarks) {
      it.disable_recursion_pending();  // empty bookkeeping, not the root's content
      continue;
    }
    if (!it->is_regular_file(ignored) || it->is_symlink(ignored)) continue;
    // An upload's temporary file: one in flight is counted by its own size
    // (or its reservation), one a crash left behind is not the root's content
    // (and is swept at the next start). In a hidden folder, where uploads are
    // never written, such a name is the operator's file and counts.
    if (upload_temporary_kind(it->path().filename().string()) != TemporaryKind::kNone) {
      const fs::path folder = it->path().parent_path().lexically_relative(data_root);
      const bool in_hidden_folder = std::any_of(folder.begin(), folder.end(), [](const fs::path& part) {
        return part.string().size() > 1 && part.string().front() == '.' && part != "..";
      });
      if (!in_hidden_folder) continue;
    }
    ++use.files;
    use.bytes += static_cast<int64_t>(it->file_size(ignored));
  }
  if (error) throw ApiError(ErrorCode::kInternal, "", "the data root cannot be read: " + error.message());
  return use;
}

ClipFile write_data_root_clip(const std::string& data_root, const UploadClipRequest& request,
                              const DataRootQuota& quota) {
  const fs::path root = data_root_folder(data_root);
  check_upload_path(request.path);
  const std::string format = clip_format(fs::path(request.path));
  // A folder of the path may be a link out of the root.
  const auto target = resolve_under_data_root(root, request.path, "path");
  if (!target) throw invalid("path", "path " + quoted(request.path) + " leads out of the data root");
  // Before the content is parsed: the size is the cheap check.
  check_upload_size(request.path, static_cast<int64_t>(request.content.size()), quota);
  std::error_code error;
  if (fs::exists(fs::symlink_status(*target, error))) {
    throw ApiError(ErrorCode::kFailedPrecondition, "path",
                   "path " + quoted(request.path) + " exists already; an upload never replaces a file, expected a new path");
  }
  check_upload_content(request.content, format, request.path);

  const auto fail = [&](const std::string& what, const std::error_code& cause) {
    throw ApiError(ErrorCode::kInternal, "path", request.path + ": " + what + ": " + cause.message());
  };
  // One upload at a time: the quota is checked against what the root holds,
  // which another upload must not change between the check and the write.
  static std::mutex one_upload;
  std::lock_guard<std::mutex> lock(one_upload);
  const int64_t size = static_cast<int64_t>(request.content.size());
  Reservation reservation;
  if (quota.shared) {
    // Replicas sharing the root: checked under the deployment's lock
    // against the root and the others' uploads in flight, and this one's
    // bytes reserved before they are written (jobs/upload_reservations.h).
    try {
      const int64_t id = quota.shared->reserve(request.path, size, [&](const UploadReservations::Reserved& reserved) {
        check_root_quota(root, request.path, size, quota, reserved);
      });
      reservation = Reservation(quota.shared, id);
    } catch (const ApiError&) {
      throw;
    } catch (const std::exception& e) {
      throw ApiError(ErrorCode::kUnavailable, "",
                     request.path + ": the data root's quota cannot be checked in the shared job store: " + e.what());
    }
  } else {
    check_root_quota(root, request.path, size, quota);
  }
  fs::create_directories(target->parent_path(), error);
  if (error) fail("cannot create its folder", error);
  // Written whole under a hidden name (ListClips skips it, the quota does
  // not count it), then linked to its own: link() fails rather than replace
  // a file that appeared meanwhile.
  try {
    StagedUpload staged(*target);
    staged.write(request.content);
    fs::create_hard_link(staged.path(), *target, error);
  } catch (const std::exception& e) {
    throw ApiError(ErrorCode::kInternal, "path", request.path + ": cannot write the file: " + e.what());
  }
  std::error_code ignored;
  if (error == std::errc::file_exists) {
    throw ApiError(ErrorCode::kFailedPrecondition, "path",
                   "path " + quoted(request.path) + " was written by another upload meanwhile; expected a new path");
  }
  if (error) fail("cannot link the written file into place", error);
  // Marked after the file is in place: a crash between the two leaves a file
  // that cannot be deleted over the wire, never a mark that lets another
  // file at that path be.
  const fs::path mark = upload_mark(root, *target);
  fs::create_directories(mark.parent_path(), error);
  if (!error) std::ofstream(mark, std::ios::binary);
  if (error || !fs::exists(mark, ignored)) {
    spdlog::warn("upload {}: written, but its mark {} could not be: DeleteClip will refuse it", request.path,
                 mark.string());
  }

  ClipFile clip;
  clip.path = target->lexically_relative(root).generic_string();
  clip.format = format;
  clip.size_bytes = static_cast<int64_t>(request.content.size());
  clip.uploaded = true;
  return clip;
}

bool is_upload_temporary_name(const std::string& filename) {
  return upload_temporary_kind(filename) != TemporaryKind::kNone;
}

SweptUploads sweep_upload_leftovers(const std::string& data_root) {
  SweptUploads swept;
  std::error_code error, ignored;
  const fs::path root(data_root);
  // Uploads are written in the folder of their path, whose components are
  // never hidden: hidden folders (the marks, the operator's) are not entered.
  fs::recursive_directory_iterator it(root, fs::directory_options::skip_permission_denied, error), end;
  for (; !error && it != end; it.increment(error)) {
    const std::string name = it->path().filename().string();
    if (it->is_directory(ignored) && !it->is_symlink(ignored)) {
      if (name.front() == '.') it.disable_recursion_pending();
      continue;
    }
    const TemporaryKind kind = upload_temporary_kind(name);
    if (kind == TemporaryKind::kNone || it->is_symlink(ignored) || !it->is_regular_file(ignored)) continue;
    if (remove_abandoned(it->path(), kind, swept.bytes)) {
      swept.paths.push_back(it->path().lexically_relative(root).generic_string());
    }
  }
  if (!swept.paths.empty()) {
    std::string paths;
    for (const auto& path : swept.paths) paths += (paths.empty() ? "" : ", ") + path;
    spdlog::info("data root: removed {} temporary file(s) of uploads a crash interrupted ({} bytes): {}",
                 swept.paths.size(), swept.bytes, paths);
  }
  return swept;
}

ClipFile delete_data_root_clip(const std::string& data_root, const std::string& path) {
  const fs::path root = data_root_folder(data_root);
  if (path.empty()) {
    throw invalid("path", "path is empty, expected an uploaded .txt or .bvh file under the data root");
  }
  const auto resolved = resolve_under_data_root(root, path, "path");
  if (!resolved || *resolved == root) {
    throw invalid("path", "path " + quoted(path) + " lies outside the data root, expected an uploaded file under it");
  }
  std::error_code error;
  if (!fs::exists(fs::symlink_status(*resolved, error))) {
    throw ApiError(ErrorCode::kNotFound, "path", "path " + quoted(path) + " names no file under the data root");
  }
  if (!fs::is_regular_file(fs::symlink_status(*resolved, error))) {
    throw invalid("path", "path " + quoted(path) + " is not a file, expected an uploaded .txt or .bvh file");
  }
  const std::string format = clip_format(*resolved);
  if (format.empty()) {
    throw invalid("path", "path " + quoted(path) + " is neither H3.6M text (.txt) nor BVH (.bvh), expected an "
                                                    "uploaded clip");
  }
  const fs::path mark = upload_mark(root, *resolved);
  if (!fs::exists(mark, error)) {
    throw ApiError(ErrorCode::kFailedPrecondition, "path",
                   "path " + quoted(path) + " was not uploaded (UploadClip): only uploads may be deleted, the rest "
                                            "of the data root is the operator's");
  }
  ClipFile clip;
  clip.path = resolved->lexically_relative(root).generic_string();
  clip.format = format;
  clip.size_bytes = static_cast<int64_t>(fs::file_size(*resolved, error));
  clip.uploaded = true;
  // One unlink: a reader has the whole file open or finds none.
  if (!fs::remove(*resolved, error) || error) {
    throw ApiError(ErrorCode::kInternal, "path", clip.path + ": cannot remove the file: " + error.message());
  }
  fs::remove(mark, error);
  return clip;
}

}  // namespace mm::service
