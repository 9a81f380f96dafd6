#include "graybox/util/read_file.h"

#include <filesystem>
#include <fstream>
#include <sstream>

namespace graybox::util {

std::optional<std::string> ReadWholeFile(const std::string& path, std::string* why) {
  std::error_code ec;
  std::ifstream in(path, std::ios::binary);
  if (!in || std::filesystem::is_directory(path, ec)) {
    if (why != nullptr) {
      *why = std::filesystem::exists(path, ec) ? "permission denied or not a regular file"
                                               : "file not found";
    }
    return std::nullopt;
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) {
    if (why != nullptr) *why = "permission denied or not a regular file";
    return std::nullopt;
  }
  return text.str();
}

}  // namespace graybox::util
