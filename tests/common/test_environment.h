// Where the tests find the H3.6M copy, the shared folder and scratch
// space. The build passes MM_DATA_DIR / MM_SHARED_DIR by environment (ctest)
// with the configured paths compiled in as a fallback for running the
// executable by hand.
#pragma once

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

namespace mm::test {

inline std::string environment_or(const char* name, const char* fallback) {
  const char* value = std::getenv(name);
  return (value != nullptr && value[0] != '\0') ? std::string(value) : std::string(fallback);
}

inline std::string data_dir() { return environment_or("MM_DATA_DIR", MM_DEFAULT_DATA_DIR); }
inline std::string shared_dir() { return environment_or("MM_SHARED_DIR", MM_DEFAULT_SHARED_DIR); }

// The folder holding S1, S5, ... (data_dir may be it or a parent of h3.6m/dataset).
inline std::filesystem::path h36m_dataset_dir() {
  const std::filesystem::path root(data_dir());
  if (std::filesystem::is_directory(root / "h3.6m" / "dataset")) return root / "h3.6m" / "dataset";
  return root;
}

inline bool has_h36m() { return std::filesystem::is_directory(h36m_dataset_dir() / "S5"); }

// Tests that need the licensed data fail when it is not extracted, so that a
// run which tested nothing cannot pass. MM_ALLOW_MISSING_H36M=1 turns the
// failure into a visible skip, for a machine that has no copy of the data
// (a GPU machine that only checks the networks, say).
inline bool missing_h36m_allowed() { return environment_or("MM_ALLOW_MISSING_H36M", "0") == "1"; }

#define MM_REQUIRE_H36M()                                                                              \
  do {                                                                                                 \
    if (!::mm::test::has_h36m()) {                                                                     \
      if (::mm::test::missing_h36m_allowed())                                                          \
        GTEST_SKIP() << "H3.6M not found under MM_DATA_DIR=" << ::mm::test::data_dir();                \
      FAIL() << "H3.6M not found under MM_DATA_DIR=" << ::mm::test::data_dir()                         \
             << ": run scripts/extract-h36m.sh (or set MM_ALLOW_MISSING_H36M=1 to skip these tests)"; \
    }                                                                                                  \
  } while (0)

// A fresh directory under the system temp folder, removed with the object.
class ScratchDir {
 public:
  ScratchDir() {
    static std::atomic<int> counter{0};
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = std::filesystem::temp_directory_path() /
            ("mm_test_" + std::to_string(::getpid()) + "_" +
             (info ? std::string(info->name()) : std::string("x")) + "_" + std::to_string(counter++));
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  std::string file(const std::string& name) const { return (path_ / name).string(); }
  std::string write(const std::string& name, const std::string& content) const {
    std::ofstream(file(name), std::ios::binary) << content;
    return file(name);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace mm::test
