// glTF 2.0 and FBX beside BVH (format/animation_file.h): our glTF files read
// back as the BVH they came from, Blender's own glTF and FBX exports of a
// BVH read as that BVH, and Blender reads our glTF as the BVH's motion. The
// H3.6M S5 walking take and a CMU dance, each the joint world positions of
// every frame compared with the BVH's forward kinematics (bvh_world_positions).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>

#include "format/animation_file.h"
#include "format/h36m_bvh.h"
#include "format/input_error.h"
#include "format/motion_text.h"
#include "format/skeleton_bvh.h"
#include "tests/common/cmu_dance.h"
#include "tests/common/command_run.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

using ::testing::HasSubstr;

constexpr double kBlenderToleranceMm = 1.0;
// glTF holds translations, rotations and times as 32-bit floats (the spec
// allows no other): a float's rounding of a root metres from the origin and
// of each rotation down a limb bounds the round trip (measured 0.0019 mm on
// S5 walking, 0.0002 mm on the dance).
constexpr double kRoundTripToleranceMm = 0.005;

// The first `frames` frames of a BVH.
BvhFile first_frames(BvhFile file, int64_t frames) {
  if (file.frame_count() > frames) file.values.resize(static_cast<size_t>(frames) * file.channel_count());
  return file;
}

// S5 walking_1 as our BVH of the H3.6M skeleton (mm, 50 Hz).
BvhFile s5_walking(int64_t frames = 1 << 30) {
  const MotionFrames motion = read_motion_text((test::h36m_dataset_dir() / "S5" / "walking_1.txt").string());
  return first_frames(h36m_motion_to_bvh(motion, 50.0), frames);
}

// A CMU dance (cm, 120 Hz, 43 joints).
BvhFile cmu_dance(int64_t frames = 1 << 30) {
  return first_frames(read_bvh_file((test::cmu_dance_dir() / "martial" / "03.bvh").string()), frames);
}

// Each named joint's (and End Site's, by bvh_skeleton's name) world
// positions in file units, per frame.
std::map<std::string, std::vector<Vec3>> positions_by_name(const BvhFile& file) {
  const Skeleton named = bvh_skeleton(file, "named");
  std::map<std::string, std::vector<Vec3>> out;
  for (int64_t f = 0; f < file.frame_count(); ++f) {
    const std::vector<Vec3> positions = bvh_world_positions(file, f);
    for (size_t j = 0; j < positions.size(); ++j) out[named.joints[j].name].push_back(positions[j]);
  }
  return out;
}

double distance(const Vec3& a, const Vec3& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

// The largest distance (mm) between the joints of `expected` that are named
// joints and the joints of the same name in `actual`, over every frame;
// fails for a joint `actual` lacks.
double max_joint_distance_mm(const BvhFile& expected, const BvhFile& actual, double millimetres_per_unit) {
  const auto want = positions_by_name(expected);
  const auto got = positions_by_name(actual);
  double worst = 0;
  for (const auto& joint : expected.joints) {
    if (joint.end_site) continue;
    const auto found = got.find(joint.name);
    if (found == got.end()) {
      ADD_FAILURE() << "joint " << joint.name << " missing";
      continue;
    }
    const auto& a = want.at(joint.name);
    const auto& b = found->second;
    for (size_t f = 0; f < std::min(a.size(), b.size()); ++f) worst = std::max(worst, distance(a[f], b[f]));
  }
  return worst * millimetres_per_unit;
}

std::string blender() { return test::environment_or("MM_BLENDER", "blender"); }
std::string script(const std::string& name) {
  return (std::filesystem::path(MM_FORMAT_TEST_SOURCE_DIR) / name).string();
}

void run_blender(const std::string& script_name, const std::string& arguments) {
  const test::CommandRun run = test::run_command(
      blender(), "--background --factory-startup --python-exit-code 1 --python " + script(script_name) + " -- " + arguments);
  ASSERT_EQ(run.exit_code, 0) << "Blender failed: " << run.err.substr(run.err.size() > 3000 ? run.err.size() - 3000 : 0);
}

struct RoundTripCase {
  const char* name;
  BvhFile (*make)(int64_t);
  double millimetres_per_unit;
};

BvhFile walking(int64_t frames) { return s5_walking(frames); }
BvhFile dance(int64_t frames) { return cmu_dance(frames); }

TEST(AnimationFileTest, GlbAndGltfRoundTripsKeepJointsFramesRateAndPositions) {
  MM_REQUIRE_H36M();
  for (const RoundTripCase& c : {RoundTripCase{"S5 walking_1", walking, 1.0}, RoundTripCase{"CMU martial/03", dance, 10.0}}) {
    const BvhFile original = c.make(1 << 30);
    for (AnimationFormat format : {AnimationFormat::kGlb, AnimationFormat::kGltf}) {
      SCOPED_TRACE(std::string(c.name) + " as " + animation_format_name(format));
      const std::string bytes = write_animation_file(original, format, c.millimetres_per_unit);
      const BvhFile back = parse_animation_file(bytes, format, "written", c.millimetres_per_unit);
      ASSERT_EQ(back.joints.size(), original.joints.size());
      for (size_t j = 0; j < back.joints.size(); ++j) {
        EXPECT_EQ(back.joints[j].name, original.joints[j].name);
        EXPECT_EQ(back.joints[j].parent, original.joints[j].parent);
        EXPECT_EQ(back.joints[j].end_site, original.joints[j].end_site);
        EXPECT_EQ(back.joints[j].channels, original.joints[j].channels) << original.joints[j].name;
      }
      EXPECT_EQ(back.frame_count(), original.frame_count());
      // The CMU files' 0.00833333 s is 120.00005 Hz; keyframes say 120.
      EXPECT_NEAR(bvh_frame_rate(back), bvh_frame_rate(original), 1e-3);
      const double worst = max_joint_distance_mm(original, back, c.millimetres_per_unit);
      std::printf("%s as %s: %lld frames, largest joint difference %.5f mm\n", c.name, animation_format_name(format),
                  static_cast<long long>(back.frame_count()), worst);
      EXPECT_LT(worst, kRoundTripToleranceMm);
    }
  }
}

TEST(AnimationFileTest, OurGlbRecordsTheRigsUnit) {
  const BvhFile original = cmu_dance(10);
  const std::string bytes = write_animation_file(original, AnimationFormat::kGlb, 10.0);
  // No unit asked: the one the file recorded (cm), not mm.
  const BvhFile back = parse_animation_file(bytes, AnimationFormat::kGlb, "written", 0);
  EXPECT_LT(max_joint_distance_mm(original, back, 10.0), kRoundTripToleranceMm);
  // In mm, lengths are ten times the cm file's.
  const BvhFile in_mm = parse_animation_file(bytes, AnimationFormat::kGlb, "written", 1.0);
  EXPECT_NEAR(in_mm.joints[1].offset[1], original.joints[1].offset[1] * 10, 1e-3);
}

TEST(AnimationFileTest, FormatsAreKnownByExtensionMediaTypeAndFirstBytes) {
  AnimationFormat format;
  ASSERT_TRUE(animation_format_of_path("a/walk.GLB", &format));
  EXPECT_EQ(format, AnimationFormat::kGlb);
  ASSERT_TRUE(animation_format_of_path("walk.fbx", &format));
  EXPECT_EQ(format, AnimationFormat::kFbx);
  EXPECT_FALSE(animation_format_of_path("walk.txt", &format));
  ASSERT_TRUE(animation_format_of_media_type("Model/glTF-Binary; charset=x", &format));
  EXPECT_EQ(format, AnimationFormat::kGlb);
  ASSERT_TRUE(animation_format_of_media_type("model/gltf+json", &format));
  EXPECT_EQ(format, AnimationFormat::kGltf);
  const BvhFile dance = cmu_dance(3);
  ASSERT_TRUE(sniff_animation_format(write_animation_file(dance, AnimationFormat::kGlb, 10).data(), 4, &format));
  EXPECT_EQ(format, AnimationFormat::kGlb);
  const std::string gltf = write_animation_file(dance, AnimationFormat::kGltf, 10);
  ASSERT_TRUE(sniff_animation_format(gltf.data(), gltf.size(), &format));
  EXPECT_EQ(format, AnimationFormat::kGltf);
  const std::string bvh = write_bvh_text(dance);
  ASSERT_TRUE(sniff_animation_format(bvh.data(), bvh.size(), &format));
  EXPECT_EQ(format, AnimationFormat::kBvh);
  EXPECT_FALSE(sniff_animation_format("0.1 0.2", 7, &format));
}

TEST(AnimationFileTest, FbxIsReadButNotWritten) {
  try {
    write_animation_file(cmu_dance(3), AnimationFormat::kFbx, 10);
    FAIL() << "FBX written";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("FBX export is not available"));
  }
}

TEST(AnimationFileTest, MalformedFilesAreRefusedNamingWhatIsWrong) {
  const BvhFile dance = cmu_dance(3);
  const std::string glb = write_animation_file(dance, AnimationFormat::kGlb, 10);
  auto refusal = [](const std::string& bytes, AnimationFormat format) -> std::string {
    try {
      parse_animation_file(bytes, format, "upload", 10);
    } catch (const InputError& e) {
      return e.what();
    }
    return "accepted";
  };
  EXPECT_THAT(refusal(glb.substr(0, glb.size() / 2), AnimationFormat::kGlb), HasSubstr("upload: not a glTF 2.0 file"));
  // A buffer by file name: never opened.
  const std::string external =
      R"({"asset": {"version": "2.0"}, "buffers": [{"uri": "/etc/passwd", "byteLength": 16}], "nodes": [{"name": "a"}],
          "animations": [{"channels": [], "samplers": []}]})";
  EXPECT_THAT(refusal(external, AnimationFormat::kGltf), HasSubstr("external file"));
  const std::string still = R"({"asset": {"version": "2.0"}, "nodes": [{"name": "a"}]})";
  EXPECT_THAT(refusal(still, AnimationFormat::kGltf), HasSubstr("holds no animation"));
  // FBX is read in a child process: junk, even with the binary header, is
  // an error and this process goes on.
  std::string junk = std::string("Kaydara FBX Binary  \0\x1a\0", 23) + std::string(4000, '\x7f');
  EXPECT_THAT(refusal(junk, AnimationFormat::kFbx), HasSubstr("upload"));
  EXPECT_THAT(refusal("nothing", AnimationFormat::kFbx), HasSubstr("not an FBX file"));
}

struct BlenderCase {
  const char* name;
  BvhFile bvh;
  double millimetres_per_unit;
};

std::vector<BlenderCase> blender_cases() {
  // Short clips: Blender's import and export take seconds per hundred frames.
  return {{"S5 walking_1", s5_walking(250), 1.0}, {"CMU martial/03", cmu_dance(600), 10.0}};
}

TEST(AnimationFileTest, BlendersGlbAndFbxExportsOfABvhReadAsThatBvh) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  for (const BlenderCase& c : blender_cases()) {
    const std::string bvh_path = dir.write("in.bvh", write_bvh_text(c.bvh));
    for (AnimationFormat format : {AnimationFormat::kGlb, AnimationFormat::kFbx}) {
      SCOPED_TRACE(std::string(c.name) + " through Blender to " + animation_format_name(format));
      const std::string out = dir.file(std::string("blender") + animation_format_extension(format));
      std::remove(out.c_str());
      run_blender("blender_convert_bvh.py", bvh_path + " " + out + " " + std::to_string(c.millimetres_per_unit / 1000));
      const BvhFile read = parse_animation_file(test::read_text(out), format, out, c.millimetres_per_unit);
      EXPECT_EQ(read.named_joint_count(), c.bvh.named_joint_count());
      EXPECT_EQ(read.frame_count(), c.bvh.frame_count());
      EXPECT_NEAR(bvh_frame_rate(read), bvh_frame_rate(c.bvh), 1e-3);
      const double worst = max_joint_distance_mm(c.bvh, read, c.millimetres_per_unit);
      std::printf("%s, Blender's %s read: %d joints, %lld frames at %g Hz, largest joint difference %.4f mm\n", c.name,
                  animation_format_name(format), read.named_joint_count(), static_cast<long long>(read.frame_count()),
                  bvh_frame_rate(read), worst);
      EXPECT_LT(worst, kBlenderToleranceMm);
      if (c.millimetres_per_unit == 1.0) {
        // Blender drops the End Sites; the H3.6M skeleton still matches, and
        // the motion is the BVH's.
        const MotionFrames want = skeleton_motion_from_bvh(Skeleton::h36m(), c.bvh, "bvh");
        const MotionFrames got = skeleton_motion_from_bvh(Skeleton::h36m(), read, out);
        ASSERT_EQ(got.values.size(), want.values.size());
        double largest = 0;
        for (size_t i = 0; i < got.values.size(); ++i) {
          // Rotations (radians) only: columns 0..2 are the root's moves.
          if (i % got.columns >= 3) largest = std::max(largest, std::abs(double(got.values[i]) - want.values[i]));
        }
        EXPECT_LT(largest, 1e-2) << "exponential-map values differ by up to " << largest;
      }
    }
  }
}

TEST(AnimationFileTest, BlenderReadsOurGlbAsTheBvhsMotion) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  for (const BlenderCase& c : blender_cases()) {
    SCOPED_TRACE(c.name);
    const std::string glb = dir.write("ours.glb", write_animation_file(c.bvh, AnimationFormat::kGlb, c.millimetres_per_unit));
    const std::string json_path = dir.file("blender.json");
    run_blender("blender_read_animation.py", glb + " " + json_path);
    const nlohmann::json read = nlohmann::json::parse(test::read_text(json_path));
    // Every joint and End Site is a bone.
    EXPECT_EQ(read["joints"].size(), c.bvh.joints.size());
    EXPECT_EQ(read["frames"].get<int64_t>(), c.bvh.frame_count());
    EXPECT_NEAR(read["rate"].get<double>(), bvh_frame_rate(c.bvh), 1e-3);
    const auto want = positions_by_name(c.bvh);
    double worst = 0;
    for (const auto& [name, frames] : want) {
      ASSERT_TRUE(read["positions"].contains(name)) << name;
      const auto& got = read["positions"][name];
      ASSERT_EQ(got.size(), frames.size()) << name;
      for (size_t f = 0; f < frames.size(); ++f) {
        const Vec3 p{got[f][0].get<double>() * 1000 / c.millimetres_per_unit,
                     got[f][1].get<double>() * 1000 / c.millimetres_per_unit,
                     got[f][2].get<double>() * 1000 / c.millimetres_per_unit};
        worst = std::max(worst, distance(p, frames[f]) * c.millimetres_per_unit);
      }
    }
    std::printf("%s, our glb read by Blender: %zu bones, %lld keys at %.4f Hz, largest joint difference %.4f mm\n",
                c.name, read["joints"].size(), static_cast<long long>(read["frames"].get<int64_t>()),
                read["rate"].get<double>(), worst);
    EXPECT_LT(worst, kBlenderToleranceMm);
  }
}

}  // namespace
}  // namespace mm
