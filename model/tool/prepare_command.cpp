// `prepare`: H3.6M text files to one prepared dataset file (Sec. 4):
// downsampled to 25 Hz, normalised on the training subjects, with the
// position-loss scale measured on them.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "commands.h"
#include "file_arguments.h"
#include "format/prepared_dataset.h"
#include "format/skeleton.h"
#include "trainer.h"

namespace mm::tool {
namespace {

struct PrepareOptions {
  std::string data_dir, out;
  SplitOptions split;
};

int64_t frame_total(const std::vector<const PreparedSequence*>& sequences) {
  int64_t frames = 0;
  for (const auto* s : sequences) frames += s->normalized.frame_count();
  return frames;
}

int run_prepare(const PrepareOptions& options) {
  check_output_file(options.out, "--out", "a prepared dataset is a binary file read by path");
  const auto started = std::chrono::steady_clock::now();
  PreparedDataset data = prepare_h36m(options.data_dir, options.split);
  data.normalization.position_scale_mm = position_scale_for(data, Skeleton::h36m());
  save_prepared_dataset(data, options.out);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();

  const auto train = data.subset(data.train_subjects), test = data.subset(data.test_subjects);
  std::printf("wrote %s (%.1f MB) in %.1f s\n", options.out.c_str(),
              static_cast<double>(std::filesystem::file_size(options.out)) / 1e6, seconds);
  std::printf("  train: %zu sequences, %lld frames at %d Hz\n", train.size(),
              static_cast<long long>(frame_total(train)), data.frame_rate);
  std::printf("  test:  %zu sequences, %lld frames at %d Hz\n", test.size(),
              static_cast<long long>(frame_total(test)), data.frame_rate);
  std::printf("  pose dimensions: %d of %d columns; position scale %.1f mm\n", data.normalization.dims(),
              data.normalization.input_columns(), data.normalization.position_scale_mm);
  return kExitSuccess;
}

}  // namespace

void add_prepare_command(CLI::App& app, Action& action) {
  auto options = std::make_shared<PrepareOptions>();
  auto* command = app.add_subcommand(
      "prepare",
      "Downsample H3.6M to 25 Hz, fit the normalisation on the training subjects and write a prepared dataset file.");
  command->add_option("--data", options->data_dir, "H3.6M folder: holds S1, S5, ... (or h3.6m/dataset/S1, ...)")
      ->required();
  command->add_option("--out", options->out, "prepared dataset file to write")->required();
  command->add_option("--train", options->split.train_subjects, "training subjects, comma-separated")
      ->delimiter(',')
      ->capture_default_str();
  command->add_option("--test", options->split.test_subjects, "test subjects, comma-separated")
      ->delimiter(',')
      ->capture_default_str();
  command->callback([options, &action] { action = [options] { return run_prepare(*options); }; });
}

}  // namespace mm::tool
