// Specification of the pose strip: rows of stick figures as SVG.
#include "model/render/pose_strip_svg.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "format/input_error.h"

namespace mm::render {
namespace {

using ::testing::HasSubstr;

size_t count_of(const std::string& text, const std::string& needle) {
  size_t count = 0;
  for (size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1)) ++count;
  return count;
}

// Joint positions of the rest pose (all-zero frame): each joint at its
// parent plus its offset, as forward kinematics computes them.
std::vector<float> rest_pose_mm(const Skeleton& skeleton, int64_t frames) {
  std::vector<float> one(skeleton.joints.size() * 3, 0.0f);
  for (size_t j = 1; j < skeleton.joints.size(); ++j) {
    const Joint& joint = skeleton.joints[j];
    for (int k = 0; k < 3; ++k) one[3 * j + k] = one[3 * joint.parent + k] + static_cast<float>(joint.offset_mm[k]);
  }
  std::vector<float> all;
  for (int64_t f = 0; f < frames; ++f) all.insert(all.end(), one.begin(), one.end());
  return all;
}

PoseRow rest_row(const Skeleton& skeleton, const std::string& label, int64_t frames) {
  return PoseRow{label, "", rest_pose_mm(skeleton, frames), frames};
}

TEST(PoseStripSvg, H36mSkeletonDrawsEveryBoneButTheZeroLengthOnes) {
  // 31 bones; the four hand helpers have zero offsets and the spine root 0.1 mm.
  EXPECT_EQ(drawn_bone_count(Skeleton::h36m()), 26);
}

TEST(PoseStripSvg, RestPoseRowsHaveOneLinePerBoneAndPoseAndTheirLabels) {
  const Skeleton skeleton = Skeleton::h36m();
  StripOptions options;
  options.frame_indices = {0, 5, 9};
  const std::string svg = render_pose_strip_svg(
      skeleton, {rest_row(skeleton, "ground truth", 10), rest_row(skeleton, "denoised", 10)}, options);

  EXPECT_EQ(count_of(svg, "class=\"bone\""), 2u * 3u * 26u);
  EXPECT_THAT(svg, HasSubstr(">ground truth</text>"));
  EXPECT_THAT(svg, HasSubstr(">denoised</text>"));
  EXPECT_EQ(count_of(svg, ">0.0 s</text>"), 2u);
  EXPECT_EQ(count_of(svg, ">0.2 s</text>"), 2u);  // frame 5 at 25 Hz
  EXPECT_EQ(count_of(svg, ">0.4 s</text>"), 2u);  // frame 9 at 25 Hz (0.36 s)
}

TEST(PoseStripSvg, IsAWholeSvgDocument) {
  const Skeleton skeleton = Skeleton::h36m();
  StripOptions options;
  options.frame_indices = {0};
  options.title = "walking <S5> & more";
  const std::string svg = render_pose_strip_svg(skeleton, {rest_row(skeleton, "a \"quoted\" label", 1)}, options);
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_EQ(svg.substr(svg.size() - 7), "</svg>\n");
  EXPECT_THAT(svg, HasSubstr("walking &lt;S5&gt; &amp; more"));
  EXPECT_THAT(svg, HasSubstr("a &quot;quoted&quot; label"));
}

TEST(PoseStripSvg, HeadIsDrawnAboveTheFeet) {
  // SVG's y points down; the skeleton's y points up.
  const Skeleton skeleton = Skeleton::h36m();
  StripOptions options;
  options.frame_indices = {0};
  const std::string svg = render_pose_strip_svg(skeleton, {rest_row(skeleton, "rest", 1)}, options);
  // The root marker is the first circle; the head must be well above it, the
  // feet well below.
  const size_t root = svg.find("<circle");
  ASSERT_NE(root, std::string::npos);
  const double root_y = std::stod(svg.substr(svg.find("cy=\"", root) + 4));
  double top = 1e9, bottom = -1e9;
  for (size_t at = svg.find("class=\"bone\""); at != std::string::npos; at = svg.find("class=\"bone\"", at + 1)) {
    const size_t line = svg.rfind("<line", at);
    for (const char* key : {"y1=\"", "y2=\""}) {
      const double y = std::stod(svg.substr(svg.find(key, line) + 4));
      top = std::min(top, y);
      bottom = std::max(bottom, y);
    }
  }
  EXPECT_LT(top, root_y - 40);     // head well above the hips
  EXPECT_GT(bottom, root_y + 40);  // feet well below
}

TEST(PoseStripSvg, FrameIndexOutOfRangeIsAnInputErrorNamingRowAndIndex) {
  const Skeleton skeleton = Skeleton::h36m();
  StripOptions options;
  options.frame_indices = {0, 12};
  try {
    render_pose_strip_svg(skeleton, {rest_row(skeleton, "ground truth", 20), rest_row(skeleton, "denoised", 10)},
                          options);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("denoised"));
    EXPECT_THAT(e.what(), HasSubstr("frame index 12"));
    EXPECT_THAT(e.what(), HasSubstr("[0, 10)"));
  }
  options.frame_indices = {-1};
  EXPECT_THROW(render_pose_strip_svg(skeleton, {rest_row(skeleton, "x", 5)}, options), InputError);
}

TEST(PoseStripSvg, PositionCountNotMatchingFramesAndJointsIsAnInputError) {
  const Skeleton skeleton = Skeleton::h36m();
  StripOptions options;
  options.frame_indices = {0};
  PoseRow row = rest_row(skeleton, "short", 2);
  row.positions_mm.pop_back();
  try {
    render_pose_strip_svg(skeleton, {row}, options);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("short"));
    EXPECT_THAT(e.what(), HasSubstr("expected 192"));
    EXPECT_THAT(e.what(), HasSubstr("found 191"));
  }
}

TEST(PoseStripSvg, NoRowsOrNoFramesIsAnInputError) {
  const Skeleton skeleton = Skeleton::h36m();
  StripOptions options;
  options.frame_indices = {0};
  EXPECT_THROW(render_pose_strip_svg(skeleton, {}, options), InputError);
  options.frame_indices.clear();
  EXPECT_THROW(render_pose_strip_svg(skeleton, {rest_row(skeleton, "x", 1)}, options), InputError);
}

}  // namespace
}  // namespace mm::render
