#include "client/cli/take_io.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>

#include "client/cli/motion_io.h"
#include "format/animation_file.h"
#include "format/atomic_file.h"
#include "format/bvh_file.h"
#include "format/input_error.h"
#include "format/motion_text.h"
#include "format/skeleton_bvh.h"
#include "wire/rest_json.h"

namespace mm::client {

// A code track file is POST /v1/takes:encode's reply, written and read by
// the same code.
using ::mm::wire::to_json;
namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (auto& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace

bool is_animation_path(const std::string& path) {
  AnimationFormat format;
  return animation_format_of_path(path, &format);
}

namespace {

// The animation format of a path is_animation_path accepts.
AnimationFormat animation_format_for(const std::string& path) {
  AnimationFormat format = AnimationFormat::kBvh;
  animation_format_of_path(path, &format);
  return format;
}

}  // namespace

TakeUpload read_take(const TakeSource& source, ModelRigs& rigs, const std::string& model, bool missing_allowed) {
  if (!is_motion_file(source.path)) {
    throw InputError("--input " + source.path + ": unknown take file type \"" + lower_extension(source.path) +
                     "\", expected .txt (exponential-map text), .bvh, .glb, .gltf or .fbx");
  }
  TakeUpload take;
  take.bvh = is_animation_path(source.path);
  take.file_bytes = read_whole_file(source.path);
  // Syntax first, so a malformed file is refused before the server is asked
  // for the model's rig. glTF and FBX are read in the rig's unit, and sent
  // on as the BVH they make.
  const AnimationFormat format = animation_format_for(source.path);
  std::optional<BvhFile> parsed;
  if (take.bvh && format == AnimationFormat::kBvh) parsed = parse_bvh_text(take.file_bytes, source.path);
  const ModelRig& rig = rigs.of(model);
  if (take.bvh && !parsed) {
    parsed = parse_animation_file(take.file_bytes, format, source.path, bvh_layout_of(rig.skeleton).millimetres_per_unit);
    take.file_bytes = write_bvh_text(*parsed);
  }
  if (take.bvh) {
    take.frames = skeleton_motion_from_bvh_at_file_rate(rig.skeleton, *parsed, source.path);
    take.header.set_frame_rate(bvh_frame_rate(*parsed));
  } else {
    take.frames = parse_motion_text_buffer(take.file_bytes.data(), take.file_bytes.size(), source.path, rig.columns,
                                           missing_allowed);
    take.header.set_frame_rate(source.rate);
  }
  take.header.set_model(rigs.pinned(model));
  take.header.set_columns(take.frames.columns);
  take.header.set_layout(rig.layout);
  return take;
}

TakeFileWriter::TakeFileWriter(std::string path, std::string error_csv, const Skeleton* skeleton,
                               bool whole_file_allowed)
    : path_(std::move(path)), error_csv_(std::move(error_csv)), skeleton_(skeleton), bvh_(is_animation_path(path_)),
      whole_file_allowed_(whole_file_allowed && error_csv_.empty()) {
  if (bvh_ && skeleton_ == nullptr) throw std::logic_error("TakeFileWriter: a BVH output needs the skeleton");
}

TakeFileWriter::~TakeFileWriter() {
  if (!temporary_.empty()) {
    text_.close();
    std::remove(temporary_.c_str());
  }
}

void TakeFileWriter::header(const v1::TakeOutputHeader& header) {
  header_ = header;
  held_.columns = header.columns();
  if (bvh_ || path_ == "-") return;
  temporary_ = path_ + ".tmp." + std::to_string(::getpid());
  text_.open(temporary_, std::ios::binary | std::ios::trunc);
  if (!text_) {
    temporary_.clear();
    throw InputError("--out " + path_ + ": cannot write a file there");
  }
}

void TakeFileWriter::chunk(const v1::FrameChunk& chunk) {
  MotionFrames frames;
  frames.columns = header_.columns();
  frames.values.assign(chunk.values().begin(), chunk.values().end());
  if (frames.frame_count() != chunk.frames()) {
    throw std::runtime_error("a reply chunk of " + std::to_string(chunk.frames()) + " frames holds " +
                             std::to_string(chunk.values_size()) + " values, not " +
                             std::to_string(chunk.frames()) + " x " + std::to_string(header_.columns()));
  }
  frames_ += chunk.frames();
  if (on_frames) on_frames(chunk.frames());
  errors_.insert(errors_.end(), chunk.error_mm().begin(), chunk.error_mm().end());
  if (bvh_) {
    held_.values.insert(held_.values.end(), frames.values.begin(), frames.values.end());
  } else if (path_ == "-") {
    write_motion_text(frames, std::cout);
  } else {
    write_motion_text(frames, text_);
    if (!text_) throw std::runtime_error("--out " + path_ + ": writing failed");
  }
}

std::string TakeFileWriter::whole_file_type() const {
  if (!whole_file_allowed_) return "";
  return bvh_ ? animation_format_media_type(animation_format_for(path_)) : "text/plain";
}

void TakeFileWriter::whole_file(const std::string& bytes, int64_t frames, double frame_rate, int64_t windows) {
  if (path_ == "-") {
    std::cout << bytes << std::flush;
  } else {
    write_file_atomically(path_, bytes);
  }
  frames_ = frames;
  header_.set_frame_rate(frame_rate);
  windows_ = windows;
  whole_ = true;
}

void TakeFileWriter::finish() {
  if (whole_) return;  // written whole as it came, and no error CSV asked for
  if (bvh_) {
    write_file_atomically(path_, write_animation_file(skeleton_motion_to_bvh(*skeleton_, bvh_layout_of(*skeleton_), held_,
                                                                             header_.frame_rate()),
                                                      animation_format_for(path_),
                                                      bvh_layout_of(*skeleton_).millimetres_per_unit));
  } else if (path_ == "-") {
    std::cout.flush();
  } else {
    text_.close();
    if (!text_) throw std::runtime_error("--out " + path_ + ": writing failed");
    std::filesystem::rename(temporary_, path_);
    temporary_.clear();
  }
  if (error_csv_.empty()) return;
  std::string csv = "frame,seconds,error_mm\n";
  char line[96];
  for (size_t i = 0; i < errors_.size(); ++i) {
    std::snprintf(line, sizeof line, "%zu,%.6f,%.4f\n", i, static_cast<double>(i) / header_.frame_rate(),
                  static_cast<double>(errors_[i]));
    csv += line;
  }
  write_file_atomically(error_csv_, csv);
}

void check_take_output(const std::string& path, const std::string& option) { check_motion_output(path, option); }

void write_code_track(const v1::CodeTrack& track, const std::string& path) {
  const std::string text = to_json(track).dump(2) + "\n";
  if (path == "-") {
    std::cout << text << std::flush;
    return;
  }
  write_file_atomically(path, text);
}

void read_code_track(const std::string& path, v1::DecodeTrackRequest& request) {
  const auto parsed = nlohmann::json::parse(read_whole_file(path), nullptr, false);
  if (parsed.is_discarded() || !parsed.is_object()) throw InputError(path + ": not a JSON object");
  v1::CodeTrack track;
  try {
    ::mm::wire::from_json(parsed, track);
  } catch (const InputError& error) {
    throw InputError(path + ": " + error.what());
  }
  if (track.windows().empty()) {
    throw InputError(path + ": windows: expected an array of {\"start_seconds\", \"code\"}, as take encode writes");
  }
  // What the wire code reads as 0 or empty when left out, a track file
  // must give: each window's start and code.
  for (int i = 0; i < track.windows_size(); ++i) {
    const std::string field = path + ": windows[" + std::to_string(i) + "]";
    const auto& window = parsed["windows"][static_cast<size_t>(i)];
    if (!window.contains("start_seconds") || window["start_seconds"].is_null()) {
      throw InputError(field + ".start_seconds", "expected a number of seconds");
    }
    if (track.windows(i).code().values().empty()) throw InputError(field + ".code", "expected an array of numbers");
  }
  request.mutable_windows()->Swap(track.mutable_windows());
}

}  // namespace mm::client
