// A tiny fake H3.6M folder with generated motions, so that corpus and
// prepared-data-set behaviour can be tested in milliseconds and without the
// licensed data.
#pragma once

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "format/motion_text.h"

namespace mm::test {

// Smooth deterministic motion: column c follows a sine whose phase depends on
// the seed; every fifth column from 12 on is constant, as unused joints are.
inline MotionFrames synthetic_motion(int frames, int seed) {
  MotionFrames motion;
  motion.columns = kH36mColumns;
  motion.values.resize(static_cast<size_t>(frames) * kH36mColumns);
  for (int i = 0; i < frames; ++i) {
    for (int c = 0; c < kH36mColumns; ++c) {
      const bool constant = c >= 12 && c % 5 == 0;
      motion.frame(i)[c] =
          constant ? 0.25f : static_cast<float>(std::sin(0.05 * i * (1 + c % 7) + seed + 0.3 * c) * (0.2 + 0.01 * c));
    }
  }
  return motion;
}

// Writes <root>/h3.6m/dataset/<subject>/<action>_<take>.txt for each entry.
struct FakeFile {
  std::string subject, action;
  int take;
  int frames;
};

inline void write_fake_h36m(const std::filesystem::path& root, const std::vector<FakeFile>& files) {
  int seed = 0;
  for (const FakeFile& file : files) {
    const auto dir = root / "h3.6m" / "dataset" / file.subject;
    std::filesystem::create_directories(dir);
    write_motion_text_file(synthetic_motion(file.frames, seed++),
                           (dir / (file.action + "_" + std::to_string(file.take) + ".txt")).string());
  }
}

}  // namespace mm::test
