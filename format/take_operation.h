// What one take is asked for, named once from the model to the client: the
// model's TakeProcessor (model/take_processor.h), the core's take calls
// (server/core/take_session.h) and the client's take commands
// (client/cli/server_connection.h) all say it with this enum.
//
// Torch-free and wire-free: the client includes it.
#pragma once

namespace mm {

// encode: a take into a code track (every window's code);
// reconstruct: the take through the manifold, back at its rate and length;
// denoise: the same with each window projected onto the manifold, missing
// values filled.
enum class TakeOperation { kEncode, kReconstruct, kDenoise };

// "encode" / "reconstruct" / "denoise": the tool's and the client's
// subcommand names.
inline const char* take_operation_name(TakeOperation operation) {
  switch (operation) {
    case TakeOperation::kEncode: return "encode";
    case TakeOperation::kReconstruct: return "reconstruct";
    case TakeOperation::kDenoise: return "denoise";
  }
  return "?";
}

}  // namespace mm
