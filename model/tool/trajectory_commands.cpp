// train-trajectory and evaluate-trajectory: the root path of generated
// motion (model/root_trajectory.h), trained for a model and measured on
// H3.6M's S5 as docs/RESULTS.md reports it (scripts/trajectory-results.sh).
#include <c10/core/InferenceMode.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>

#include "format/atomic_file.h"
#include "format/foot_contacts.h"
#include "format/h36m_corpus.h"
#include "format/input_error.h"
#include "format/motion_text.h"
#include "format/rig_folder_dataset.h"
#include "format/root_path.h"
#include "format/skeleton_bvh.h"
#include "model/default_model.h"
#include "model/latent_operations.h"
#include "model/render/svg_document.h"
#include "model/take_processor.h"
#include "model/tool/commands.h"
#include "model/trajectory_evaluation.h"
#include "model/trajectory_training.h"

namespace mm::tool {
namespace {

constexpr double kRate = 25.0;

// The subjects' recordings at 25 Hz, both phases, with the root's true
// change per 25 Hz frame.
std::vector<MotionSequence> sequences_keeping_root(const std::string& data, const std::vector<std::string>& subjects) {
  std::vector<MotionSequence> result;
  for (auto& recording : load_h36m_corpus(data, subjects, 1)) {
    auto phases = split_phases_keeping_root_path(recording.frames, 2);
    for (int p = 0; p < 2; ++p) {
      MotionSequence sequence{recording.subject, recording.action, recording.take, p, std::move(phases[static_cast<size_t>(p)])};
      result.push_back(std::move(sequence));
    }
  }
  return result;
}

// The recordings of a rig's own animation files (every .bvh, .glb, .gltf
// and .fbx under `folder`) at 25 Hz in the model's world layout
// (skeleton_bvh.h).
std::vector<MotionFrames> rig_recordings(const std::string& folder, const Skeleton& skeleton) {
  std::vector<MotionFrames> motions;
  for (const auto& relative : list_animation_files(folder)) {
    motions.push_back(read_rig_motion(skeleton, folder + "/" + relative));
  }
  return motions;
}

struct TrainTrajectoryOptions {
  std::string model_dir, data = "data", rig, out;
  std::vector<std::string> subjects{"S1", "S6", "S7", "S8", "S9", "S11"};
  TrajectoryTrainingOptions training;
};

int run_train_trajectory(const TrainTrajectoryOptions& o) {
  MotionManifold model = MotionManifold::load(o.model_dir);
  const bool rig = trajectory_frame_of(model.skeleton()) == TrajectoryFrame::kHeadingMoves;
  std::vector<MotionFrames> motions;
  if (!o.rig.empty()) {
    if (!rig) {
      throw InputError("--rig: " + o.model_dir + " is a model of H3.6M's skeleton, whose recordings are the text "
                       "files of --data; --rig is for a model of a rig read from its animation files (prepare --rig)");
    }
    motions = rig_recordings(o.rig, model.skeleton());
  } else {
    if (rig || model.normalization().input_columns() != kH36mColumns) {
      throw InputError("--model: " + o.model_dir + " is a model of the skeleton \"" + model.skeleton().name +
                       "\", not H3.6M's: give its folder of animation files with --rig");
    }
    for (auto& sequence : sequences_keeping_root(o.data, o.subjects)) motions.push_back(std::move(sequence.frames));
  }
  std::fprintf(stderr, "train-trajectory: %zu sequences at 25 Hz\n", motions.size());
  TrajectoryTrainingOptions training = o.training;
  training.progress = [](int iteration, double loss) {
    std::fprintf(stderr, "train-trajectory: iteration %d loss %.4f\n", iteration, loss);
  };
  const auto report = train_root_trajectory(model, motions, training);
  const std::string out = o.out.empty() ? o.model_dir : o.out;
  model.save(out, model.provenance_json());
  std::fprintf(stderr, "train-trajectory: %d iterations in %.0f s, final loss %.4f; written to %s\n", report.iterations,
               report.seconds, report.final_loss, out.c_str());
  return kExitSuccess;
}

struct EvaluateTrajectoryOptions {
  std::string model_dir, data = "data", out, svg;
  int hop_frames = 50;
  int samples = 64;
  uint64_t seed = 1;
  FootContactThresholds thresholds;
};

bool is_walking(const std::string& action) {
  return action == "walking" || action == "walkingdog" || action == "walkingtogether";
}

// 150-frame windows of phase 0 every hop frames, their first root change
// zeroed (the step into the clip is not part of its path), as recorded
// (what the model reads).
struct Clip {
  std::string action;
  MotionFrames motion;
};
std::vector<Clip> test_clips(const std::vector<MotionSequence>& sequences, int frames, int hop) {
  std::vector<Clip> clips;
  for (const auto& sequence : sequences) {
    if (sequence.phase != 0) continue;
    for (int64_t start = 0; start + frames <= sequence.frames.frame_count(); start += hop) {
      Clip clip{sequence.action, {}};
      clip.motion.columns = sequence.frames.columns;
      clip.motion.values.assign(sequence.frames.frame(start), sequence.frames.frame(start) + frames * sequence.frames.columns);
      clip.motion.frame(0)[0] = clip.motion.frame(0)[1] = clip.motion.frame(0)[2] = 0.0f;
      clips.push_back(std::move(clip));
    }
  }
  return clips;
}

nlohmann::json errors_json(const PathErrors& e) {
  nlohmann::json json = {{"clips", e.clips},
                         {"distance_cm", e.distance_mm / 10},
                         {"path_error_cm", e.path_error_mm / 10},
                         {"path_error_share", e.path_error_share},
                         {"final_error_cm", e.final_error_mm / 10},
                         {"final_error_share", e.final_error_share},
                         {"speed_error_cm_s", e.speed_error_mm_s / 10}};
  json["heading_error_deg"] = e.heading_error_deg ? nlohmann::json(*e.heading_error_deg) : nlohmann::json();
  return json;
}

void print_errors_row(const std::string& set, const std::string& method, const PathErrors& e) {
  std::string heading = e.heading_error_deg ? std::to_string(static_cast<int>(std::lround(*e.heading_error_deg))) : "-";
  std::printf("| %s | %s | %d | %.0f | %.1f (%.0f%%) | %.1f (%.0f%%) | %.1f | %s |\n", set.c_str(), method.c_str(),
              e.clips, e.distance_mm / 10, e.path_error_mm / 10, 100 * e.path_error_share, e.final_error_mm / 10,
              100 * e.final_error_share, e.speed_error_mm_s / 10, heading.c_str());
}

std::vector<MotionFrames> planted(const Skeleton& skeleton, std::vector<MotionFrames> motions,
                                  const FootContactThresholds& thresholds) {
  for (auto& motion : motions) plant_feet(skeleton, motion, kRate, thresholds);
  return motions;
}

// Top-down paths of a few clips, recorded against generated, one panel each.
std::string paths_svg(const std::vector<MotionFrames>& recorded, const std::vector<MotionFrames>& generated,
                      const std::vector<MotionFrames>& from_poses, const std::vector<std::string>& titles) {
  const double panel = 260, margin = 30;
  const size_t count = recorded.size();
  render::SvgDocument svg(panel * static_cast<double>(count) + margin, panel + 2 * margin);
  svg.text(margin / 2, 20, "S5 walking, 6 s clips, the root from above (grid 1 m). Black: recorded; green: from the "
                           "recorded poses; blue: decoded from the clip's code", 13);
  for (size_t i = 0; i < count; ++i) {
    const double left = margin / 2 + panel * static_cast<double>(i), top = margin + 10, size = panel - 20;
    auto path_of = [](const MotionFrames& m) {
      std::vector<std::array<double, 2>> path{{0, 0}};
      for (int64_t f = 1; f < m.frame_count(); ++f) path.push_back({path.back()[0] + m.frame(f)[0], path.back()[1] + m.frame(f)[2]});
      return path;
    };
    const auto truth = path_of(recorded[i]), guess = path_of(generated[i]), posed = path_of(from_poses[i]);
    double extent = 1000;
    for (const auto* path : {&truth, &guess, &posed}) {
      for (const auto& p : *path) extent = std::max({extent, std::fabs(p[0]) * 1.1, std::fabs(p[1]) * 1.1});
    }
    const double scale = size / (2 * extent);
    auto x = [&](double mm) { return left + size / 2 + mm * scale; };
    auto y = [&](double mm) { return top + size / 2 - mm * scale; };  // z (forward) points up the page
    svg.rect(left, top, size, size, "#fafafa", "#cccccc");
    for (double g = -std::floor(extent / 1000) * 1000; g <= extent; g += 1000) {
      svg.line(x(g), top, x(g), top + size, "#e4e4e4", 1);
      svg.line(left, y(g), left + size, y(g), "#e4e4e4", 1);
    }
    for (const auto& [path, colour] :
         {std::pair{&posed, "#2ca02c"}, std::pair{&truth, "#222222"}, std::pair{&guess, "#1f77b4"}}) {
      std::string points;
      for (const auto& p : *path) points += render::px(x(p[0])) + "," + render::px(y(p[1])) + " ";
      svg.polyline(points, colour, 2);
    }
    svg.circle(x(0), y(0), 3, "#222222");
    svg.text(left + size / 2, top + size + 16, titles[i], 12, "middle");
  }
  return svg.finish();
}

int run_evaluate_trajectory(const EvaluateTrajectoryOptions& o) {
  c10::InferenceMode inference;
  const MotionManifold model = MotionManifold::load(o.model_dir);
  if (!model.has_trajectory()) throw InputError("--model: " + o.model_dir + " has no trajectory network (train-trajectory)");
  const Skeleton& skeleton = model.skeleton();
  const auto clips = test_clips(sequences_keeping_root(o.data, {"S5"}), model.config().frames, o.hop_frames);
  // Each set as recorded (the model's input) and as the reference path:
  // the recording's root integrated in the world, levelled, on the floor.
  std::map<std::string, std::vector<MotionFrames>> sets;
  for (const auto& clip : clips) {
    sets["all"].push_back(clip.motion);
    if (is_walking(clip.action)) sets["walking"].push_back(clip.motion);
  }
  auto world_of = [&](std::vector<MotionFrames> motions) {
    for (auto& motion : motions) integrate_level_root_path(skeleton, motion, kRootRotationStepsPerFrame);
    return motions;
  };
  nlohmann::json result = {{"model", o.model_dir},
                           {"clips", "S5, phase 0 at 25 Hz, 150-frame windows every " + std::to_string(o.hop_frames) +
                                         " frames"},
                           {"thresholds", {{"near_floor_mm", o.thresholds.near_floor_mm},
                                           {"planted_speed_mm_s", o.thresholds.planted_speed_mm_s},
                                           {"skating_speed_mm_s", o.thresholds.skating_speed_mm_s}}}};
  std::printf("| clips | root from | clips | distance (cm) | path error, cm (share) | final displacement error, cm "
              "(share) | speed error (cm/s) | heading error (deg) |\n|---|---|---:|---:|---:|---:|---:|---:|\n");
  std::vector<MotionFrames> walking_recorded, walking_decoded, walking_from_poses;
  for (const auto& [name, as_recorded] : sets) {
    const auto recorded = world_of(as_recorded);
    const auto codes = encode_motions(model, as_recorded);
    const auto decoded = decode_codes(model, codes, model.default_decoder());
    std::vector<MotionFrames> from_recorded_poses = as_recorded;
    write_generated_roots(model, model.to_normalized([&] {
      auto raw = at::empty({static_cast<int64_t>(as_recorded.size()), model.config().frames, model.normalization().input_columns()});
      for (size_t i = 0; i < as_recorded.size(); ++i) {
        std::memcpy(raw[static_cast<int64_t>(i)].data_ptr<float>(), as_recorded[i].values.data(), as_recorded[i].values.size() * sizeof(float));
      }
      return raw;
    }()), codes, from_recorded_poses);
    const std::vector<std::pair<std::string, std::vector<MotionFrames>>> methods = {
        {"decoded from the clip's code", decoded},
        {"decoded, feet planted", planted(skeleton, decoded, o.thresholds)},
        {"the recorded poses", from_recorded_poses},
        {"zero (baseline)", standing_roots(recorded)},
        {"first second's velocity held (baseline)", held_first_second_roots(recorded, kRate)}};
    for (const auto& [method, motions] : methods) {
      const PathErrors errors = compare_root_paths(recorded, motions, kRate);
      result["paths"][name][method] = errors_json(errors);
      print_errors_row(name == "walking" ? "S5 walking" : "S5, all 15 actions", method, errors);
    }
    if (name == "walking") {
      walking_recorded = recorded;
      walking_decoded = decoded;
      walking_from_poses = from_recorded_poses;
    }
    // Skating of recorded, reconstructed, sampled and interpolated motion.
    std::vector<std::pair<std::string, std::vector<MotionFrames>>> kinds = {{"recorded", recorded},
                                                                           {"reconstructed", decoded}};
    if (name == "all") {
      kinds.emplace_back("sampled", decode_codes(model, sample_codes(model, o.samples, o.seed), model.default_decoder()));
      std::vector<at::Tensor> between;
      for (int64_t i = 0; i + 1 < codes.size(0) && static_cast<int>(between.size()) < o.samples; i += 2) {
        between.push_back(interpolate_codes(codes[i], codes[i + 1], 5, true).narrow(0, 1, 3));
      }
      kinds.emplace_back("interpolated", decode_codes(model, at::cat(between), model.default_decoder()));
    }
    for (const auto& [kind, motions] : kinds) {
      const SkatingCount plain = total_skating(skeleton, motions, kRate, o.thresholds);
      const SkatingCount cleaned = total_skating(skeleton, planted(skeleton, motions, o.thresholds), kRate, o.thresholds);
      result["skating"][name][kind] = {{"motions", motions.size()},
                                       {"frames", plain.frames},
                                       {"ratio", plain.ratio()},
                                       {"ratio_feet_planted", cleaned.ratio()}};
    }
  }
  std::printf("\n| clips | motion | motions | skating ratio | with feet planted |\n|---|---|---:|---:|---:|\n");
  for (const auto& [name, kinds] : result["skating"].items()) {
    for (const auto& [kind, row] : kinds.items()) {
      std::printf("| %s | %s | %d | %.3f | %.3f |\n", name == "walking" ? "S5 walking" : "S5, all 15 actions", kind.c_str(),
                  row["motions"].get<int>(), row["ratio"].get<double>(), row["ratio_feet_planted"].get<double>());
    }
  }
  // Whole takes (trial 1 of every action) as the service's take operation
  // gives them with a generated root, at 25 Hz: how far they travel against
  // the recording, and how much their feet skate.
  std::printf("\n| S5 take | minutes | recorded distance (m) | generated distance (m) | skating, recorded | "
              "skating, generated |\n|---|---:|---:|---:|---:|---:|\n");
  double recorded_total = 0, generated_total = 0;
  SkatingCount recorded_skating, generated_skating;
  for (const auto& sequence : sequences_keeping_root(o.data, {"S5"})) {
    if (sequence.phase != 0 || sequence.take != 1) continue;
    MotionFrames recorded = sequence.frames;
    recorded.frame(0)[0] = recorded.frame(0)[1] = recorded.frame(0)[2] = 0.0f;
    MotionFrames as_recorded = recorded;
    integrate_level_root_path(skeleton, recorded, kRootRotationStepsPerFrame);
    TakeOptions take;
    take.frame_rate = kRate;
    take.root = TakeRoot::kGenerated;
    take.decoder = model.default_decoder();
    const MotionFrames generated = process_take(model, as_recorded, take).frames;
    auto travelled = [](const MotionFrames& m) {
      double length = 0;
      for (int64_t f = 1; f < m.frame_count(); ++f) length += std::hypot(m.frame(f)[0], m.frame(f)[2]);
      return length;
    };
    const double a = travelled(recorded), b = travelled(generated);
    const SkatingCount sa = skating_ratio(skeleton, recorded, kRate, o.thresholds);
    const SkatingCount sb = skating_ratio(skeleton, generated, kRate, o.thresholds);
    recorded_total += a, generated_total += b;
    recorded_skating.skating += sa.skating, recorded_skating.frames += sa.frames;
    generated_skating.skating += sb.skating, generated_skating.frames += sb.frames;
    result["takes"][sequence.action] = {{"frames", recorded.frame_count()},
                                        {"recorded_distance_m", a / 1000},
                                        {"generated_distance_m", b / 1000},
                                        {"skating_recorded", sa.ratio()},
                                        {"skating_generated", sb.ratio()}};
    std::printf("| %s_1 | %.1f | %.1f | %.1f | %.3f | %.3f |\n", sequence.action.c_str(),
                static_cast<double>(recorded.frame_count()) / kRate / 60, a / 1000, b / 1000, sa.ratio(), sb.ratio());
  }
  std::printf("| all | | %.1f | %.1f | %.3f | %.3f |\n", recorded_total / 1000, generated_total / 1000,
              recorded_skating.ratio(), generated_skating.ratio());
  if (!o.out.empty()) write_file_atomically(o.out, result.dump(1) + "\n");
  if (!o.svg.empty() && !walking_recorded.empty()) {
    std::vector<MotionFrames> shown_recorded, shown_decoded, shown_from_poses;
    std::vector<std::string> titles;
    const size_t step = std::max<size_t>(1, walking_recorded.size() / 4);
    for (size_t i = 0; i < walking_recorded.size() && shown_recorded.size() < 4; i += step) {
      shown_recorded.push_back(walking_recorded[i]);
      shown_decoded.push_back(walking_decoded[i]);
      shown_from_poses.push_back(walking_from_poses[i]);
      titles.push_back("walking clip " + std::to_string(i + 1));
    }
    write_file_atomically(o.svg, paths_svg(shown_recorded, shown_decoded, shown_from_poses, titles));
  }
  return kExitSuccess;
}

}  // namespace

void add_trajectory_commands(CLI::App& app, Action& action) {
  auto train = std::make_shared<TrainTrajectoryOptions>();
  auto* t = app.add_subcommand("train-trajectory",
                               "train a model's root trajectory network on H3.6M's training subjects (or, for a "
                               "model of one's own rig, on its animation files), so that its generated motion travels "
                               "(the model folder is rewritten with it, or --out)");
  t->add_option("--model", train->model_dir, "model folder")->required();
  t->add_option("--data", train->data, "the H3.6M folder (holding S1, S5, ...)")->capture_default_str();
  t->add_option("--rig,--bvh", train->rig,
                "for a model of one's own rig: the folder of its animation files (every .bvh, .glb, .gltf and .fbx under "
                "it; --bvh is its former name)");
  t->add_option("--out", train->out, "write the model here instead of over --model");
  t->add_option("--iterations", train->training.iterations, "training iterations")->capture_default_str()->check(CLI::Range(1, 1000000));
  t->add_option("--seed", train->training.seed, "random seed")->capture_default_str();
  t->add_option("--windows", train->training.windows,
                "windows in the training pool, each encoded and decoded once")->capture_default_str()->check(CLI::Range(1, 100000));
  t->callback([train, &action] { action = [train] { return run_train_trajectory(*train); }; });

  auto evaluate = std::make_shared<EvaluateTrajectoryOptions>();
  auto* e = app.add_subcommand("evaluate-trajectory",
                               "measure the generated root paths and foot skating on H3.6M's S5 against the recorded "
                               "root and two baselines (markdown tables on stdout)");
  e->add_option("--model", evaluate->model_dir, "model folder")->required();
  e->add_option("--data", evaluate->data, "the H3.6M folder (holding S1, S5, ...)")->capture_default_str();
  e->add_option("--out", evaluate->out, "write the results as JSON here");
  e->add_option("--svg", evaluate->svg, "draw the top-down paths of four S5 walking clips here");
  e->add_option("--hop", evaluate->hop_frames, "frames between clip starts")->capture_default_str()->check(CLI::Range(1, 1000));
  e->add_option("--samples", evaluate->samples, "samples from the prior, and interpolations, for the skating table")
      ->capture_default_str()->check(CLI::Range(1, 10000));
  e->add_option("--near-floor-mm", evaluate->thresholds.near_floor_mm, "a foot this near the floor is on it (mm)")
      ->capture_default_str();
  e->add_option("--planted-speed", evaluate->thresholds.planted_speed_mm_s,
                "a foot on the floor slower than this is planted (mm/s)")->capture_default_str();
  e->add_option("--skating-speed", evaluate->thresholds.skating_speed_mm_s,
                "a foot on the floor faster than this skates (mm/s)")->capture_default_str();
  e->callback([evaluate, &action] { action = [evaluate] { return run_evaluate_trajectory(*evaluate); }; });
}

}  // namespace mm::tool
