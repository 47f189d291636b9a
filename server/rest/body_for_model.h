// A request body read for the model its call runs on (core/core.h's
// ChosenModel): REST's BVH, glTF and FBX bodies, a take's motion text, a
// join's clips. The REST frontend chooses the model first
// (Core::choose_model), reads the body here for that model's shape, then
// runs the operation on the chosen model: the core never reads a body.
//
// Torch-free. Thread safety: as the core's calls.
#pragma once

#include <exception>

#include "server/api/api_types.h"
#include "server/core/core.h"

namespace mm::service::rest {

// What `read` makes of the body for `chosen`'s shape (read(shape)). A body
// it cannot read ends the call: its refusal (an ApiError: INVALID_ARGUMENT
// naming the body's line; anything else as INTERNAL) is counted as the
// call's outcome (Core::refuse_body) and thrown for the frontend to answer.
template <typename Read>
auto read_body_for_model(Core& core, const ChosenModel& chosen, Read&& read) -> decltype(read(chosen.shape())) {
  try {
    return read(chosen.shape());
  } catch (const ApiError& error) {
    core.refuse_body(chosen, error);
    throw;
  } catch (const std::exception& error) {
    const ApiError internal(ErrorCode::kInternal, "", error.what());
    core.refuse_body(chosen, internal);
    throw internal;
  }
}

}  // namespace mm::service::rest
