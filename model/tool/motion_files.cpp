#include "model/tool/motion_files.h"

#include <cctype>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <system_error>

#include "format/animation_file.h"
#include "format/atomic_file.h"
#include "format/input_error.h"
#include "format/motion_text.h"
#include "format/skeleton_bvh.h"
#include "model/tool/file_arguments.h"

namespace mm::tool {

const char* const kMotionRateNote =
    "Input motions are H3.6M exponential-map text files, at 50 Hz (the data set; the default) or at 25 Hz (what "
    "decode, sample, interpolate, analogy and denoise write): give --rate 25 for the latter. At 50 Hz every "
    "second frame is kept. A window of the model's clip length (150 frames = 6 s at 25 Hz) is taken from --start, "
    "counted in the file's own frames (a text file's rows at its --rate, a BVH's frames), as the service's start "
    "counts them. - reads standard input. BVH files of the model's skeleton (a .bvh name, or text that starts "
    "with HIERARCHY) are read at their own frame time, nearest frames at 25 Hz, and --rate does not apply. Output "
    "motions are written in the same text layout at 25 Hz, or as BVH when the file name ends in .bvh and as glTF "
    "when it ends in .glb or .gltf. glTF (.glb, .gltf) and FBX (.fbx) files are read as BVH is (a .glb, .gltf or "
    ".fbx name, or their first bytes), joints by name, lengths in metres as animation tools write them.";

bool is_bvh_path(const std::string& path) {
  if (path.size() < 4) return false;
  std::string extension = path.substr(path.size() - 4);
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return extension == ".bvh";
}

bool is_bvh_input(const std::string& path, const std::string& text) {
  if (is_bvh_path(path)) return true;
  size_t at = text.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;
  while (at < text.size() && std::isspace(static_cast<unsigned char>(text[at]))) ++at;
  return text.compare(at, 9, "HIERARCHY") == 0;
}

bool is_animation_path(const std::string& path) {
  AnimationFormat format;
  return animation_format_of_path(path, &format);
}

bool is_animation_input(const std::string& path, const std::string& text) {
  AnimationFormat format;
  return animation_format_of_input(path, text.data(), text.size(), &format);
}

BvhFile parse_animation_input(const std::string& text, const std::string& name, const Skeleton& skeleton) {
  AnimationFormat format = AnimationFormat::kBvh;
  animation_format_of_input(name, text.data(), text.size(), &format);
  return parse_animation_file(text, format, name, bvh_layout_of(skeleton).millimetres_per_unit);
}

std::string animation_output_bytes(const BvhFile& file, const std::string& path, const Skeleton& skeleton) {
  AnimationFormat format = AnimationFormat::kBvh;
  animation_format_of_path(path, &format);
  return write_animation_file(file, format, bvh_layout_of(skeleton).millimetres_per_unit);
}

MotionFrames motion_at_model_rate(const std::string& text, const std::string& name, int rate,
                                  const Skeleton& skeleton) {
  if (is_animation_input(name, text)) return skeleton_motion_from_bvh(skeleton, parse_animation_input(text, name, skeleton), name);
  return at_model_rate(parse_motion_text_buffer(text.data(), text.size(), name, skeleton_motion_columns(skeleton)),
                       rate, name);
}

MotionFrames at_model_rate(const MotionFrames& motion, int rate, const std::string& name) {
  if (rate == kModelRate) return motion;
  if (rate == 2 * kModelRate) return split_phases(motion, 2)[0];
  throw InputError(name + ": rate " + std::to_string(rate) + " Hz is not supported, expected 25 or 50");
}

MotionFrames motion_window(const std::string& text, const std::string& name, int frames, int start, int rate,
                           const Skeleton& skeleton) {
  const int columns = skeleton_motion_columns(skeleton);
  if (start < 0) throw InputError(name + ": --start must be >= 0, found " + std::to_string(start));
  if (is_animation_input(name, text)) {
    const BvhFile file = parse_animation_input(text, name, skeleton);
    if (start >= file.frame_count()) {
      throw InputError(name + ": --start " + std::to_string(start) + " is past the file's last frame (it has " +
                       std::to_string(file.frame_count()) + " frames)");
    }
    return skeleton_motion_window_from_bvh(skeleton, file, name, start, frames);
  }
  const MotionFrames file = parse_motion_text_buffer(text.data(), text.size(), name, columns);
  if (rate != kModelRate && rate != 2 * kModelRate) {
    throw InputError(name + ": rate " + std::to_string(rate) + " Hz is not supported, expected 25 or 50");
  }
  // --start counts the file's rows; at 50 Hz every second row from it is kept.
  const int64_t step = rate / kModelRate;
  const int64_t needed = static_cast<int64_t>(start) + (frames - 1) * step + 1;
  if (file.frame_count() < needed) {
    throw InputError(name + ": too short: " + std::to_string(file.frame_count()) + " frames at " +
                     std::to_string(rate) + " Hz, need " + std::to_string(needed) + " (the model's " +
                     std::to_string(frames) + " frames at 25 Hz from frame " + std::to_string(start) + ")" +
                     // Enough frames read at 25 Hz: most likely a file the tool wrote.
                     (rate != kModelRate && file.frame_count() >= start + frames ? "; if the file is at 25 Hz, give --rate 25"
                                                                                 : ""));
  }
  MotionFrames window;
  window.columns = file.columns;
  for (int64_t f = 0; f < frames; ++f) {
    const float* row = file.frame(start + f * step);
    window.values.insert(window.values.end(), row, row + file.columns);
  }
  return window;
}

void write_motion_output(const MotionFrames& motion, const std::string& path, const Skeleton& skeleton) {
  if (is_animation_path(path)) {
    write_file_atomically(path, animation_output_bytes(skeleton_motion_to_bvh(skeleton, bvh_layout_of(skeleton), motion, kModelRate), path, skeleton));
    return;
  }
  if (!is_standard_stream(path)) {
    write_motion_text_file(motion, path);
    return;
  }
  std::ostringstream text;
  write_motion_text(motion, text);
  write_output_file(path, text.str());
}

void ensure_directory(const std::string& dir, const std::string& option) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) throw InputError(option + " " + dir + ": cannot create the directory: " + error.message());
}

std::string numbered_motion_path(const std::string& dir, const std::string& stem, int index,
                                 const std::string& extension) {
  char number[16];
  std::snprintf(number, sizeof number, "%03d", index);
  return dir + "/" + stem + "_" + number + "." + extension;
}

}  // namespace mm::tool
