// The user-mode CPU time of the calling thread: a clock for budgets whose outcome must not depend
// on the machine's load (waiting for a lock or for a core does not advance it) nor on the process
// it runs in (the kernel's time, such as the page faults of a freshly forked process filling its
// memory, does not count).
#pragma once

namespace graybox::util {

/// User-mode CPU time [s] consumed by the calling thread so far (getrusage RUSAGE_THREAD,
/// ru_utime).
double ThreadUserSeconds();

}  // namespace graybox::util
