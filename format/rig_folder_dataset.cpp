#include "format/rig_folder_dataset.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>

#include "format/animation_file.h"
#include "format/atomic_file.h"
#include "format/bvh_file.h"
#include "format/input_error.h"
#include "format/skeleton_bvh.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

bool is_bvh(const std::string& path) {
  AnimationFormat format;
  return animation_format_of_path(path, &format) && format == AnimationFormat::kBvh;
}

// "martial/03.glb" -> "martial/03": a file's sequence name.
std::string without_extension(const std::string& relative) {
  const fs::path path(relative);
  return (path.parent_path() / path.stem()).generic_string();
}

// "./martial/" -> "martial": the forms a user may type for one entry.
std::string normalized_entry(std::string entry) {
  while (entry.rfind("./", 0) == 0) entry.erase(0, 2);
  while (!entry.empty() && entry.back() == '/') entry.pop_back();
  return entry;
}

std::vector<bool> test_selection(const std::vector<std::string>& files, const RigFolderOptions& options,
                                 const std::string& folder) {
  std::vector<bool> test(files.size(), false);
  if (options.test_files.empty()) {
    if (files.size() >= 5) {
      for (size_t i = 4; i < files.size(); i += 5) test[i] = true;
    } else if (files.size() >= 2) {
      test.back() = true;
    }
  }
  for (const std::string& raw : options.test_files) {
    const std::string entry = normalized_entry(raw);
    bool matched = false;
    for (size_t i = 0; i < files.size(); ++i) {
      if (!entry.empty() && (files[i] == entry || files[i].rfind(entry + "/", 0) == 0)) {
        test[i] = true;
        matched = true;
      }
    }
    if (!matched) {
      throw InputError("test file \"" + raw + "\" names no animation file under " + folder +
                       ", expected a file or folder relative to it (such as \"" + files.front() + "\")");
    }
  }
  const size_t test_count = static_cast<size_t>(std::count(test.begin(), test.end(), true));
  if (test_count == files.size()) {
    throw InputError(folder + ": every one of its " + std::to_string(files.size()) +
                     " animation files is a test file, expected at least one training file");
  }
  if (test_count == 0) {
    throw InputError(folder + ": no test file (it holds " + std::to_string(files.size()) + " animation file" +
                     (files.size() == 1 ? "" : "s") + "), expected at least one file for testing");
  }
  return test;
}

// Whether `text` is UTF-8: the skeleton travels as JSON (dataset header,
// model manifest), which holds nothing else.
bool is_utf8(const std::string& text) {
  for (size_t i = 0; i < text.size();) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    const size_t length = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xE ? 3 : (c >> 3) == 0x1E ? 4 : 0;
    if (length == 0 || i + length > text.size()) return false;
    for (size_t k = 1; k < length; ++k) {
      if ((static_cast<unsigned char>(text[i + k]) >> 6) != 0x2) return false;
    }
    i += length;
  }
  return true;
}

}  // namespace

std::vector<std::string> list_animation_files(const std::string& folder) {
  const std::string expected = std::string("expected a folder of animation files of one hierarchy (") +
                               animation_formats_listed() + " each, any case)";
  std::error_code error;
  if (!fs::is_directory(folder, error)) throw InputError(folder + ": not a folder, " + expected);
  std::vector<std::string> files;
  fs::recursive_directory_iterator it(folder, error), end;
  if (error) throw InputError(folder + ": cannot be read: " + error.message());
  for (; it != end; it.increment(error)) {
    if (error) throw InputError(folder + ": cannot be read: " + error.message());
    std::error_code ignored;
    AnimationFormat format;
    if (it->is_regular_file(ignored) && animation_format_of_path(it->path().string(), &format)) {
      files.push_back(fs::relative(it->path(), folder, ignored).generic_string());
    }
  }
  if (error) throw InputError(folder + ": cannot be read: " + error.message());
  if (files.empty()) throw InputError(folder + ": holds no animation file, " + expected);
  std::sort(files.begin(), files.end());
  return files;
}

void check_one_file_per_name(const std::vector<std::string>& files, const std::string& folder) {
  std::map<std::string, std::string> by_name;
  for (const std::string& file : files) {
    const auto [at, added] = by_name.emplace(without_extension(file), file);
    if (!added) {
      throw InputError(folder + ": " + at->second + " and " + file + " are two files of the name \"" + at->first +
                       "\", expected one file a name (a file's name without its extension names its sequence)");
    }
  }
}

double detect_bvh_millimetres_per_unit(const BvhFile& file, const std::string& source_name) {
  BvhFile rest = file;
  rest.values.assign(static_cast<size_t>(file.channel_count()), 0.0);
  const std::vector<Vec3> positions = bvh_world_positions(rest, 0);
  double extent = 0;
  for (int axis = 0; axis < 3; ++axis) {
    double low = positions[0][axis], high = positions[0][axis];
    for (const Vec3& p : positions) {
      low = std::min(low, p[axis]);
      high = std::max(high, p[axis]);
    }
    extent = std::max(extent, high - low);
  }
  if (extent >= 500 && extent <= 3000) return 1.0;
  if (extent >= 50 && extent <= 300) return 10.0;
  if (extent >= 0.5 && extent <= 3) return 1000.0;
  throw InputError(source_name + ": its rest pose spans " + std::to_string(extent) +
                   " units, which is no person's height in mm, cm or m; give the unit (--unit mm, cm, m or in)");
}

BvhFile read_rig_file(const std::string& path, double millimetres_per_unit) {
  AnimationFormat format = AnimationFormat::kBvh;
  if (!animation_format_of_path(path, &format)) {
    throw InputError(path + ": not an animation file, expected " + animation_formats_listed());
  }
  return parse_animation_file(read_whole_file(path), format, path, millimetres_per_unit);
}

MotionFrames read_rig_motion(const Skeleton& skeleton, const std::string& path) {
  return skeleton_motion_from_bvh(skeleton, read_rig_file(path, bvh_layout_of(skeleton).millimetres_per_unit), path);
}

PreparedDataset prepare_rig_folder(const std::string& folder, const RigFolderOptions& options) {
  if (!(options.millimetres_per_unit >= 0) || !std::isfinite(options.millimetres_per_unit) ||
      options.millimetres_per_unit > 1e6) {
    throw InputError("millimetres per unit " + std::to_string(options.millimetres_per_unit) +
                     ", expected a number in (0, 1e6] (or 0 to detect it)");
  }
  const std::vector<std::string> files = list_animation_files(folder);
  check_one_file_per_name(files, folder);
  const std::vector<bool> test = test_selection(files, options, folder);
  auto path_of = [&](size_t i) { return (fs::path(folder) / files[i]).string(); };

  // The skeleton's unit is the BVH files' (so that a model of the rig
  // writes BVH as its recordings are): given, else told from the first BVH
  // file, read here ahead of the files before it when they are glTF or FBX.
  const auto first_bvh = std::find_if(files.begin(), files.end(), is_bvh);
  std::optional<BvhFile> first_bvh_file;
  double unit = options.millimetres_per_unit;
  if (unit == 0 && first_bvh != files.end()) {
    const std::string path = path_of(static_cast<size_t>(first_bvh - files.begin()));
    first_bvh_file = read_rig_file(path, 0);
    unit = detect_bvh_millimetres_per_unit(*first_bvh_file, path);
  }
  if (unit == 0) unit = 1;  // glTF and FBX only: mm

  PreparedDataset data;
  data.rig_folder = fs::absolute(folder).lexically_normal().string();
  data.train_subjects = {"train"};
  data.test_subjects = {"test"};
  data.frame_rate = static_cast<int>(kBvhImportRate);
  std::vector<MotionFrames> motions;
  for (size_t i = 0; i < files.size(); ++i) {
    const std::string path = path_of(i);
    const bool read_ahead = first_bvh_file && files.begin() + static_cast<std::ptrdiff_t>(i) == first_bvh;
    const BvhFile file = read_ahead ? std::move(*first_bvh_file) : read_rig_file(path, unit);
    if (i == 0) {
      std::string name = options.skeleton_name;
      if (name.empty()) name = fs::path(folder).lexically_normal().filename().string();
      if (name.empty() || name == "." || name == "..") name = fs::absolute(folder).lexically_normal().filename().string();
      if (name.empty()) name = "rig";
      for (const BvhJoint& joint : file.joints) {
        if (!is_utf8(joint.name)) throw InputError(path + ": a joint name that is not UTF-8 text, expected one");
      }
      if (!is_utf8(name)) throw InputError("skeleton name: not UTF-8 text, expected one (give --name)");
      data.skeleton = bvh_skeleton(file, name, unit);
    }
    motions.push_back(skeleton_motion_from_bvh(data.skeleton, file, path));
  }
  std::vector<const MotionFrames*> train;
  for (size_t i = 0; i < files.size(); ++i) {
    if (!test[i]) train.push_back(&motions[i]);
  }
  // Test files must not leak into the statistics the model is trained with.
  data.normalization = PoseNormalization::fit(train, options.min_std, true);
  for (size_t i = 0; i < files.size(); ++i) {
    PreparedSequence sequence;
    sequence.subject = test[i] ? "test" : "train";
    sequence.action = without_extension(files[i]);
    sequence.normalized = data.normalization.normalize(motions[i]);
    motions[i].values = {};
    data.sequences.push_back(std::move(sequence));
  }
  return data;
}

std::vector<MotionFrames> read_rig_training_motions(const PreparedDataset& data) {
  if (data.rig_folder.empty()) throw InputError("the dataset was not prepared from a folder of a rig's files");
  std::vector<MotionFrames> motions;
  const std::vector<std::string> files = list_animation_files(data.rig_folder);
  for (const PreparedSequence* sequence : data.subset(data.train_subjects)) {
    const auto file = std::find_if(files.begin(), files.end(), [&](const std::string& relative) {
      return without_extension(relative) == sequence->action;
    });
    if (file == files.end()) {
      throw InputError((fs::path(data.rig_folder) / sequence->action).string() +
                       " (" + animation_formats_listed() +
                       "): the dataset's training file is no longer in the folder it was prepared from");
    }
    motions.push_back(read_rig_motion(data.skeleton, (fs::path(data.rig_folder) / *file).string()));
  }
  return motions;
}

}  // namespace mm
