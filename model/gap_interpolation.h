// Gaps in a motion and the ways to fill them: where a joint is missing
// (NaN) for a run of frames, filled by interpolating what was observed on
// either side, or by the manifold's fill made to meet the observed frames.
//
// Motions are MotionFrames in the exponential-map layout (columns 0..2 the
// root translation, then 3 values per joint, radians); joint j's rotation is
// columns 3 + 3j .. 5 + 3j. A joint is missing in a frame when any of its
// three values is NaN. Rotations are interpolated on unit quaternions, and
// written back as the exponential map nearest the linear blend of the
// gap's observed borders (so a motion's maps stay continuous across pi).
//
// Why the border-matched fill: the manifold's fill of a gap carries the
// model's whole reconstruction error (about 80 mm on H3.6M), while
// interpolation is exact at the gap's borders; the manifold's fill taken
// relative to its own interpolation across the gap (its "detail": how it
// moves inside the gap) and laid over the observed interpolation meets the
// observed frames exactly and keeps the manifold's movement.
//
// Torch-free and reentrant: pure functions over value types.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "format/motion_frames.h"

namespace mm {

// One joint's run of missing frames, first..last inclusive (a maximal run:
// frames first - 1 and last + 1, where they exist, are observed).
struct JointGap {
  int joint = 0;
  int64_t first = 0, last = 0;
};

// Every joint's gaps, by joint then frame.
std::vector<JointGap> find_joint_gaps(const MotionFrames& motion);

// A run of frames where any joint value is missing, first..last inclusive.
struct FrameSpan {
  int64_t first = 0, last = 0;
  int64_t length() const { return last - first + 1; }
};

// The runs of frames where some joint is missing, in order.
std::vector<FrameSpan> find_missing_spans(const MotionFrames& motion);

enum class GapMethod {
  kHold,      // the last observed rotation (the next one for a gap at the start)
  kSlerp,     // per joint, slerp from the rotation before the gap to the one after
  kCubic,     // cubic Hermite on quaternions with the border frames' angular velocities
  kManifold,  // the manifold's fill as it is (what keep_observed did before)
  kMatched,   // the manifold's detail over the cubic, scaled by detail_weight()
  // kMatched over the frames of a code fitted to each gap's centred window
  // (gap_code_fit.h): fill_gaps() fills it as kMatched from the frames it is
  // given; the take path (take_processor.h) gives it the fitted frames.
  kFitted,
  // The take's own movement where it repeats itself: kMatched over the
  // take's own stretch most like each gap's surroundings (borrowed_motion.h)
  // where one is like enough (BorrowOptions::max_cost), kFitted elsewhere.
  kBorrowed,
};
const char* gap_method_name(GapMethod method);  // "hold", "slerp", "cubic", "manifold", "matched", "fitted", "borrowed"
// The method of that name; InputError naming `field`, the value and the names.
GapMethod parse_gap_method(const std::string& name, const std::string& field);
// kMatched, kFitted and kBorrowed: the manifold's (or the borrowed) detail over the cubic.
bool lays_manifold_detail(GapMethod method);
// kFitted and kBorrowed: the manifold's frames they read are those of codes
// fitted to each gap's window (gap_code_fit.h).
bool reads_fitted_codes(GapMethod method);

// Where the borrowed fill (borrowed_motion.h) looks for a gap's movement,
// and when it takes it.
struct BorrowOptions {
  // Observed frames compared on each side of a gap, from its border outward.
  double context_seconds = 0.4;
  // How far before a gap its source may start (what a streamed take holds).
  double search_seconds = 60.0;
  // How far after a gap its source may end (what a streamed take waits for
  // before it fills the gap).
  double lookahead_seconds = 10.0;
  // Spans (frames where any joint is missing) longer than this borrow
  // nothing: as long as the bridge (GapFillOptions::max_bridged_seconds),
  // so that a streamed take knows a span will not borrow once it is longer,
  // and answers its frames as any long gap's.
  double max_span_seconds = 10.0;
  // How much a source may be longer or shorter than the gap (the ratio of
  // their lengths), tried in steps of at most `stretch_step` of the gap.
  double min_stretch = 0.8, max_stretch = 1.25, stretch_step = 0.02;
  // A source is used where its cost (BorrowedSpan::cost) is at most this;
  // elsewhere the fitted fill's detail is laid. Chosen on S5's trial-1
  // takes, every joint missing for 2 and 4 s (docs/RESULTS.md, "Gaps"): the
  // bound of least MPJPE over both lengths.
  double max_cost = 0.02;
  // Spans shorter than this borrow nothing (the fitted fill's): on S5 the
  // take's stretches were nearer than the fitted fill in gaps of 2 s and
  // 4 s, and further in every-joint gaps of 1 s (docs/RESULTS.md, "Gaps").
  double min_seconds = 2.0;
  // The source's movement is laid at this weight.
  double weight = 1.0;
  // The source's detail's slow movement taken out
  // (GapFillOptions::detail_lowcut_seconds, for the borrowed spans; 0: none).
  double detail_lowcut_seconds = 0.0;
  // Where no stretch of the whole body costs at most max_cost: groups of
  // joints whose stretches are searched and taken apart, each compared on
  // its own joints and taken where it costs at most part_max_cost; a joint
  // in no group borrows nothing there. Empty: the whole body alone. The take
  // path searches the legs and the upper body (body_parts() in
  // borrowed_motion.h, from the model's skeleton): a take's legs repeat
  // their steps where its arms do something else, while one stretch of the
  // whole body, where there is one, keeps the arms in step with the legs. A
  // part's cost, over fewer joints, finds a like stretch more easily than
  // the whole body's, so its bound is tighter; both chosen on S5's trial-1
  // takes (docs/RESULTS.md, "Gaps").
  std::vector<std::vector<int>> parts;
  double part_max_cost = 0.005;
};

// How much of the manifold's detail the matched fill keeps, by the gap's
// length and whether most joints are missing with it (in-betweening) or a
// few: interpolation for short gaps, where it is better than any model
// fill, and as much of the manifold's movement for longer ones as makes the
// fill nearer the recording. The weights were chosen for the fitted fill on
// the training subjects' takes (S1 and S6; docs/RESULTS.md "Gaps"): the
// weight of least MPJPE in each length and joint count, which is full
// weight but for most joints at 4 s. There a quarter: the model fills its
// training subjects' gaps far better than anyone else's (every joint at
// 2 s, 47.9 mm against interpolation's 89.2 on S1 and S6, 87.5 against 87.4
// on S5), and every user's take is someone else's. At 4 s the training
// subjects' best, half (106.3 mm against 111.2 at a quarter), was 7% worse
// than interpolation on S5 (93 gaps: 124.5 against 116.4; trial-1 takes
// 126.1 against 113.9), past the 5% a fill may cost; a quarter was within
// 2% on both trials (117.0 over all). With the bound on the fit's error
// (GapCodeFitOptions::max_observed_error) half is the training subjects'
// best again (103.3 mm against 106.3) and within 5% on S5's trial-1 takes
// (114.6 against interpolation's 112.6), but only a quarter keeps those
// takes below interpolation (112.1), as the issue asks of every-joint gaps
// of 2 s and more; more weight moves faster but further, so the weight is
// the largest that does.
struct GapFillOptions {
  GapMethod method = GapMethod::kBorrowed;
  // No detail between lone keyframes (gap_borders_lone_keyframe: the cubic
  // is nearer there), nor up to
  // `interpolate_below_seconds`; from there the weight
  // rises linearly to the weight at 1 s (is that weight from 0 s on when
  // interpolate_below_seconds is 0), then linearly between the weights
  // at 1, 2 and 4 s, and stays at the 4 s weight beyond.
  double interpolate_below_seconds = 0.6;
  std::array<double, 3> few_joints_detail = {1.0, 1.0, 1.0};  // at 1, 2, 4 s: gaps of under half the joints
  std::array<double, 3> most_joints_detail = {1.0, 1.0, 0.25}; // at 1, 2, 4 s: half the joints or more missing together
  // The detail's gain by the recording's speed around the gap, off by
  // default: the fitted code's decoder output moves less than the
  // recording (the prior pulls it toward the mean), so where the weight
  // above is not 0, each joint's detail may be scaled by the gain that
  // makes the fill's mean angular speed across the gap that of the joint's
  // observed frames within `speed_context_seconds` before and after the gap
  // (what the fill is given, never the gap's own frames), the gain clamped
  // to `speed_gain_range` (1 and 1: the weight as it is). Off, as measured
  // on the training subjects (evaluate-gaps --speed-gain, the JSON's speed_
  // and shared_ columns; the 15 `_1` takes of S1 and of S6, seed 1, 12 to 16
  // gaps a configuration): it brings every-joint gaps of 2 s to the
  // recording's speed but further from it (gain 0.5 to 1.5: 65.4 mm at
  // 0.96x per joint, 64.9 at 1.01x shared, against 51.5 at 0.81x without),
  // and costs MPJPE in every configuration of 1 and 2 s; S5 agrees (every
  // joint at 2 s, gain 0.5 to 2 per joint: 78.6 mm at 0.89x against 62.3 at
  // 0.69x).
  std::array<double, 2> speed_gain_range = {1.0, 1.0};
  double speed_context_seconds = 1.0;
  // Where not 0: the detail's movement slower than this period (s) is taken
  // out of it before it is laid (a Gaussian low-pass of the detail, half its
  // amplitude at this period, subtracted), so that the cubic says where a
  // joint goes across a long gap and the detail only how it moves on the way:
  // a detail's slow drift puts the whole pose somewhere the recording was
  // not, its faster movement is what keeps the fill from freezing. The
  // detail is continued past each border as its odd mirror image (it is nil
  // at both borders), so the filtered detail is nil there too and the fill
  // still meets the observed frames. Gaps with both borders only. Off, as
  // measured (evaluate-gaps, the JSON's `*lowcut*` columns; docs/RESULTS.md
  // "Gaps"): on the training subjects the manifold's slow movement is right,
  // and taking it out of the fitted fallback costs every-joint gaps of 2 s
  // 88.1 mm against 56.3; on S5 it gains 3% at 2 s and nothing sure at 4 s.
  double detail_lowcut_seconds = 0.0;
  // fill_gaps(): one gain for the joints missing over the same frames,
  // matching the sum of their speeds, instead of one a joint.
  bool speed_gain_shared = false;
  // The cubic's tangents: each border's velocity carried for a third of
  // the gap, but at most this long (s), since a velocity carried across a
  // long gap overshoots far past where the motion went.
  double max_tangent_seconds = 0.2;
  // A gap is interpolated between its borders over at most its last
  // `max_bridged_seconds` (at least 4 s, where the detail's weight stops
  // changing). Before those, a longer gap is filled as a gap that runs to
  // the motion's end is: the joint's last observed rotation with the
  // manifold's movement since then laid over it at the 4 s weight (the
  // manifold's own rotation where nothing was observed before the gap, as
  // at a motion's start); the bridge then starts from there. Why: the take
  // path can hand a frame out only once it is final, and without this
  // bound a joint lost for good held every later frame of a streamed take
  // until the take ended; with it, a frame is final at most this long after
  // it arrived. Longer than any gap the benchmark measures (4 s), so those
  // fills are unchanged.
  double max_bridged_seconds = 10.0;
  // kBorrowed: where the take's own movement is looked for, and when used.
  BorrowOptions borrow;
};

// Whether one of `gap`'s borders (a joint's gap in `observed`, as
// find_joint_gaps() gives it) is a lone keyframe: an observed frame whose
// next frame outward is missing too (sparse keyframes). The matched and
// fitted fills lay no manifold detail over such a gap, only the cubic, and
// the take path fits no code to it (gap_gets_fitted, gap_code_fit.h). False
// for a gap at the motion's start or end (one border).
bool gap_borders_lone_keyframe(const MotionFrames& observed, const JointGap& gap);

// The weight of the manifold's detail in a gap of `seconds`, for a gap of
// most joints or of a few.
double detail_weight(const GapFillOptions& options, double seconds, bool most_joints);

// `observed` with every gap filled as options.method says; `manifold` (the
// model's output for the same frames, same columns; for kFitted and
// kBorrowed the fitted codes' frames) is read for kManifold, kMatched,
// kFitted and kBorrowed only and may be null otherwise; a gap whose manifold
// frames are missing (NaN: a fitted window past
// GapCodeFitOptions::max_observed_error) gets the cubic. kBorrowed lays the
// take's own movement (borrowed_motion.h) over a gap whose source costs at
// most options.borrow.max_cost, and is kFitted elsewhere. Values outside
// gaps (and the root translation columns) are the observed ones. `rate_hz`
// converts gap lengths to seconds. Gaps ending before frame `needed_from`
// may be left unfilled (a caller that hands those frames out already).
// `as_given` (null: `observed`): the same frames before any long gap's head
// was written into them (the take path writes heads as it goes), what
// kBorrowed borrows from. std::invalid_argument when `manifold` is needed
// and missing or of another shape.
MotionFrames fill_gaps(const MotionFrames& observed, const MotionFrames* manifold, const GapFillOptions& options,
                       double rate_hz, int64_t needed_from = 0, const MotionFrames* as_given = nullptr);

// The same for one gap, written into `out` (same shape as observed; only
// the gap's frames of its joint are written).
void fill_gap(const MotionFrames& observed, const MotionFrames* manifold, const JointGap& gap,
              const GapFillOptions& options, double rate_hz, MotionFrames& out);

// The frames a gap is bridged over at most (GapFillOptions::max_bridged_seconds).
int64_t max_bridged_frames(const GapFillOptions& options, double rate_hz);

// What fills the head of a long gap (its frames before the bridge, or all
// of it when it runs to the motion's end): taken at the gap's first frame,
// from the observed frame before it and the manifold's frame there.
struct LongGapHead {
  int joint = 0;
  bool has_left = false;  // an observed frame before the gap
  float left[3] = {0, 0, 0}, manifold_left[3] = {0, 0, 0};
  double weight = 0;  // of the manifold's movement since the left border
};
// The head of `gap` (find_joint_gaps() of `observed`): `most_joints`
// whether half the joints or more are missing in the gap's first frame.
LongGapHead long_gap_head(const MotionFrames& observed, const MotionFrames* manifold, const JointGap& gap,
                          const GapFillOptions& options, bool most_joints);
// Writes the head's fill of frame `frame` (the joint's 3 values) into `out`,
// reading the manifold's frame `frame` (null for the methods that lay none).
void fill_long_gap_head_frame(const LongGapHead& head, const MotionFrames* manifold, int64_t frame,
                              const GapFillOptions& options, MotionFrames& out);
// Whether half the joints or more are missing (any of a joint's values NaN)
// in `frame` of `observed`.
bool most_joints_missing(const MotionFrames& observed, int64_t frame);
// The same for one frame's values (`columns` of them, in the layout above).
bool most_joints_missing(const float* values, int columns);

// Geodesic angle (radians, 0..pi) between two rotations given as exponential maps.
double expmap_angle_between(const float* a, const float* b);

}  // namespace mm
