// The version and the git revision recorded in every result.json (GRAYBOX_GIT_REVISION comes from
// the header the graybox_revision target regenerates at every build, apps/CMakeLists.txt; only
// this file includes it, so a new revision recompiles one TU).
#include "app.h"
#include "graybox_revision.h"

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
