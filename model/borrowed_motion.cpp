#include "model/borrowed_motion.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "format/expmap_slerp.h"

namespace mm {
namespace {

using Quaternion = std::array<double, 4>;  // w, x, y, z

Quaternion quaternion_of(const float* expmap) {
  const double x = expmap[0], y = expmap[1], z = expmap[2];
  const double angle = std::sqrt(x * x + y * y + z * z);
  const double half_sinc = angle < 1e-6 ? 0.5 - angle * angle / 48.0 : std::sin(angle / 2) / angle;
  return {std::cos(angle / 2), x * half_sinc, y * half_sinc, z * half_sinc};
}

// 1 - cos^2 of half the angle between two rotations: 0 alike, 1 opposite,
// blind to q against -q, and cheap (no trigonometry in the search's loop).
double unlikeness(const Quaternion& a, const Quaternion& b) {
  const double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  return 1.0 - dot * dot;
}

bool at_rest(const float* v) { return v[0] == 0 && v[1] == 0 && v[2] == 0; }

// One joint value around or inside the gap to compare with a source's, and
// where the source's is: a context frame at the same offset from the
// source's border as from the gap's, a frame inside the gap at the same
// fraction across the stretched source.
struct Comparison {
  int joint = 0;
  Quaternion target;
  int64_t before = 0;  // context before the gap: -k (source frame start - k)
  int64_t after = -1;  // context after: k >= 0 (source frame start + stretched + k)
  double inside = -1;  // inside the gap: the fraction (f - left) / (right - left)
};

// A take read for the search: its rotations, and which frames are observed whole.
class SearchableTake {
 public:
  SearchableTake(const MotionFrames& observed, double rate_hz, const BorrowOptions& options)
      : observed_(observed),
        options_(options),
        frames_(observed.frame_count()),
        joints_((observed.columns - kRootTranslationValues) / 3),
        context_(std::max<int64_t>(1, std::lround(options.context_seconds * rate_hz))),
        search_(std::max<int64_t>(1, std::lround(options.search_seconds * rate_hz))),
        lookahead_(std::max<int64_t>(0, std::lround(options.lookahead_seconds * rate_hz))),
        // At high rates the search compares and starts every stride-th
        // frame, which keeps its cost that of a 25 Hz take.
        stride_(std::max<int64_t>(1, std::lround(rate_hz / 25.0))),
        reach_before_(std::max<int64_t>(context_ - 1, 2)),
        reach_after_(std::max<int64_t>(context_ - 1, 3)),
        rotations_(static_cast<size_t>(frames_ * std::max(joints_, 0))),
        present_(static_cast<size_t>(frames_ * std::max(joints_, 0))),
        whole_before_(static_cast<size_t>(frames_ + 1), 0) {
    for (int64_t f = 0; f < frames_; ++f) {
      bool whole = true;
      for (int j = 0; j < joints_; ++j) {
        const float* v = observed.frame(f) + kRootTranslationValues + 3 * j;
        const bool seen = !std::isnan(v[0]) && !std::isnan(v[1]) && !std::isnan(v[2]);
        present_[index(f, j)] = seen;
        if (seen) rotations_[index(f, j)] = quaternion_of(v);
        whole = whole && seen;
      }
      whole_before_[static_cast<size_t>(f + 1)] = whole_before_[static_cast<size_t>(f)] + (whole ? 1 : 0);
    }
  }

  bool whole(int64_t from, int64_t to) const {  // inclusive
    return from >= 0 && to < frames_ &&
           whole_before_[static_cast<size_t>(to + 1)] - whole_before_[static_cast<size_t>(from)] == to - from + 1;
  }

  // The best source of `span` (both borders inside the take), searched
  // wholly before its left border and within the search.
  // `part` (may be null: every joint) limits the joints compared.
  BorrowedSpan search(const FrameSpan& span, const std::vector<int>* part) const {
    BorrowedSpan record;
    record.span = span;
    const int64_t left = span.first - 1, right = span.last + 1;
    const int64_t across = right - left;
    // The gap's values to compare: every joint but the root (whose rotation
    // carries the heading, which differs from one pass of a walk to the
    // next, and which the fill takes from the borders) and those at rest
    // (a skeleton's unanimated joints, all zeros), in the context on both
    // sides and, where observed, inside the gap.
    std::vector<Comparison> compared;
    const auto add = [&](int64_t f, Comparison c) {
      if (f < 0 || f >= frames_) return;
      for (int j = 1; j < joints_; ++j) {
        if (part && std::find(part->begin(), part->end(), j) == part->end()) continue;
        if (!present_[index(f, j)] || at_rest(observed_.frame(left) + kRootTranslationValues + 3 * j)) continue;
        c.joint = j;
        c.target = rotations_[index(f, j)];
        compared.push_back(c);
      }
    };
    for (int64_t k = 0; k < context_; k += stride_) {
      Comparison before;
      before.before = -k;
      add(left - k, before);
      Comparison after;
      after.after = k;
      add(right + k, after);
    }
    for (int64_t f = span.first; f <= span.last; f += stride_) {
      Comparison inside;
      inside.inside = static_cast<double>(f - left) / static_cast<double>(across);
      add(f, inside);
    }
    if (compared.empty()) return record;
    const auto count = static_cast<double>(compared.size());
    double best = std::numeric_limits<double>::infinity();
    const int64_t shortest = std::max<int64_t>(2, static_cast<int64_t>(std::ceil(options_.min_stretch * across)));
    const int64_t longest = static_cast<int64_t>(std::floor(options_.max_stretch * across));
    const int64_t step = std::max<int64_t>(stride_, std::lround(options_.stretch_step * static_cast<double>(across)));
    const int64_t earliest = std::max(reach_before_, left - search_ + reach_before_);
    std::vector<int64_t> offsets(compared.size());
    for (int64_t stretched = shortest; stretched <= longest; stretched += step) {
      for (size_t i = 0; i < compared.size(); ++i) {
        const Comparison& c = compared[i];
        offsets[i] = c.inside >= 0 ? std::lround(c.inside * static_cast<double>(stretched))
                     : c.after >= 0 ? stretched + c.after
                                    : c.before;
      }
      // Before the gap from the latest start back, then after it up to the
      // lookahead, on grids fixed to the gap's borders: a streamed take
      // holding only the search's frames and the lookahead tries the same
      // starts in the same order.
      std::vector<int64_t> starts;
      for (int64_t start = left - reach_after_ - stretched; start >= earliest; start -= stride_) starts.push_back(start);
      for (int64_t start = right + reach_before_; start + stretched + reach_after_ <= right + lookahead_; start += stride_) {
        starts.push_back(start);
      }
      for (int64_t start : starts) {
        if (!whole(start - reach_before_, start + stretched + reach_after_)) continue;
        double cost = 0;
        for (size_t i = 0; i < compared.size() && cost < best * count; ++i) {
          cost += unlikeness(compared[i].target, rotations_[index(start + offsets[i], compared[i].joint)]);
        }
        cost /= count;
        if (cost < best) {
          best = cost;
          record.found = true;
          record.source_left = start;
          record.source_frames = stretched;
          record.cost = cost;
        }
      }
    }
    return record;
  }

 private:
  size_t index(int64_t f, int j) const { return static_cast<size_t>(f * joints_ + j); }

  const MotionFrames& observed_;
  BorrowOptions options_;
  int64_t frames_;
  int joints_;
  int64_t context_, search_, lookahead_, stride_, reach_before_, reach_after_;
  std::vector<Quaternion> rotations_;
  std::vector<char> present_;
  std::vector<int64_t> whole_before_;  // whole frames among 0..f-1
};

// Writes `source`'s frames, stretched, into `donor`'s frames left - 1 ..
// right + 1 of its span (those the fill reads), for the joints of `part`
// (null: every joint).
void write_source(const MotionFrames& observed, const BorrowedSpan& source, const std::vector<int>* part,
                  MotionFrames& donor) {
  const int64_t frames = observed.frame_count();
  const int joints = (observed.columns - kRootTranslationValues) / 3;
  const int64_t left = source.span.first - 1, right = source.span.last + 1;
  const double scale = static_cast<double>(source.source_frames) / static_cast<double>(right - left);
  for (int64_t f = std::max<int64_t>(0, left - 1); f <= std::min(frames - 1, right + 1); ++f) {
    const double at = static_cast<double>(source.source_left) + static_cast<double>(f - left) * scale;
    const auto below = static_cast<int64_t>(std::floor(at));
    for (int j = 0; j < joints; ++j) {
      if (part && std::find(part->begin(), part->end(), j) == part->end()) continue;
      const int column = kRootTranslationValues + 3 * j;
      slerp_expmap(observed.frame(below) + column, observed.frame(below + 1) + column, at - static_cast<double>(below),
                   donor.frame(f) + column);
    }
  }
}

}  // namespace

std::vector<std::vector<int>> body_parts(const Skeleton& skeleton) {
  const int n = skeleton.joint_count();
  if (n < 2) return {};
  std::vector<std::vector<int>> children(static_cast<size_t>(n));
  for (int j = 1; j < n; ++j) children[static_cast<size_t>(skeleton.joints[static_cast<size_t>(j)].parent)].push_back(j);
  // The pelvis: the first joint from the root with more than one child.
  int pelvis = 0;
  while (children[static_cast<size_t>(pelvis)].size() == 1) pelvis = children[static_cast<size_t>(pelvis)].front();
  const auto& branches = children[static_cast<size_t>(pelvis)];
  if (branches.size() < 2) return {};
  // Each joint's branch below the pelvis (-1: the pelvis and above it).
  std::vector<int> branch(static_cast<size_t>(n), -1);
  std::vector<int> size(static_cast<size_t>(n), 0);
  for (int j = 1; j < n; ++j) {
    const int parent = skeleton.joints[static_cast<size_t>(j)].parent;
    branch[static_cast<size_t>(j)] = parent == pelvis ? j : branch[static_cast<size_t>(parent)];
    if (branch[static_cast<size_t>(j)] >= 0) ++size[static_cast<size_t>(branch[static_cast<size_t>(j)])];
  }
  const int upper = *std::max_element(branches.begin(), branches.end(), [&](int a, int b) {
    return size[static_cast<size_t>(a)] < size[static_cast<size_t>(b)];
  });
  std::vector<std::vector<int>> parts(2);  // the legs with the pelvis and above it, the upper body
  for (int j = 0; j < n; ++j) parts[branch[static_cast<size_t>(j)] == upper ? 1 : 0].push_back(j);
  return parts;
}

MotionFrames borrow_take_motion(const MotionFrames& observed, double rate_hz, const BorrowOptions& options,
                                int64_t needed_from, std::vector<BorrowedSpan>* spans) {
  MotionFrames donor = observed;
  if (spans) spans->clear();
  const int64_t frames = observed.frame_count();
  if (frames == 0 || observed.columns <= kRootTranslationValues) return donor;
  std::vector<FrameSpan> searched;
  for (const FrameSpan& span : find_missing_spans(observed)) {
    // A span at either end has one border: held, nothing to borrow between.
    if (span.first < 1 || span.last + 1 >= frames || span.last < needed_from) continue;
    const auto seconds = static_cast<double>(span.length()) / rate_hz;
    if (seconds >= options.min_seconds - 1e-9 && seconds <= options.max_span_seconds) searched.push_back(span);
  }
  // The take path calls this at every hand-out: a take with nothing to
  // search costs no reading of its rotations.
  if (searched.empty()) return donor;
  const SearchableTake searchable(observed, rate_hz, options);
  for (const FrameSpan& span : searched) {
    // The whole body first: one stretch keeps the arms in step with the legs.
    BorrowedSpan record = searchable.search(span, nullptr);
    record.used = record.found && record.cost <= options.max_cost;
    if (record.used) write_source(observed, record, nullptr, donor);
    if (spans) spans->push_back(record);
    if (record.used) continue;
    for (size_t p = 0; p < options.parts.size(); ++p) {
      const std::vector<int>& part = options.parts[p];
      BorrowedSpan record = searchable.search(span, &part);
      record.part = static_cast<int>(p);
      record.used = record.found && record.cost <= options.part_max_cost;
      if (record.used) write_source(observed, record, &part, donor);
      if (spans) spans->push_back(record);
    }
  }
  return donor;
}

}  // namespace mm
