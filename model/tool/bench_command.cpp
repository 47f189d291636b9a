// `bench`: the paper's model size (hidden 1024, 150 frames) on this machine:
// one full training iteration (Trainer::step, DKGM; on a GPU with and
// without CUDA graphs, and also at batch 256) and inference (encode,
// rotation decode; on the CPU with the weights unpacked, packed in fp32 and
// in bf16), with random weights on synthetic or real data; with
// --root-path, what the root path and the feet add to a decode to motions.
// The numbers behind docs/PERFORMANCE.md.
#include <ATen/Parallel.h>
#include <c10/core/InferenceMode.h>
#include <torch/cuda.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <fstream>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>
#include <utility>

#include "format/atomic_file.h"
#include "format/foot_contacts.h"
#include "format/input_error.h"
#include "model/cuda_graph_replay.h"
#include "model/gru_inference.h"
#include "model/inference_precision.h"
#include "model/latent_operations.h"
#include "model/packed_linear.h"
#include "model/synthetic_dataset.h"
#include "model/tool/cli_validators.h"
#include "model/tool/commands.h"
#include "model/tool/device_option.h"
#include "model/tool/file_arguments.h"
#include "model/tool/operation_count.h"
#include "model/trainer.h"

namespace mm::tool {
namespace {

struct BenchOptions {
  int hidden = 1024;
  int iterations = 5;
  bool inference_only = false, profile = false, root_path = false;
  std::string dataset, out, device = "all";
};

struct Timing {
  std::string operation;
  int batch = 0;
  std::string device;
  std::vector<double> ms;  // one per repeat, after two warm-ups
  int64_t operations = 0;  // tensor operations of one run (count_operations)
  double median() const {
    auto sorted = ms;
    std::sort(sorted.begin(), sorted.end());
    const size_t n = sorted.size();
    return n % 2 ? sorted[n / 2] : (sorted[n / 2 - 1] + sorted[n / 2]) / 2;
  }
  double min() const { return *std::min_element(ms.begin(), ms.end()); }
};

void synchronize(c10::Device device) {
  if (device.is_cuda()) torch::cuda::synchronize();
}

// Two warm-up runs: the allocator, the thread pool and CUDA's kernels settle
// in the first, and a CUDA graph is captured in the second.
template <class Work>
Timing measure(const std::string& operation, int batch, c10::Device device, int repeats, Work&& work) {
  std::fprintf(stderr, "  %s, batch %d, %s ...", operation.c_str(), batch, device.str().c_str());
  std::fflush(stderr);
  Timing timing{operation, batch, device.str(), {}};
  for (int i = 0; i < 2; ++i) work();
  synchronize(device);
  for (int i = 0; i < repeats; ++i) {
    const auto started = std::chrono::steady_clock::now();
    work();
    synchronize(device);
    timing.ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count());
  }
  timing.operations = count_operations(work);
  synchronize(device);
  std::fprintf(stderr, " median %.1f ms, %lld operations\n", timing.median(), static_cast<long long>(timing.operations));
  return timing;
}

void bench_device(const BenchOptions& o, const PreparedDataset& data, c10::Device device, std::vector<Timing>& out) {
  TrainConfig config = variant_config("DKGM");
  config.model.hidden = o.hidden;
  config.model.pose_dims = data.normalization.dims();
  config.iterations = 1 << 30;
  config.output_dir.clear();  // no checkpoints or logs
  // On a GPU: with and without the recurrences as CUDA graphs, and at a
  // large batch, which the launch-bound uncaptured step barely notices.
  std::vector<bool> graph_settings{false};
  std::vector<int> batches{4, 30};
  if (device.is_cuda()) {
    graph_settings = {false, true};
    batches.push_back(256);
  }
  if (o.inference_only) graph_settings.clear();
  for (bool graphs : graph_settings) {
    set_cuda_graphs_enabled(graphs);
    const std::string operation = !device.is_cuda() ? "training iteration (DKGM)"
                                  : graphs           ? "training iteration (DKGM, CUDA graphs)"
                                                     : "training iteration (DKGM, uncaptured)";
    for (int batch : batches) {
      config.batch = batch;
      Trainer trainer(config, data, device);
      out.push_back(measure(operation, batch, device, o.iterations, [&] { trainer.step(); }));
    }
  }
  set_cuda_graphs_enabled(true);

  MotionManifold model(config.model, data.normalization, Skeleton::h36m());
  model.to(device);
  model.train(false);
  // Inference on the CPU: the weights as they are (LibTorch's products),
  // packed in fp32 (what a loaded model uses), and packed in bf16 and int8
  // where the CPU has bf16 dot products; one run, one machine, for before
  // and after.
  std::vector<std::pair<std::string, std::optional<Precision>>> settings{{"", std::nullopt}};
  if (device.is_cpu()) {
    settings = {{" (unpacked fp32)", std::nullopt}, {" (packed fp32)", Precision::kFp32}};
    for (const Precision lower : {Precision::kBf16, Precision::kInt8}) {
      if (precision_available(lower)) settings.emplace_back(std::string(" (packed ") + precision_name(lower) + ")", lower);
    }
  }
  // Inference is cheap: more repeats for a steadier median.
  const int repeats = std::max(o.iterations, 10);
  for (const auto& [label, precision] : settings) {
    if (precision) {
      model.pack_for_inference(*precision);
    } else {
      model.discard_inference_packs();
    }
    for (int batch : {1, 30}) {
      c10::InferenceMode inference;
      const auto clips = at::randn({batch, config.model.frames, config.model.pose_dims}).to(device);
      const auto codes = at::randn({batch, config.model.latent}).to(device);
      out.push_back(measure("encode" + label, batch, device, repeats, [&] { model.encode(clips); }));
      out.push_back(measure("decode (rotation)" + label, batch, device, repeats,
                            [&] { model.decode(codes, DecoderKind::kRotation); }));
    }
  }
  // What a decode to motions (the service's) adds to the networks: the
  // frames in the layout, the trajectory network's root path in the world
  // (a network of the shipped shape, random weights: it costs the same),
  // and the feet planted; bench --root-path times them alternately and
  // part by part.
  if (!device.is_cpu()) return;
  model.pack_for_inference(Precision::kFp32);
  for (int batch : {1, 30}) {
    c10::InferenceMode inference;
    const auto codes = at::randn({batch, config.model.latent});
    model.set_trajectory(RootTrajectory(nullptr));
    out.push_back(measure("decode to motions, standing (packed fp32)", batch, device, repeats,
                          [&] { decode_codes(model, codes, DecoderKind::kRotation); }));
    model.set_trajectory(RootTrajectory(config.model.pose_dims, config.model.latent, TrajectoryConfig{}));
    out.push_back(measure("decode to motions, root path (packed fp32)", batch, device, repeats,
                          [&] { decode_codes(model, codes, DecoderKind::kRotation); }));
    out.push_back(measure("decode to motions, root path, feet planted (packed fp32)", batch, device, repeats, [&] {
      auto motions = decode_codes(model, codes, DecoderKind::kRotation);
      plant_feet_of_each(model.skeleton(), motions, 25);
    }));
  }
  model.set_trajectory(RootTrajectory(nullptr));
}

// Where a decoder step's time goes on the CPU: each of its products (the
// input gates, 51 -> 3H; the hidden gates, H -> 3H; the pose, H -> 51) and its
// element-wise update, timed alone over the 150 steps of a clip, unpacked
// (LibTorch's products, a scalar-free vectorised update) and packed in each
// precision (int8 as a model packs it: the hidden gates in int8, the input
// gates and the pose in bf16). Random weights of the model's shapes.
void profile_decoder_step(const BenchOptions& o, std::vector<Timing>& out) {
  const int64_t hidden = o.hidden, dims = 51, steps = 150;
  const auto w_input = at::randn({3 * hidden, dims}) * 0.1, b_input = at::randn({3 * hidden});
  const auto w_hidden = at::randn({3 * hidden, hidden}) * 0.03, b_hidden = at::randn({3 * hidden});
  const auto w_pose = at::randn({dims, hidden}) * 0.03, b_pose = at::randn({dims});
  std::vector<std::pair<std::string, std::optional<Precision>>> settings{{"unpacked fp32", std::nullopt},
                                                                         {"packed fp32", Precision::kFp32}};
  for (const Precision lower : {Precision::kBf16, Precision::kInt8}) {
    if (precision_available(lower)) settings.emplace_back(std::string("packed ") + precision_name(lower), lower);
  }
  const int repeats = std::max(o.iterations, 10);
  for (int64_t batch : {1, 30}) {
    auto input = at::randn({batch, dims}), state = at::randn({batch, hidden});
    auto input_gates = at::empty({batch, 3 * hidden}), hidden_gates = at::empty({batch, 3 * hidden});
    auto pose = at::empty({batch, dims});
    for (const auto& [label, precision] : settings) {
      auto product = [&](const at::Tensor& w, const at::Tensor& b,
                         bool recurrent) -> std::function<void(const at::Tensor&, at::Tensor&)> {
        if (!precision) return [&w, &b](const at::Tensor& x, at::Tensor& y) { affine_into(y, b, w, x); };
        auto packed = std::make_shared<PackedLinear>(w, b, recurrent ? *precision : outside_recurrence(*precision));
        return [packed](const at::Tensor& x, at::Tensor& y) { packed->apply(x, y); };
      };
      const auto input_product = product(w_input, b_input, false),
                 hidden_product = product(w_hidden, b_hidden, true), pose_product = product(w_pose, b_pose, false);
      const std::string suffix = " x150, " + label;
      out.push_back(measure("step: input gates" + suffix, batch, c10::kCPU, repeats, [&] {
        for (int64_t t = 0; t < steps; ++t) input_product(input, input_gates);
      }));
      out.push_back(measure("step: hidden gates" + suffix, batch, c10::kCPU, repeats, [&] {
        for (int64_t t = 0; t < steps; ++t) hidden_product(state, hidden_gates);
      }));
      out.push_back(measure("step: pose" + suffix, batch, c10::kCPU, repeats, [&] {
        for (int64_t t = 0; t < steps; ++t) pose_product(state, pose);
      }));
    }
    // The update is the same code on every path (a GRU's state stays in
    // (-1, 1), so repeating it keeps the values finite).
    out.push_back(measure("step: element-wise update x150", batch, c10::kCPU, repeats, [&] {
      for (int64_t t = 0; t < steps; ++t) gru_combine(state, input_gates, hidden_gates);
    }));
  }
}

// What the root path and the feet add to a decode to motions, and where
// their time goes, at batch 1 and 30: the three decodes (standing, root
// path, root path with the feet planted) alternate within every round, so
// that a neighbour's load on a shared machine falls on all three alike,
// and each part is also timed alone on the same decoded clips: the
// trajectory network, the path's integration, levelling and settling on
// the floor, and plant_feet. The paper's model size, random weights, a
// trajectory network of the shipped shape (its cost does not depend on its
// weights), weights packed in fp32 as a loaded model's are.
// The CPU time of the whole process (ms), every thread's: on a machine
// shared with other work it counts only this process's own, where the wall
// clock also counts the waits for a core.
double process_cpu_ms() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) * 1e3 + static_cast<double>(now.tv_nsec) / 1e6;
}

// What the root path and the feet add to a decode to motions, and where
// their time goes, at batch 1 and 30: the three decodes (standing, root
// path, root path with the feet planted) alternate within every round,
// each first in turn, so that a neighbour's load on a shared machine falls
// on all three alike; then each part alone on one decode's clips: the
// trajectory network, the path (network, integration, levelling, floor)
// and plant_feet. Each is timed by the wall clock and by the process's CPU
// time (rows marked "CPU time"; with one LibTorch thread, OMP_NUM_THREADS=1,
// that is the work itself, where more threads also count their waits). The
// paper's model size, random weights, a trajectory network of the shipped
// shape (its cost does not depend on its weights), the weights packed in
// fp32 as a loaded model's are.
void bench_root_path(const BenchOptions& o, const PreparedDataset& data, std::vector<Timing>& out) {
  TrainConfig config = variant_config("DKGM");
  config.model.hidden = o.hidden;
  config.model.pose_dims = data.normalization.dims();
  MotionManifold model(config.model, data.normalization, Skeleton::h36m());
  model.train(false);
  model.pack_for_inference(Precision::kFp32);
  RootTrajectory network(config.model.pose_dims, config.model.latent, TrajectoryConfig{});
  network->eval();
  const int rounds = std::max(o.iterations, 10);
  for (int batch : {1, 30}) {
    c10::InferenceMode inference;
    const auto codes = at::randn({batch, config.model.latent});
    const auto normalized = model.decode(codes, DecoderKind::kRotation);
    model.set_trajectory(RootTrajectory(nullptr));
    const auto standing = decode_codes(model, codes, DecoderKind::kRotation);
    model.set_trajectory(network);
    const auto travelling = decode_codes(model, codes, DecoderKind::kRotation);
    struct Work {
      std::string name;
      bool path;  // the model has the trajectory network
      std::function<void()> run;
    };
    const std::vector<Work> decodes{
        {"decode to motions, standing (packed fp32)", false, [&] { decode_codes(model, codes, DecoderKind::kRotation); }},
        {"decode to motions, root path (packed fp32)", true, [&] { decode_codes(model, codes, DecoderKind::kRotation); }},
        {"decode to motions, root path, feet planted (packed fp32)", true, [&] {
           auto motions = decode_codes(model, codes, DecoderKind::kRotation);
           plant_feet_of_each(model.skeleton(), motions, 25);
         }}};
    const std::vector<Work> parts{
        {"root path: trajectory network", true, [&] {
           std::vector<float> raw(static_cast<size_t>(normalized.size(0) * normalized.size(1)) *
                                  static_cast<size_t>(model.normalization().input_columns()));
           write_generated_root_changes(model, normalized, codes, raw.data(), model.normalization().input_columns());
         }},
        {"root path: network, integration, levelling, floor", true, [&] {
           auto motions = standing;
           write_generated_roots(model, normalized, codes, motions);
         }},
        {"feet planted: plant_feet of each motion", true, [&] {
           auto motions = travelling;
           plant_feet_of_each(model.skeleton(), motions, 25);
         }}};
    for (const auto* works : {&decodes, &parts}) {
      std::vector<Timing> wall, cpu;
      for (const auto& work : *works) {
        wall.push_back(Timing{work.name, batch, "cpu", {}});
        cpu.push_back(Timing{work.name + ", CPU time", batch, "cpu", {}});
        model.set_trajectory(work.path ? network : RootTrajectory(nullptr));
        for (int i = 0; i < 2; ++i) work.run();
      }
      const size_t n = works->size();
      for (int round = 0; round < rounds; ++round) {
        for (size_t k = 0; k < n; ++k) {
          const size_t v = (static_cast<size_t>(round) + k) % n;  // each first in turn
          model.set_trajectory((*works)[v].path ? network : RootTrajectory(nullptr));
          const double cpu_before = process_cpu_ms();
          const auto started = std::chrono::steady_clock::now();
          (*works)[v].run();
          wall[v].ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count());
          cpu[v].ms.push_back(process_cpu_ms() - cpu_before);
        }
      }
      for (size_t v = 0; v < n; ++v) {
        std::fprintf(stderr, "  %s, batch %d: median %.1f ms, CPU time %.1f ms\n", wall[v].operation.c_str(), batch,
                     wall[v].median(), cpu[v].median());
        out.push_back(std::move(wall[v]));
      }
      for (auto& timing : cpu) out.push_back(std::move(timing));
    }
  }
  model.set_trajectory(RootTrajectory(nullptr));
}

std::string cpu_name() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  }
  return "unknown CPU";
}

int run_bench(const BenchOptions& o) {
  std::vector<c10::Device> devices;
  if (o.device == "all") {
    devices.push_back(c10::kCPU);
    if (cuda_available()) devices.emplace_back(c10::kCUDA, 0);
  } else if (o.device == "cpu" || o.device == "cuda") {
    devices.push_back(parse_device(o.device));
  } else {
    throw InputError("--device: expected cpu, cuda or all, found \"" + o.device + "\"");
  }
  if (!o.dataset.empty()) check_input_file(o.dataset, "--dataset");
  if (!o.out.empty()) check_output_file(o.out, "--out", "it carries the table of timings");
  const PreparedDataset data = o.dataset.empty() ? synthetic_h36m_dataset() : load_prepared_dataset(o.dataset);
  const std::string machine = cpu_name() + ", " + std::to_string(std::thread::hardware_concurrency()) +
                              " hardware threads, " + std::to_string(at::get_num_threads()) + " torch threads";
  std::fprintf(stderr, "bench: hidden %d, %s data, %s\n", o.hidden, o.dataset.empty() ? "synthetic" : "prepared",
               machine.c_str());

  std::vector<Timing> timings;
  if (o.root_path) {
    bench_root_path(o, data, timings);
  } else {
    for (const auto& device : devices) bench_device(o, data, device, timings);
  }
  if (o.profile) profile_decoder_step(o, timings);

  std::printf("| operation | batch | device | median (ms) | min (ms) | repeats | operations |\n");
  std::printf("|---|---:|---|---:|---:|---:|---:|\n");
  nlohmann::json results = nlohmann::json::array();
  for (const auto& t : timings) {
    std::printf("| %s | %d | %s | %.1f | %.1f | %zu | %lld |\n", t.operation.c_str(), t.batch, t.device.c_str(),
                t.median(), t.min(), t.ms.size(), static_cast<long long>(t.operations));
    results.push_back({{"operation", t.operation},
                       {"batch", t.batch},
                       {"device", t.device},
                       {"median_ms", t.median()},
                       {"min_ms", t.min()},
                       {"operations", t.operations},
                       {"ms", t.ms}});
  }
  if (!o.out.empty()) {
    const nlohmann::json report = {{"hidden", o.hidden},   {"frames", 150},
                                   {"machine", machine},   {"data", o.dataset.empty() ? "synthetic" : o.dataset},
                                   {"results", results}};
    write_file_atomically(o.out, report.dump(2) + "\n");
  }
  return kExitSuccess;
}

}  // namespace

void add_bench_command(CLI::App& app, Action& action) {
  auto o = std::make_shared<BenchOptions>();
  auto* command = app.add_subcommand(
      "bench",
      "Time a full training iteration (DKGM, batch 4 and 30; on a GPU also 256, with and without CUDA graphs) and "
      "inference (encode, rotation decode; batch 1 and 30; on the CPU with the weights unpacked, packed in fp32 and "
      "packed in bf16 where the CPU has bf16 dot products) at the paper's model size with random weights. Prints a markdown table of median and minimum times and "
      "of the tensor operations one run issues (one kernel launch or a few each on a GPU).");
  command->add_option("--hidden", o->hidden, "GRU hidden size")->check(at_least(1))->capture_default_str();
  command->add_option("--iterations", o->iterations, "timed repeats after two warm-ups (inference: at least 10)")
      ->check(at_least(1))
      ->capture_default_str();
  command->add_flag("--inference-only", o->inference_only, "time inference only, no training iteration");
  command->add_flag("--profile", o->profile,
                    "also time each part of a decoder step alone on the CPU (its three products, unpacked and "
                    "packed, and its element-wise update), 150 steps at batch 1 and 30");
  command->add_flag("--root-path", o->root_path,
                    "time only what the root path and the feet add to a decode to motions (CPU, batch 1 and 30): "
                    "the decodes standing, with the root path and with the feet planted alternating in every round, "
                    "and each part alone");
  command->add_option("--dataset", o->dataset, "prepared dataset to draw clips from (default: synthetic data)");
  command->add_option("--device", o->device, "cpu, cuda, or all (the CPU, plus CUDA when available)")
      ->capture_default_str();
  command->add_option("--out", o->out, "also write the results as JSON");
  command->callback([o, &action] { action = [o] { return run_bench(*o); }; });
}

}  // namespace mm::tool
