// The server's configuration: every setting has a command-line flag, a
// key in the configuration file (--config FILE, TOML or INI) and an
// environment variable (MM_<NAME>), in that order of precedence, with defaults
// that run the shipped model on one machine.
#pragma once

#include <string>

#include "server/core/core_config.h"
#include "server/grpc/grpc_frontend.h"
#include "server/jobs/training_jobs.h"
#include "server/rest/rest_frontend.h"

namespace mm::service {

struct ServerConfig {
  CoreConfig core;
  GrpcOptions grpc;
  RestOptions rest;
  JobsConfig jobs;  // jobs.state_dir empty: no training jobs
  std::string ready_file;  // written (JSON: ports, pid) once both frontends listen
  std::string log_level = "info";
  std::string log_format = "text";  // "text" or "json"
};

// Parses argv (and the environment and --config file). Returns the exit code
// to leave with (0 after --help or --version) or -1 to go on serving.
int parse_server_config(int argc, char** argv, ServerConfig& config);

}  // namespace mm::service
