// What a crash leaves behind, through the real server: an upload SIGKILLed
// while its file is being written leaves a temporary file, which the next
// start removes (saying so in its log) and which never counts against the
// data root's quota, so the same upload retried succeeds; the sweep removes
// only the server's own temporary files whose writer is gone, never another
// live process's upload in flight (a replica sharing the data root), a file
// of another name, or anything in a hidden folder.
#include <gtest/gtest.h>
#include <httplib.h>
#include <sys/file.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>

#include "tests/common/test_environment.h"
#include "tests/server/rest_call.h"
#include "tests/server/server_process.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

const char* const kToken = "crash-token";

std::string file_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// A valid H3.6M text file of at least `bytes` bytes: S5 walking, repeated.
std::string walking_text(size_t bytes) {
  const std::string walking = file_text(test::h36m_dataset_dir() / "S5" / "walking_1.txt");
  std::string text;
  while (text.size() < bytes) text += walking;
  return text;
}

// Bytes of the regular files under `root` (links and the upload marks left
// out), as the quota counts what the root visibly holds.
int64_t root_bytes(const fs::path& root) {
  int64_t bytes = 0;
  for (auto it = fs::recursive_directory_iterator(root); it != fs::recursive_directory_iterator(); ++it) {
    if (it->path().filename() == ".uploads") {
      it.disable_recursion_pending();
      continue;
    }
    if (!it->is_symlink() && it->is_regular_file()) bytes += static_cast<int64_t>(it->file_size());
  }
  return bytes;
}

// The temporary file of an upload of `name` in `folder`, if there is one.
std::optional<fs::path> temporary_of(const fs::path& folder, const std::string& name) {
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(folder, error)) {
    if (entry.path().filename().string().rfind("." + name + ".upload.", 0) == 0) return entry.path();
  }
  return std::nullopt;
}

test::Reply upload(const test::ServerProcess& server, const std::string& path, const std::string& content) {
  return test::post(server.rest_port(), "/v1/clips:upload?path=" + path, content, test::bearer(kToken),
                    "application/octet-stream");
}

// A file held as a live writer holds its upload's temporary file: open and
// exclusively locked (flock) until the object goes.
class HeldFile {
 public:
  HeldFile(const fs::path& path, const std::string& content) {
    std::ofstream(path, std::ios::binary) << content;
    fd_ = ::open(path.c_str(), O_RDWR | O_CLOEXEC);
    EXPECT_GE(fd_, 0);
    EXPECT_EQ(::flock(fd_, LOCK_EX | LOCK_NB), 0);
  }
  ~HeldFile() { ::close(fd_); }

 private:
  int fd_ = -1;
};

TEST(CrashLeftovers, AnUploadKilledMidWriteIsSweptAtRestartNeverCountsAndItsRetrySucceeds) {
  MM_REQUIRE_H36M();
  test::ScratchDir scratch;
  const fs::path root = scratch.path() / "data";
  fs::create_directories(root / "operator");
  fs::create_directories(root / "mine");
  std::ofstream(root / "operator" / "walking.txt", std::ios::binary) << walking_text(1);
  // What the sweep must leave: a name like the server's but not one of its
  // temporary names, and one of its names inside a hidden folder (the
  // operator's, where uploads are never written).
  const fs::path unlike = root / "operator" / ".walk.txt.upload.12";
  std::ofstream(unlike, std::ios::binary) << "not a temporary file";
  fs::create_directories(root / ".operator-cache");
  const fs::path hidden = root / ".operator-cache" / ".walk.txt.upload.1.0";
  std::ofstream(hidden, std::ios::binary) << "the operator's";

  const std::string content = walking_text(60'000'000);  // 60 MB, as in the report
  const int64_t visible = root_bytes(root);
  // Room for the upload and 1 MB more: a leftover of more than that, or the
  // live upload below (2 MB), counted against the quota refuses the retry.
  const int64_t margin = 1'000'000;
  // Another replica's upload in flight, sharing the data root: its server
  // is alive and holds its temporary file locked.
  HeldFile in_flight(root / "mine" / ".other.txt.upload.4242.0", std::string(2'000'000, 'x'));

  test::ServerProcess server({"--data-root", root.string(), "--max-data-root-bytes",
                              std::to_string(visible + static_cast<int64_t>(content.size()) + margin),
                              "--max-upload-bytes", "64000000", "--auth-token", kToken});

  // The upload is killed once a quarter of it is on disk; a write that
  // finished before the kill (the file in place) is deleted and tried again.
  std::optional<fs::path> leftover;
  int64_t leftover_bytes = 0;
  std::string path;
  for (int attempt = 0; attempt < 5 && !leftover; ++attempt) {
    path = "mine/big" + std::to_string(attempt) + ".txt";
    const std::string name = fs::path(path).filename().string();
    std::atomic<bool> returned{false};
    int status = 0;
    std::string body;
    std::thread call([&] {
      httplib::Client client("127.0.0.1", server.rest_port());
      client.set_read_timeout(300);
      client.set_write_timeout(300);
      const auto result = client.Post(("/v1/clips:upload?path=" + path).c_str(), test::bearer(kToken), content,
                                      "application/octet-stream");
      if (result) {
        status = result->status;
        body = result->body;
      }
      returned = true;
    });
    bool killed = false;
    while (!returned && !fs::exists(root / path)) {
      const auto temporary = temporary_of(root / "mine", name);
      std::error_code error;
      if (temporary && static_cast<int64_t>(fs::file_size(*temporary, error)) >=
                           static_cast<int64_t>(content.size() / 4) && !error) {
        server.kill();
        killed = true;
        break;
      }
    }
    call.join();
    if (!killed) {
      // Refused before a byte was written: the quota counted what it must not.
      ASSERT_EQ(status, 200) << "the upload was refused: " << body;
      // The file was written before the kill could come: try again.
      test::rest_call(server.rest_port(), kToken, "DELETE", "/v1/clips?path=" + path);
      continue;
    }
    if (fs::exists(root / path)) {
      server.restart();
      test::rest_call(server.rest_port(), kToken, "DELETE", "/v1/clips?path=" + path);
      continue;
    }
    leftover = temporary_of(root / "mine", name);
    if (leftover) leftover_bytes = static_cast<int64_t>(fs::file_size(*leftover));
    if (!leftover) server.restart();
  }
  ASSERT_TRUE(leftover) << "no upload was killed mid-write in 5 attempts";
  ASSERT_GT(leftover_bytes, margin) << "the leftover must be large enough for the quota to tell";
  const std::string leftover_relative = leftover->lexically_relative(root).generic_string();
  std::cout << "killed with " << leftover_bytes << " of " << content.size() << " bytes written\n";

  server.restart();
  EXPECT_FALSE(fs::exists(*leftover)) << leftover_relative << " was not swept at the start";
  EXPECT_NE(server.log().find("removed 1 temporary file(s) of uploads a crash interrupted (" +
                              std::to_string(leftover_bytes) + " bytes): " + leftover_relative),
            std::string::npos)
      << server.log();
  EXPECT_TRUE(fs::exists(root / "mine" / ".other.txt.upload.4242.0")) << "a live writer's upload was swept";
  EXPECT_TRUE(fs::exists(unlike)) << "a file of another name was swept";
  EXPECT_TRUE(fs::exists(hidden)) << "a file in a hidden folder was swept";

  // Only the visible files count: the retry fits, the live upload beside it
  // counted by its own server, not this one.
  const test::Reply retry = upload(server, path, content);
  EXPECT_EQ(retry.status, 200) << retry.body;
  EXPECT_EQ(fs::file_size(root / path), content.size());
  const auto listed = test::rest_call(server.rest_port(), kToken, "GET", "/v1/clips");
  bool found = false;
  for (const auto& clip : listed["clips"]) found = found || clip["path"] == path;
  EXPECT_TRUE(found) << listed.dump();
  EXPECT_FALSE(temporary_of(root / "mine", fs::path(path).filename().string()));
}

}  // namespace
}  // namespace mm
