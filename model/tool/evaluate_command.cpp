// `evaluate`: Table 1 of the paper for one trained model on the test
// subjects of a prepared dataset (JSON on stdout, a short table on stderr).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>

#include "format/atomic_file.h"
#include "format/input_error.h"
#include "model/default_model.h"
#include "model/evaluation.h"
#include "model/tool/cli_validators.h"
#include "model/tool/commands.h"
#include "model/tool/device_option.h"
#include "model/tool/file_arguments.h"
#include "model/tool/precision_option.h"

namespace mm::tool {
namespace {

struct EvaluateOptions {
  std::string model_dir, dataset, out, device = "cpu", precision = "fp32";
  EvaluationOptions evaluation = [] {
    EvaluationOptions defaults;
    defaults.spread_seeds = 5;  // a reader sees how much of a difference is sampling noise
    return defaults;
  }();
};

bool same_normalization(const PoseNormalization& a, const PoseNormalization& b) {
  return a.mean == b.mean && a.stddev == b.stddev && a.kept_columns == b.kept_columns &&
         a.drop_root_translation == b.drop_root_translation;
}

void print_row(const char* name, const nlohmann::json& values) {
  std::fprintf(stderr, "  %-9s", name);
  for (const auto& value : values) std::fprintf(stderr, " %8.3f", value.get<double>());
  std::fprintf(stderr, "\n");
}

void print_table(const nlohmann::json& result) {
  const double interval = result.at("interval_seconds").get<double>();
  for (const auto& [decoder, errors] : result.at("decoders").items()) {
    const size_t intervals = errors.at("E_r").size();
    std::fprintf(stderr, "%-11s", decoder.c_str());
    for (size_t i = 0; i < intervals; ++i) std::fprintf(stderr, " %7.1fs", interval * static_cast<double>(i + 1));
    std::fprintf(stderr, "\n");
    const auto& paper = errors.at("paper_units");
    if (paper.contains("E_r")) print_row("E_r paper", paper.at("E_r"));
    if (paper.contains("E_p")) print_row("E_p paper", paper.at("E_p"));
    print_row("E_r", errors.at("E_r"));
    print_row("E_p", errors.at("E_p"));
    print_row("mpjpe", errors.at("mpjpe_mm"));
    print_row("angle", errors.at("angle_error_rad"));
    std::fprintf(stderr, "  E_z       %8.3f\n", errors.at("E_z").get<double>());
    if (result.contains("seed_spread")) {
      const auto& spread = result.at("seed_spread").at("decoders").at(decoder).at("paper_units");
      const auto& generated =
          result.at("generation_order").at("seed_spread_decoders").at(decoder).at("paper_units");
      std::fprintf(stderr, "  over %zu seeds (mean +- std):\n", result.at("seed_spread").at("seeds").size());
      for (const auto& [order, table] : {std::pair<const char*, const nlohmann::json&>{"", spread},
                                         std::pair<const char*, const nlohmann::json&>{", generation order", generated}}) {
        for (const char* name : {"E_r", "E_p"}) {
          if (!table.contains(name)) continue;
          std::fprintf(stderr, "  %s paper%s", name, order);
          const auto& mean = table.at(name).at("mean");
          const auto& std = table.at(name).at("std");
          for (size_t i = 0; i < mean.size(); ++i) {
            std::fprintf(stderr, " %.3f+-%.3f", mean[i].get<double>(), std[i].get<double>());
          }
          std::fprintf(stderr, "\n");
        }
      }
      std::fprintf(stderr, "  E_z       %.3f+-%.3f\n", spread.at("E_z").at("mean").get<double>(),
                   spread.at("E_z").at("std").get<double>());
    }
  }
  std::fprintf(stderr,
               "(columns in clip time, the clip's start first; generation order: from the clip's end, as the "
               "decoders generate. paper: the reference implementation's units, per-triplet norms; E_r: normalised "
               "angles, one norm per frame; E_p: positions in units of %.1f mm; mpjpe in mm; angle in rad)\n",
               result.at("position_unit_mm").get<double>());
  if (result.contains("denoising")) {
    const auto& d = result.at("denoising");
    std::fprintf(stderr, "denoising (p = %.2f, %s decoder), mean per-joint position error in mm:\n",
                 d.at("probability").get<double>(), d.at("decoder").get<std::string>().c_str());
    std::fprintf(stderr, "  %-22s %9s %9s %9s %9s %9s\n", "corruption", "corrupted", "projected", "missing",
                 "kept", "interp.");
    for (const auto& c : d.at("corruptions")) {
      std::string name = c.at("corruption").get<std::string>();
      if (c.contains("window_frames")) name += " " + std::to_string(c.at("window_frames").get<int>()) + " frames";
      std::fprintf(stderr, "  %-22s %9.1f %9.1f %9.1f %9.1f %9.1f\n", name.c_str(),
                   c.at("corrupted_mpjpe_mm").get<double>(), c.at("denoised_mpjpe_mm").get<double>(),
                   c.at("denoised_missing_mpjpe_mm").get<double>(), c.at("filled_missing_mpjpe_mm").get<double>(),
                   c.at("time_interpolation_mpjpe_mm").get<double>());
    }
    std::fprintf(stderr,
                 "  (projected: as the paper projects; missing: dropped values treated as missing; kept: the same "
                 "keeping observed values; interp.: interpolated in time, no manifold)\n");
  }
}

int run_evaluate(const EvaluateOptions& o) {
  check_input_file(o.dataset, "--dataset");
  if (!o.out.empty()) check_output_file(o.out, "--out", "the JSON goes there already");
  const auto device = parse_device(o.device);
  if (o.precision != "fp32" && !device.is_cpu()) throw InputError("--precision: " + o.precision + " is for the CPU only");
  const MotionManifold model =
      device.is_cpu() ? load_model_at_precision(o.model_dir, o.precision) : MotionManifold::load(o.model_dir, device);
  PreparedDataset data = load_prepared_dataset(o.dataset);
  if (data.test_subjects.empty()) throw InputError(o.dataset + ": the dataset has no test subjects");
  if (!same_normalization(data.normalization, model.normalization())) {
    // The dataset was normalised for another model: bring its test clips into
    // this model's units. Columns the dataset dropped come back as its mean.
    std::fprintf(stderr, "note: %s was normalised differently from the model; re-normalising its test sequences\n",
                 o.dataset.c_str());
    for (auto& s : data.sequences) {
      s.normalized = model.normalization().normalize(data.normalization.denormalize(s.normalized));
    }
  }
  // The reference's position unit: per-coordinate statistics of the FK
  // positions of the training frames, computed here from the dataset.
  const auto positions = fit_position_standardization(model, data.subset(data.train_subjects));
  const std::string text = evaluate_reconstruction(model, data.subset(data.test_subjects), o.evaluation, &positions);
  const nlohmann::json result = nlohmann::json::parse(text);
  const std::string pretty = result.dump(2) + "\n";
  std::fputs(pretty.c_str(), stdout);
  if (!o.out.empty()) write_file_atomically(o.out, pretty);
  print_table(result);
  return kExitSuccess;
}

}  // namespace

void add_evaluate_command(CLI::App& app, Action& action) {
  auto o = std::make_shared<EvaluateOptions>();
  auto* command = app.add_subcommand(
      "evaluate",
      "Reconstruction errors (Table 1: E_r, E_p, E_z) of a model on random clips of the dataset's test subjects, in "
      "the units of the paper's public reference implementation (paper_units; position statistics from the "
      "dataset's training subjects) and in this project's own, plus mm and radians, with their spread over "
      "several clip sets, and the denoising experiment. JSON on stdout, a summary table on stderr.");
  o->model_dir = default_model_dir();
  command->add_option("--model", o->model_dir, "model folder (default: $MM_MODEL_DIR or the shipped model)");
  command->add_option("--dataset", o->dataset, "prepared dataset file; its test subjects are used")->required();
  command->add_option("--clips", o->evaluation.clips, "number of random test clips")
      ->check(at_least(1))
      ->capture_default_str();
  command->add_option("--seed", o->evaluation.seed, "seed choosing the clips")->capture_default_str();
  command->add_option("--spread-seeds", o->evaluation.spread_seeds,
                      "also report the mean and standard deviation of every Table 1 number over this many clip sets "
                      "(seeds --seed, --seed + 1, ...)")
      ->check(at_least(1))
      ->capture_default_str();
  command->add_option("--corruption-probability", o->evaluation.corruption_probability,
                      "denoising experiment (Sec. 5.4): probability of dropping each joint-angle value; 0 skips it")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  command->add_option("--out", o->out, "also write the JSON to this file");
  command->add_option("--device", o->device, "cpu, cuda or auto")->capture_default_str();
  add_precision_option(command, o->precision);
  command->callback([o, &action] { action = [o] { return run_evaluate(*o); }; });
}

}  // namespace mm::tool
