// clips list | read: the motion files of the server's --data-root, picked
// on the server instead of sent from here.
#include <CLI/CLI.hpp>
#include <cinttypes>
#include <cstdio>
#include <memory>

#include "commands.h"
#include "format/input_error.h"
#include "motion_io.h"
#include "server_connection.h"
#include "server_error.h"
#include "wire_json.h"

namespace mm::client {

void add_clip_commands(CLI::App& app, const ClientSettings& settings, Action& action) {
  auto* clips = app.add_subcommand("clips", "The motion files of the server's --data-root: list, read");
  clips->require_subcommand(1);

  clips->add_subcommand("list", "Every H3.6M text (.txt) and BVH file under the data root: format, bytes, path")
      ->callback([&settings, &action] {
        action = [&settings] {
          const auto reply = connect(settings.connection)->list_clips();
          if (settings.json) {
            print_json(to_json(reply));
            return kExitSuccess;
          }
          for (const auto& c : reply.clips()) {
            std::printf("%-9s %10" PRId64 "  %s\n", c.format().c_str(), static_cast<int64_t>(c.size_bytes()),
                        c.path().c_str());
          }
          if (reply.truncated()) std::printf("(more files than the server lists)\n");
          return kExitSuccess;
        };
      });

  struct ReadOptions {
    std::string path, model, out;
    int64_t start = 0;
  };
  auto o = std::make_shared<ReadOptions>();
  auto* read = clips->add_subcommand(
      "read", "One window of a data-root file (the model's 150 frames at 25 Hz from --start), as a motion file");
  read->add_option("path", o->path, "the file, relative to the data root as `clips list` names it")->required();
  read->add_option("--start", o->start, "the window's first frame, in the file's own frames (50 Hz for H3.6M text)")
      ->capture_default_str();
  read->add_option("--model", o->model, "model whose clip length and skeleton the window takes (default: the active one)");
  read->add_option("--out", o->out, "motion file to write the window to (.txt, .bvh, - for stdout)");
  read->callback([o, &settings, &action] {
    action = [o, &settings] {
      if (o->out.empty() && !settings.json) throw InputError("--out is required (or --json to print the reply)");
      if (!o->out.empty()) check_motion_output(o->out, "--out");
      v1::ReadClipRequest request;
      request.set_path(o->path);
      request.set_start(o->start);
      request.set_model(o->model);
      const auto server = connect(settings.connection);
      const auto reply = server->read_clip(request);
      ModelRigs rigs(*server);
      if (!o->out.empty()) write_motion(reply.motion(), o->out, rigs, o->model);
      if (settings.json) {
        print_json(to_json(reply));
      } else if (o->out != "-") {
        std::printf("%s: %d frames at 25 Hz of %s from frame %" PRId64 " of %" PRId64 " at %g Hz (last start %" PRId64
                    ")\n",
                    o->out.c_str(), reply.motion().frames(), reply.path().c_str(), static_cast<int64_t>(reply.start()),
                    static_cast<int64_t>(reply.file_frames()), reply.file_frame_rate(),
                    static_cast<int64_t>(reply.last_start()));
      }
      return kExitSuccess;
    };
  });
}

}  // namespace mm::client
