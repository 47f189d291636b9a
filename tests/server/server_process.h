// The real server binary as a child process on free loopback ports, for the
// integration tests: started with a temporary model store that holds the
// shipped models (symbolic links), waited for through its --ready-file, and
// stopped with SIGTERM (or killed) at the end.
//
// The binary comes from MM_SERVER_BINARY, the shipped models from
// MM_SOURCE_DIR/models (compile definitions). Not thread safe.
#pragma once

#include <signal.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace mm::test {

class ServerProcess {
 public:
  // Starts the server with `args` after the harness's own (ports, ready
  // file, loopback and the model store unless `args` name them) and waits
  // until it serves.
  // Throws std::runtime_error with the server's log when it exits first or
  // is not ready within `timeout`.
  explicit ServerProcess(std::vector<std::string> args = {},
                         std::chrono::seconds timeout = std::chrono::seconds(120)) {
    namespace fs = std::filesystem;
    std::random_device random;
    dir_ = fs::temp_directory_path() / ("mm-server-" + std::to_string(getpid()) + "-" + std::to_string(random()));
    fs::create_directories(dir_);
    const bool own_store = std::find(args.begin(), args.end(), "--model-store") != args.end();
    if (!own_store) {
      model_store_ = (dir_ / "models").string();
      fs::create_directories(model_store_);
      for (const char* name : {"h36m-dkgm-h100", "h36m-dkgm-cpu"}) {
        fs::create_directory_symlink(fs::path(MM_SOURCE_DIR) / "models" / name, fs::path(model_store_) / name);
      }
    } else {
      model_store_ = *(std::find(args.begin(), args.end(), "--model-store") + 1);
    }
    std::vector<std::string> argv = {MM_SERVER_BINARY, "--grpc-port", "0", "--rest-port", "0", "--ready-file",
                                     (dir_ / "ready.json").string()};
    // Loopback unless the test listens elsewhere (the clients below still
    // call through 127.0.0.1, which a 0.0.0.0 listener serves too).
    if (std::find(args.begin(), args.end(), "--address") == args.end()) {
      argv.push_back("--address");
      argv.push_back("127.0.0.1");
    }
    if (!own_store) {
      argv.push_back("--model-store");
      argv.push_back(model_store_);
    }
    // One LibTorch thread unless the test asks otherwise: its OpenMP threads
    // spin, and two servers of two threads each on a 2-core machine (ctest
    // -j2) slow each other several times over; no test here times them.
    if (std::find(args.begin(), args.end(), "--threads") == args.end()) {
      argv.push_back("--threads");
      argv.push_back("1");
    }
    argv.insert(argv.end(), args.begin(), args.end());
    argv_ = argv;
    start(argv_, timeout);
  }

  // Starts the server again with the same arguments (after terminate() or
  // kill()), on new ports; the model store and scratch folder stay.
  void restart(std::chrono::seconds timeout = std::chrono::seconds(120)) {
    if (pid_ > 0) throw std::runtime_error("restart: the server is still running");
    start(argv_, timeout);
  }

  // Starts the server again on the ports it had, as a restarted service
  // comes back at the same address: for clients that reconnect on their own
  // (a job watch). The ports were the server's until it stopped; another
  // process could take them meanwhile, which a test run on loopback makes
  // unlikely enough.
  void restart_on_same_ports(std::chrono::seconds timeout = std::chrono::seconds(120)) {
    if (pid_ > 0) throw std::runtime_error("restart: the server is still running");
    std::vector<std::string> argv = argv_;
    for (size_t i = 0; i + 1 < argv.size(); ++i) {
      if (argv[i] == "--grpc-port") argv[i + 1] = std::to_string(grpc_port_);
      if (argv[i] == "--rest-port") argv[i + 1] = std::to_string(rest_port_);
    }
    start(argv, timeout);
  }

  ~ServerProcess() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  int grpc_port() const { return grpc_port_; }
  int rest_port() const { return rest_port_; }
  std::string grpc_target() const { return "127.0.0.1:" + std::to_string(grpc_port_); }
  std::string rest_url() const { return "http://127.0.0.1:" + std::to_string(rest_port_); }
  const std::string& model_store() const { return model_store_; }
  // A scratch folder removed with the harness (state, data roots).
  std::filesystem::path scratch() const { return dir_; }
  pid_t pid() const { return pid_; }
  // The server's stdout and stderr so far.
  std::string log() const {
    std::ifstream in(dir_ / "server.log");
    return std::string(std::istreambuf_iterator<char>(in), {});
  }

  // SIGTERM, then waits; returns the exit status (128 + signal if killed).
  int terminate(std::chrono::seconds timeout = std::chrono::seconds(60)) {
    if (pid_ <= 0) return -1;
    ::kill(pid_, SIGTERM);
    return wait_exit(timeout);
  }
  // SIGKILL, then waits.
  void kill() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    wait_exit(std::chrono::seconds(30));
  }

 private:
  void start(const std::vector<std::string>& args, std::chrono::seconds timeout) {
    const std::string log_path = (dir_ / "server.log").string();
    pid_ = fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      std::vector<char*> argv;
      for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      FILE* log = std::fopen(log_path.c_str(), "a");
      if (log) {
        dup2(fileno(log), STDOUT_FILENO);
        dup2(fileno(log), STDERR_FILENO);
      }
      execv(argv[0], argv.data());
      _exit(127);
    }
    const auto ready = dir_ / "ready.json";
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!std::filesystem::exists(ready)) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        throw std::runtime_error("the server exited before it was ready:\n" + log());
      }
      if (std::chrono::steady_clock::now() > deadline) {
        throw std::runtime_error("the server was not ready in time:\n" + log());
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    std::ifstream in(ready);
    const auto ports = nlohmann::json::parse(in);
    grpc_port_ = ports.at("grpc_port").get<int>();
    rest_port_ = ports.at("rest_port").get<int>();
  }

  int wait_exit(std::chrono::seconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    int status = 0;
    while (waitpid(pid_, &status, WNOHANG) == 0) {
      if (std::chrono::steady_clock::now() > deadline) {
        ::kill(pid_, SIGKILL);
        waitpid(pid_, &status, 0);
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    pid_ = -1;
    std::filesystem::remove(dir_ / "ready.json");
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }

  std::filesystem::path dir_;
  std::vector<std::string> argv_;
  std::string model_store_;
  pid_t pid_ = -1;
  int grpc_port_ = 0, rest_port_ = 0;
};

}  // namespace mm::test
