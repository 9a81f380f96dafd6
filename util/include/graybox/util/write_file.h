// Atomic file writes: the content goes to a temporary file in the target's folder
// (".<name>.tmp-<pid>-<n>") and is renamed over the target, so a reader sees the old file whole
// or the new one whole, never half of one.
//
// Failure behaviour: WriteFileAtomically throws std::runtime_error naming the file and the reason
// (the temporary file removed, the target untouched).
#pragma once

#include <string>

namespace graybox::util {

void WriteFileAtomically(const std::string& path, const std::string& content);

}  // namespace graybox::util
