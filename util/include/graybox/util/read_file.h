// Reading a file whole: the one reader of the project's text inputs (problem, suite, parameter,
// CSV and bench files), each caller wording its own error from the reason given here.
#pragma once

#include <optional>
#include <string>

namespace graybox::util {

/// The content of the regular file at `path`, or std::nullopt with `*why` (when given) set to
/// "file not found" or "permission denied or not a regular file" (a folder, a file that cannot
/// be opened or read).
std::optional<std::string> ReadWholeFile(const std::string& path, std::string* why = nullptr);

}  // namespace graybox::util
