// The CMU dances of ../shared/data/cmu-dance-bvh.tar.xz (15 BVH files of one
// 43-joint hierarchy, cm, 120 Hz; free to use in tests), extracted once per
// test program into a scratch folder: a skeleton other than H3.6M's.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "tests/common/test_environment.h"

namespace mm::test {

// The folder holding indian/ and martial/. Throws std::runtime_error when the
// archive is missing or cannot be extracted, so the test fails (never skips).
inline std::filesystem::path cmu_dance_dir() {
  static ScratchDir* dir = nullptr;
  if (dir == nullptr) {
    const std::string archive = shared_dir() + "/data/cmu-dance-bvh.tar.xz";
    if (!std::filesystem::exists(archive)) throw std::runtime_error(archive + " not found");
    dir = new ScratchDir();  // removed at exit
    const std::string command = "tar xJf '" + archive + "' -C '" + dir->path().string() + "'";
    if (std::system(command.c_str()) != 0) throw std::runtime_error(command + " failed");
    std::atexit([] { delete dir; });
  }
  return dir->path() / "cmu-dance-bvh";
}

}  // namespace mm::test
