// clips list | read | upload: the motion files of the server's --data-root,
// picked on the server instead of sent from here, and a user's own files
// put there to train on.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "client/cli/commands.h"
#include "client/cli/motion_io.h"
#include "client/cli/server_connection.h"
#include "client/cli/server_error.h"
#include "client/cli/take_progress.h"
#include "format/atomic_file.h"
#include "format/input_error.h"
#include "wire/rest_json.h"

namespace mm::client {

// --json prints a reply as REST answers it, written by the same code.
using ::mm::wire::to_json;
namespace {

namespace fs = std::filesystem;

struct Upload {
  std::string local;   // the file here
  std::string remote;  // its path under the data root
};

// What `clips upload` sends: a file as <to>/<its name>; a folder's .txt and
// .bvh files (recursively, hidden ones left out) as <to>/<their path in it>,
// in path order. InputError for a missing path or a folder without any.
std::vector<Upload> uploads_of(const std::vector<std::string>& locals, const std::string& to) {
  std::vector<Upload> uploads;
  for (const auto& local : locals) {
    std::error_code error;
    if (fs::is_regular_file(local, error)) {
      uploads.push_back({local, to + "/" + fs::path(local).filename().string()});
      continue;
    }
    if (!fs::is_directory(local, error)) throw InputError(local + ": no such file or folder");
    std::vector<Upload> found;
    for (auto it = fs::recursive_directory_iterator(local, error); !error && it != fs::recursive_directory_iterator();
         it.increment(error)) {
      const std::string name = it->path().filename().string();
      if (!name.empty() && name.front() == '.') {
        if (it->is_directory()) it.disable_recursion_pending();
        continue;
      }
      if (it->is_regular_file() && is_motion_file(it->path().string())) {
        found.push_back({it->path().string(), to + "/" + it->path().lexically_relative(local).generic_string()});
      }
    }
    if (error) throw InputError(local + ": cannot read the folder: " + error.message());
    if (found.empty()) throw InputError(local + ": holds no .txt or .bvh file");
    std::sort(found.begin(), found.end(), [](const Upload& a, const Upload& b) { return a.remote < b.remote; });
    uploads.insert(uploads.end(), found.begin(), found.end());
  }
  return uploads;
}

void add_upload(CLI::App* clips, const ClientSettings& settings, Action& action) {
  struct Options {
    std::vector<std::string> locals;
    std::string to;
  };
  auto o = std::make_shared<Options>();
  auto* upload = clips->add_subcommand(
      "upload", "Put motion files of your own (H3.6M text, or BVH of any rig) under the data root, to train on: "
                "jobs submit --dataset <to>. A folder sends its .txt and .bvh files with their paths in it. An upload "
                "never replaces a file; files sent before a refusal stay. Needs the token.");
  upload->add_option("files", o->locals, "files or folders to send")->required();
  upload->add_option("--to", o->to, "folder under the data root to put them in (\"mine\": mine/walk_01.bvh)")->required();
  upload->callback([o, &settings, &action] {
    action = [o, &settings] {
      std::string to = o->to;
      while (!to.empty() && to.back() == '/') to.pop_back();
      if (to.empty()) throw InputError("--to is empty, expected a folder under the data root");
      const std::vector<Upload> uploads = uploads_of(o->locals, to);
      const auto server = connect(settings.connection);
      // A folder of recordings takes a while: on a terminal, the bytes sent
      // so far of all the files' (a file counts once the server has it).
      int64_t total_bytes = 0;
      for (const Upload& u : uploads) {
        std::error_code error;
        const auto size = fs::file_size(u.local, error);
        if (!error) total_bytes += static_cast<int64_t>(size);
      }
      TakeProgress progress(stderr, TakeProgress::stderr_is_terminal() && !settings.json,
                            "clips upload to " + to, total_bytes, "bytes");
      nlohmann::json sent = nlohmann::json::array();
      // The files sent are listed once the line is cleared, a refusal's
      // included (those before it stay on the server).
      std::string listing;
      const auto list_sent = [&] {
        progress.finish();
        std::fputs(listing.c_str(), stdout);
      };
      try {
        for (const Upload& u : uploads) {
          v1::UploadClipRequest request;
          request.set_path(u.remote);
          request.set_content(read_whole_file(u.local));
          const v1::ClipFile clip = server->upload_clip(request);
          progress.add(static_cast<int64_t>(request.content().size()));
          if (settings.json) {
            sent.push_back(to_json(clip));
          } else {
            char line[512];
            std::snprintf(line, sizeof line, "%-9s %10" PRId64 "  ", clip.format().c_str(),
                          static_cast<int64_t>(clip.size_bytes()));
            listing += line + clip.path() + "\n";
          }
        }
      } catch (...) {
        list_sent();
        throw;
      }
      list_sent();
      if (settings.json) print_json(nlohmann::json{{"clips", sent}});
      return kExitSuccess;
    };
  });
}

void add_delete(CLI::App* clips, const ClientSettings& settings, Action& action) {
  auto paths = std::make_shared<std::vector<std::string>>();
  auto* remove = clips->add_subcommand(
      "delete", "Remove files you uploaded from the data root (only uploads: the rest is the operator's). Files "
                "removed before a refusal stay removed. Needs the token.");
  remove->add_option("paths", *paths, "the files, relative to the data root as `clips list` names them")->required();
  remove->callback([paths, &settings, &action] {
    action = [paths, &settings] {
      const auto server = connect(settings.connection);
      nlohmann::json removed = nlohmann::json::array();
      for (const auto& path : *paths) {
        const v1::ClipFile clip = server->delete_clip(path);
        if (settings.json) {
          removed.push_back(to_json(clip));
        } else {
          std::printf("deleted %-9s %10" PRId64 "  %s\n", clip.format().c_str(),
                      static_cast<int64_t>(clip.size_bytes()), clip.path().c_str());
        }
      }
      if (settings.json) print_json(nlohmann::json{{"clips", removed}});
      return kExitSuccess;
    };
  });
}

}  // namespace

void add_clip_commands(CLI::App& app, const ClientSettings& settings, Action& action) {
  auto* clips = app.add_subcommand("clips", "The motion files of the server's --data-root: list, read, upload, delete");
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
    bool whole = false;
  };
  auto o = std::make_shared<ReadOptions>();
  auto* read = clips->add_subcommand(
      "read", "One window of a data-root file (the model's 150 frames at 25 Hz from --start), as a motion file");
  read->add_option("path", o->path, "the file, relative to the data root as `clips list` names it")->required();
  read->add_option("--start", o->start,
                   "the window's first frame, in the file's own frames (a row of H3.6M text, 50 Hz; a BVH's "
                   "frame), as encode's --start")
      ->capture_default_str();
  read->add_flag("--whole", o->whole,
                 "the whole file at its own rate instead of one window, as a take of it reads it (H3.6M text every "
                 "row at 50 Hz); refused past the server's --max-take-seconds or --max-message-bytes");
  read->add_option("--model", o->model, "model whose clip length and skeleton the window takes (default: the active one)");
  read->add_option("--out", o->out, "motion file to write the window to (.txt, .bvh, - for stdout)");
  read->callback([o, &settings, &action] {
    action = [o, &settings] {
      if (o->out.empty() && !settings.json) throw InputError("--out is required (or --json to print the reply)");
      if (!o->out.empty()) check_motion_output(o->out, "--out");
      v1::ReadClipRequest request;
      request.set_path(o->path);
      request.set_start(o->start);
      request.set_whole(o->whole);
      request.set_model(o->model);
      const auto server = connect(settings.connection);
      const auto reply = server->read_clip(request);
      ModelRigs rigs(*server);
      if (!o->out.empty()) write_motion(reply.motion(), o->out, rigs, o->model);
      if (settings.json) {
        print_json(to_json(reply));
      } else if (o->out != "-" && o->whole) {
        std::printf("%s: %d frames at %g Hz, the whole of %s\n", o->out.c_str(), reply.motion().frames(),
                    reply.motion().frame_rate(), reply.path().c_str());
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
  add_upload(clips, settings, action);
  add_delete(clips, settings, action);
}

}  // namespace mm::client
