// `prepare`: H3.6M text files, or a folder of animation files (BVH, glTF,
// FBX) of one's own skeleton, to one prepared dataset file (Sec. 4): at 25 Hz, normalised on
// the training subjects (files), with the position-loss scale measured on them.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "format/input_error.h"
#include "format/prepared_dataset.h"
#include "format/rig_folder_dataset.h"
#include "format/skeleton.h"
#include "model/tool/commands.h"
#include "model/tool/file_arguments.h"
#include "model/trainer.h"

namespace mm::tool {
namespace {

struct PrepareOptions {
  std::string data_dir, rig_dir, out, unit = "auto";
  SplitOptions split;
  RigFolderOptions rig;
};

// Millimetres per unit of a --unit value; 0 for auto (detected).
double millimetres_per_unit(const std::string& unit) {
  if (unit == "auto") return 0;
  if (unit == "mm") return 1;
  if (unit == "cm") return 10;
  if (unit == "m") return 1000;
  if (unit == "in") return 25.4;
  throw InputError("--unit " + unit + ", expected auto, mm, cm, m or in");
}

int64_t frame_total(const std::vector<const PreparedSequence*>& sequences) {
  int64_t frames = 0;
  for (const auto* s : sequences) frames += s->normalized.frame_count();
  return frames;
}

int run_prepare(const PrepareOptions& options) {
  check_output_file(options.out, "--out", "a prepared dataset is a binary file read by path");
  const auto started = std::chrono::steady_clock::now();
  PreparedDataset data;
  if (!options.rig_dir.empty()) {
    RigFolderOptions rig = options.rig;
    rig.millimetres_per_unit = millimetres_per_unit(options.unit);
    data = prepare_rig_folder(options.rig_dir, rig);
  } else {
    // "--test ''" means no test subjects (a dataset of the user's own
    // subjects, none held out): CLI11 reads it as one empty name.
    SplitOptions split = options.split;
    for (auto* list : {&split.train_subjects, &split.test_subjects}) {
      list->erase(std::remove(list->begin(), list->end(), std::string()), list->end());
    }
    data = prepare_h36m(options.data_dir, split);
  }
  data.normalization.position_scale_mm = position_scale_for(data, data.skeleton);
  save_prepared_dataset(data, options.out);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();

  const auto train = data.subset(data.train_subjects), test = data.subset(data.test_subjects);
  std::printf("wrote %s (%.1f MB) in %.1f s\n", options.out.c_str(),
              static_cast<double>(std::filesystem::file_size(options.out)) / 1e6, seconds);
  std::printf("  train: %zu sequences, %lld frames at %d Hz\n", train.size(),
              static_cast<long long>(frame_total(train)), data.frame_rate);
  std::printf("  test:  %zu sequences, %lld frames at %d Hz\n", test.size(),
              static_cast<long long>(frame_total(test)), data.frame_rate);
  std::printf("  skeleton %s: %d joints (%.4g mm a unit)\n", data.skeleton.name.c_str(), data.skeleton.joint_count(),
              data.skeleton.bvh ? data.skeleton.bvh->millimetres_per_unit : 1.0);
  std::printf("  pose dimensions: %d of %d columns; position scale %.1f mm\n", data.normalization.dims(),
              data.normalization.input_columns(), data.normalization.position_scale_mm);
  return kExitSuccess;
}

}  // namespace

void add_prepare_command(CLI::App& app, Action& action) {
  auto options = std::make_shared<PrepareOptions>();
  auto* command = app.add_subcommand(
      "prepare",
      "Bring H3.6M (--data) or a folder of animation files of one skeleton (--rig: BVH, glTF, FBX) to 25 Hz, fit the "
      "normalisation on the training subjects or files and write a prepared dataset file.");
  auto* data = command->add_option("--data", options->data_dir, "H3.6M folder: holds S1, S5, ... (or h3.6m/dataset/S1, ...)");
  auto* rig = command->add_option(
      "--rig,--bvh", options->rig_dir,
      "folder of animation files of one hierarchy (.bvh, .glb, .gltf, .fbx, any case, mixed; searched "
      "recursively; --bvh is its former name): the skeleton (the first file's in path order), its channel layout, "
      "the kept dimensions and the statistics come from them; split into train and test by file (--test-files)");
  data->excludes(rig);
  rig->excludes(data);
  command->add_option("--test-files", options->rig.test_files,
                      "with --rig: test files or folders relative to it, comma-separated (default: every fifth file)")
      ->delimiter(',');
  command->add_option("--unit", options->unit,
                      "with --rig: the BVH files' length unit, and the skeleton's: auto (from the first BVH file's "
                      "rest pose height; mm for a folder of glTF and FBX only, whose files carry their unit), mm, "
                      "cm, m or in")
      ->check(CLI::IsMember({"auto", "mm", "cm", "m", "in"}))
      ->capture_default_str();
  command->add_option("--name", options->rig.skeleton_name, "with --rig: the skeleton's name (default: the folder's)");
  command->add_option("--out", options->out, "prepared dataset file to write")->required();
  command->add_option("--train", options->split.train_subjects, "training subjects, comma-separated")
      ->delimiter(',')
      ->capture_default_str();
  command->add_option("--test", options->split.test_subjects, "test subjects, comma-separated ('' for none)")
      ->delimiter(',')
      ->capture_default_str();
  command->callback([options, &action, data, rig] {
    if (data->count() == 0 && rig->count() == 0) throw CLI::RequiredError("--data or --rig");
    action = [options] { return run_prepare(*options); };
  });
}

}  // namespace mm::tool
