// models list | describe | activate | delete: the server's model store.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>

#include "client/cli/commands.h"
#include "client/cli/server_connection.h"
#include "client/cli/server_error.h"
#include "wire/rest_json.h"

namespace mm::client {

// --json prints a reply as REST answers it, written by the same code.
using ::mm::wire::to_json;
namespace {

void print_model_line(const v1::ModelInfo& m) {
  std::printf("%s %-24s %s  %-6s hidden %-4d latent %-3d %-4s %s\n", m.active() ? "*" : " ", m.name().c_str(),
              m.version().c_str(), m.variant().c_str(), m.hidden(), m.latent(), m.precision().c_str(),
              m.loaded() ? "loaded" : "");
}

}  // namespace

void add_model_commands(CLI::App& app, const ClientSettings& settings, Action& action) {
  auto* models = app.add_subcommand("models", "The server's model store: list, describe, activate, delete");
  models->require_subcommand(1);

  models->add_subcommand("list", "Every model of the store (* marks the active one)")->callback([&settings, &action] {
    action = [&settings] {
      const auto reply = connect(settings.connection)->list_models();
      if (settings.json) {
        print_json(to_json(reply));
      } else {
        for (const auto& m : reply.models()) print_model_line(m);
      }
      return kExitSuccess;
    };
  });

  auto name = std::make_shared<std::string>();
  auto* describe = models->add_subcommand("describe", "One model with its provenance, evaluation and model card");
  describe->add_option("name", *name, "model name (default: the active model)");
  describe->callback([name, &settings, &action] {
    action = [name, &settings] {
      const auto model = connect(settings.connection)->describe_model(*name);
      const auto document = to_json(model);
      if (settings.json) {
        print_json(document);
        return kExitSuccess;
      }
      for (const auto& [key, value] : document.items()) {
        if (key == "model_card" || key == "provenance" || key == "evaluation") continue;
        std::printf("%-13s %s\n", (key + ":").c_str(), value.is_string() ? value.get<std::string>().c_str()
                                                                         : value.dump().c_str());
      }
      std::printf("provenance:   %s\nevaluation:   %s\n", document["provenance"].dump(2).c_str(),
                  document["evaluation"].dump(2).c_str());
      if (!model.model_card().empty()) std::printf("\n%s\n", model.model_card().c_str());
      return kExitSuccess;
    };
  });

  auto target = std::make_shared<std::string>();
  auto* activate = models->add_subcommand("activate", "Make a model the active one (loads it; needs the token)");
  activate->add_option("name", *target, "model name")->required();
  activate->callback([target, &settings, &action] {
    action = [target, &settings] {
      const auto model = connect(settings.connection)->activate_model(*target);
      if (settings.json) {
        print_json(to_json(model));
      } else {
        std::printf("active model: %s (version %s)\n", model.name().c_str(), model.version().c_str());
      }
      return kExitSuccess;
    };
  });

  auto doomed = std::make_shared<std::string>();
  auto* remove = models->add_subcommand(
      "delete", "Take a model out of the store, its folder removed (not the active model nor the server's default; "
                "needs the token)");
  remove->add_option("name", *doomed, "model name")->required();
  remove->callback([doomed, &settings, &action] {
    action = [doomed, &settings] {
      const auto model = connect(settings.connection)->delete_model(*doomed);
      if (settings.json) {
        print_json(to_json(model));
      } else {
        std::printf("deleted model: %s (version %s)\n", model.name().c_str(), model.version().c_str());
      }
      return kExitSuccess;
    };
  });
}

}  // namespace mm::client
