#include "graybox/util/thread_user_time.h"

#include <sys/resource.h>

namespace graybox::util {

double ThreadUserSeconds() {
  rusage usage{};
  getrusage(RUSAGE_THREAD, &usage);
  return static_cast<double>(usage.ru_utime.tv_sec) +
         1e-6 * static_cast<double>(usage.ru_utime.tv_usec);
}

}  // namespace graybox::util
