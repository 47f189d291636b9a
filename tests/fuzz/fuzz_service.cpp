#include "tests/fuzz/fuzz_service.h"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include "server/engine/manifold_core.h"
#include "server/jobs/training_jobs.h"

namespace mm::fuzz {
namespace {

namespace fs = std::filesystem;
using namespace mm::service;

[[noreturn]] void fail_setup(const std::string& message) {
  std::cerr << "fuzz setup: " << message << "\n";
  std::exit(2);
}

std::string environment_or(const char* name, const std::string& fallback) {
  const char* value = std::getenv(name);
  return value != nullptr && value[0] != '\0' ? value : fallback;
}

// 320 rows of 99 values at 50 Hz: root translation in mm, then slow
// rotations, enough for one 150-frame window at 25 Hz from row 0 to 20.
std::string small_h36m_text() {
  std::ostringstream text;
  for (int row = 0; row < 320; ++row) {
    for (int column = 0; column < 99; ++column) {
      const double value = column < 3 ? 10.0 * row : 0.2 * std::sin(0.05 * row + column);
      text << (column ? "," : "") << value;
    }
    text << "\n";
  }
  return text.str();
}

// One CMU dance cut to its first `frames` frames (120 Hz), so that a read of
// it is quick: the hierarchy as recorded, the motion shortened.
void write_short_cmu_dance(const fs::path& scratch, const fs::path& out, int frames) {
  const std::string archive = environment_or("MM_SHARED_DIR", MM_DEFAULT_SHARED_DIR) + "/data/cmu-dance-bvh.tar.xz";
  const std::string member = "cmu-dance-bvh/martial/04.bvh";
  const std::string command = "tar xJf '" + archive + "' -C '" + scratch.string() + "' " + member;
  if (std::system(command.c_str()) != 0) fail_setup(command + " failed (MM_SHARED_DIR names the shared folder)");
  std::ifstream in(scratch / member);
  std::ofstream written(out);
  std::string line;
  int motion_lines = -1;  // -1: still in the hierarchy
  while (std::getline(in, line) && motion_lines < frames) {
    if (line.rfind("Frames:", 0) == 0) {
      written << "Frames: " << frames << "\n";
    } else {
      written << line << "\n";
      if (line.rfind("Frame Time:", 0) == 0) motion_lines = 0;
      else if (motion_lines >= 0) ++motion_lines;
    }
  }
  if (motion_lines != frames) fail_setup(member + " has fewer than " + std::to_string(frames) + " frames");
  fs::remove_all(scratch / "cmu-dance-bvh");
}

struct Service {
  fs::path scratch;
  ServiceMetrics metrics;
  std::unique_ptr<TrainingJobs> jobs;
  std::unique_ptr<ManifoldCore> core;
  FuzzService view;

  explicit Service(fs::path folder) : scratch(std::move(folder)), core(start_core()), view{metrics, *core} {}
  ~Service() {
    core->drain();
    jobs->shutdown();
    std::error_code ignored;
    fs::remove_all(scratch, ignored);
  }

  std::unique_ptr<ManifoldCore> start_core() {
    const fs::path store = scratch / "models", data = scratch / "data", state = scratch / "state";
    const fs::path model = fs::path(MM_SOURCE_DIR) / "models" / "h36m-dkgm-cpu";
    if (!fs::is_directory(model)) fail_setup(model.string() + " not found");
    fs::create_directories(store);
    fs::copy(model, store / "h36m-dkgm-cpu", fs::copy_options::recursive);
    // A text tree (a training subject, so a job may name it) and a folder
    // of two BVH files of one rig (a dataset too).
    fs::create_directories(data / "tree" / "S1");
    std::ofstream(data / "tree" / "S1" / "walking_1.txt") << small_h36m_text();
    fs::create_directories(data / "cmu");
    write_short_cmu_dance(scratch, data / "cmu" / "dance_a.bvh", 800);
    write_short_cmu_dance(scratch, data / "cmu" / "dance_b.bvh", 400);

    JobsConfig jobs_config;
    jobs_config.state_dir = state.string();
    jobs_config.data_root = data.string();
    jobs_config.model_store = store.string();
    jobs_config.tool_path = "/bin/false";
    jobs = std::make_unique<TrainingJobs>(jobs_config, [](const std::string&) {});

    CoreConfig config;
    config.model_store = store.string();
    config.default_model = "h36m-dkgm-cpu";
    config.data_root = data.string();
    config.limits.max_motions = 4;
    config.limits.max_sample_count = 4;
    config.limits.max_steps = 8;
    config.limits.max_denoise_iterations = 4;
    config.batching.threads = 1;
    auto started = std::make_unique<ManifoldCore>(config, metrics, jobs.get());
    jobs->start();
    started->start();
    return started;
  }
};

}  // namespace

FuzzService& fuzz_service() {
  static Service* service = [] {
    // Refusals are the expected answers to almost every input: logging
    // each would drown libFuzzer's own report.
    spdlog::set_level(spdlog::level::off);
    std::string folder = (fs::temp_directory_path() / "mm_fuzz_XXXXXX").string();
    if (mkdtemp(folder.data()) == nullptr) fail_setup("cannot create a scratch folder in " + folder);
    auto* created = new Service(folder);
    std::atexit([] { delete service; });
    return created;
  }();
  return service->view;
}

void print_answer_when_verbose(const std::string& request, int status, const std::string& reply) {
  static const bool verbose = environment_or("MM_FUZZ_VERBOSE", "0") == "1";
  if (verbose) std::cerr << request << " -> " << status << " " << reply.substr(0, 300) << "\n";
}

void report_internal_error(const std::string& where, const std::string& message) {
  std::cerr << "\n" << where << " answered INTERNAL or nothing, a bug for any request: " << message << "\n";
  std::abort();
}

}  // namespace mm::fuzz
