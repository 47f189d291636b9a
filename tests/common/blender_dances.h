// Three short CMU dances (cmu_dance.h) as BVH and as Blender's own glTF
// binary (.glb) and FBX exports of them (tests/format/blender_convert_bvh.py:
// Blender's BVH importer and its glTF and FBX exporters, every frame baked),
// made once per test program in a scratch folder: a rig's training folder
// in each format, of one motion.
//
// The dances are indian/04, indian/06 and martial/03, each its first 7 s at
// its own rate: 30, 40 and 60 Hz (every 4th, 3rd and 2nd frame of the 120 Hz
// recording), 175 frames each at 25 Hz, more than the 150 of a model's clip.
// Short, because Blender takes seconds a few hundred frames; one Blender
// run a format.
//
// Needs the script's path, MM_BLENDER_CONVERT_SCRIPT or else below
// MM_SOURCE_DIR, defined by the build, and Blender (MM_BLENDER, default
// "blender").
#pragma once

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "format/bvh_file.h"
#include "tests/common/cmu_dance.h"
#include "tests/common/command_run.h"
#include "tests/common/test_environment.h"

#ifndef MM_BLENDER_CONVERT_SCRIPT
#define MM_BLENDER_CONVERT_SCRIPT MM_SOURCE_DIR "/tests/format/blender_convert_bvh.py"
#endif

namespace mm::test {

struct BlenderDances {
  // Each holds indian/04, indian/06 and martial/03 with the folder's
  // extension (.bvh, .glb, .fbx).
  std::filesystem::path bvh, glb, fbx;
  // The relative paths without extension, in path order.
  std::vector<std::string> names;
};

// The dances; the first call makes them (Blender twice: about 10 s of CPU).
// Throws std::runtime_error with Blender's last output when a conversion
// fails, so the test fails (never skips).
inline const BlenderDances& blender_dances() {
  static BlenderDances* dances = nullptr;
  static ScratchDir* dir = nullptr;
  if (dances != nullptr) return *dances;
  struct Cut {
    const char* name;
    int every;  // of the 120 Hz frames: 4 is 30 Hz
  };
  const std::vector<Cut> cuts = {{"indian/04", 4}, {"indian/06", 3}, {"martial/03", 2}};
  constexpr double kSeconds = 7;
  dir = new ScratchDir();  // removed at exit
  std::atexit([] { delete dir; });
  auto made = std::make_unique<BlenderDances>();
  made->bvh = dir->path() / "bvh";
  made->glb = dir->path() / "glb";
  made->fbx = dir->path() / "fbx";
  std::string glb_arguments, fbx_arguments;
  for (const Cut& cut : cuts) {
    const BvhFile recording = read_bvh_file((cmu_dance_dir() / (std::string(cut.name) + ".bvh")).string());
    BvhFile file = recording;
    file.frame_time_s = recording.frame_time_s * cut.every;
    file.values.clear();
    const int channels = recording.channel_count();
    const int64_t frames = static_cast<int64_t>(kSeconds / file.frame_time_s + 0.5);
    for (int64_t f = 0; f < frames; ++f) {
      const double* frame = recording.values.data() + f * cut.every * channels;
      file.values.insert(file.values.end(), frame, frame + channels);
    }
    for (const auto& folder : {made->bvh, made->glb, made->fbx}) {
      std::filesystem::create_directories((folder / cut.name).parent_path());
    }
    const std::string bvh = (made->bvh / (std::string(cut.name) + ".bvh")).string();
    std::ofstream(bvh, std::ios::binary) << write_bvh_text(file);
    glb_arguments += " '" + bvh + "' '" + (made->glb / (std::string(cut.name) + ".glb")).string() + "'";
    fbx_arguments += " '" + bvh + "' '" + (made->fbx / (std::string(cut.name) + ".fbx")).string() + "'";
    made->names.push_back(cut.name);
  }
  // The CMU files are in cm: 0.01 m a unit, as Blender's importer is told.
  for (const std::string& arguments : {glb_arguments, fbx_arguments}) {
    const CommandRun run =
        run_command(environment_or("MM_BLENDER", "blender"),
                    std::string("--background --factory-startup --python-exit-code 1 --python '") +
                        MM_BLENDER_CONVERT_SCRIPT + "' --" + arguments + " 0.01");
    if (run.exit_code != 0) {
      const std::string output = run.out + run.err;
      throw std::runtime_error("Blender failed converting the dances: " +
                               output.substr(output.size() > 3000 ? output.size() - 3000 : 0));
    }
  }
  dances = made.release();
  return *dances;
}

}  // namespace mm::test
