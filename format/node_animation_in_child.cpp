#include "format/node_animation_in_child.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "format/input_error.h"

namespace mm {
namespace {

// ---- the animation as bytes, for the pipe ----

template <typename T>
void put(std::string& out, const T& value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}
void put_string(std::string& out, const std::string& text) {
  put<uint64_t>(out, text.size());
  out += text;
}

std::string serialised(const NodeAnimation& animation) {
  std::string out;
  put<uint64_t>(out, animation.nodes.size());
  for (const AnimationNode& node : animation.nodes) {
    put_string(out, node.name);
    put(out, node.parent);
    put(out, node.rest_translation);
    put(out, node.rest_rotation);
    put(out, node.rest_scale);
    put<uint8_t>(out, node.has_bvh_layout);
    put<uint8_t>(out, node.end_site);
    put<uint8_t>(out, node.animated_translation);
    put<uint8_t>(out, node.animated_rotation);
    put<uint64_t>(out, node.bvh_channels.size());
    for (BvhChannel channel : node.bvh_channels) put<int32_t>(out, static_cast<int32_t>(channel));
  }
  put(out, animation.above_root_linear);
  put(out, animation.above_root_translation);
  put(out, animation.rate_hz);
  put(out, animation.frames);
  put(out, animation.millimetres_per_unit);
  put<uint64_t>(out, animation.translations.size());
  out.append(reinterpret_cast<const char*>(animation.translations.data()), animation.translations.size() * sizeof(Vec3));
  put<uint64_t>(out, animation.rotations.size());
  out.append(reinterpret_cast<const char*>(animation.rotations.data()), animation.rotations.size() * sizeof(Quaternion));
  return out;
}

class Reader {
 public:
  explicit Reader(const std::string& bytes) : bytes_(bytes) {}
  template <typename T>
  T get() {
    T value;
    take(&value, sizeof(T));
    return value;
  }
  std::string get_string() {
    const uint64_t size = get<uint64_t>();
    if (size > bytes_.size() - at_) throw std::runtime_error("truncated");
    std::string text = bytes_.substr(at_, size);
    at_ += size;
    return text;
  }
  template <typename T>
  void get_array(std::vector<T>* values) {
    const uint64_t count = get<uint64_t>();
    if (count > (bytes_.size() - at_) / sizeof(T)) throw std::runtime_error("truncated");
    values->resize(count);
    take(values->data(), count * sizeof(T));
  }

 private:
  void take(void* to, size_t size) {
    if (size > bytes_.size() - at_) throw std::runtime_error("truncated");
    std::memcpy(to, bytes_.data() + at_, size);
    at_ += size;
  }
  const std::string& bytes_;
  size_t at_ = 1;  // after the status byte
};

NodeAnimation deserialised(const std::string& bytes) {
  Reader in(bytes);
  NodeAnimation animation;
  const uint64_t nodes = in.get<uint64_t>();
  if (nodes > static_cast<uint64_t>(kMaxBvhJoints)) throw std::runtime_error("too many nodes");
  for (uint64_t j = 0; j < nodes; ++j) {
    AnimationNode node;
    node.name = in.get_string();
    node.parent = in.get<int>();
    node.rest_translation = in.get<Vec3>();
    node.rest_rotation = in.get<Quaternion>();
    node.rest_scale = in.get<Vec3>();
    node.has_bvh_layout = in.get<uint8_t>();
    node.end_site = in.get<uint8_t>();
    node.animated_translation = in.get<uint8_t>();
    node.animated_rotation = in.get<uint8_t>();
    std::vector<int32_t> channels;
    in.get_array(&channels);
    for (int32_t c : channels) node.bvh_channels.push_back(static_cast<BvhChannel>(c));
    animation.nodes.push_back(std::move(node));
  }
  animation.above_root_linear = in.get<Mat3>();
  animation.above_root_translation = in.get<Vec3>();
  animation.rate_hz = in.get<double>();
  animation.frames = in.get<int64_t>();
  animation.millimetres_per_unit = in.get<double>();
  in.get_array(&animation.translations);
  in.get_array(&animation.rotations);
  if (animation.translations.size() != static_cast<size_t>(animation.frames) * nodes ||
      animation.rotations.size() != animation.translations.size()) {
    throw std::runtime_error("inconsistent frame arrays");
  }
  return animation;
}

size_t address_space_now() {
  FILE* statm = std::fopen("/proc/self/statm", "r");
  if (!statm) return 0;
  unsigned long pages = 0;
  const int read = std::fscanf(statm, "%lu", &pages);
  std::fclose(statm);
  return read == 1 ? pages * static_cast<size_t>(sysconf(_SC_PAGESIZE)) : 0;
}

void write_all(int fd, const std::string& bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    done += static_cast<size_t>(n);
  }
}

[[noreturn]] void run_child(int fd, size_t memory_bytes, const std::function<NodeAnimation()>& read) {
  const size_t now = address_space_now();
  if (now > 0) {
    const rlimit memory{now + memory_bytes, now + memory_bytes};
    setrlimit(RLIMIT_AS, &memory);
  }
  const rlimit cpu{60, 60};
  setrlimit(RLIMIT_CPU, &cpu);
  std::string out;
  try {
    out = std::string(1, '\0') + serialised(read());
  } catch (const InputError& e) {
    out = std::string(1, '\1') + e.what();
  } catch (const std::bad_alloc&) {
    out = std::string(1, '\2') + "it needs more memory than a file of its size may take";
  } catch (const std::exception& e) {
    out = std::string(1, '\2') + e.what();
  } catch (...) {
    out = std::string(1, '\2') + "an unknown error";
  }
  write_all(fd, out);
  _exit(0);
}

}  // namespace

size_t child_memory_budget(size_t input_bytes) { return input_bytes * 64 + (size_t{512} << 20); }

NodeAnimation read_in_child_process(const std::string& what, size_t memory_bytes,
                                    const std::function<NodeAnimation()>& read) {
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error(what + ": no pipe: " + std::strerror(errno));
  const pid_t pid = fork();
  if (pid < 0) {
    const int error = errno;
    close(fds[0]);
    close(fds[1]);
    throw std::runtime_error(what + ": no child process: " + std::strerror(error));
  }
  if (pid == 0) {
    close(fds[0]);
    run_child(fds[1], memory_bytes, read);
  }
  close(fds[1]);
  std::string answer;
  char buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fds[0], buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    answer.append(buffer, static_cast<size_t>(n));
  }
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFSIGNALED(status)) {
    const int signal = WTERMSIG(status);
    throw InputError(what + " stopped on this file (signal " + std::to_string(signal) + ", " + strsignal(signal) +
                     (signal == SIGXCPU ? ": more than 60 s of CPU" : "") + ")");
  }
  if (answer.empty()) throw InputError(what + " ended without an answer on this file");
  if (answer[0] != '\0') throw InputError(answer[0] == '\1' ? answer.substr(1) : what + " failed: " + answer.substr(1));
  try {
    return deserialised(answer);
  } catch (const std::exception& e) {
    throw std::runtime_error(what + ": the child's answer is malformed (" + e.what() + ")");
  }
}

}  // namespace mm
