#include "format/bvh_dataset.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>

#include "format/bvh_file.h"
#include "format/input_error.h"
#include "format/skeleton_bvh.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

bool has_bvh_extension(const fs::path& path) {
  std::string extension = path.extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return extension == ".bvh";
}

std::string without_bvh_extension(const std::string& relative) { return relative.substr(0, relative.size() - 4); }

// "./martial/" -> "martial": the forms a user may type for one entry.
std::string normalized_entry(std::string entry) {
  while (entry.rfind("./", 0) == 0) entry.erase(0, 2);
  while (!entry.empty() && entry.back() == '/') entry.pop_back();
  return entry;
}

std::vector<bool> test_selection(const std::vector<std::string>& files, const BvhFolderOptions& options,
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
      throw InputError("test file \"" + raw + "\" names no .bvh file under " + folder +
                       ", expected a file or folder relative to it (such as \"" + files.front() + "\")");
    }
  }
  const size_t test_count = static_cast<size_t>(std::count(test.begin(), test.end(), true));
  if (test_count == files.size()) {
    throw InputError(folder + ": every one of its " + std::to_string(files.size()) +
                     " .bvh files is a test file, expected at least one training file");
  }
  if (test_count == 0) {
    throw InputError(folder + ": no test file (it holds " + std::to_string(files.size()) +
                     " .bvh file), expected at least one file for testing");
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

std::vector<std::string> list_bvh_files(const std::string& folder) {
  std::error_code error;
  if (!fs::is_directory(folder, error)) throw InputError(folder + ": not a folder, expected a folder of .bvh files");
  std::vector<std::string> files;
  fs::recursive_directory_iterator it(folder, error), end;
  if (error) throw InputError(folder + ": cannot be read: " + error.message());
  for (; it != end; it.increment(error)) {
    if (error) throw InputError(folder + ": cannot be read: " + error.message());
    std::error_code ignored;
    if (it->is_regular_file(ignored) && has_bvh_extension(it->path())) {
      files.push_back(fs::relative(it->path(), folder, ignored).generic_string());
    }
  }
  if (error) throw InputError(folder + ": cannot be read: " + error.message());
  if (files.empty()) throw InputError(folder + ": holds no .bvh file, expected a folder of BVH files of one hierarchy");
  std::sort(files.begin(), files.end());
  return files;
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

PreparedDataset prepare_bvh_folder(const std::string& folder, const BvhFolderOptions& options) {
  if (!(options.millimetres_per_unit >= 0) || !std::isfinite(options.millimetres_per_unit) ||
      options.millimetres_per_unit > 1e6) {
    throw InputError("millimetres per unit " + std::to_string(options.millimetres_per_unit) +
                     ", expected a number in (0, 1e6] (or 0 to detect it)");
  }
  const std::vector<std::string> files = list_bvh_files(folder);
  const std::vector<bool> test = test_selection(files, options, folder);
  const std::string first_path = (fs::path(folder) / files.front()).string();

  PreparedDataset data;
  data.bvh_folder = fs::absolute(folder).lexically_normal().string();
  data.train_subjects = {"train"};
  data.test_subjects = {"test"};
  data.frame_rate = static_cast<int>(kBvhImportRate);
  std::vector<MotionFrames> motions;
  for (size_t i = 0; i < files.size(); ++i) {
    const std::string path = (fs::path(folder) / files[i]).string();
    const BvhFile file = read_bvh_file(path);
    if (i == 0) {
      std::string name = options.skeleton_name;
      if (name.empty()) name = fs::path(folder).lexically_normal().filename().string();
      if (name.empty() || name == "." || name == "..") name = fs::absolute(folder).lexically_normal().filename().string();
      if (name.empty()) name = "bvh-skeleton";
      const double unit = options.millimetres_per_unit > 0 ? options.millimetres_per_unit
                                                          : detect_bvh_millimetres_per_unit(file, path);
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
    sequence.action = without_bvh_extension(files[i]);
    sequence.normalized = data.normalization.normalize(motions[i]);
    motions[i].values = {};
    data.sequences.push_back(std::move(sequence));
  }
  return data;
}

std::vector<MotionFrames> read_bvh_training_motions(const PreparedDataset& data) {
  if (data.bvh_folder.empty()) throw InputError("the dataset was not prepared from a BVH folder");
  std::vector<MotionFrames> motions;
  const std::vector<std::string> files = list_bvh_files(data.bvh_folder);
  for (const PreparedSequence* sequence : data.subset(data.train_subjects)) {
    const auto file = std::find_if(files.begin(), files.end(), [&](const std::string& relative) {
      return without_bvh_extension(relative) == sequence->action;
    });
    const std::string path = (fs::path(data.bvh_folder) / (sequence->action + ".bvh")).string();
    if (file == files.end()) {
      throw InputError(path + ": the dataset's training file is no longer in the folder it was prepared from");
    }
    const std::string found = (fs::path(data.bvh_folder) / *file).string();
    motions.push_back(skeleton_motion_from_bvh(data.skeleton, read_bvh_file(found), found));
  }
  return motions;
}

}  // namespace mm
