// The tool on a rig's own training folder of glTF files, as a user runs it:
// `prepare --rig` reads Blender's .glb exports of three CMU dances
// (blender_dances.h), a short `train` makes a model of that rig, and the
// model reconstructs a .glb clip (`denoise`) and decodes its code into .glb
// files of the same rig, in the same mm as the recording.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "format/animation_file.h"
#include "format/bvh_file.h"
#include "tests/common/blender_dances.h"
#include "tests/common/command_run.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

test::CommandRun run_tool(const std::string& arguments) { return test::run_command(MM_TOOL_PATH, arguments); }

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// A .glb the tool wrote, read in mm: the rig's joints by name with their
// offsets, 150 frames at 25 Hz (the model's clip), finite values.
void expect_glb_of_the_rig(const std::string& path, const BvhFile& recording) {
  const BvhFile file = parse_animation_file(test::read_text(path), AnimationFormat::kGlb, path, 1.0);
  std::map<std::string, const BvhJoint*> joints;
  for (const BvhJoint& joint : file.joints) {
    if (!joint.end_site) joints[joint.name] = &joint;
  }
  EXPECT_EQ(file.named_joint_count(), recording.named_joint_count()) << path;
  // The CMU files are in cm: 10 mm a unit.
  for (const BvhJoint& joint : recording.joints) {
    if (joint.end_site) continue;
    const auto found = joints.find(joint.name);
    if (found == joints.end()) {
      ADD_FAILURE() << path << ": no joint " << joint.name;
      continue;
    }
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(found->second->offset[a], joint.offset[a] * 10, 0.01) << joint.name;
  }
  EXPECT_EQ(file.frame_count(), 150) << path;
  EXPECT_NEAR(file.frame_time_s, 0.04, 1e-6) << path;
  for (double value : file.values) ASSERT_TRUE(std::isfinite(value)) << path;
}

// The mean of the root's Yposition (BVH's up) over a file's frames, in its
// unit.
double mean_root_height(const BvhFile& file) {
  const auto& channels = file.joints.at(0).channels;
  const auto y = std::find(channels.begin(), channels.end(), BvhChannel::kYposition);
  EXPECT_NE(y, channels.end());
  double sum = 0;
  for (int64_t f = 0; f < file.frame_count(); ++f) sum += file.values[f * file.channel_count() + (y - channels.begin())];
  return sum / static_cast<double>(file.frame_count());
}

TEST(ToolRig, AModelTrainedOnAFolderOfGlbReconstructsAGlbClipOfItsRig) {
  const test::BlenderDances& dances = test::blender_dances();
  test::ScratchDir dir;
  const std::string dataset = dir.file("dances.mmd");
  auto started = std::chrono::steady_clock::now();
  auto r = run_tool("prepare --rig " + dances.glb.string() + " --name dances --out " + dataset);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::printf("prepare --rig of 3 glb files: %.1f s\n", seconds_since(started));
  // The folder's skeleton: Blender's 43 joints (it drops the End Sites), in
  // mm (glTF carries metres); the last of three files for testing.
  EXPECT_NE(r.out.find("skeleton dances: 43 joints (1 mm a unit)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("train: 2 sequences, 350 frames at 25 Hz"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("test:  1 sequences, 175 frames at 25 Hz"), std::string::npos) << r.out;

  started = std::chrono::steady_clock::now();
  const std::string run = dir.file("run");
  r = run_tool("train --variant DKGM --dataset " + dataset + " --hidden 16 --batch 2 --iterations 3 --seed 1 --out " +
               run);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::printf("train (3 iterations, hidden 16; its root path 100): %.1f s\n", seconds_since(started));
  // The rig's root trajectory, from the glb files read again.
  EXPECT_NE(r.err.find("on 2 files of " + fs::absolute(dances.glb).lexically_normal().string()), std::string::npos)
      << r.err;
  EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
  const std::string model = "--model " + run + "/model";

  const BvhFile recording = read_bvh_file((dances.bvh / "martial/03.bvh").string());
  const std::string clip = (dances.glb / "martial/03.glb").string();
  started = std::chrono::steady_clock::now();
  r = run_tool("denoise " + model + " --input " + clip + " --out " + dir.file("reconstructed.glb"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json report = nlohmann::json::parse(r.out);
  std::printf("denoise of a glb clip: error %.1f mm (a model of 3 iterations), %.1f s\n",
              report["denoised_mpjpe_mm"].get<double>(), seconds_since(started));
  EXPECT_TRUE(std::isfinite(report["denoised_mpjpe_mm"].get<double>()));
  expect_glb_of_the_rig(dir.file("reconstructed.glb"), recording);

  r = run_tool("encode " + model + " --input " + clip);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_tool("decode " + model + " --code " + dir.write("code.json", r.out) + " --out " + dir.file("decoded.glb"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  expect_glb_of_the_rig(dir.file("decoded.glb"), recording);
  // The decoded root stands about as high as the recording's hips (mm, not
  // cm or m): the trajectory network was trained in the rig's unit.
  const BvhFile decoded = parse_animation_file(test::read_text(dir.file("decoded.glb")), AnimationFormat::kGlb,
                                               "decoded.glb", 1.0);
  const double recorded_height_mm = mean_root_height(recording) * 10, decoded_height_mm = mean_root_height(decoded);
  std::printf("hips: %.0f mm high recorded, %.0f mm decoded\n", recorded_height_mm, decoded_height_mm);
  EXPECT_GT(decoded_height_mm, 0.5 * recorded_height_mm);
  EXPECT_LT(decoded_height_mm, 2.0 * recorded_height_mm);
}

}  // namespace
}  // namespace mm
