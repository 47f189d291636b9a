#include "model/gap_evaluation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <set>

#include "format/foot_contacts.h"
#include "format/input_error.h"
#include "model/borrowed_motion.h"
#include "model/gap_code_fit.h"
#include "model/take_processor.h"
#include "model/take_windows.h"

namespace mm {
namespace {

constexpr double kRate = kTakeModelRate;
// The methods the tables show, then the fitted fill at fixed detail
// weights, then with its weights and the speed-matched gain in other
// ranges (the JSON's, for choosing them on training subjects).
constexpr int kShown = 9, kFixedWeights = 5, kMethods = 33;
// The fitted codes' frames as they are, and their detail at full weight.
constexpr int kFitRaw = 5, kFitFull = 6;
// The borrowed fill (borrowed_motion.h) with its defaults, and with every
// source taken whatever its cost (the JSON's, for choosing the cost bound),
// then with the detail's slow movement taken out (of the sources' and the
// fitted fallback's, or of the fallback's alone, at its weights or at full
// weight) and a speed gain on the fallback (the JSON's, for choosing
// GapFillOptions::detail_lowcut_seconds).
constexpr int kBorrowed = 8, kBorrowedUngated = 21, kLowcut = 22;
// Then the borrowed fill with every fitted window laying its detail, none
// bounded by its error on its observed values (GapCodeFitOptions::max_observed_error).
constexpr int kFitUnbounded = 28;
// Then the borrowed fill searching the whole body alone, the legs and the
// upper body alone, and both at other bounds for the parts
// (BorrowOptions::parts and part_max_cost; the JSON's, for choosing them).
constexpr int kParts = 29, kPartVariants = 4;
const char* const kMethodNames[kMethods] = {
    "hold",          "slerp",           "cubic",          "manifold",        "matched",
    "fit_raw",       "fit_full",        "fitted",         "borrowed",        "detail_0",
    "detail_0.25",   "detail_0.5",      "detail_0.75",    "detail_1",        "speed_0.5_1.5",
    "speed_0.5_2",   "shared_0.5_1.5",  "shared_0.5_2",   "shared_1_2",      "shared_0.75_1.5",
    "shared_0.5_3",  "borrow_ungated",  "borrowed_lowcut_1", "fallback_lowcut_1", "fallback_lowcut_1_full",
    "fallback_lowcut_1_full_gain_1_2", "fallback_lowcut_1_full_gain_1_3", "fallback_lowcut_0.5_full",
    "borrowed_no_fit_bound", "borrowed_whole_body", "borrowed_parts_only", "borrowed_parts_0.0025",
    "borrowed_parts_0.0075"};
// Those columns: whether the whole body is searched first, whether the
// parts are searched where it finds nothing like enough, and their bound
// (the whole body alone is the borrowed fill as it was; the parts alone
// search no whole body first).
struct PartVariant {
  bool whole_body, parts;
  double part_max_cost;
};
constexpr PartVariant kPartVariantList[kPartVariants] = {
    {true, false, 0.005}, {false, true, 0.005}, {true, true, 0.0025}, {true, true, 0.0075}};
// The low-cut period (s, 0: none) of the fitted fallback's detail and of
// the sources', whether the fallback lays its detail at full weight, and
// the fallback's speed gain.
struct LowcutVariant {
  double fallback_seconds, source_seconds;
  bool full_weight;
  std::array<double, 2> gain;
};
constexpr LowcutVariant kLowcutVariants[kFitUnbounded - kLowcut] = {
    {1.0, 1.0, false, {1.0, 1.0}}, {1.0, 0.0, false, {1.0, 1.0}}, {1.0, 0.0, true, {1.0, 1.0}},
    {1.0, 0.0, true, {1.0, 2.0}},  {1.0, 0.0, true, {1.0, 3.0}},  {0.5, 0.0, true, {1.0, 1.0}}};
// The speed-matched gain's range, and whether a gap's joints share it.
struct SpeedGainVariant {
  std::array<double, 2> range;
  bool shared;
};
constexpr SpeedGainVariant kSpeedGainVariants[kBorrowedUngated - kShown - kFixedWeights] = {
    {{0.5, 1.5}, false}, {{0.5, 2.0}, false}, {{0.5, 1.5}, true}, {{0.5, 2.0}, true},
    {{1.0, 2.0}, true},  {{0.75, 1.5}, true}, {{0.5, 3.0}, true}};

struct Config {
  double seconds = 0;
  int joints = 0;  // 0: every joint
};

std::string config_joints_name(int joints) { return joints == 0 ? "every joint" : std::to_string(joints) + (joints == 1 ? " joint" : " joints"); }

struct PlacedGap {
  size_t config = 0;
  std::vector<int> joints;
  int64_t first = 0, last = 0;
};

// Sums of one method's measures over gaps, pooled as each measure needs.
struct Sums {
  int64_t gaps = 0;
  double mpjpe = 0, angle = 0, jump_ratio = 0, jump_mm = 0, median_move = 0;
  int64_t over_limit = 0;       // gaps whose border jump exceeds 1.5x the median move
  // The recording's own move at the same frames, over the same median: what
  // a fill that continues the motion without a pop jumps by.
  double recorded_jump_ratio = 0;
  int64_t recorded_over_limit = 0;
  double moved = 0, moved_recorded = 0;  // mm over the gap's transitions
  SkatingCount skating, skating_recorded;
  void add(const Sums& o) {
    gaps += o.gaps;
    mpjpe += o.mpjpe;
    angle += o.angle;
    jump_ratio += o.jump_ratio;
    jump_mm += o.jump_mm;
    median_move += o.median_move;
    over_limit += o.over_limit;
    recorded_jump_ratio += o.recorded_jump_ratio;
    recorded_over_limit += o.recorded_over_limit;
    moved += o.moved;
    moved_recorded += o.moved_recorded;
    skating.skating += o.skating.skating;
    skating.frames += o.skating.frames;
    skating_recorded.skating += o.skating_recorded.skating;
    skating_recorded.frames += o.skating_recorded.frames;
  }
  nlohmann::json json() const {
    const double n = std::max<double>(1, static_cast<double>(gaps));
    return {{"gaps", gaps},
            {"mpjpe_mm", mpjpe / n},
            {"angle_error_deg", angle / n},
            {"border_jump_mm", jump_mm / n},
            {"median_move_mm", median_move / n},
            {"border_jump_ratio", jump_ratio / n},
            {"border_jump_over_1_5_share", static_cast<double>(over_limit) / n},
            {"recorded_border_jump_ratio", recorded_jump_ratio / n},
            {"recorded_border_jump_over_1_5_share", static_cast<double>(recorded_over_limit) / n},
            {"speed_ratio", moved_recorded > 0 ? moved / moved_recorded : 0.0},
            {"skating_ratio", skating.ratio()},
            {"recorded_skating_ratio", skating_recorded.ratio()}};
  }
};

double distance(const Vec3& a, const Vec3& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

// Joint positions of frames [first, last] (frame-major, joint_count each).
std::vector<Vec3> positions_of(const Skeleton& skeleton, const MotionFrames& motion, int64_t first, int64_t last) {
  std::vector<Vec3> positions;
  positions.reserve(static_cast<size_t>((last - first + 1) * skeleton.joint_count()));
  for (int64_t f = first; f <= last; ++f) {
    const auto pose = pose_positions(skeleton, motion.frame(f));
    positions.insert(positions.end(), pose.begin(), pose.end());
  }
  return positions;
}

// Mean over `joints` of the move between two frames' positions.
double mean_move(const std::vector<Vec3>& p, int joint_count, int64_t a, int64_t b, const std::vector<int>& joints) {
  double sum = 0;
  for (int j : joints) sum += distance(p[static_cast<size_t>(a * joint_count + j)], p[static_cast<size_t>(b * joint_count + j)]);
  return sum / static_cast<double>(std::max<size_t>(1, joints.size()));
}

MotionFrames slice(const MotionFrames& motion, int64_t first, int64_t last) {
  MotionFrames part;
  part.columns = motion.columns;
  part.values.assign(motion.frame(first), motion.frame(last) + motion.columns);
  return part;
}

std::string number(double value, const char* format = "%.1f") {
  char text[32];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

}  // namespace

GapBenchmarkResult run_gap_benchmark(const MotionManifold& model, const std::vector<GapBenchmarkTake>& takes,
                                     const GapBenchmarkOptions& options) {
  const Skeleton& skeleton = model.skeleton();
  const int joint_count = skeleton.joint_count();
  // The fills as the take path gives them: the borrowed fill searching the
  // model's legs and upper body apart.
  GapFillOptions fill = options.fill;
  fill.borrow.parts = body_parts(skeleton);
  std::vector<Config> configs;
  for (int joints : options.joint_counts) {
    for (double seconds : options.gap_seconds) configs.push_back({seconds, joints});
  }
  // Joints a gap of a few joints may take: animated (a kept column), not
  // the root, and moving some joint below them.
  std::set<int> animated;
  for (int c : model.normalization().kept_columns) {
    if (c >= kRootTranslationValues) animated.insert((c - kRootTranslationValues) / 3);
  }
  std::vector<std::vector<int>> descendants(static_cast<size_t>(joint_count));
  for (int j = joint_count - 1; j > 0; --j) {
    const int parent = skeleton.joints[static_cast<size_t>(j)].parent;
    const auto& o = skeleton.joints[static_cast<size_t>(j)].offset_mm;
    if (o[0] != 0 || o[1] != 0 || o[2] != 0) descendants[static_cast<size_t>(parent)].push_back(j);
    for (int d : descendants[static_cast<size_t>(j)]) descendants[static_cast<size_t>(parent)].push_back(d);
  }
  std::vector<int> candidates;
  for (int j : animated) {
    if (j > 0 && !descendants[static_cast<size_t>(j)].empty()) candidates.push_back(j);
  }
  std::vector<int> every_joint(static_cast<size_t>(joint_count));
  for (int j = 0; j < joint_count; ++j) every_joint[static_cast<size_t>(j)] = j;
  std::vector<int> moved_by_every;
  for (int j = 1; j < joint_count; ++j) moved_by_every.push_back(j);

  std::mt19937_64 engine(options.seed);
  std::vector<size_t> deck;
  size_t deck_next = 0;
  auto next_config = [&] {
    if (deck_next == deck.size()) {
      deck.resize(configs.size());
      for (size_t i = 0; i < deck.size(); ++i) deck[i] = i;
      std::shuffle(deck.begin(), deck.end(), engine);
      deck_next = 0;
    }
    return deck[deck_next++];
  };

  // [config][method] overall and per action.
  std::vector<std::array<Sums, kMethods>> overall(configs.size());
  std::map<std::string, std::vector<std::array<Sums, kMethods>>> per_action;
  int64_t total_gaps = 0;
  nlohmann::json gap_records = nlohmann::json::array();
  const auto spacing = static_cast<int64_t>(std::lround(options.spacing_seconds * kRate));
  const int64_t margin = static_cast<int64_t>(kRate);  // 1 s of recording before the first gap and after the last

  for (const auto& take : takes) {
    if (per_action.find(take.action) == per_action.end()) per_action[take.action].resize(configs.size());
    const int64_t frames = take.frames.frame_count();
    const auto recorded_positions = positions_of(skeleton, take.frames, 0, frames - 1);
    for (int round = 0; round < options.rounds; ++round) {
      // Place this run's gaps.
      std::vector<PlacedGap> gaps;
      MotionFrames corrupted = take.frames;
      std::uniform_int_distribution<int64_t> jitter(0, static_cast<int64_t>(2 * kRate));
      int64_t at = margin + jitter(engine);
      while (true) {
        const size_t config = next_config();
        const auto length = std::max<int64_t>(1, std::lround(configs[config].seconds * kRate));
        if (at + length + margin > frames) break;
        PlacedGap gap{config, {}, at, at + length - 1};
        if (configs[config].joints == 0) {
          gap.joints = every_joint;
        } else {
          std::vector<int> pool = candidates;
          std::shuffle(pool.begin(), pool.end(), engine);
          pool.resize(std::min<size_t>(pool.size(), static_cast<size_t>(configs[config].joints)));
          std::sort(pool.begin(), pool.end());
          gap.joints = pool;
        }
        for (int64_t f = gap.first; f <= gap.last; ++f) {
          for (int j : gap.joints) {
            std::fill_n(corrupted.frame(f) + kRootTranslationValues + 3 * j, 3, std::numeric_limits<float>::quiet_NaN());
          }
        }
        gaps.push_back(gap);
        at = gap.last + 1 + spacing + jitter(engine);
      }
      if (gaps.empty()) continue;
      // The manifold's output for the whole run (keep_observed off: the
      // decoded frames everywhere, which the matched fills read at the borders).
      TakeOptions take_options;
      take_options.operation = TakeOperation::kDenoise;
      take_options.frame_rate = kRate;
      take_options.at_model_rate = true;
      take_options.decoder = options.decoder;
      const TakeResult decoded = process_take(model, corrupted, take_options);
      // The code fitted to each gap's centred window (gap_code_fit.h), every
      // window's clip written (what the fitted codes give as they are, and
      // the fixed weights' columns), and as options.code_fit's bound on the
      // fit's error leaves them (the default fills').
      std::vector<GapFitWindow> fit_windows;
      GapCodeFitOptions unbounded_fit = options.code_fit;
      unbounded_fit.max_observed_error = std::numeric_limits<double>::infinity();
      const MotionFrames fitted =
          fit_gap_codes(model, corrupted, decoded.frames, options.decoder, unbounded_fit, nullptr, &fit_windows);
      MotionFrames bounded = fitted;
      std::vector<bool> bounded_written(static_cast<size_t>(frames), false);
      for (GapFitWindow& window : fit_windows) {
        window.lays_detail = window_lays_detail(window, corrupted.frame(window.start), corrupted.columns, options.code_fit);
        // Its gaps written missing: no clip read.
        if (!window.lays_detail) write_fitted_window(window, nullptr, model.config().frames, true, bounded, 0, bounded_written);
      }
      // Where each span's movement would be borrowed from, and at what
      // cost: the whole body's source, and each body part's (no whole-body
      // source taken, so that every part is searched).
      std::vector<BorrowedSpan> borrowed_spans;
      BorrowOptions every_search = fill.borrow;
      every_search.max_cost = -1;
      borrow_take_motion(corrupted, kRate, every_search, 0, &borrowed_spans);
      GapFillOptions method_options[kMethods];
      for (auto& o : method_options) {
        o.max_tangent_seconds = options.fill.max_tangent_seconds;
        o.speed_gain_range = {1.0, 1.0};  // the detail's weight as it is, but for the fitted fill's own
      }
      method_options[0].method = GapMethod::kHold;
      method_options[1].method = GapMethod::kSlerp;
      method_options[2].method = GapMethod::kCubic;
      method_options[3].method = GapMethod::kManifold;
      // The matched fill before the fitted codes: the take's windows'
      // movement over the cubic, from none up to 0.6 s to full from 2 s.
      method_options[4].method = GapMethod::kMatched;
      method_options[4].interpolate_below_seconds = 0.6;
      method_options[4].few_joints_detail = method_options[4].most_joints_detail = {0.4 / 1.4, 1.0, 1.0};
      method_options[kFitRaw].method = GapMethod::kManifold;
      method_options[kFitFull].method = GapMethod::kMatched;
      method_options[kFitFull].interpolate_below_seconds = 0;
      method_options[kFitFull].few_joints_detail = method_options[kFitFull].most_joints_detail = {1.0, 1.0, 1.0};
      method_options[7] = options.fill;
      method_options[7].method = GapMethod::kMatched;
      method_options[kBorrowed] = fill;
      method_options[kBorrowed].method = GapMethod::kBorrowed;
      method_options[kBorrowedUngated] = method_options[kBorrowed];
      method_options[kBorrowedUngated].borrow.max_cost = std::numeric_limits<double>::infinity();
      method_options[kFitUnbounded] = method_options[kBorrowed];
      for (int m = kParts; m < kParts + kPartVariants; ++m) {
        const PartVariant& variant = kPartVariantList[m - kParts];
        method_options[m] = method_options[kBorrowed];
        if (!variant.whole_body) method_options[m].borrow.max_cost = -1;  // no cost is below it
        if (!variant.parts) method_options[m].borrow.parts.clear();
        method_options[m].borrow.part_max_cost = variant.part_max_cost;
      }
      for (int m = kLowcut; m < kFitUnbounded; ++m) {
        const LowcutVariant& variant = kLowcutVariants[m - kLowcut];
        method_options[m] = method_options[kBorrowed];
        method_options[m].detail_lowcut_seconds = variant.fallback_seconds;
        method_options[m].borrow.detail_lowcut_seconds = variant.source_seconds;
        if (variant.full_weight) method_options[m].most_joints_detail = {1.0, 1.0, 1.0};
        method_options[m].speed_gain_range = variant.gain;
      }
      for (int m = kShown + kFixedWeights; m < kBorrowedUngated; ++m) {
        method_options[m] = options.fill;
        method_options[m].method = GapMethod::kMatched;
        method_options[m].speed_gain_range = kSpeedGainVariants[m - kShown - kFixedWeights].range;
        method_options[m].speed_gain_shared = kSpeedGainVariants[m - kShown - kFixedWeights].shared;
      }
      for (int m = kShown; m < kShown + kFixedWeights; ++m) {
        const double w = 0.25 * (m - kShown);
        method_options[m].method = GapMethod::kMatched;
        method_options[m].interpolate_below_seconds = 0;
        method_options[m].few_joints_detail = method_options[m].most_joints_detail = {w, w, w};
      }
      MotionFrames filled[kMethods];
      for (int m = 0; m < kMethods; ++m) {
        const bool reads_unbounded =
            m == kFitRaw || m == kFitFull || (m >= kShown && m < kShown + kFixedWeights) || m == kFitUnbounded;
        filled[m] = fill_gaps(corrupted, m < 5 ? &decoded.frames : reads_unbounded ? &fitted : &bounded, method_options[m], kRate);
      }

      for (const PlacedGap& gap : gaps) {
        ++total_gaps;
        const bool every = configs[gap.config].joints == 0;
        std::vector<int> moved_joints;
        if (every) {
          moved_joints = moved_by_every;
        } else {
          std::set<int> set;
          for (int j : gap.joints) set.insert(descendants[static_cast<size_t>(j)].begin(), descendants[static_cast<size_t>(j)].end());
          moved_joints.assign(set.begin(), set.end());
        }
        // The take's median move of these joints, per frame.
        std::vector<double> moves;
        for (int64_t f = 1; f < frames; ++f) moves.push_back(mean_move(recorded_positions, joint_count, f - 1, f, moved_joints));
        std::nth_element(moves.begin(), moves.begin() + static_cast<std::ptrdiff_t>(moves.size() / 2), moves.end());
        const double median_move = moves[moves.size() / 2];
        const int64_t left = gap.first - 1, right = gap.last + 1;
        const int64_t context_first = std::max<int64_t>(0, left - static_cast<int64_t>(kRate));
        const int64_t context_last = std::min<int64_t>(frames - 1, right + static_cast<int64_t>(kRate));
        const SkatingCount recorded_skating = skating_ratio(skeleton, slice(take.frames, context_first, context_last), kRate);
        double recorded_moved = 0;
        for (int64_t f = left; f < right; ++f) recorded_moved += mean_move(recorded_positions, joint_count, f, f + 1, moved_joints);
        const double recorded_jump = std::max(mean_move(recorded_positions, joint_count, left, left + 1, moved_joints),
                                              mean_move(recorded_positions, joint_count, right - 1, right, moved_joints));
        const double recorded_jump_ratio = recorded_jump / std::max(median_move, 1e-6);
        // One row a gap (the JSON's gap_records): where it is, how well its
        // window's fitted code met the observed values, and the MPJPE and
        // speed ratio of each method and fixed detail weight, for choosing
        // weights on some takes and measuring them on others.
        nlohmann::json record = {{"take", take.name},
                                 {"action", take.action},
                                 {"first", gap.first},
                                 {"seconds", configs[gap.config].seconds},
                                 {"joints", configs[gap.config].joints}};
        for (const GapFitWindow& window : fit_windows) {
          for (const FrameSpan& span : window.spans) {
            if (span.first <= gap.first && gap.last <= span.last) {
              record["fit_observed_error"] = window.observed_error;
              record["fit_lays_detail"] = window.lays_detail;
            }
          }
        }
        for (const BorrowedSpan& span : borrowed_spans) {
          if (!(span.span.first <= gap.first && gap.last <= span.span.last && span.found)) continue;
          if (span.part >= 0) {
            record["part_borrow_costs"][std::to_string(span.part)] = span.cost;
          } else {
            record["borrow_cost"] = span.cost;
            record["borrow_source"] = {span.source_left, span.source_frames};
          }
        }
        for (int m = 0; m < kMethods; ++m) {
          const auto p = positions_of(skeleton, filled[m], left, right);  // frame 0 is `left`
          Sums s;
          s.gaps = 1;
          double error = 0, angle = 0;
          for (int64_t f = gap.first; f <= gap.last; ++f) {
            for (int j : moved_joints) {
              error += distance(p[static_cast<size_t>((f - left) * joint_count + j)],
                                recorded_positions[static_cast<size_t>(f * joint_count + j)]);
            }
            for (int j : gap.joints) {
              const int column = kRootTranslationValues + 3 * j;
              angle += expmap_angle_between(filled[m].frame(f) + column, take.frames.frame(f) + column);
            }
          }
          const double gap_frames = static_cast<double>(gap.last - gap.first + 1);
          s.mpjpe = error / (gap_frames * static_cast<double>(moved_joints.size()));
          s.angle = angle / (gap_frames * static_cast<double>(gap.joints.size())) * 180.0 / M_PI;
          const double jump_in = mean_move(p, joint_count, 0, 1, moved_joints);
          const double jump_out = mean_move(p, joint_count, right - left - 1, right - left, moved_joints);
          s.jump_mm = std::max(jump_in, jump_out);
          s.median_move = median_move;
          s.jump_ratio = s.jump_mm / std::max(median_move, 1e-6);
          s.over_limit = s.jump_ratio > 1.5 ? 1 : 0;
          s.recorded_jump_ratio = recorded_jump_ratio;
          s.recorded_over_limit = recorded_jump_ratio > 1.5 ? 1 : 0;
          for (int64_t f = 0; f < right - left; ++f) s.moved += mean_move(p, joint_count, f, f + 1, moved_joints);
          s.moved_recorded = recorded_moved;
          s.skating = skating_ratio(skeleton, slice(filled[m], context_first, context_last), kRate);
          s.skating_recorded = recorded_skating;
          overall[gap.config][static_cast<size_t>(m)].add(s);
          per_action[take.action][gap.config][static_cast<size_t>(m)].add(s);
          if (m < kShown + kFixedWeights || m >= kBorrowedUngated) {
            record[kMethodNames[m]] = {{"mpjpe_mm", s.mpjpe},
                                       {"speed_ratio", s.moved_recorded > 0 ? s.moved / s.moved_recorded : 0.0}};
          }
        }
        gap_records.push_back(std::move(record));
      }
    }
  }
  if (total_gaps == 0) throw InputError("takes", "none is long enough to hold a gap with 1 s of recording on each side");

  // JSON: every configuration's methods, overall and per action.
  nlohmann::json config_rows = nlohmann::json::array();
  for (size_t c = 0; c < configs.size(); ++c) {
    nlohmann::json methods = nlohmann::json::object(), actions = nlohmann::json::object();
    for (int m = 0; m < kMethods; ++m) methods[kMethodNames[m]] = overall[c][static_cast<size_t>(m)].json();
    for (const auto& [action, sums] : per_action) {
      nlohmann::json a = nlohmann::json::object();
      for (int m = 0; m < kMethods; ++m) a[kMethodNames[m]] = sums[c][static_cast<size_t>(m)].json();
      actions[action] = a;
    }
    config_rows.push_back({{"gap_seconds", configs[c].seconds},
                           {"joints", configs[c].joints == 0 ? nlohmann::json("every") : nlohmann::json(configs[c].joints)},
                           {"methods", methods},
                           {"actions", actions}});
  }
  nlohmann::json document = {
      {"takes", takes.size()},
      {"rounds", options.rounds},
      {"seed", options.seed},
      {"spacing_seconds", options.spacing_seconds},
      {"gaps", total_gaps},
      {"rate_hz", kRate},
      {"decoder", decoder_name(options.decoder)},
      {"fitted_fill",
       {{"interpolate_below_seconds", options.fill.interpolate_below_seconds},
        {"few_joints_detail_at_1_2_4_seconds", options.fill.few_joints_detail},
        {"most_joints_detail_at_1_2_4_seconds", options.fill.most_joints_detail},
        {"speed_gain_range", options.fill.speed_gain_range},
        {"speed_context_seconds", options.fill.speed_context_seconds},
        {"speed_gain_shared", options.fill.speed_gain_shared},
        {"code_fit_iterations", options.code_fit.iterations},
        {"code_fit_min_seconds", options.code_fit.min_seconds},
        {"code_fit_max_observed_error", std::isfinite(options.code_fit.max_observed_error)
                                            ? nlohmann::json(options.code_fit.max_observed_error)
                                            : nlohmann::json(nullptr)}}},
      {"configurations", config_rows},
      {"gap_records", gap_records}};

  // Markdown: one table per measure, configurations by method, then the
  // every-joint gaps per action.
  std::string md;
  // `recorded_key`: the recording's own value of the measure, in a column
  // before the methods'.
  auto table = [&](const char* title, const char* key, const char* format, const char* recorded_key = nullptr) {
    md += std::string("\n") + title + "\n\n| joints | gap (s) | gaps |" + (recorded_key ? " recording |" : "");
    for (int m = 0; m < kShown; ++m) md += std::string(" ") + kMethodNames[m] + " |";
    md += std::string("\n|---|---:|---:|") + (recorded_key ? "---:|" : "");
    for (int m = 0; m < kShown; ++m) md += "---:|";
    md += "\n";
    for (size_t c = 0; c < configs.size(); ++c) {
      md += "| " + config_joints_name(configs[c].joints) + " | " + number(configs[c].seconds) + " | " +
            std::to_string(overall[c][0].gaps) + " |";
      if (recorded_key) md += " " + number(overall[c][0].json()[recorded_key].get<double>(), format) + " |";
      for (int m = 0; m < kShown; ++m) md += " " + number(overall[c][static_cast<size_t>(m)].json()[key].get<double>(), format) + " |";
      md += "\n";
    }
  };
  table("MPJPE on the gap frames (mm, joints the missing rotations move):", "mpjpe_mm", "%.1f");
  table("Joint-angle error of the missing joints (degrees):", "angle_error_deg", "%.1f");
  table("Border jump, the larger of into and out of the gap, over the take's median move of the same joints "
        "(recording: the recording's own move at the same frames):",
        "border_jump_ratio", "%.2f", "recorded_border_jump_ratio");
  table("Share of gaps whose border jump exceeds 1.5x the take's median move:", "border_jump_over_1_5_share", "%.2f",
        "recorded_border_jump_over_1_5_share");
  table("Speed ratio: the joints' movement across the gap over the recording's:", "speed_ratio", "%.2f");
  table("Foot-skating ratio of the gap with 1 s each side (the recording's beside it in the JSON):", "skating_ratio",
        "%.3f");
  for (size_t c = 0; c < configs.size(); ++c) {
    if (configs[c].joints != 0 || configs[c].seconds < 2.0) continue;
    md += "\nEvery joint missing for " + number(configs[c].seconds) + " s, per action: MPJPE (mm) / speed ratio\n\n| action | gaps |";
    for (int m = 0; m < kShown; ++m) md += std::string(" ") + kMethodNames[m] + " |";
    md += "\n|---|---:|";
    for (int m = 0; m < kShown; ++m) md += "---|";
    md += "\n";
    for (const auto& [action, sums] : per_action) {
      md += "| " + action + " | " + std::to_string(sums[c][0].gaps) + " |";
      for (int m = 0; m < kShown; ++m) {
        const auto j = sums[c][static_cast<size_t>(m)].json();
        md += " " + number(j["mpjpe_mm"].get<double>()) + " / " + number(j["speed_ratio"].get<double>(), "%.2f") + " |";
      }
      md += "\n";
    }
  }
  return {document.dump(2) + "\n", md};
}

GapBenchmarkResult run_keyframe_benchmark(const MotionManifold& model, const std::vector<GapBenchmarkTake>& takes,
                                          const KeyframeBenchmarkOptions& options) {
  constexpr int kKeyMethods = 4;
  const char* const key_method_names[kKeyMethods] = {"slerp", "cubic", "manifold", "fitted"};
  const Skeleton& skeleton = model.skeleton();
  const int joint_count = skeleton.joint_count();
  std::vector<int> moved;
  for (int j = 1; j < joint_count; ++j) moved.push_back(j);
  const int64_t window = model.config().frames;
  // [interval][method], and per action.
  std::vector<std::array<Sums, kKeyMethods>> overall(options.intervals.size());
  std::map<std::string, std::vector<std::array<Sums, kKeyMethods>>> per_action;
  std::vector<double> key_error_deg(options.intervals.size(), 0.0);
  int used_takes = 0;
  for (const auto& take : takes) {
    const int64_t frames =
        std::min<int64_t>(take.frames.frame_count(), static_cast<int64_t>(std::lround(options.take_seconds * kRate)));
    if (frames < window) continue;
    ++used_takes;
    if (per_action.find(take.action) == per_action.end()) per_action[take.action].resize(options.intervals.size());
    const MotionFrames recorded = slice(take.frames, 0, frames - 1);
    const auto recorded_positions = positions_of(skeleton, recorded, 0, frames - 1);
    for (size_t i = 0; i < options.intervals.size(); ++i) {
      const auto every = std::max<int64_t>(2, std::lround(options.intervals[i] * kRate));
      MotionFrames keyed = recorded;
      for (int64_t f = 0; f < frames; ++f) {
        if (f % every == 0 || f == frames - 1) continue;
        std::fill_n(keyed.frame(f) + kRootTranslationValues, keyed.columns - kRootTranslationValues,
                    std::numeric_limits<float>::quiet_NaN());
      }
      TakeOptions take_options;
      take_options.operation = TakeOperation::kDenoise;
      take_options.frame_rate = kRate;
      take_options.at_model_rate = true;
      take_options.decoder = options.decoder;
      const TakeResult decoded = process_take(model, keyed, take_options);
      const MotionFrames fitted = fit_gap_codes(model, keyed, decoded.frames, options.decoder, options.code_fit);
      GapFillOptions method_options[kKeyMethods];
      for (auto& o : method_options) o.max_tangent_seconds = options.fill.max_tangent_seconds;
      method_options[0].method = GapMethod::kSlerp;
      method_options[1].method = GapMethod::kCubic;
      method_options[2].method = GapMethod::kManifold;
      method_options[3] = options.fill;
      method_options[3].method = GapMethod::kMatched;
      for (int m = 0; m < kKeyMethods; ++m) {
        const MotionFrames filled = fill_gaps(keyed, m < 3 ? &decoded.frames : &fitted, method_options[m], kRate);
        const auto p = positions_of(skeleton, filled, 0, frames - 1);
        Sums s;
        s.gaps = 1;
        double error = 0, angle = 0;
        int64_t between = 0;
        for (int64_t f = 0; f < frames; ++f) {
          const bool key = f % every == 0 || f == frames - 1;
          for (int j = 0; j < joint_count; ++j) {
            const int column = kRootTranslationValues + 3 * j;
            const double a = expmap_angle_between(filled.frame(f) + column, recorded.frame(f) + column) * 180.0 / M_PI;
            if (key) {
              if (m == 3) key_error_deg[i] = std::max(key_error_deg[i], a);
            } else {
              angle += a;
            }
          }
          if (key) continue;
          ++between;
          for (int j : moved) {
            error += distance(p[static_cast<size_t>(f * joint_count + j)], recorded_positions[static_cast<size_t>(f * joint_count + j)]);
          }
        }
        s.mpjpe = error / static_cast<double>(between * static_cast<int64_t>(moved.size()));
        s.angle = angle / static_cast<double>(between * joint_count);
        for (int64_t f = 0; f + 1 < frames; ++f) {
          s.moved += mean_move(p, joint_count, f, f + 1, moved);
          s.moved_recorded += mean_move(recorded_positions, joint_count, f, f + 1, moved);
        }
        s.skating = skating_ratio(skeleton, filled, kRate);
        s.skating_recorded = skating_ratio(skeleton, recorded, kRate);
        overall[i][static_cast<size_t>(m)].add(s);
        per_action[take.action][i][static_cast<size_t>(m)].add(s);
      }
    }
  }
  if (used_takes == 0) throw InputError("takes", "none is one window (" + std::to_string(window) + " frames at 25 Hz) long");

  nlohmann::json rows = nlohmann::json::array();
  for (size_t i = 0; i < options.intervals.size(); ++i) {
    nlohmann::json methods = nlohmann::json::object(), actions = nlohmann::json::object();
    for (int m = 0; m < kKeyMethods; ++m) methods[key_method_names[m]] = overall[i][static_cast<size_t>(m)].json();
    for (const auto& [action, sums] : per_action) {
      nlohmann::json a = nlohmann::json::object();
      for (int m = 0; m < kKeyMethods; ++m) a[key_method_names[m]] = sums[i][static_cast<size_t>(m)].json();
      actions[action] = a;
    }
    rows.push_back({{"interval_seconds", options.intervals[i]},
                    {"keyframe_max_angle_error_deg", key_error_deg[i]},
                    {"methods", methods},
                    {"actions", actions}});
  }
  nlohmann::json document = {{"takes", used_takes},
                             {"take_seconds", options.take_seconds},
                             {"rate_hz", kRate},
                             {"decoder", decoder_name(options.decoder)},
                             {"intervals", rows}};
  std::string md = "\nKeyframes: one pose every interval, every other frame filled (" + std::to_string(used_takes) +
                   " takes, their first " + number(options.take_seconds, "%.0f") +
                   " s). MPJPE (mm) / speed ratio / skating ratio on the frames between keyframes:\n\n| interval (s) |";
  for (const char* name : key_method_names) md += std::string(" ") + name + " |";
  md += " keyframes returned (largest angle error, degrees) |\n|---:|";
  for (int m = 0; m < kKeyMethods; ++m) md += "---|";
  md += "---:|\n";
  for (size_t i = 0; i < options.intervals.size(); ++i) {
    md += "| " + number(options.intervals[i]) + " |";
    for (int m = 0; m < kKeyMethods; ++m) {
      const auto j = overall[i][static_cast<size_t>(m)].json();
      md += " " + number(j["mpjpe_mm"].get<double>()) + " / " + number(j["speed_ratio"].get<double>(), "%.2f") + " / " +
            number(j["skating_ratio"].get<double>(), "%.3f") + " |";
    }
    md += " " + number(key_error_deg[i], "%.4f") + " |\n";
  }
  for (size_t i = 0; i < options.intervals.size(); ++i) {
    md += "\nKeyframes every " + number(options.intervals[i]) + " s, per action: MPJPE (mm) / speed ratio\n\n| action |";
    for (const char* name : key_method_names) md += std::string(" ") + name + " |";
    md += "\n|---|";
    for (int m = 0; m < kKeyMethods; ++m) md += "---|";
    md += "\n";
    for (const auto& [action, sums] : per_action) {
      md += "| " + action + " |";
      for (int m = 0; m < kKeyMethods; ++m) {
        const auto j = sums[i][static_cast<size_t>(m)].json();
        md += " " + number(j["mpjpe_mm"].get<double>()) + " / " + number(j["speed_ratio"].get<double>(), "%.2f") + " |";
      }
      md += "\n";
    }
  }
  return {document.dump(2) + "\n", md};
}

}  // namespace mm
