// `train` and `resume`: run Trainer (Sec. 3.3) with a progress line, stop
// cleanly on SIGINT/SIGTERM (checkpoint, export, exit 130) and export the
// trained model with its provenance. With --progress-json each progress
// report is also one JSON line on stdout, for a program that runs the tool
// (the service's training jobs) to read.
#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>

#include "format/atomic_file.h"
#include "format/input_error.h"
#include "format/rig_folder_dataset.h"
#include "model/cuda_graph_replay.h"
#include "model/tool/cli_validators.h"
#include "model/tool/commands.h"
#include "model/tool/device_option.h"
#include "model/tool/file_arguments.h"
#include "model/tool/motion_files.h"
#include "model/tool/progress_line.h"
#include "model/trainer.h"
#include "model/trajectory_training.h"

namespace mm::tool {
namespace {

// Set by the signal handler, read by Trainer::run between iterations.
std::atomic<bool> g_cancel{false};
static_assert(std::atomic<bool>::is_always_lock_free, "the cancel flag is set from a signal handler");

extern "C" void request_cancel(int) {
  g_cancel.store(true);
  static const char kMessage[] =
      "\ncancelling: finishing this iteration, then checkpointing and exporting (signal again to quit at once)\n";
  ssize_t ignored = write(STDERR_FILENO, kMessage, sizeof kMessage - 1);
  (void)ignored;
}

// Routes SIGINT and SIGTERM to the cancel flag while alive. SA_RESETHAND
// makes a second signal act as usual, so a stuck run can still be killed.
class CancelOnSignal {
 public:
  CancelOnSignal() {
    g_cancel.store(false);
    struct sigaction action {};
    action.sa_handler = request_cancel;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESETHAND;
    sigaction(SIGINT, &action, &old_int_);
    sigaction(SIGTERM, &action, &old_term_);
  }
  ~CancelOnSignal() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  CancelOnSignal(const CancelOnSignal&) = delete;
  CancelOnSignal& operator=(const CancelOnSignal&) = delete;
  const std::atomic<bool>* flag() const { return &g_cancel; }

 private:
  struct sigaction old_int_ {}, old_term_ {};
};

struct TrainOptions {
  std::string config_path, variant, dataset, out, resume, init_from, device = "auto";
  // Loss forms (training_config.h): the preset first, then each form given.
  std::string losses, loss_angle, loss_position, loss_mmd, loss_adversarial;
  int64_t iterations = 0;
  bool progress_json = false, cuda_graphs = true;
  int batch = 0, hidden = 0;
  uint64_t seed = 0;
  CLI::Option* seed_option = nullptr;
};

PreparedDataset load_dataset(const std::string& path) {
  std::fprintf(stderr, "loading %s\n", path.c_str());
  PreparedDataset data = load_prepared_dataset(path);
  int64_t frames = 0;
  const auto train = data.subset(data.train_subjects);
  for (const auto* s : train) frames += s->normalized.frame_count();
  std::fprintf(stderr, "  %zu training sequences, %lld frames at %d Hz\n", train.size(),
               static_cast<long long>(frames), data.frame_rate);
  return data;
}

// One progress report as a JSON line on stdout, flushed at once so that a
// reader on a pipe sees it when it happens:
// {"iteration":..,"total":..,"losses":{..},"iterations_per_second":..,"eta_seconds":..}
void print_progress_json(const TrainProgress& p) {
  nlohmann::json losses = nlohmann::json::object();
  // NaN/inf have no JSON spelling; null keeps the line parseable.
  for (const auto& [name, value] : p.losses) losses[name] = std::isfinite(value) ? nlohmann::json(value) : nlohmann::json();
  const nlohmann::json line = {{"iteration", p.iteration},
                               {"total", p.total},
                               {"losses", losses},
                               {"iterations_per_second", p.iterations_per_second},
                               {"eta_seconds", p.eta_seconds}};
  std::fputs((line.dump() + "\n").c_str(), stdout);
  std::fflush(stdout);
}

// Runs the trainer to its end or to a signal, then exports the model to
// <output_dir>/model with its provenance, to which `origin` (where the run
// started from, if not from scratch) is added. Returns the exit code.
// A model of one's own rig learns where its root goes from the animation files
// its dataset was prepared from (model/root_trajectory.h), so that what it
// generates travels: as many iterations as the manifold's, 100 to 3000 (the
// default H3.6M model's took 3000, 100 s on 2 cores). The model folder is
// saved again with it.
void train_rig_trajectory(MotionManifold& model, const PreparedDataset& data, int64_t manifold_iterations,
                          const std::string& model_dir) {
  const std::vector<MotionFrames> motions = read_rig_training_motions(data);
  TrajectoryTrainingOptions options;
  options.iterations = static_cast<int>(std::clamp<int64_t>(manifold_iterations, 100, 3000));
  options.windows = 1024;
  std::fprintf(stderr, "training the root trajectory of the skeleton \"%s\" on %zu files of %s: %d iterations\n",
               data.skeleton.name.c_str(), motions.size(), data.rig_folder.c_str(), options.iterations);
  const TrajectoryTrainingReport report = train_root_trajectory(model, motions, options);
  model.save(model_dir, model.provenance_json());
  std::fprintf(stderr, "root trajectory: %d iterations in %.0f s, final loss %.4f\n", report.iterations, report.seconds,
               report.final_loss);
}

int train_and_export(Trainer& trainer, const PreparedDataset& data, c10::Device device,
                     const std::string& dataset_path, const std::string& command_line, const nlohmann::json& origin,
                     bool progress_json) {
  const TrainConfig& config = trainer.config();
  ensure_directory(config.output_dir, "--out");
  write_file_atomically(config.output_dir + "/config.json", to_json_text(config));
  std::fprintf(stderr, "training %s (hidden %d, batch %d, %s losses) on %s: iterations %lld to %lld, output in %s\n",
               config.variant.c_str(), config.model.hidden, config.batch, loss_preset_name(config.losses).c_str(),
               device.str().c_str(),
               static_cast<long long>(trainer.iteration()), static_cast<long long>(config.iterations),
               config.output_dir.c_str());

  const int64_t first = trainer.iteration();
  const auto started = std::chrono::steady_clock::now();
  ProgressLine line(stderr);
  TrainOutcome outcome;
  {
    CancelOnSignal cancel;
    outcome = trainer.run(
        [&line, progress_json](const TrainProgress& p) {
          line.update(p.iteration, p.total, p.losses, p.iterations_per_second, p.eta_seconds);
          if (progress_json) print_progress_json(p);
        },
        cancel.flag());
  }
  line.finish();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  const bool cancelled = outcome == TrainOutcome::kCancelled;

  nlohmann::json provenance = {
      {"command", command_line},
      {"iterations", trainer.iteration()},
      {"iterations_this_run", trainer.iteration() - first},
      {"seconds", seconds},
      {"device", device.str()},
      {"cuda_graphs", device.is_cuda() && cuda_graphs_enabled()},
      {"dataset", dataset_path},
      {"variant", config.variant},
      {"outcome", cancelled ? "cancelled" : "finished"},
  };
  provenance.update(origin);
  // A run that diverged exports nothing: a model of NaN weights would load
  // and answer every call with NaN (a training job would publish it).
  for (const at::Tensor& parameter : trainer.model().generator_parameters()) {
    if (!at::isfinite(parameter).all().item<bool>()) {
      std::fprintf(stderr,
                   "error: training diverged: after %lld iterations the weights hold NaN or infinite values; no model "
                   "exported (try a smaller learning_rate or a larger batch)\n",
                   static_cast<long long>(trainer.iteration()));
      return kExitFailure;
    }
  }
  // A model is always exported from the CPU so that it loads on machines
  // without a GPU.
  trainer.model().to(c10::kCPU);
  const std::string model_dir = config.output_dir + "/model";
  trainer.model().save(model_dir, provenance.dump());
  if (!cancelled && !data.rig_folder.empty()) {
    // The manifold is exported whatever happens here: its files may have
    // moved since they were prepared.
    try {
      train_rig_trajectory(trainer.model(), data, trainer.iteration(), model_dir);
    } catch (const InputError& e) {
      std::fprintf(stderr, "warning: no root trajectory network: %s (train-trajectory --rig FOLDER gives it one)\n",
                   e.what());
    }
  }

  std::fprintf(stderr, "%s after %lld iterations (%s); checkpoint %s/checkpoint.pt, model %s\n",
               cancelled ? "cancelled" : "finished", static_cast<long long>(trainer.iteration()),
               format_duration(seconds).c_str(), config.output_dir.c_str(), model_dir.c_str());
  if (cancelled) {
    std::fprintf(stderr, "continue with: motion-manifold resume %s/checkpoint.pt --dataset %s\n",
                 config.output_dir.c_str(), dataset_path.c_str());
    return kExitCancelled;
  }
  return kExitSuccess;
}

// The iterations an exported model was trained for, as its manifest's
// provenance records; 0 when it does not say.
int64_t exported_iterations(const MotionManifold& model) {
  const auto provenance = nlohmann::json::parse(model.provenance_json());
  const auto iterations = provenance.value("iterations", nlohmann::json());
  return iterations.is_number_integer() ? iterations.get<int64_t>() : 0;
}

// The configuration `train` runs: the --config file (or --variant's
// defaults) with the flags given, by the rule a training job's spec follows
// too (resolve_train_config). Numbers too large for a double (1e999) in the
// file are refused as bad input naming it.
ResolvedTrainConfig resolve_config(const TrainOptions& o) {
  const std::string text = o.config_path.empty() ? "" : read_input_file(o.config_path, "--config");
  TrainOverrides overrides;
  overrides.iterations = o.iterations;
  overrides.batch = o.batch;
  overrides.hidden = o.hidden;
  if (o.seed_option->count() > 0) overrides.seed = o.seed;
  if (!o.losses.empty()) overrides.losses = loss_preset(o.losses, "--losses");
  if (!o.loss_angle.empty()) overrides.loss_angle = parse_angle_reduction(o.loss_angle, "--loss-angle");
  if (!o.loss_position.empty()) overrides.loss_position = parse_position_reduction(o.loss_position, "--loss-position");
  if (!o.loss_mmd.empty()) overrides.loss_mmd = parse_mmd_form(o.loss_mmd, "--loss-mmd");
  if (!o.loss_adversarial.empty()) {
    overrides.loss_adversarial = parse_adversarial_reduction(o.loss_adversarial, "--loss-adversarial");
  }
  overrides.dataset = o.dataset;
  overrides.output_dir = o.out;
  try {
    return resolve_train_config(text, o.variant, overrides, o.config_path, "--");
  } catch (const nlohmann::json::exception& e) {
    throw InputError(o.config_path + ": not a valid training configuration (JSON): " + json_error_reason(e.what()));
  }
}

int run_resume(const std::string& checkpoint, const std::string& dataset_path, int64_t iterations,
               const std::string& device_name, const std::string& command_line, bool progress_json) {
  check_input_file(checkpoint, "checkpoint");
  check_input_file(dataset_path, "--dataset");
  const c10::Device device = parse_device(device_name);
  const PreparedDataset data = load_dataset(dataset_path);
  auto trainer = Trainer::resume(checkpoint, data, device, iterations);
  if (trainer->config().output_dir.empty()) throw InputError(checkpoint + ": the checkpoint's run has no output_dir");
  return train_and_export(*trainer, data, device, dataset_path, command_line, {{"resumed_from", checkpoint}},
                          progress_json);
}

int run_train(const TrainOptions& o, const std::string& command_line) {
  if (!o.resume.empty()) {
    if (o.dataset.empty()) throw InputError("--resume needs --dataset (the prepared dataset the run was trained on)");
    return run_resume(o.resume, o.dataset, o.iterations, o.device, command_line, o.progress_json);
  }
  ResolvedTrainConfig resolved = resolve_config(o);
  TrainConfig& config = resolved.config;
  if (config.dataset.empty()) throw InputError("train", "no dataset: give --dataset or \"dataset\" in the configuration");
  if (config.output_dir.empty()) {
    throw InputError("train", "no output folder: give --out or \"output_dir\" in the configuration");
  }
  check_input_file(config.dataset, o.dataset.empty() ? "dataset" : "--dataset");
  const c10::Device device = parse_device(o.device);
  const PreparedDataset data = load_dataset(config.dataset);
  if (resolved.pose_dims_from_dataset) config.model.pose_dims = data.normalization.dims();
  Trainer trainer(config, data, device);
  nlohmann::json origin = nlohmann::json::object();
  if (!o.init_from.empty()) {
    const MotionManifold start = MotionManifold::load(o.init_from);
    const int64_t iteration = exported_iterations(start);
    trainer.start_from(start, iteration);
    origin = {{"started_from", o.init_from}, {"started_at_iteration", iteration}};
    std::fprintf(stderr, "starting from %s at iteration %lld (fresh optimiser moments)\n", o.init_from.c_str(),
                 static_cast<long long>(iteration));
  }
  return train_and_export(trainer, data, device, config.dataset, command_line, origin, o.progress_json);
}

}  // namespace

constexpr const char* kProgressJsonHelp =
    "also print each progress report as one JSON line on stdout: {\"iteration\", \"total\", \"losses\" "
    "(every loss term by name), \"iterations_per_second\", \"eta_seconds\"}; stderr is unchanged";

void add_train_commands(CLI::App& app, Action& action, const std::string& command_line) {
  auto o = std::make_shared<TrainOptions>();
  o->variant = "DKGM";
  auto* train = app.add_subcommand(
      "train",
      "Train a motion manifold (Sec. 3.3). Writes <out>/config.json, train_log.csv, checkpoint.pt (every "
      "checkpoint_every iterations and at the end) and the exported model in <out>/model. SIGINT/SIGTERM stop "
      "after the current iteration, checkpoint, export and exit with 130.");
  auto* config = train->add_option("--config", o->config_path,
                                   "training configuration JSON (fields of TrainConfig; missing ones take the "
                                   "variant's defaults)");
  auto* variant = train->add_option("--variant", o->variant, "Table 1 variant: S, D, DK, DKG, DKGM, DKGMZ, Seq2seq")
                      ->capture_default_str();
  config->excludes(variant);
  train->add_option("--dataset", o->dataset, "prepared dataset file (overrides the configuration)");
  auto* out = train->add_option("--out", o->out, "output folder (overrides the configuration)");
  train->add_option("--iterations", o->iterations, "iterations in total (overrides)")->check(at_least(1));
  // Two clips at least: the MMD estimate needs two samples (as in a configuration file).
  auto* batch = train->add_option("--batch", o->batch, "clips per batch (overrides)")->check(at_least(2));
  auto* hidden = train->add_option("--hidden", o->hidden, "GRU hidden size (overrides)")->check(at_least(1));
  o->seed_option = train->add_option("--seed", o->seed, "random seed (overrides)");
  auto* losses = train->add_option("--losses", o->losses,
                                   "loss forms: frame-norm (the shipped models' forms, default), paper (Eq. 9, 10, "
                                   "13 and 14 as written) or reference (the public reference implementation's four "
                                   "forms); overrides the configuration");
  auto* loss_angle =
      train->add_option("--loss-angle", o->loss_angle, "angle loss: frame-norm, triplet-mean or joint-sum");
  auto* loss_position = train->add_option("--loss-position", o->loss_position,
                                          "position loss: frame-norm, standardized-triplet-mean or joint-sum");
  auto* loss_mmd = train->add_option("--loss-mmd", o->loss_mmd, "MMD: single-scale or seven-scales");
  auto* loss_adversarial = train->add_option("--loss-adversarial", o->loss_adversarial,
                                             "LSGAN reduction: half-mean, batch-sum or half-sum");
  train->add_option("--device", o->device, "cpu, cuda or auto (CUDA when available)")->capture_default_str();
  auto* resume = train->add_option("--resume", o->resume,
                                   "continue the run saved in this checkpoint (needs --dataset; the output folder "
                                   "and configuration are the checkpoint's)");
  for (auto* excluded : {config, variant, out, batch, hidden, o->seed_option, losses, loss_angle, loss_position,
                         loss_mmd, loss_adversarial}) {
    resume->excludes(excluded);
  }
  auto* init_from = train->add_option(
      "--init-from", o->init_from,
      "start from the weights of this exported model (same shape and dataset) at the iteration its manifest "
      "records, with fresh optimiser moments: for continuing a model whose checkpoint is not at hand");
  init_from->excludes(resume);
  train->add_flag("--progress-json", o->progress_json, kProgressJsonHelp);
  add_cuda_graphs_option(*train, o->cuda_graphs);
  train->callback([o, &action, &command_line] {
    action = [o, &command_line] {
      set_cuda_graphs_enabled(o->cuda_graphs);
      return run_train(*o, command_line);
    };
  });

  struct ResumeOptions {
    std::string checkpoint, dataset, device = "auto";
    int64_t iterations = 0;
    bool progress_json = false, cuda_graphs = true;
  };
  auto r = std::make_shared<ResumeOptions>();
  auto* resume_command = app.add_subcommand(
      "resume", "Continue a training run from its checkpoint, exactly as if it had not stopped (same as train --resume).");
  resume_command->add_option("checkpoint", r->checkpoint, "checkpoint.pt of the run")->required();
  resume_command->add_option("--dataset", r->dataset, "the prepared dataset the run was trained on")->required();
  resume_command->add_option("--iterations", r->iterations, "new total number of iterations")
      ->check(at_least(1));
  resume_command->add_option("--device", r->device, "cpu, cuda or auto (CUDA when available)")->capture_default_str();
  resume_command->add_flag("--progress-json", r->progress_json, kProgressJsonHelp);
  add_cuda_graphs_option(*resume_command, r->cuda_graphs);
  resume_command->callback([r, &action, &command_line] {
    action = [r, &command_line] {
      set_cuda_graphs_enabled(r->cuda_graphs);
      return run_resume(r->checkpoint, r->dataset, r->iterations, r->device, command_line, r->progress_json);
    };
  });
}

}  // namespace mm::tool
