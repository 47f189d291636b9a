#include "motion_files.h"

#include <cstdio>
#include <filesystem>
#include <system_error>

#include "format/input_error.h"

namespace mm::tool {

const char* const kMotionRateNote =
    "Input motions are H3.6M exponential-map text files at 50 Hz; every second frame is kept (25 Hz) and a "
    "window of the model's clip length (150 frames = 6 s) is taken from --start (in 25 Hz frames). Output motions "
    "are written in the same text layout at 25 Hz.";

MotionFrames read_motion_window(const std::string& path, int frames, int start, int columns) {
  if (start < 0) throw InputError(path + ": start frame must be >= 0, found " + std::to_string(start));
  const MotionFrames full = read_motion_text(path, columns);
  const MotionFrames slow = split_phases(full, 2)[0];
  const int64_t needed = static_cast<int64_t>(start) + frames;
  if (slow.frame_count() < needed) {
    throw InputError(path + ": too short: " + std::to_string(slow.frame_count()) + " frames at 25 Hz (" +
                     std::to_string(full.frame_count()) + " at 50 Hz), need " + std::to_string(needed) + " (" +
                     std::to_string(frames) + " frames from frame " + std::to_string(start) + ")");
  }
  MotionFrames window;
  window.columns = slow.columns;
  window.values.assign(slow.frame(start), slow.frame(start) + static_cast<size_t>(frames) * slow.columns);
  return window;
}

void ensure_directory(const std::string& dir, const std::string& option) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) throw InputError(option + " " + dir + ": cannot create the directory: " + error.message());
}

std::string numbered_motion_path(const std::string& dir, const std::string& stem, int index) {
  char number[16];
  std::snprintf(number, sizeof number, "%03d", index);
  return dir + "/" + stem + "_" + number + ".txt";
}

}  // namespace mm::tool
