// The service as the fuzz targets drive it: the real ManifoldCore on the
// small shipped model (models/h36m-dkgm-cpu, hidden 256, so that a request
// that gets through runs real inference quickly), with training jobs and a
// scratch data root holding a CMU dance BVH and a small hand-made H3.6M-layout
// text file. Built once per process, on first use, in a scratch folder under
// $TMPDIR (or /tmp), removed at a normal exit (not after a crash: run.sh
// gives each run a TMPDIR of its own and removes it).
//
// Differences from scripts/serve.sh, each to keep one input's cost small:
// the request limits are low (4 motions, 4 samples, 8 steps, 4 denoising
// iterations; the checks are the same, at other numbers), the executor has
// one thread, and a job's tool is /bin/false, so a job that passes the core's
// checks fails at once instead of training.
//
// Any refusal is a correct answer; an INTERNAL one (500) to a request is a
// bug the targets report as a crash (report_internal_error).
#pragma once

#include <string>

#include "server/core/core.h"
#include "server/core/service_metrics.h"

namespace mm::fuzz {

struct FuzzService {
  service::ServiceMetrics& metrics;
  service::Core& core;  // the real ManifoldCore, seen as the frontends see it
};

// Starts the service on first call. Exits the process naming what is
// missing when it cannot (the shipped model, the CMU archive).
FuzzService& fuzz_service();

// With MM_FUZZ_VERBOSE=1 in the environment, each answer is printed
// (status and the start of the reply), to see what seeds reach.
void print_answer_when_verbose(const std::string& request, int status, const std::string& reply);

// Prints what the request got and aborts, so that libFuzzer keeps the input.
[[noreturn]] void report_internal_error(const std::string& where, const std::string& message);

}  // namespace mm::fuzz
