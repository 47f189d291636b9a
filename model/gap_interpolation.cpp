#include "model/gap_interpolation.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <utility>
#include <stdexcept>
#include <vector>

#include "format/expmap_slerp.h"
#include "format/input_error.h"
#include "model/borrowed_motion.h"

namespace mm {
namespace {

struct Quaternion {
  double w = 1, x = 0, y = 0, z = 0;
};

struct Vector {
  double x = 0, y = 0, z = 0;
};

Quaternion multiply(const Quaternion& a, const Quaternion& b) {
  return {a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z, a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
          a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x, a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}

Quaternion inverse(const Quaternion& q) { return {q.w, -q.x, -q.y, -q.z}; }

// The rotation vector (axis times angle, the angle in [0, pi]) of a unit
// quaternion: q and -q are one rotation, and the shorter turn is taken.
Vector log_of(Quaternion q) {
  if (q.w < 0) q = {-q.w, -q.x, -q.y, -q.z};
  const double s = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
  // 2 atan2(s, w) / s, by its series 2 / w near s = 0.
  const double scale = s < 1e-12 ? 2.0 / std::max(q.w, 1e-12) : 2.0 * std::atan2(s, q.w) / s;
  return {q.x * scale, q.y * scale, q.z * scale};
}

Quaternion exp_of(const Vector& v) {
  const double angle = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
  const double half_sinc = angle < 1e-6 ? 0.5 - angle * angle / 48.0 : std::sin(angle / 2) / angle;
  return {std::cos(angle / 2), v.x * half_sinc, v.y * half_sinc, v.z * half_sinc};
}

Vector scaled(const Vector& v, double s) { return {v.x * s, v.y * s, v.z * s}; }

Quaternion quaternion_of(const float* expmap) { return exp_of({expmap[0], expmap[1], expmap[2]}); }

// The map of q nearest `reference`, so that a joint's maps stay continuous.
void write_expmap(const Quaternion& q, const double* reference, float* out) {
  write_expmap_nearest(q.w, q.x, q.y, q.z, reference, out);
}

// The angular velocity (rotation vector per frame, in the joint's own
// axes: q(to) = q(from) exp(v)) between two frames, or zero when either
// is missing or outside the motion.
Vector velocity(const MotionFrames& motion, int column, int64_t from, int64_t to) {
  if (from < 0 || to < 0 || from >= motion.frame_count() || to >= motion.frame_count()) return {};
  const float* a = motion.frame(from) + column;
  const float* b = motion.frame(to) + column;
  for (int i = 0; i < 3; ++i) {
    if (std::isnan(a[i]) || std::isnan(b[i])) return {};
  }
  return log_of(multiply(inverse(quaternion_of(a)), quaternion_of(b)));
}

bool observed_at(const MotionFrames& motion, int column, int64_t frame) {
  if (frame < 0 || frame >= motion.frame_count()) return false;
  const float* v = motion.frame(frame) + column;
  return !std::isnan(v[0]) && !std::isnan(v[1]) && !std::isnan(v[2]);
}

// The angular velocity at a gap's border frame `border`, whose other border
// is `other`: from the border and the frame beyond it where that is
// observed; where it is missing too (sparse keyframes: a gap on each side),
// the central difference between the nearest observed frame beyond (within
// `reach` frames) and the other border, as Catmull-Rom's tangents are; zero
// when nothing is observed beyond.
Vector border_velocity(const MotionFrames& motion, int column, int64_t border, int64_t other, int64_t reach) {
  const int64_t outward = border < other ? -1 : 1;
  if (observed_at(motion, column, border + outward)) {
    return outward < 0 ? velocity(motion, column, border - 1, border) : velocity(motion, column, border, border + 1);
  }
  for (int64_t beyond = border + 2 * outward; std::llabs(beyond - border) <= reach; beyond += outward) {
    if (beyond < 0 || beyond >= motion.frame_count()) break;
    if (!observed_at(motion, column, beyond)) continue;
    const int64_t from = std::min(beyond, other), to = std::max(beyond, other);
    return scaled(velocity(motion, column, from, to), 1.0 / static_cast<double>(to - from));
  }
  return {};
}

// A rotation path across a gap from frame `left` to frame `right`: the
// cubic on quaternions with the given end velocities (Kim, Kim and Shin's
// cumulative Bezier form, which meets both ends and their velocities
// exactly), or the slerp when no velocities are used.
class BorderPath {
 public:
  BorderPath(const Quaternion& left, const Quaternion& right, const Vector& left_velocity,
             const Vector& right_velocity, double tangent_frames, bool cubic)
      : start_(left), cubic_(cubic) {
    if (!cubic_) {
      arc_ = log_of(multiply(inverse(left), right));
      return;
    }
    // Bezier control points `tangent_frames` along each end's velocity (a
    // third of the span gives the Hermite cubic).
    const Quaternion q1 = multiply(left, exp_of(scaled(left_velocity, tangent_frames)));
    const Quaternion q2 = multiply(right, exp_of(scaled(right_velocity, -tangent_frames)));
    w1_ = log_of(multiply(inverse(left), q1));
    w2_ = log_of(multiply(inverse(q1), q2));
    w3_ = log_of(multiply(inverse(q2), right));
  }
  // u in 0..1 across the gap.
  Quaternion at(double u) const {
    if (!cubic_) return multiply(start_, exp_of(scaled(arc_, u)));
    const double b1 = 1 - (1 - u) * (1 - u) * (1 - u), b2 = 3 * u * u - 2 * u * u * u, b3 = u * u * u;
    return multiply(multiply(multiply(start_, exp_of(scaled(w1_, b1))), exp_of(scaled(w2_, b2))),
                    exp_of(scaled(w3_, b3)));
  }

 private:
  Quaternion start_;
  bool cubic_;
  Vector arc_, w1_, w2_, w3_;
};

// Angle (radians, 0..pi) between two unit quaternions' rotations.
double angle_between(const Quaternion& a, const Quaternion& b) {
  const Quaternion d = multiply(inverse(a), b);
  return 2 * std::atan2(std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z), std::fabs(d.w));
}

// The joint's mean angle per frame over the observed frames within
// `context` frames outside the gap (pairs of consecutive frames both
// observed), or a negative value when there is no such pair.
double observed_speed_around(const MotionFrames& motion, int column, const JointGap& gap, int64_t context) {
  double sum = 0;
  int64_t pairs = 0;
  const auto add = [&](int64_t from, int64_t to) {
    for (int64_t f = std::max<int64_t>(from, 0); f < to && f + 1 < motion.frame_count(); ++f) {
      if (!observed_at(motion, column, f) || !observed_at(motion, column, f + 1)) continue;
      sum += angle_between(quaternion_of(motion.frame(f) + column), quaternion_of(motion.frame(f + 1) + column));
      ++pairs;
    }
  };
  add(gap.first - 1 - context, gap.first - 1);
  add(gap.last + 1, gap.last + 1 + context);
  return pairs > 0 ? sum / static_cast<double>(pairs) : -1.0;
}

// The fill's mean angle per frame across the gap (from its observed border
// frames, where there are, through the filled frames) with the detail at
// weight `w`.
double fill_speed(const MotionFrames& observed, int column, const JointGap& gap, const std::vector<Quaternion>& base,
                  const std::vector<Vector>& detail, double w) {
  const bool has_left = gap.first > 0, has_right = gap.last + 1 < observed.frame_count();
  double sum = 0;
  int64_t pairs = 0;
  Quaternion previous;
  bool have_previous = false;
  if (has_left) {
    previous = quaternion_of(observed.frame(gap.first - 1) + column);
    have_previous = true;
  }
  for (size_t i = 0; i < base.size(); ++i) {
    const Quaternion q = multiply(base[i], exp_of(scaled(detail[i], w)));
    if (have_previous) {
      sum += angle_between(previous, q);
      ++pairs;
    }
    previous = q;
    have_previous = true;
  }
  if (has_right) {
    sum += angle_between(previous, quaternion_of(observed.frame(gap.last + 1) + column));
    ++pairs;
  }
  return pairs > 0 ? sum / static_cast<double>(pairs) : 0.0;
}

// The detail's weight that makes the joint's fill move as fast as the
// observed frames around it: `weight` times a gain in
// options.speed_gain_range, by bisection (the fill's speed grows with the
// detail's weight where the detail moves).
double speed_matched_weight(const MotionFrames& observed, int column, const JointGap& gap,
                            const std::vector<Quaternion>& base, const std::vector<Vector>& detail, double weight,
                            const GapFillOptions& options, double rate_hz) {
  const double low = weight * options.speed_gain_range[0], high = weight * options.speed_gain_range[1];
  if (!(high > low)) return low;
  const double target =
      observed_speed_around(observed, column, gap, std::lround(options.speed_context_seconds * rate_hz));
  if (target < 0) return weight;
  const auto speed = [&](double w) { return fill_speed(observed, column, gap, base, detail, w); };
  if (speed(high) <= target) return high;
  if (speed(low) >= target) return low;
  double a = low, b = high;
  for (int step = 0; step < 20; ++step) {
    const double middle = (a + b) / 2;
    (speed(middle) < target ? a : b) = middle;
  }
  return (a + b) / 2;
}

// `detail` (a gap's frames, nil at the border frames just outside it) less
// its movement slower than `period_frames`: a Gaussian low-pass (half
// response at that period) of the detail continued past each border as its
// odd mirror image (period 2 (n + 1), nil at -1 and n), subtracted.
void remove_slow_detail(std::vector<Vector>& detail, double period_frames) {
  const auto n = static_cast<int64_t>(detail.size());
  if (n == 0 || !(period_frames > 0)) return;
  const double sigma = std::sqrt(std::log(2.0) / 2.0) / M_PI * period_frames;
  const auto radius = static_cast<int64_t>(std::ceil(3 * sigma));
  std::vector<double> kernel(static_cast<size_t>(radius + 1));
  double kernel_sum = 0;
  for (int64_t k = 0; k <= radius; ++k) {
    kernel[static_cast<size_t>(k)] = std::exp(-0.5 * static_cast<double>(k * k) / (sigma * sigma));
    kernel_sum += (k == 0 ? 1 : 2) * kernel[static_cast<size_t>(k)];
  }
  const int64_t period = 2 * (n + 1);
  const auto extended = [&](int64_t i) {
    int64_t j = (i + 1) % period;
    if (j < 0) j += period;
    if (j == 0 || j == n + 1) return Vector{};
    if (j <= n) return detail[static_cast<size_t>(j - 1)];
    return scaled(detail[static_cast<size_t>(2 * n + 1 - j)], -1.0);
  };
  std::vector<Vector> slow(detail.size());
  for (int64_t i = 0; i < n; ++i) {
    Vector sum;
    for (int64_t k = -radius; k <= radius; ++k) {
      const Vector v = extended(i + k);
      const double w = kernel[static_cast<size_t>(std::abs(k))];
      sum.x += w * v.x;
      sum.y += w * v.y;
      sum.z += w * v.z;
    }
    slow[static_cast<size_t>(i)] = scaled(sum, 1.0 / kernel_sum);
  }
  for (int64_t i = 0; i < n; ++i) {
    Vector& d = detail[static_cast<size_t>(i)];
    d.x -= slow[static_cast<size_t>(i)].x;
    d.y -= slow[static_cast<size_t>(i)].y;
    d.z -= slow[static_cast<size_t>(i)].z;
  }
}

// The gains a gap's joints share (GapFillOptions::speed_gain_shared) are
// chosen among these steps across speed_gain_range.
constexpr int kSharedGainSteps = 64;
double shared_gain_step(const GapFillOptions& options, int step) {
  return options.speed_gain_range[0] +
         (options.speed_gain_range[1] - options.speed_gain_range[0]) * step / (kSharedGainSteps - 1);
}

// What one joint's gap adds to its group's choice of a shared gain: its
// observed speed around the gap, and its fill's speed at each step.
struct SharedGainProbe {
  double target = 0;
  std::vector<double> speeds;  // kSharedGainSteps, empty when the joint takes no part
};

void fill_gap_with(const MotionFrames& observed, const MotionFrames* manifold, const JointGap& gap,
                   const GapFillOptions& options, double rate_hz, MotionFrames* out, const double* shared_gain,
                   SharedGainProbe* probe);

}  // namespace

const char* gap_method_name(GapMethod method) {
  switch (method) {
    case GapMethod::kHold: return "hold";
    case GapMethod::kSlerp: return "slerp";
    case GapMethod::kCubic: return "cubic";
    case GapMethod::kManifold: return "manifold";
    case GapMethod::kMatched: return "matched";
    case GapMethod::kFitted: return "fitted";
    case GapMethod::kBorrowed: return "borrowed";
  }
  return "?";
}

GapMethod parse_gap_method(const std::string& name, const std::string& field) {
  for (GapMethod method : {GapMethod::kBorrowed, GapMethod::kFitted, GapMethod::kMatched, GapMethod::kCubic,
                           GapMethod::kSlerp, GapMethod::kHold, GapMethod::kManifold}) {
    if (name == gap_method_name(method)) return method;
  }
  throw InputError(field,
                   "expected \"borrowed\", \"fitted\", \"matched\", \"cubic\", \"slerp\", \"hold\" or \"manifold\", "
                   "found \"" + name + "\"");
}

bool reads_fitted_codes(GapMethod method) { return method == GapMethod::kFitted || method == GapMethod::kBorrowed; }

bool lays_manifold_detail(GapMethod method) {
  return method == GapMethod::kMatched || method == GapMethod::kFitted || method == GapMethod::kBorrowed;
}

std::vector<JointGap> find_joint_gaps(const MotionFrames& motion) {
  std::vector<JointGap> gaps;
  const int joints = (motion.columns - kRootTranslationValues) / 3;
  const int64_t frames = motion.frame_count();
  for (int j = 0; j < joints; ++j) {
    const int column = kRootTranslationValues + 3 * j;
    int64_t start = -1;
    for (int64_t f = 0; f <= frames; ++f) {
      bool missing = false;
      if (f < frames) {
        const float* v = motion.frame(f) + column;
        missing = std::isnan(v[0]) || std::isnan(v[1]) || std::isnan(v[2]);
      }
      if (missing && start < 0) start = f;
      if (!missing && start >= 0) {
        gaps.push_back({j, start, f - 1});
        start = -1;
      }
    }
  }
  return gaps;
}

std::vector<FrameSpan> find_missing_spans(const MotionFrames& motion) {
  std::vector<FrameSpan> spans;
  int64_t start = -1;
  for (int64_t f = 0; f <= motion.frame_count(); ++f) {
    bool missing = false;
    if (f < motion.frame_count()) {
      const float* v = motion.frame(f);
      for (int c = kRootTranslationValues; c < motion.columns && !missing; ++c) missing = std::isnan(v[c]);
    }
    if (missing && start < 0) start = f;
    if (!missing && start >= 0) {
      spans.push_back({start, f - 1});
      start = -1;
    }
  }
  return spans;
}

bool gap_borders_lone_keyframe(const MotionFrames& observed, const JointGap& gap) {
  const int column = kRootTranslationValues + 3 * gap.joint;
  const int64_t frames = observed.frame_count();
  if (gap.first < 1 || gap.last + 1 >= frames) return false;  // one border: held, not between keyframes
  // A border that is a lone observed frame (the frame beyond it missing
  // too) is a keyframe between gaps: too little is observed there for the
  // manifold's detail to follow the motion, and the cubic is nearer
  // (keyframes every 1 s over 13 S5 takes: 60.6 mm for the cubic against
  // 77.1 with the fitted detail; every 2 s 86.9 against 133.8).
  const auto lone = [&](int64_t beyond) {
    return beyond >= 0 && beyond < frames && !observed_at(observed, column, beyond);
  };
  return lone(gap.first - 2) || lone(gap.last + 2);
}

double detail_weight(const GapFillOptions& options, double seconds, bool most_joints) {
  const auto& w = most_joints ? options.most_joints_detail : options.few_joints_detail;
  if (seconds <= options.interpolate_below_seconds) return 0.0;
  if (seconds < 1.0) {
    // From none at interpolate_below (all at once when that is 0 s).
    if (options.interpolate_below_seconds <= 0) return w[0];
    return w[0] * (seconds - options.interpolate_below_seconds) / (1.0 - options.interpolate_below_seconds);
  }
  if (seconds < 2.0) return w[0] + (w[1] - w[0]) * (seconds - 1.0);
  if (seconds < 4.0) return w[1] + (w[2] - w[1]) * (seconds - 2.0) / 2.0;
  return w[2];
}

void fill_gap(const MotionFrames& observed, const MotionFrames* manifold, const JointGap& gap,
              const GapFillOptions& options, double rate_hz, MotionFrames& out) {
  fill_gap_with(observed, manifold, gap, options, rate_hz, &out, nullptr, nullptr);
}

namespace {

// fill_gap, with the detail's gain given (`shared_gain`) rather than
// matched per joint, or (`probe`) only measuring what a shared gain needs.
void fill_gap_with(const MotionFrames& observed, const MotionFrames* manifold, const JointGap& gap,
                   const GapFillOptions& options, double rate_hz, MotionFrames* out_frames, const double* shared_gain,
                   SharedGainProbe* probe) {
  if (probe && !lays_manifold_detail(options.method)) return;
  MotionFrames scratch;
  MotionFrames& out = out_frames ? *out_frames : scratch;
  const int column = kRootTranslationValues + 3 * gap.joint;
  const int64_t frames = observed.frame_count();
  const int64_t left = gap.first - 1, right = gap.last + 1;
  const bool has_left = left >= 0, has_right = right < frames;
  const bool uses_manifold = options.method == GapMethod::kManifold || lays_manifold_detail(options.method);
  if (uses_manifold && (!manifold || manifold->columns != observed.columns || manifold->frame_count() != frames)) {
    throw std::invalid_argument("fill_gap: the manifold's frames are needed, of the observed motion's shape");
  }
  if (probe && !has_left && !has_right) return;
  // The manifold's frames as they are, unless they were written missing (a
  // fitted window that lays no detail, GapCodeFitOptions::max_observed_error):
  // then the cubic, as the matched fills give such a gap.
  const bool manifold_missing = uses_manifold && std::isnan(manifold->frame(gap.first)[column]);
  if (!manifold_missing && (options.method == GapMethod::kManifold || (!has_left && !has_right && uses_manifold))) {
    for (int64_t f = gap.first; f <= gap.last; ++f) std::copy_n(manifold->frame(f) + column, 3, out.frame(f) + column);
    return;
  }
  if (!has_left && !has_right) {
    // Nothing observed to interpolate from: the joint stays at rest.
    for (int64_t f = gap.first; f <= gap.last; ++f) std::fill_n(out.frame(f) + column, 3, 0.0f);
    return;
  }
  // The observed borders; a gap at either end of the motion has only one,
  // and is held there.
  const float* left_value = observed.frame(has_left ? left : right) + column;
  const float* right_value = observed.frame(has_right ? right : left) + column;
  const bool one_border = !has_left || !has_right;
  const double span = static_cast<double>(right - left);
  const double tangent_frames = std::min(span / 3, options.max_tangent_seconds * rate_hz);
  const bool cubic = !one_border && options.method != GapMethod::kSlerp;
  const bool hold = options.method == GapMethod::kHold || one_border;

  const Quaternion observed_left = quaternion_of(left_value), observed_right = quaternion_of(right_value);
  const auto reach = static_cast<int64_t>(std::lround(2 * rate_hz));
  BorderPath observed_path(observed_left, observed_right, border_velocity(observed, column, left, right, reach),
                           border_velocity(observed, column, right, left, reach), tangent_frames, cubic);
  double weight = 0;
  std::optional<BorderPath> manifold_path;
  if (lays_manifold_detail(options.method)) {
    // Whether most joints are missing with this one, at the gap's middle.
    weight = detail_weight(options, static_cast<double>(gap.last - gap.first + 1) / rate_hz,
                           most_joints_missing(observed, (gap.first + gap.last) / 2));
    if (gap_borders_lone_keyframe(observed, gap)) weight = 0;
    if (manifold_missing) weight = 0;  // the cubic alone, as above
    const float* m_left = manifold->frame(has_left ? left : right) + column;
    const float* m_right = manifold->frame(has_right ? right : left) + column;
    manifold_path.emplace(quaternion_of(m_left), quaternion_of(m_right), velocity(*manifold, column, left - 1, left),
                          velocity(*manifold, column, right, right + 1), tangent_frames, cubic);
  }
  // Each gap frame's rotation without the detail, and the detail (the
  // manifold's rotation relative to its own path across the gap, identity
  // at both borders) as a rotation vector.
  const int64_t count = gap.last - gap.first + 1;
  std::vector<Quaternion> base(static_cast<size_t>(count));
  std::vector<Vector> detail(static_cast<size_t>(manifold_path && weight > 0 ? count : 0));
  for (int64_t f = gap.first; f <= gap.last; ++f) {
    const double u = one_border ? (has_left ? 0.0 : 1.0) : static_cast<double>(f - left) / span;
    const auto i = static_cast<size_t>(f - gap.first);
    if (options.method == GapMethod::kHold) {
      base[i] = has_left ? observed_left : observed_right;
    } else {
      base[i] = hold ? (has_left ? observed_left : observed_right) : observed_path.at(u);
    }
    if (!detail.empty()) {
      detail[i] = log_of(multiply(inverse(manifold_path->at(u)), quaternion_of(manifold->frame(f) + column)));
    }
  }
  if (!detail.empty() && !one_border && options.detail_lowcut_seconds > 0) {
    remove_slow_detail(detail, options.detail_lowcut_seconds * rate_hz);
  }
  if (probe) {
    if (detail.empty()) return;
    probe->target =
        observed_speed_around(observed, column, gap, std::lround(options.speed_context_seconds * rate_hz));
    if (probe->target < 0) return;
    for (int step = 0; step < kSharedGainSteps; ++step) {
      probe->speeds.push_back(fill_speed(observed, column, gap, base, detail, weight * shared_gain_step(options, step)));
    }
    return;
  }
  if (!detail.empty()) {
    weight = shared_gain ? weight * *shared_gain
                         : speed_matched_weight(observed, column, gap, base, detail, weight, options, rate_hz);
  }
  for (int64_t f = gap.first; f <= gap.last; ++f) {
    const double u = one_border ? (has_left ? 0.0 : 1.0) : static_cast<double>(f - left) / span;
    const auto i = static_cast<size_t>(f - gap.first);
    Quaternion q = base[i];
    if (!detail.empty()) q = multiply(q, exp_of(scaled(detail[i], weight)));
    double reference[3];
    const double t = one_border ? 0.0 : u;
    for (int i3 = 0; i3 < 3; ++i3) reference[i3] = (1 - t) * left_value[i3] + t * right_value[i3];
    write_expmap(q, reference, out.frame(f) + column);
  }
}

}  // namespace

bool most_joints_missing(const MotionFrames& observed, int64_t frame) {
  return most_joints_missing(observed.frame(frame), observed.columns);
}

bool most_joints_missing(const float* values, int columns) {
  const int joints = (columns - kRootTranslationValues) / 3;
  int missing = 0;
  for (int j = 0; j < joints; ++j) {
    const float* v = values + kRootTranslationValues + 3 * j;
    missing += std::isnan(v[0]) || std::isnan(v[1]) || std::isnan(v[2]) ? 1 : 0;
  }
  return 2 * missing >= joints;
}

int64_t max_bridged_frames(const GapFillOptions& options, double rate_hz) {
  return std::max<int64_t>(1, std::lround(options.max_bridged_seconds * rate_hz));
}

namespace {

void require_manifold(const MotionFrames* manifold, const MotionFrames& observed) {
  if (!manifold || manifold->columns != observed.columns || manifold->frame_count() != observed.frame_count()) {
    throw std::invalid_argument("fill_gap: the manifold's frames are needed, of the observed motion's shape");
  }
}

}  // namespace

LongGapHead long_gap_head(const MotionFrames& observed, const MotionFrames* manifold, const JointGap& gap,
                          const GapFillOptions& options, bool most_joints) {
  const int column = kRootTranslationValues + 3 * gap.joint;
  LongGapHead head;
  head.joint = gap.joint;
  head.has_left = gap.first > 0;
  const bool uses_manifold = options.method == GapMethod::kManifold || lays_manifold_detail(options.method);
  if (uses_manifold) require_manifold(manifold, observed);
  if (!head.has_left) return head;
  std::copy_n(observed.frame(gap.first - 1) + column, 3, head.left);
  if (lays_manifold_detail(options.method)) {
    std::copy_n(manifold->frame(gap.first - 1) + column, 3, head.manifold_left);
    head.weight = detail_weight(options, options.max_bridged_seconds, most_joints);
  }
  return head;
}

void fill_long_gap_head_frame(const LongGapHead& head, const MotionFrames* manifold, int64_t frame,
                              const GapFillOptions& options, MotionFrames& out) {
  const int column = kRootTranslationValues + 3 * head.joint;
  float* value = out.frame(frame) + column;
  const bool uses_manifold = options.method == GapMethod::kManifold || lays_manifold_detail(options.method);
  if (options.method == GapMethod::kManifold || (!head.has_left && uses_manifold)) {
    std::copy_n(manifold->frame(frame) + column, 3, value);
    return;
  }
  if (!head.has_left) {
    std::fill_n(value, 3, 0.0f);  // nothing observed before: at rest, as a gap with no border
    return;
  }
  // As a gap that runs to the motion's end: held at the left border, with
  // the manifold's rotation since its own left border frame laid over it.
  Quaternion q = quaternion_of(head.left);
  if (head.weight > 0) {
    const Vector detail = log_of(multiply(inverse(quaternion_of(head.manifold_left)), quaternion_of(manifold->frame(frame) + column)));
    q = multiply(q, exp_of(scaled(detail, head.weight)));
  }
  const double reference[3] = {head.left[0], head.left[1], head.left[2]};
  write_expmap(q, reference, value);
}

MotionFrames fill_gaps(const MotionFrames& observed, const MotionFrames* manifold, const GapFillOptions& options,
                       double rate_hz, int64_t needed_from, const MotionFrames* as_given) {
  // A gap longer than the bridge has its head filled first, from its left
  // border alone; what is left of it is bridged from there as any gap.
  const auto gaps = find_joint_gaps(observed);
  const int64_t bridge = max_bridged_frames(options, rate_hz);
  MotionFrames out = observed;
  bool headed = false;
  for (const JointGap& gap : gaps) {
    if (gap.last - gap.first + 1 <= bridge) continue;
    const LongGapHead head = long_gap_head(observed, manifold, gap, options, most_joints_missing(observed, gap.first));
    const int64_t head_last = gap.last + 1 < observed.frame_count() ? gap.last - bridge : gap.last;
    for (int64_t f = gap.first; f <= head_last; ++f) fill_long_gap_head_frame(head, manifold, f, options, out);
    headed = true;
  }
  if (headed) return fill_gaps(MotionFrames(out), manifold, options, rate_hz, needed_from, as_given ? as_given : &observed);
  if (options.method == GapMethod::kBorrowed) {
    // The take's own movement where it repeats itself closely enough, the
    // fitted fill's (the manifold's frames given) elsewhere. Borrowed from
    // the motion as given: a long gap's head, written as if observed, is no
    // source, and a span that joins one is as long as given (too long to
    // borrow for), in a streamed take as in the whole.
    const MotionFrames borrowed = borrow_take_motion(as_given ? *as_given : observed, rate_hz, options.borrow, needed_from);
    GapFillOptions fitted = options;
    fitted.method = GapMethod::kMatched;
    GapFillOptions from_take = fitted;
    from_take.interpolate_below_seconds = 0;
    from_take.few_joints_detail.fill(options.borrow.weight);
    from_take.most_joints_detail.fill(options.borrow.weight);
    from_take.speed_gain_range = {1.0, 1.0};
    from_take.detail_lowcut_seconds = options.borrow.detail_lowcut_seconds;
    for (const JointGap& gap : gaps) {
      if (gap.last < needed_from) continue;
      // A span borrowed for holds its source's values; any other, its NaN
      // (in any of the joint's values: a joint is missing where one is).
      if (observed_at(borrowed, kRootTranslationValues + 3 * gap.joint, gap.first)) {
        fill_gap(observed, &borrowed, gap, from_take, rate_hz, out);
      } else {
        fill_gap(observed, manifold, gap, fitted, rate_hz, out);
      }
    }
    return out;
  }
  const bool shared = options.speed_gain_shared && lays_manifold_detail(options.method) &&
                      options.speed_gain_range[1] > options.speed_gain_range[0];
  if (!shared) {
    for (const JointGap& gap : gaps) fill_gap(observed, manifold, gap, options, rate_hz, out);
    return out;
  }
  // One gain for the joints missing over the same frames: the step whose
  // fill moves them together (the sum of their mean angles per frame) as
  // fast as the observed frames around them, the first at or above it.
  std::map<std::pair<int64_t, int64_t>, std::vector<const JointGap*>> groups;
  for (const JointGap& gap : gaps) groups[{gap.first, gap.last}].push_back(&gap);
  for (const auto& [extent, members] : groups) {
    double target = 0;
    std::vector<double> speeds(kSharedGainSteps, 0.0);
    bool measured = false;
    for (const JointGap* gap : members) {
      SharedGainProbe probe;
      fill_gap_with(observed, manifold, *gap, options, rate_hz, nullptr, nullptr, &probe);
      if (probe.speeds.empty()) continue;
      measured = true;
      target += probe.target;
      for (int step = 0; step < kSharedGainSteps; ++step) speeds[static_cast<size_t>(step)] += probe.speeds[static_cast<size_t>(step)];
    }
    double gain = 1.0;
    if (measured) {
      int step = 0;
      while (step + 1 < kSharedGainSteps && speeds[static_cast<size_t>(step)] < target) ++step;
      gain = shared_gain_step(options, step);
    }
    for (const JointGap* gap : members) fill_gap_with(observed, manifold, *gap, options, rate_hz, &out, &gain, nullptr);
  }
  return out;
}

double expmap_angle_between(const float* a, const float* b) {
  const Quaternion d = multiply(inverse(quaternion_of(a)), quaternion_of(b));
  return 2 * std::atan2(std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z), std::fabs(d.w));
}

}  // namespace mm
