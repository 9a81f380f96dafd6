// The CPU time of the calling thread: a clock for budgets whose outcome must not depend on the
// machine's load (waiting for a lock or for a core does not advance it).
#pragma once

namespace graybox::util {

/// CPU time [s] consumed by the calling thread so far (CLOCK_THREAD_CPUTIME_ID).
double ThreadCpuSeconds();

}  // namespace graybox::util
