// Block plugins: a user's own C++ blocks, built as a shared library against the installed package
// (find_package(graybox)), registered into BlockRegistry::Global() at run time, so problem files
// (`[model] plugins = ["libmy_blocks.so"]`, docs/problem-format.md) and the `graybox` command can
// use them like the built-in blocks: fits, result.json, covariance, metrics, plots, the diagnosis.
//
// The library defines one function with C linkage,
//
//   #include "graybox/models/block_plugin.h"
//   GRAYBOX_BLOCK_PLUGIN(registry) {
//     registry.Register("user.spring", [](const graybox::models::BlockOptions& o) {
//       return std::make_unique<UserSpring>(o);
//     });
//   }
//
// and is built as a MODULE library that does NOT link the graybox libraries: its references to
// graybox (BlockRegistry, libexpr's operators for Compute<Expr>) resolve at load time to the
// loading program's own copies, which the `graybox` executable exports (CMake ENABLE_EXPORTS),
// so the registry and libexpr's expression tables are shared, never duplicated
// (tests/consumer/CMakeLists.txt is a complete example). A program of the user's own that loads
// plugins links with ENABLE_EXPORTS (-rdynamic) too.
//
// Failure behaviour. LoadBlockPlugin throws std::runtime_error naming the file and the reason:
// a file that cannot be opened or loaded (dlerror's message: a missing file, an undefined symbol
// the program does not export), no graybox_register_blocks function, or a registration that
// throws (a type registered twice). Loading the same file (same canonical path) again does nothing
// and returns the types it registered the first time.
#pragma once

#include <string>
#include <vector>

#include "graybox/models/block.h"

/// Defines the registration function of a block plugin (see the file comment).
#define GRAYBOX_BLOCK_PLUGIN(registry)                                            \
  extern "C" __attribute__((visibility("default"))) void graybox_register_blocks( \
      graybox::models::BlockRegistry& registry)

namespace graybox::models {

/// The name of the function a plugin defines.
inline constexpr char kBlockPluginFunction[] = "graybox_register_blocks";

/// Loads the shared library at `path` and registers its blocks into BlockRegistry::Global();
/// returns the block types it added, sorted.
std::vector<std::string> LoadBlockPlugin(const std::string& path);

}  // namespace graybox::models
