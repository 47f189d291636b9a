#include "client/cli/motion_io.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <optional>
#include <nlohmann/json.hpp>
#include <sstream>

#include "format/animation_file.h"
#include "format/atomic_file.h"
#include "format/bvh_file.h"
#include "format/input_error.h"
#include "format/motion_text.h"
#include "format/skeleton_bvh.h"

namespace mm::client {
namespace {

enum class MotionFormat { kText, kBvh };

std::string extension_of(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (auto& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

// The one place that maps a file name to a format.
MotionFormat format_of(const std::string& path, const std::string& what) {
  if (path == "-") return MotionFormat::kText;
  const std::string ext = extension_of(path);
  if (ext == ".txt") return MotionFormat::kText;
  // glTF and FBX go where BVH does (format/animation_file.h).
  AnimationFormat animation;
  if (animation_format_of_path(path, &animation)) return MotionFormat::kBvh;
  throw InputError(what + " " + path + ": unknown motion file type \"" + ext +
                   "\", expected .txt (exponential-map text), .bvh, .glb, .gltf or .fbx");
}

std::string read_all(const std::string& path) {
  if (path == "-") return std::string(std::istreambuf_iterator<char>(std::cin), {});
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the file");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string display_name(const std::string& path) { return path == "-" ? "<stdin>" : path; }

}  // namespace

const char* const kMotionInputNote =
    "Input motions are exponential-map text files (.txt) of the model's layout (H3.6M's 99 values a line), at "
    "50 Hz (the H3.6M data set; the default) or at 25 Hz (what this client writes): give --rate 25 for the latter. "
    "At 50 Hz every second frame is kept. A clip of the model's length (150 frames, 6 s at 25 Hz) is taken from "
    "--start, counted in the file's own frames (a text file's rows, a BVH's frames), as clips read's --start and "
    "the service count them. BVH files (.bvh) of the model's skeleton (H3.6M's, or the rig a model learnt from "
    "BVH files) are read at their own frame time and resampled to 25 Hz. Output motions are text, or BVH of the "
    "model's skeleton for a .bvh name, at 25 Hz.";

namespace {

// read_motion's work: the model's clip from source.start, or with `whole`
// every frame from there to the file's end.
v1::Motion read_motion_frames(const MotionSource& source, ModelRigs& rigs, const std::string& model, bool whole) {
  const std::string name = display_name(source.path);
  const bool bvh = format_of(source.path, "motion") == MotionFormat::kBvh;
  if (!bvh && source.rate != 25 && source.rate != 50) {
    throw InputError(name + ": rate " + std::to_string(source.rate) + " Hz is not supported, expected 25 or 50");
  }
  if (source.start < 0) throw InputError(name + ": --start must be >= 0, found " + std::to_string(source.start));
  const std::string text = read_all(source.path);
  // A BVH file states its own frame time and comes back at 25 Hz. Its syntax
  // is checked before the server is asked for the model's skeleton.
  // glTF and FBX are read in the unit of the model's rig, once it is known.
  AnimationFormat animation = AnimationFormat::kBvh;
  if (bvh) animation_format_of_path(source.path, &animation);
  std::optional<BvhFile> parsed;
  if (bvh && animation == AnimationFormat::kBvh) parsed = parse_bvh_text(text, name);
  const ModelRig& rig = rigs.of(model);
  if (bvh && !parsed) {
    parsed = parse_animation_file(text, animation, name, bvh_layout_of(rig.skeleton).millimetres_per_unit);
  }
  // --start counts the file's own frames (a text file's rows, a BVH's
  // frames), as ReadClip's start and a take's start_frame do.
  MotionFrames window;
  if (bvh) {
    if (source.start >= parsed->frame_count()) {
      throw InputError(name + ": --start " + std::to_string(source.start) + " is past the file's last frame (it has " +
                       std::to_string(parsed->frame_count()) + " frames)");
    }
    const int64_t frames =
        whole ? bvh_imported_frame_count(parsed->frame_count() - source.start, parsed->frame_time_s) : rig.frames;
    window = skeleton_motion_window_from_bvh(rig.skeleton, *parsed, name, source.start, frames);
  } else {
    // The server would keep every second frame of a 50 Hz motion too; doing
    // it here sends only the clip.
    const MotionFrames file = parse_motion_text_buffer(text.data(), text.size(), name, rig.columns);
    const int64_t step = source.rate / kModelRate;
    const int64_t frames =
        whole ? std::max<int64_t>(0, (file.frame_count() - source.start + step - 1) / step) : rig.frames;
    const int64_t needed = whole ? static_cast<int64_t>(source.start) + 1
                                 : static_cast<int64_t>(source.start) + (rig.frames - 1) * step + 1;
    if (file.frame_count() < needed) {
      throw InputError(name + ": too short: " + std::to_string(file.frame_count()) + " frames at " +
                       std::to_string(source.rate) + " Hz, need " + std::to_string(needed) + " (the model's " +
                       std::to_string(rig.frames) + " frames at 25 Hz from frame " + std::to_string(source.start) +
                       ")" +
                       (source.rate == 50 && file.frame_count() >= source.start + rig.frames
                            ? "; if the file is at 25 Hz, give --rate 25"
                            : ""));
    }
    window.columns = file.columns;
    for (int64_t f = 0; f < frames; ++f) {
      const float* row = file.frame(source.start + f * step);
      window.values.insert(window.values.end(), row, row + file.columns);
    }
  }
  v1::Motion message;
  message.set_frames(static_cast<int>(window.frame_count()));
  message.set_columns(window.columns);
  message.set_frame_rate(kModelRate);
  message.set_layout(rig.layout);
  message.mutable_values()->Add(window.values.begin(), window.values.end());
  return message;
}

}  // namespace

v1::Motion read_motion(const MotionSource& source, ModelRigs& rigs, const std::string& model) {
  return read_motion_frames(source, rigs, model, /*whole=*/false);
}

v1::Motion read_whole_motion(const MotionSource& source, ModelRigs& rigs, const std::string& model) {
  return read_motion_frames(source, rigs, model, /*whole=*/true);
}

bool is_code_file(const std::string& path) { return extension_of(path) == ".json"; }

bool is_motion_file(const std::string& path) {
  const std::string ext = extension_of(path);
  AnimationFormat animation;
  return ext == ".txt" || animation_format_of_path(path, &animation);
}

v1::Code read_code(const std::string& path) {
  const std::string name = display_name(path);
  const auto parsed = nlohmann::json::parse(read_all(path), nullptr, false);
  if (parsed.is_discarded()) throw InputError(name + ": not JSON");
  // {"codes": [[...]]} as encode prints it (the tool's and REST's shape
  // too), or the older {"code": [...]}, or a bare array.
  const nlohmann::json* values = &parsed;
  if (parsed.is_object() && parsed.contains("codes")) {
    const auto& codes = parsed["codes"];
    if (!codes.is_array() || codes.size() != 1) {
      throw InputError(name + ": codes: expected an array of one code" +
                       (codes.is_array() ? ", found " + std::to_string(codes.size()) + " codes" : ""));
    }
    values = &codes[0];
  } else if (parsed.is_object() && parsed.contains("code")) {
    values = &parsed["code"];
  }
  if (!values->is_array() || values->empty()) {
    throw InputError(name + ": expected {\"codes\": [[numbers]]} or an array of numbers");
  }
  v1::Code code;
  for (size_t i = 0; i < values->size(); ++i) {
    if (!(*values)[i].is_number()) {
      throw InputError(name + ": code[" + std::to_string(i) + "] is " + (*values)[i].dump() + ", not a number");
    }
    code.add_values((*values)[i].get<float>());
  }
  return code;
}

void check_motion_output(const std::string& path, const std::string& option) { format_of(path, option); }

void write_motion(const v1::Motion& motion, const std::string& path, ModelRigs& rigs, const std::string& model) {
  MotionFrames frames;
  frames.columns = motion.columns();
  frames.values.assign(motion.values().begin(), motion.values().end());
  if (format_of(path, "--out") == MotionFormat::kBvh) {
    // As the server writes it for Accept: application/x-bvh (model/gltf-binary...).
    const Skeleton& skeleton = rigs.of(model).skeleton;
    AnimationFormat animation = AnimationFormat::kBvh;
    animation_format_of_path(path, &animation);
    write_file_atomically(path, write_animation_file(skeleton_motion_to_bvh(skeleton, bvh_layout_of(skeleton), frames,
                                                                            motion.frame_rate()),
                                                     animation, bvh_layout_of(skeleton).millimetres_per_unit));
    return;
  }
  if (path == "-") {
    write_motion_text(frames, std::cout);
    std::cout.flush();
    return;
  }
  write_motion_text_file(frames, path);  // text of any column count, written whole then renamed
}

std::vector<std::string> write_numbered_motions(const google::protobuf::RepeatedPtrField<v1::Motion>& motions,
                                                const std::string& dir, const std::string& stem,
                                                const std::string& extension, ModelRigs& rigs,
                                                const std::string& model) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) throw InputError("--out-dir " + dir + ": cannot create the directory: " + error.message());
  std::vector<std::string> paths;
  for (int i = 0; i < motions.size(); ++i) {
    char number[16];
    std::snprintf(number, sizeof number, "%03d", i);
    paths.push_back(dir + "/" + stem + "_" + number + "." + extension);
    write_motion(motions[i], paths.back(), rigs, model);
  }
  return paths;
}

}  // namespace mm::client
