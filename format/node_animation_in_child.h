// Runs a reader of a node animation (node_animation.h) in a child process,
// for readers built on a library that may abort or exhaust memory on a
// malformed file: Debian's assimp is built with its assertions on, and an
// assertion ends the process (ai_assert calls abort()), which in the server
// would end every request in flight. In a child the worst a file can do is
// end the child: the caller gets an InputError.
//
// The child has `memory_bytes` of address space beyond the parent's and 60 s
// of CPU; it sends the animation back through a pipe. Safe to call from any
// thread (fork() copies only the calling thread; the child calls nothing
// but the reader and _exit).
#pragma once

#include <cstddef>
#include <functional>
#include <string>

#include "format/node_animation.h"

namespace mm {

// The address space a reader may take for a file of `input_bytes`: 64 times
// its size plus 512 MiB (assimp's FBX import took about 20 times).
size_t child_memory_budget(size_t input_bytes);

// `read()`'s animation, run in a child process. Throws InputError naming
// `what` with the child's InputError message, or saying that it stopped (a
// signal: an assertion, the memory or CPU limit) or failed (any other
// exception); std::runtime_error when no child can be started.
NodeAnimation read_in_child_process(const std::string& what, size_t memory_bytes,
                                    const std::function<NodeAnimation()>& read);

}  // namespace mm
