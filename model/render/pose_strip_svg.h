// Pose strips: an SVG picture of one or more motions as rows of stick
// figures at chosen frames, e.g. "ground truth", "corrupted" and "denoised"
// one above the other, for reports and for checking a model by eye.
//
// Torch-free: it takes joint positions already computed by forward
// kinematics (mm::ForwardKinematics in mm_model) and the skeleton's parents.
// All functions here are reentrant and may be called concurrently.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "format/skeleton.h"

namespace mm::render {

// One motion to draw as a row of poses.
struct PoseRow {
  std::string label;   // written left of the row, e.g. "denoised"
  std::string colour;  // any SVG colour ("#1f77b4", "crimson"); empty picks one from a palette by row
  // frames x J x 3 joint positions in millimetres, row-major (frame, joint,
  // xyz), y up, as ForwardKinematics::positions returns them. The root may be
  // anywhere; poses are placed relative to it (or to their own extent, see
  // StripOptions::center_poses).
  std::vector<float> positions_mm;
  int64_t frames = 0;
};

// Layout of the picture. Defaults fit six poses of a 25 Hz motion.
struct StripOptions {
  // Frames to draw, as indices into every row (0-based, in the rows' own
  // frame rate). Required, the same for all rows.
  std::vector<int64_t> frame_indices;
  double frame_rate = 25;        // Hz; the time under a pose is index / frame_rate ("1.2 s")
  double pose_width_px = 90;     // width of the cell of one pose
  double pose_height_px = 150;   // height of the drawing area of one pose (without its time text)
  double label_width_px = 120;   // column of the row labels
  double line_width_px = 2.2;
  // Direction of the view around the vertical axis. The picture's horizontal
  // coordinate is x cos(a) + z sin(a): 90 (the default) is the side view, the
  // body's forward z to the right (the H3.6M skeleton's rest pose faces +z
  // with its left on +x), which shows sitting, bending and stepping; 0 is the
  // front view (x to the right), where a sitting pose looks like a standing
  // one. Angles between give an oblique view.
  double view_azimuth_deg = 90;
  // false: the root joint sits at the centre of its cell, so a pose's lean
  // and stride show relative to the hips. true: each pose is shifted
  // horizontally so that its own x extent is centred in the cell, which keeps
  // wide poses (a stride, a reach) from crossing into the neighbour's cell.
  bool center_poses = false;
  std::string title;             // drawn above the rows when not empty
};

// Bones whose rest offset is shorter than this are not drawn (the H3.6M
// skeleton has zero-length helper joints at the hands and a 0.1 mm spine
// root); their children are still drawn from the (coincident) parent.
constexpr double kMinDrawnBoneMm = 1.0;

// The number of bones render_pose_strip_svg draws per pose: joints with a
// parent and a rest offset of at least kMinDrawnBoneMm (26 for Skeleton::h36m()).
int drawn_bone_count(const Skeleton& skeleton);

// Renders the rows as an SVG document (UTF-8 text starting with "<svg" and
// ending with "</svg>\n"). The view is orthographic, y up, from the azimuth
// of StripOptions::view_azimuth_deg (by default from the side: z to the
// right, x dropped). One scale is shared by all rows and poses, so
// heights compare across rows; the vertical range is that of all drawn poses,
// so rows line up. Each bone is one <line class="bone">; the bones of the
// side away from the viewer (joints named "Left..." when the azimuth is in
// [0, 180), "Right..." otherwise) are drawn lighter so the sides can be told
// apart.
//
// Throws InputError when: the skeleton has no joints; there are no rows or no
// frame indices; a row has frames < 1 or positions_mm.size() differs from
// frames x J x 3 (naming the row's label and both sizes); a frame index is
// outside [0, frames) of a row (naming the row and the index); a drawn
// position is not finite; or frame_rate, pose_width_px or pose_height_px is
// not positive.
std::string render_pose_strip_svg(const Skeleton& skeleton, const std::vector<PoseRow>& rows,
                                  const StripOptions& options);

}  // namespace mm::render
