// motion-manifold-client: the Motion Manifold service from the command line,
// over gRPC (or REST with --rest). Links no LibTorch: motions are read and
// written by the torch-free format library, all computing is the
// server's.
#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <iostream>

#include "client/cli/commands.h"
#include "client/cli/server_error.h"
#include "format/input_error.h"

namespace mm::client {

void print_json(const nlohmann::json& value) { std::cout << value.dump(2) << std::endl; }
void print_json(const ::mm::wire::FloatJson& value) { std::cout << value.dump(2) << std::endl; }

namespace {

int run(int argc, char** argv) {
  CLI::App app{
      "motion-manifold-client: a client of motion-manifold-server (gRPC, or REST with --rest): the latent space of "
      "human motion (encode, decode, sample, interpolate, analogy, denoise), takes of any length, its models and its "
      "training jobs.\n"
      "Exit status: 0 success, 1 the server refused or could not be reached, 2 bad usage or a bad local file."};
  app.set_version_flag("--version", "motion-manifold-client " MM_VERSION);
  app.require_subcommand(1);
  // Connection flags and --json may come before or after the command.
  app.fallthrough();
  ClientSettings settings;
  add_connection_options(app, settings.connection);
  app.add_flag("--json", settings.json, "print the server's reply as JSON (the REST frontend's form)");
  Action action;
  add_inference_commands(app, settings, action);
  add_model_commands(app, settings, action);
  add_clip_commands(app, settings, action);
  add_job_commands(app, settings, action);
  add_take_commands(app, settings, action);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    std::fprintf(stderr, "error: %s\nRun with --help for more information.\n", e.what());
    return kExitUsage;
  }
  if (!action) {
    std::fprintf(stderr, "error: no command given\nRun with --help for more information.\n");
    return kExitUsage;
  }
  return action();
}

}  // namespace
}  // namespace mm::client

int main(int argc, char** argv) {
  // A server that closes the connection while a body is still being sent
  // (one far over its limit) is an error to report, not a reason to die.
  std::signal(SIGPIPE, SIG_IGN);
  try {
    return mm::client::run(argc, argv);
  } catch (const mm::client::ServerError& e) {
    // As the server wrote it: code, then "<field>: <message>".
    std::fprintf(stderr, "error: %s\n", e.what());
    return mm::client::kExitServerError;
  } catch (const mm::InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return mm::client::kExitUsage;
  } catch (const std::exception& e) {
    // A reply this client cannot read (a server of another version).
    std::fprintf(stderr, "error: %s\n", e.what());
    return mm::client::kExitServerError;
  }
}
