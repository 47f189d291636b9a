#include "model/render/pose_strip_svg.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "format/input_error.h"
#include "model/render/svg_document.h"

namespace mm::render {
namespace {

const char* const kPalette[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2"};

constexpr double kMarginPx = 10;      // around the picture
constexpr double kPadPx = 8;          // inside a pose's cell, around the figure
constexpr double kTimeTextPx = 22;    // below each pose, for its time
constexpr double kTitlePx = 28;
constexpr double kPi = 3.14159265358979323846;

std::string row_name(const std::vector<PoseRow>& rows, size_t r) {
  return "row " + std::to_string(r) + " (\"" + rows[r].label + "\")";
}

std::string time_text(int64_t frame, double frame_rate) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.1f s", static_cast<double>(frame) / frame_rate);
  return buffer;
}

bool starts_with(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

void validate(const Skeleton& skeleton, const std::vector<PoseRow>& rows, const StripOptions& o) {
  if (skeleton.joint_count() == 0) throw InputError("pose strip: the skeleton has no joints");
  if (rows.empty()) throw InputError("pose strip: no motions to draw");
  if (o.frame_indices.empty()) throw InputError("pose strip: no frame indices to draw");
  if (!(o.frame_rate > 0)) throw InputError("pose strip: frame rate must be > 0, found " + std::to_string(o.frame_rate));
  if (!(o.pose_width_px > 0) || !(o.pose_height_px > 0)) {
    throw InputError("pose strip: pose width and height must be > 0, found " + std::to_string(o.pose_width_px) +
                     " x " + std::to_string(o.pose_height_px));
  }
  const int64_t joints = skeleton.joint_count();
  for (size_t r = 0; r < rows.size(); ++r) {
    const PoseRow& row = rows[r];
    if (row.frames < 1) {
      throw InputError("pose strip: " + row_name(rows, r) + ": expected at least 1 frame, found " +
                       std::to_string(row.frames));
    }
    const auto expected = static_cast<uint64_t>(row.frames) * static_cast<uint64_t>(joints) * 3;
    if (row.positions_mm.size() != expected) {
      throw InputError("pose strip: " + row_name(rows, r) + ": expected " + std::to_string(expected) +
                       " position values (" + std::to_string(row.frames) + " frames x " + std::to_string(joints) +
                       " joints x 3), found " + std::to_string(row.positions_mm.size()));
    }
    for (int64_t f : o.frame_indices) {
      if (f < 0 || f >= row.frames) {
        throw InputError("pose strip: " + row_name(rows, r) + ": frame index " + std::to_string(f) +
                         " is out of range [0, " + std::to_string(row.frames) + ")");
      }
      const float* p = row.positions_mm.data() + f * joints * 3;
      for (int64_t i = 0; i < joints * 3; ++i) {
        if (!std::isfinite(p[i])) {
          throw InputError("pose strip: " + row_name(rows, r) + ": frame " + std::to_string(f) + ", joint " +
                           skeleton.joints[static_cast<size_t>(i / 3)].name + ": position is not finite");
        }
      }
    }
  }
}

bool is_drawn(const Joint& joint) {
  if (joint.parent < 0) return false;
  const auto& o = joint.offset_mm;
  return std::sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]) >= kMinDrawnBoneMm;
}

// The horizontal picture coordinate (mm) of the view at azimuth `a`.
struct View {
  double cos_a, sin_a;
  explicit View(double degrees)
      : cos_a(std::cos(degrees * kPi / 180)), sin_a(std::sin(degrees * kPi / 180)) {}
  double horizontal(const float* pose, int j) const { return pose[3 * j] * cos_a + pose[3 * j + 2] * sin_a; }
};

// Horizontal placement of one pose inside its cell: the horizontal
// coordinate that lands on the cell's centre.
double pose_anchor(const View& view, const float* pose, int joints, bool center) {
  if (!center) return view.horizontal(pose, 0);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (int j = 0; j < joints; ++j) {
    lo = std::min(lo, view.horizontal(pose, j));
    hi = std::max(hi, view.horizontal(pose, j));
  }
  return 0.5 * (lo + hi);
}

}  // namespace

int drawn_bone_count(const Skeleton& skeleton) {
  return static_cast<int>(std::count_if(skeleton.joints.begin(), skeleton.joints.end(), is_drawn));
}

std::string render_pose_strip_svg(const Skeleton& skeleton, const std::vector<PoseRow>& rows,
                                  const StripOptions& o) {
  validate(skeleton, rows, o);
  const int joints = skeleton.joint_count();
  const View view(o.view_azimuth_deg);
  // The viewer looks along (sin a, 0, -cos a); the skeleton's left is +x.
  const char* const far_side = view.sin_a >= 0 ? "Left" : "Right";
  auto pose_of = [&](const PoseRow& row, int64_t f) { return row.positions_mm.data() + f * joints * 3; };

  // One scale for everything: the tallest vertical range and the widest
  // horizontal reach from the anchor over all drawn poses must fit a cell.
  double y_low = std::numeric_limits<double>::infinity(), y_high = -y_low, reach = 0;
  for (const PoseRow& row : rows) {
    for (int64_t f : o.frame_indices) {
      const float* pose = pose_of(row, f);
      const double anchor = pose_anchor(view, pose, joints, o.center_poses);
      for (int j = 0; j < joints; ++j) {
        y_low = std::min(y_low, static_cast<double>(pose[3 * j + 1]));
        y_high = std::max(y_high, static_cast<double>(pose[3 * j + 1]));
        reach = std::max(reach, std::abs(view.horizontal(pose, j) - anchor));
      }
    }
  }
  const double height_mm = std::max(y_high - y_low, 1.0);
  const double usable_height = std::max(o.pose_height_px - 2 * kPadPx, 1.0);
  const double usable_half_width = std::max(o.pose_width_px / 2 - kPadPx / 2, 1.0);
  const double scale = std::min(usable_height / height_mm, usable_half_width / std::max(reach, 1.0));
  // Centre the figures vertically when the width limits the scale.
  const double figure_top_px = kPadPx + (usable_height - height_mm * scale) / 2;

  const double columns = static_cast<double>(o.frame_indices.size());
  const double row_height = o.pose_height_px + kTimeTextPx;
  const double top = kMarginPx + (o.title.empty() ? 0 : kTitlePx);
  const double width = 2 * kMarginPx + o.label_width_px + columns * o.pose_width_px;
  const double height = top + rows.size() * row_height + kMarginPx;

  SvgDocument svg(width, height);
  if (!o.title.empty()) svg.text(kMarginPx, kMarginPx + 18, o.title, 16, "start", "#222", "font-weight=\"bold\"");
  const double strip_left = kMarginPx + o.label_width_px;
  for (size_t r = 0; r < rows.size(); ++r) {
    const PoseRow& row = rows[r];
    const std::string colour = row.colour.empty() ? kPalette[r % (sizeof kPalette / sizeof kPalette[0])] : row.colour;
    const double row_top = top + r * row_height;
    if (r > 0) svg.line(kMarginPx, row_top, width - kMarginPx, row_top, "#dddddd", 1);
    svg.text(kMarginPx, row_top + o.pose_height_px / 2 + 5, row.label, 14, "start", colour,
             "font-weight=\"bold\"");
    for (size_t c = 0; c < o.frame_indices.size(); ++c) {
      const int64_t f = o.frame_indices[c];
      const float* pose = pose_of(row, f);
      const double centre_px = strip_left + (c + 0.5) * o.pose_width_px;
      const double anchor = pose_anchor(view, pose, joints, o.center_poses);
      auto sx = [&](int j) { return centre_px + (view.horizontal(pose, j) - anchor) * scale; };
      auto sy = [&](int j) { return row_top + figure_top_px + (y_high - pose[3 * j + 1]) * scale; };
      // Far side first, lighter, so the near side is drawn over it.
      for (int pass = 0; pass < 2; ++pass) {
        for (int j = 0; j < joints; ++j) {
          const Joint& joint = skeleton.joints[static_cast<size_t>(j)];
          if (!is_drawn(joint) || starts_with(joint.name, far_side) != (pass == 0)) continue;
          svg.line(sx(joint.parent), sy(joint.parent), sx(j), sy(j), colour, o.line_width_px,
                   pass == 0 ? "class=\"bone\" stroke-opacity=\"0.45\"" : "class=\"bone\"");
        }
      }
      svg.circle(sx(0), sy(0), o.line_width_px * 1.2, colour);
      svg.text(centre_px, row_top + o.pose_height_px + 15, time_text(f, o.frame_rate), 11, "middle", "#555");
    }
  }
  return svg.finish();
}

}  // namespace mm::render
