// The server's configuration as an operator gives it: a flag, a key of the
// --config file and an environment variable MM_<NAME>, in that order of
// precedence (CLI11's: an option the file sets is not read from the
// environment).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tests/common/command_run.h"
#include "tests/server/rest_call.h"
#include "tests/server/server_process.h"

namespace mm::test {
namespace {

// The limit the server states when refusing a Sample of `count`.
std::string sample_refusal(const ServerProcess& server, int count) {
  const Reply reply = post(server.rest_port(), "/v1/sample", nlohmann::json{{"count", count}});
  return reply.status == 200 ? "accepted" : reply.body;
}

TEST(ServerConfig, TheEnvironmentSetsALimitAFileOverridesItAndAFlagOverridesBoth) {
  const auto file = std::filesystem::temp_directory_path() / ("mm-config-" + std::to_string(getpid()) + ".toml");
  std::ofstream(file) << "# limits\nmax-sample-count = 3\nmax-steps = 7\n";
  setenv("MM_MAX_SAMPLE_COUNT", "2", 1);
  {
    ServerProcess server;
    EXPECT_NE(sample_refusal(server, 3).find("at most 2 allowed (the server's max_sample_count)"), std::string::npos);
    EXPECT_EQ(sample_refusal(server, 2), "accepted");
  }
  {
    ServerProcess server({"--config", file.string()});
    EXPECT_NE(sample_refusal(server, 4).find("at most 3 allowed"), std::string::npos);
    EXPECT_EQ(sample_refusal(server, 3), "accepted");
  }
  {
    ServerProcess server({"--config", file.string(), "--max-sample-count", "5"});
    EXPECT_EQ(sample_refusal(server, 5), "accepted");
    EXPECT_NE(sample_refusal(server, 6).find("at most 5 allowed"), std::string::npos);
  }
  unsetenv("MM_MAX_SAMPLE_COUNT");
  std::filesystem::remove(file);
}

TEST(ServerConfig, AnUnknownKeyOrABadValueStopsTheServerNamingIt) {
  const auto file = std::filesystem::temp_directory_path() / ("mm-config-bad-" + std::to_string(getpid()) + ".toml");
  std::ofstream(file) << "max-sample-count = -1\n";
  try {
    ServerProcess server({"--config", file.string()}, std::chrono::seconds(30));
    ADD_FAILURE() << "the server started with max-sample-count = -1";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("max-sample-count"), std::string::npos) << e.what();
  }
  std::filesystem::remove(file);
}

bool cpu_has_bf16_dot_products() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  const std::string text((std::istreambuf_iterator<char>(cpuinfo)), std::istreambuf_iterator<char>());
  return text.find("avx512_bf16") != std::string::npos || text.find("amx_bf16") != std::string::npos;
}

// The poses of one seeded sample of the default model.
std::vector<double> sampled_poses(const ServerProcess& server) {
  const Reply reply = post(server.rest_port(), "/v1/sample", nlohmann::json{{"count", 1}, {"seed", 3}});
  EXPECT_EQ(reply.status, 200) << reply.body;
  const auto body = nlohmann::json::parse(reply.body);
  // The joints' exponential maps: the root's path (columns 0..2, mm) is the
  // trajectory network's, from these poses.
  std::vector<double> values;
  const auto& all = body["motions"][0]["values"];
  for (size_t i = 0; i < all.size(); ++i) {
    if (i % 99 >= 3) values.push_back(all[i].get<double>());
  }
  return values;
}

// --precision bf16 and int8 pack the default model's weights anew where the
// CPU has bf16 dot products: the same sample then comes out close to fp32's
// but not equal; where it has none, the server refuses to start, naming why.
TEST(ServerConfig, LowerPrecisionsDecodeCloseToFp32OrAreRefusedNamingTheCpu) {
  for (const std::string precision : {"bf16", "int8"}) {
    SCOPED_TRACE(precision);
    if (!cpu_has_bf16_dot_products()) {
      try {
        ServerProcess server({"--precision", precision}, std::chrono::seconds(30));
        ADD_FAILURE() << "the server started in " << precision << " on a CPU without bf16 dot products";
      } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("bf16 dot products"), std::string::npos) << e.what();
      }
      continue;
    }
    std::vector<double> fp32, lower;
    {
      ServerProcess server;
      fp32 = sampled_poses(server);
    }
    {
      ServerProcess server({"--precision", "h36m-dkgm-h100=" + precision});
      lower = sampled_poses(server);
      // The model list says which precision each model is served in.
      const Reply models = get(server.rest_port(), "/v1/models");
      ASSERT_EQ(models.status, 200) << models.body;
      int listed = 0;
      const auto document = nlohmann::json::parse(models.body);  // the loop below reads into it
      for (const auto& model : document["models"]) {
        const bool named = model["name"] == "h36m-dkgm-h100";
        EXPECT_EQ(model["precision"], named ? precision : "fp32") << model["name"];
        listed += named;
      }
      EXPECT_EQ(listed, 1);
    }
    ASSERT_EQ(fp32.size(), lower.size());
    ASSERT_FALSE(fp32.empty());
    double largest = 0, mean = 0;
    for (size_t i = 0; i < fp32.size(); ++i) {
      largest = std::max(largest, std::abs(fp32[i] - lower[i]));
      mean += std::abs(fp32[i] - lower[i]) / static_cast<double>(fp32.size());
    }
    std::printf("%s against fp32: %.5f rad apart on average, %.4f at most\n", precision.c_str(), mean, largest);
    EXPECT_GT(largest, 0.0);  // it is not the fp32 path
    EXPECT_LT(mean, 0.01);    // radians (exponential-map values)
  }
}

TEST(ServerConfig, AnUnknownPrecisionStopsTheServerNamingIt) {
  try {
    ServerProcess server({"--precision", "fp16"}, std::chrono::seconds(30));
    ADD_FAILURE() << "the server started with --precision fp16";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("--precision \"fp16\": unknown value \"fp16\""), std::string::npos) << e.what();
  }
}

// --help is read on machines other than the build's: the defaults that are
// this build's source and build tree (model store, web root, tool) are
// described, not shown as absolute paths.
TEST(ServerConfig, HelpShowsNoPathOfTheBuildMachine) {
  const CommandRun run = run_command(MM_SERVER_BINARY, "--help");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  // The options' part: the Usage line names the binary as it was called.
  const std::string options = run.out.substr(std::min(run.out.find("Options:"), run.out.size()));
  EXPECT_EQ(options.find(MM_SOURCE_DIR), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("models/ of the source tree"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("--tool"), std::string::npos) << run.out;
}

// A second server given a port the first one serves on stops with an error
// naming it, instead of sharing the port (SO_REUSEPORT) and half the
// connections with the first.
TEST(ServerConfig, APortInUseStopsASecondServerNamingTheAddress) {
  ServerProcess first;
  const std::string common = std::string("--model-store ") + first.model_store() + " --address 127.0.0.1 --web-root ''";
  // `timeout` ends a second server that did start (exit 124).
  const std::string second = std::string("timeout 60 ") + MM_SERVER_BINARY;
  const CommandRun rest_clash =
      run_command(second, common + " --grpc-port 0 --rest-port " + std::to_string(first.rest_port()));
  EXPECT_EQ(rest_clash.exit_code, 1) << rest_clash.err;
  // The log (standard output) says why.
  EXPECT_NE(rest_clash.out.find("cannot listen on 127.0.0.1:" + std::to_string(first.rest_port())), std::string::npos)
      << rest_clash.out;
  const CommandRun grpc_clash =
      run_command(second, common + " --rest-port 0 --grpc-port " + std::to_string(first.grpc_port()));
  EXPECT_EQ(grpc_clash.exit_code, 1) << grpc_clash.err;
  EXPECT_NE(grpc_clash.out.find("cannot listen on 127.0.0.1:" + std::to_string(first.grpc_port())), std::string::npos)
      << grpc_clash.out;
  // The first serves on.
  EXPECT_EQ(get(first.rest_port(), "/v1/models").status, 200);
}

}  // namespace
}  // namespace mm::test
