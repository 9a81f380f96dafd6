// The version and the git revision recorded in every result.json (GRAYBOX_GIT_REVISION is set at
// configure time by apps/CMakeLists.txt, on this file only, so a new revision recompiles one TU).
#include "app.h"

#ifndef GRAYBOX_GIT_REVISION
#define GRAYBOX_GIT_REVISION "unknown"
#endif
#ifndef GRAYBOX_VERSION
#define GRAYBOX_VERSION "unknown"
#endif

namespace graybox::app {

const char* GitRevision() { return GRAYBOX_GIT_REVISION; }
const char* Version() { return GRAYBOX_VERSION; }

}  // namespace graybox::app
