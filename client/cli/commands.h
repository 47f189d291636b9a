// The client's commands, one file per group: inference (encode ... denoise),
// models, clips of the data root, jobs and takes. Each adds its subcommands to the app; the one the user
// picked sets `action`, which main() runs after parsing and whose result is
// the exit status (server_error.h). Errors are thrown: ServerError (exit 1),
// InputError (exit 2).
#pragma once

#include <functional>
#include <nlohmann/json.hpp>

#include "client/cli/connection_options.h"
#include "wire/rest_json.h"

namespace CLI {
class App;
}

namespace mm::client {

using Action = std::function<int()>;

// What every command shares: where the server is, and whether replies are
// printed as JSON (--json) instead of files and text.
struct ClientSettings {
  ConnectionOptions connection;
  bool json = false;
};

void add_inference_commands(CLI::App& app, const ClientSettings& settings, Action& action);
void add_model_commands(CLI::App& app, const ClientSettings& settings, Action& action);
void add_clip_commands(CLI::App& app, const ClientSettings& settings, Action& action);
void add_job_commands(CLI::App& app, const ClientSettings& settings, Action& action);
void add_take_commands(CLI::App& app, const ClientSettings& settings, Action& action);

// Prints `value` on standard output, indented, with a newline.
void print_json(const nlohmann::json& value);
// A document of motions or codes, its floats in their shortest form.
void print_json(const ::mm::wire::FloatJson& value);

}  // namespace mm::client
