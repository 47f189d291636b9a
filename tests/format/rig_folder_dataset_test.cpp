// A rig's training folder (format/rig_folder_dataset.h): CMU dances (43
// joints and 14 End Sites, cm, 120 Hz) prepared into a dataset split by
// file; a file of another hierarchy or a malformed one named; and Blender's
// own glTF and FBX exports of three dances (blender_dances.h), in folders
// of one format or mixed, prepared into the sequences their BVH gives: the
// same frames at 25 Hz, values within what the exports' round trip moves
// them, in the same mm.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "format/animation_file.h"
#include "format/bvh_file.h"
#include "format/h36m_bvh.h"
#include "format/input_error.h"
#include "format/prepared_dataset.h"
#include "format/rig_folder_dataset.h"
#include "format/skeleton_bvh.h"
#include "tests/common/blender_dances.h"
#include "tests/common/cmu_dance.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;

template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

std::string cmu(const std::string& relative) { return (test::cmu_dance_dir() / relative).string(); }

TEST(RigFolder, CmuDancesPrepareSplitByFile) {
  const PreparedDataset data = prepare_rig_folder(test::cmu_dance_dir().string(), RigFolderOptions{});
  EXPECT_EQ(data.skeleton.name, "cmu-dance-bvh");
  EXPECT_EQ(data.skeleton.joint_count(), 57);
  ASSERT_TRUE(data.skeleton.bvh.has_value());
  EXPECT_EQ(data.skeleton.bvh->millimetres_per_unit, 10.0);  // detected: a person about 170 units tall
  EXPECT_EQ(data.normalization.input_columns(), 174);
  EXPECT_EQ(data.frame_rate, 25);
  ASSERT_EQ(data.sequences.size(), 15u);
  std::vector<std::string> test_files;
  for (const auto* s : data.subset(data.test_subjects)) test_files.push_back(s->action);
  // Every fifth file in path order.
  EXPECT_EQ(test_files, (std::vector<std::string>{"indian/13", "martial/05", "martial/10"}));
  EXPECT_EQ(data.subset(data.train_subjects).size(), 12u);
  // Root translation and the End Sites' zeros are not modelled.
  for (int column : data.normalization.kept_columns) {
    EXPECT_GE(column, 3);
    EXPECT_FALSE(data.skeleton.bvh->end_site[(column - 3) / 3]) << data.skeleton.joints[(column - 3) / 3].name;
  }
  // The rig's eyes, fingers and toes never turn in these files: 17 joints x 3.
  EXPECT_EQ(data.normalization.dims(), 51);

  // The file keeps the skeleton with its layout.
  test::ScratchDir dir;
  save_prepared_dataset(data, dir.file("cmu.mmd"));
  const PreparedDataset loaded = load_prepared_dataset(dir.file("cmu.mmd"));
  EXPECT_EQ(loaded.skeleton.to_json_text(), data.skeleton.to_json_text());
  EXPECT_EQ(loaded.sequences[0].action, "indian/04");
}

TEST(RigFolder, TestFilesNameFilesOrFolders) {
  RigFolderOptions options;
  options.test_files = {"martial/", "indian/15.bvh"};
  options.skeleton_name = "dancer";
  options.millimetres_per_unit = 10;
  const PreparedDataset data = prepare_rig_folder(test::cmu_dance_dir().string(), options);
  EXPECT_EQ(data.skeleton.name, "dancer");
  EXPECT_EQ(data.subset(data.test_subjects).size(), 9u);
  EXPECT_EQ(data.subset(data.train_subjects).size(), 6u);

  options.test_files = {"ballet"};
  EXPECT_THAT(error_of([&] { prepare_rig_folder(test::cmu_dance_dir().string(), options); }),
              HasSubstr("test file \"ballet\" names no animation file under"));
  options.test_files = {"indian", "martial"};
  EXPECT_THAT(error_of([&] { prepare_rig_folder(test::cmu_dance_dir().string(), options); }),
              HasSubstr("expected at least one training file"));
}

TEST(RigFolder, AFileOfAnotherHierarchyOrMalformedIsNamed) {
  test::ScratchDir dir;
  fs::copy_file(cmu("indian/04.bvh"), dir.file("a.bvh"));
  MotionFrames h36m;
  h36m.values.assign(2 * kH36mColumns, 0.0f);
  std::ofstream(dir.file("b.bvh")) << h36m_motion_to_bvh_text(h36m, 25);
  EXPECT_THAT(error_of([&] { prepare_rig_folder(dir.path().string(), {}); }),
              AllOf(HasSubstr(dir.file("b.bvh") + ": not the skeleton \""), HasSubstr("missing joints: hip")));

  // Cut inside the motion: the file and the line.
  std::ifstream in(cmu("indian/06.bvh"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t frames = text.find("Frame Time");
  const size_t cut = text.find('\n', frames + 2000);
  std::ofstream(dir.file("b.bvh"), std::ios::trunc) << text.substr(0, cut) << "\n1 2 three\n";
  EXPECT_THAT(error_of([&] { prepare_rig_folder(dir.path().string(), {}); }),
              AllOf(HasSubstr(dir.file("b.bvh") + ":"), HasSubstr("\"three\" is not a number")));

  // A folder without BVH, a unit that cannot be told.
  test::ScratchDir empty;
  EXPECT_THAT(error_of([&] { prepare_rig_folder(empty.path().string(), {}); }), HasSubstr("holds no animation file"));
  BvhFile tiny = read_bvh_file(cmu("indian/04.bvh"));
  for (auto& j : tiny.joints) j.offset = {j.offset[0] * 1e-3, j.offset[1] * 1e-3, j.offset[2] * 1e-3};
  EXPECT_THAT(error_of([&] { detect_bvh_millimetres_per_unit(tiny, "tiny.bvh"); }),
              AllOf(HasSubstr("tiny.bvh: its rest pose spans"), HasSubstr("--unit")));
}


// A sequence's motion in its skeleton's whole layout: root moves in mm,
// exponential maps in radians.
MotionFrames motion_of(const PreparedDataset& data, const std::string& action) {
  for (const PreparedSequence& sequence : data.sequences) {
    if (sequence.action == action) return data.normalization.denormalize(sequence.normalized);
  }
  ADD_FAILURE() << "no sequence " << action;
  return {};
}

// The angle (radians) of the rotation between two exponential maps: 0 for
// the same rotation, whichever of its maps each is.
double rotation_between(const float* a, const float* b) {
  const Mat3 difference = multiply(transpose(expmap_to_matrix({a[0], a[1], a[2]})), expmap_to_matrix({b[0], b[1], b[2]}));
  const double cosine = (difference[0][0] + difference[1][1] + difference[2][2] - 1) / 2;
  return std::acos(std::clamp(cosine, -1.0, 1.0));
}

struct Difference {
  double offset_mm = 0, rotation_rad = 0;
};

// How far the dataset `got` lies from `want`, the BVH folder's, the joints
// matched by name: every named joint of `want` is one of `got` with the same
// parent (End Sites may be absent: animation tools drop them), the same
// sequences in the same split with the same frame count, the same kept
// dimensions; the largest differences of the bone offsets and the joints'
// rotations. (A prepared dataset keeps no root moves: see
// root_difference_mm.)
Difference difference_from(const PreparedDataset& want, const PreparedDataset& got) {
  Difference worst;
  std::map<std::string, int> want_index;
  for (int j = 0; j < want.skeleton.joint_count(); ++j) want_index[want.skeleton.joints[j].name] = j;
  std::vector<int> match(got.skeleton.joints.size(), -1);  // got's joint -> want's
  for (size_t j = 0; j < got.skeleton.joints.size(); ++j) {
    const Joint& joint = got.skeleton.joints[j];
    const auto found = want_index.find(joint.name);
    if (found == want_index.end()) {
      ADD_FAILURE() << "joint " << joint.name << " is no joint of the BVH's skeleton";
      continue;
    }
    match[j] = found->second;
    const Joint& expected = want.skeleton.joints[found->second];
    EXPECT_EQ(joint.parent < 0 ? "" : got.skeleton.joints[joint.parent].name,
              expected.parent < 0 ? "" : want.skeleton.joints[expected.parent].name)
        << joint.name;
    for (int a = 0; a < 3; ++a) worst.offset_mm = std::max(worst.offset_mm, std::abs(joint.offset_mm[a] - expected.offset_mm[a]));
  }
  for (int j = 0; j < want.skeleton.joint_count(); ++j) {
    if (want.skeleton.bvh->end_site[j]) continue;
    EXPECT_NE(std::find(match.begin(), match.end(), j), match.end()) << want.skeleton.joints[j].name << " missing";
  }
  EXPECT_EQ(got.normalization.dims(), want.normalization.dims());
  EXPECT_EQ(got.frame_rate, want.frame_rate);
  EXPECT_EQ(got.sequences.size(), want.sequences.size());
  for (const PreparedSequence& sequence : want.sequences) {
    const MotionFrames a = motion_of(want, sequence.action), b = motion_of(got, sequence.action);
    EXPECT_EQ(b.frame_count(), a.frame_count()) << sequence.action;
    EXPECT_EQ(got.subset({sequence.subject}).size(), want.subset({sequence.subject}).size());
    for (int64_t f = 0; f < std::min(a.frame_count(), b.frame_count()); ++f) {
      const float* x = a.frame(f);
      const float* y = b.frame(f);
      for (size_t j = 0; j < match.size(); ++j) {
        if (match[j] < 0) continue;
        worst.rotation_rad = std::max(worst.rotation_rad, rotation_between(x + 3 + 3 * match[j], y + 3 + 3 * j));
      }
    }
  }
  return worst;
}

// The largest difference (mm) of the root's moves, frame by frame, between
// each file of `folder` read as a motion of `got`'s skeleton (as a rig's
// root trajectory training reads it) and the same dance's BVH in
// `bvh_folder` read as one of `want`'s. `height_mm` receives the root's
// height (y) in the first frame of the first file, which is its position.
double root_difference_mm(const PreparedDataset& want, const fs::path& bvh_folder, const PreparedDataset& got,
                          const fs::path& folder, double* height_mm) {
  const std::vector<std::string> want_files = list_animation_files(bvh_folder.string());
  const std::vector<std::string> got_files = list_animation_files(folder.string());
  EXPECT_EQ(got_files.size(), want_files.size());
  double worst = 0;
  for (size_t i = 0; i < std::min(want_files.size(), got_files.size()); ++i) {
    const MotionFrames a = read_rig_motion(want.skeleton, (bvh_folder / want_files[i]).string());
    const MotionFrames b = read_rig_motion(got.skeleton, (folder / got_files[i]).string());
    EXPECT_EQ(b.frame_count(), a.frame_count()) << got_files[i];
    for (int64_t f = 0; f < std::min(a.frame_count(), b.frame_count()); ++f) {
      for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(double(a.frame(f)[c]) - b.frame(f)[c]));
    }
    if (i == 0) *height_mm = b.values[1];
  }
  return worst;
}

// What Blender's round trip may move, from 32-bit floats (glTF holds no
// other; Blender computes its armatures in them): a float's step is 1.2e-7
// of a value, so 2e-5 mm of a 200 mm bone, 1e-4 mm of a root 1 m from the
// origin and 1e-7 rad of a rotation, and a few dozen steps of arithmetic in
// Blender's importer and exporters (measured: offsets 1.2e-4 mm, rotations
// 2.2e-6 rad). The tolerances are about ten times that, far below what a
// wrong unit (a factor of 10), axis or frame would make.
constexpr double kOffsetToleranceMm = 2e-3;
constexpr double kRootToleranceMm = 2e-2;
constexpr double kRotationToleranceRad = 5e-5;

void copy_as(const fs::path& from, const fs::path& to) {
  fs::create_directories(to.parent_path());
  fs::copy_file(from, to);
}

TEST(RigFolder, BlendersGlbAndFbxOfTheDancesPrepareAsTheirBvhInTheSameMillimetres) {
  const auto started = std::chrono::steady_clock::now();
  const test::BlenderDances& dances = test::blender_dances();
  const double blender_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  const PreparedDataset bvh = prepare_rig_folder(dances.bvh.string(), {});
  ASSERT_EQ(bvh.sequences.size(), 3u);
  EXPECT_EQ(bvh.skeleton.bvh->millimetres_per_unit, 10.0);  // told from the rest pose: cm

  // A mixed folder: a .glb first (its skeleton, without End Sites), an .FBX
  // in capitals, then the BVH whose rest pose tells the unit of the folder.
  test::ScratchDir mixed;
  copy_as(dances.glb / "indian/04.glb", mixed.path() / "indian/04.glb");
  copy_as(dances.fbx / "indian/06.fbx", mixed.path() / "indian/06.FBX");
  copy_as(dances.bvh / "martial/03.bvh", mixed.path() / "martial/03.bvh");

  struct Case {
    const char* name;
    fs::path folder;
    double skeleton_unit;  // the skeleton's BVH unit, mm
  };
  for (const Case& c : {Case{"glb", dances.glb, 1.0}, Case{"fbx", dances.fbx, 1.0}, Case{"mixed", mixed.path(), 10.0}}) {
    SCOPED_TRACE(c.name);
    const auto before = std::chrono::steady_clock::now();
    const PreparedDataset got = prepare_rig_folder(c.folder.string(), {});
    const double prepare_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - before).count();
    // Blender drops the End Sites: the 43 joints.
    EXPECT_EQ(got.skeleton.joint_count(), 43);
    EXPECT_EQ(got.skeleton.bvh->millimetres_per_unit, c.skeleton_unit);
    const Difference d = difference_from(bvh, got);
    double height_mm = 0;
    const double root_mm = root_difference_mm(bvh, dances.bvh, got, c.folder, &height_mm);
    std::printf("%s folder: %zu sequences of %lld frames at 25 Hz, %d dimensions, prepared in %.2f s; largest "
                "difference from the BVH folder's: offsets %.2e mm, rotations %.2e rad, root moves %.2e mm (its "
                "height %.1f mm)\n",
                c.name, got.sequences.size(), static_cast<long long>(got.sequences[0].normalized.frame_count()),
                got.normalization.dims(), prepare_s, d.offset_mm, d.rotation_rad, root_mm, height_mm);
    EXPECT_LT(d.offset_mm, kOffsetToleranceMm);
    EXPECT_LT(d.rotation_rad, kRotationToleranceRad);
    EXPECT_LT(root_mm, kRootToleranceMm);
    // mm, not cm or m: the hips of a person standing.
    EXPECT_GT(height_mm, 500);
    EXPECT_LT(height_mm, 1500);
  }
  std::printf("Blender made the dances' glb and fbx in %.1f s\n", blender_s);

  // Read again as a rig's trajectory training reads them: the dataset's
  // folder, each file by its name without extension, in the skeleton's unit.
  const PreparedDataset glb = prepare_rig_folder(mixed.path().string(), {});
  const std::vector<MotionFrames> motions = read_rig_training_motions(glb);
  ASSERT_EQ(motions.size(), 2u);
  const MotionFrames recorded = read_rig_motion(bvh.skeleton, (dances.bvh / "indian/04.bvh").string());
  ASSERT_EQ(motions[0].frame_count(), recorded.frame_count());
  // Frame 0's root move is the root's position (mm): the same from the glb.
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(motions[0].values[c], recorded.values[c], kRootToleranceMm);
}

TEST(RigFolder, AGltfOfAnotherHierarchyOrTwoFilesOfOneNameAreRefusedNamingThem) {
  test::ScratchDir dir;
  fs::copy_file(cmu("indian/04.bvh"), dir.file("a.bvh"));
  MotionFrames h36m;
  h36m.values.assign(2 * kH36mColumns, 0.0f);
  dir.write("b.glb", write_animation_file(h36m_motion_to_bvh(h36m, 25), AnimationFormat::kGlb, 1.0));
  EXPECT_THAT(error_of([&] { prepare_rig_folder(dir.path().string(), {}); }),
              AllOf(HasSubstr(dir.file("b.glb") + ": not the skeleton \""), HasSubstr("missing joints: hip")));
  // The glb first: its skeleton, and the BVH is the other hierarchy.
  fs::rename(dir.file("a.bvh"), dir.file("c.bvh"));
  EXPECT_THAT(error_of([&] { prepare_rig_folder(dir.path().string(), {}); }),
              AllOf(HasSubstr(dir.file("c.bvh") + ": not the skeleton \""), HasSubstr("unexpected joints")));
  // A sequence is named by its file's name without the extension.
  fs::copy_file(cmu("indian/06.bvh"), dir.file("b.BVH"));
  EXPECT_THAT(error_of([&] { prepare_rig_folder(dir.path().string(), {}); }),
              HasSubstr("b.BVH and b.glb are two files of the name \"b\""));
  EXPECT_THAT(error_of([&] { list_animation_files(dir.file("c.bvh")); }), HasSubstr("not a folder"));
}

}  // namespace
}  // namespace mm
