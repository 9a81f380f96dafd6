// LoadBlockPlugin (models/block_plugin.h) reports what it cannot load, naming the file: a missing
// file, a file that is not a shared library. (A working plugin is built against the installed
// package and fitted by the installed command in tools/test.sh: tests/consumer/.)
#include "graybox/models/block_plugin.h"

#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

namespace graybox::models {
namespace {

std::string ErrorOf(const std::string& path) {
  try {
    LoadBlockPlugin(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected a std::runtime_error";
  return "";
}

TEST(BlockPlugin, MissingFilesAndNonLibrariesAreReportedWithTheirPath) {
  const std::string missing = "/nonexistent/libno_blocks.so";
  const std::string e1 = ErrorOf(missing);
  EXPECT_NE(e1.find("block plugin '" + missing + "': cannot open it"), std::string::npos) << e1;
  const std::string text = ::testing::TempDir() + "not_a_library.so";
  std::ofstream(text) << "plain text\n";
  const std::string e2 = ErrorOf(text);
  EXPECT_NE(e2.find("block plugin '" + text + "': cannot load it"), std::string::npos) << e2;
  std::remove(text.c_str());
}

}  // namespace
}  // namespace graybox::models
