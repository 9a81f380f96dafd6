// Atomic writes of output files.
#include <unistd.h>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>

#include "app.h"

namespace graybox::app {

bool IsControlCharacter(char c) {
  const auto u = static_cast<unsigned char>(c);
  return u < 0x20 || u == 0x7f;
}

std::string Printable(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    if (IsControlCharacter(c) && c != '\n' && c != '\t') {
      const auto u = static_cast<unsigned char>(c);
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", u);
      out += buf;
    } else {
      out += c;
    }
  }
  return out;
}

namespace {
// DIR without a trailing separator, absolute (so that its parent and name are defined for ".").
std::filesystem::path Normalised(const std::string& dir) {
  namespace fs = std::filesystem;
  fs::path p = fs::absolute(fs::path(dir)).lexically_normal();
  if (p.filename().empty()) p = p.parent_path();
  return p;
}

// ".<name>.<tag>-<pid>" beside `target`: this process' staging or previous folder.
std::filesystem::path Beside(const std::filesystem::path& target, const std::string& tag) {
  return target.parent_path() / ("." + target.filename().string() + "." + tag + "-" +
                                 std::to_string(static_cast<long>(::getpid())));
}
}  // namespace

RunOutput::RunOutput(const std::string& dir) : dir_(dir) {
  namespace fs = std::filesystem;
  if (dir.empty()) throw std::invalid_argument("--out: expected an output directory, got ''");
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) {
    throw std::invalid_argument("--out '" + dir +
                                "': expected a directory (or a path to create), got an existing "
                                "file");
  }
  const fs::path target = Normalised(dir);
  const fs::path parent = target.parent_path();
  fs::create_directories(parent, ec);
  if (ec || !fs::is_directory(parent)) {
    throw std::invalid_argument("--out '" + dir + "': cannot create its parent folder '" +
                                parent.string() + "'" + (ec ? ": " + ec.message() : ""));
  }
  const fs::path staging = Beside(target, "partial");
  fs::remove_all(staging, ec);
  if (!fs::create_directory(staging, ec) || ec) {
    throw std::invalid_argument("--out '" + dir + "': cannot write beside it in '" +
                                parent.string() + "'" + (ec ? ": " + ec.message() : ""));
  }
  staging_ = staging.string();
}

RunOutput::~RunOutput() {
  if (done_ || staging_.empty()) return;
  std::error_code ignored;
  std::filesystem::remove_all(staging_, ignored);
}

std::string RunOutput::Commit() {
  namespace fs = std::filesystem;
  const fs::path target = Normalised(dir_);
  // From here the staging folder is either moved into place or kept and named in the error.
  done_ = true;
  std::error_code ec;
  if (!fs::exists(target, ec)) {
    fs::rename(staging_, target, ec);
    if (ec) {
      throw std::runtime_error("cannot move this run's outputs to '" + dir_ + "': " + ec.message() +
                               "; they are in '" + staging_ + "'");
    }
    return "created " + dir_;
  }
  const fs::path previous = Beside(target, "previous");
  fs::remove_all(previous, ec);
  fs::rename(target, previous, ec);
  if (ec) {
    throw std::runtime_error("cannot replace the earlier run in '" + dir_ + "' (" + ec.message() +
                             "): it is left untouched; this run's outputs are in '" + staging_ +
                             "'");
  }
  fs::rename(staging_, target, ec);
  if (ec) {
    std::error_code back;
    fs::rename(previous, target, back);
    throw std::runtime_error("cannot move this run's outputs to '" + dir_ + "' (" + ec.message() +
                             "): " +
                             (back ? "the earlier run is in '" + previous.string() + "'"
                                   : std::string("the earlier run is left in place")) +
                             "; this run's outputs are in '" + staging_ + "'");
  }
  fs::remove_all(previous, ec);
  return "replaced the earlier run in " + dir_ +
         (ec ? " (its old files are in '" + previous.string() + "': " + ec.message() + ")"
             : " (removed)");
}

}  // namespace graybox::app
