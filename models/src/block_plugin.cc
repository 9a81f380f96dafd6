#include "graybox/models/block_plugin.h"

#include <dlfcn.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

namespace graybox::models {

std::vector<std::string> LoadBlockPlugin(const std::string& path) {
  static std::mutex mutex;
  static std::map<std::string, std::vector<std::string>> loaded;  // canonical path -> types
  const std::lock_guard<std::mutex> lock(mutex);
  std::error_code ec;
  const std::filesystem::path canonical = std::filesystem::canonical(path, ec);
  if (ec) {
    throw std::runtime_error("block plugin '" + path + "': cannot open it (" + ec.message() + ")");
  }
  const auto done = loaded.find(canonical.string());
  if (done != loaded.end()) return done->second;
  // RTLD_NOW: an undefined symbol fails here, with its name, not at the first call.
  void* handle = dlopen(canonical.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* error = dlerror();
    throw std::runtime_error("block plugin '" + path + "': cannot load it (" +
                             (error ? error : "unknown error") +
                             "); a plugin must not link the graybox libraries, see block_plugin.h");
  }
  using RegisterFunction = void (*)(BlockRegistry&);
  const auto registration = reinterpret_cast<RegisterFunction>(dlsym(handle, kBlockPluginFunction));
  if (!registration) {
    dlclose(handle);
    throw std::runtime_error("block plugin '" + path + "': expected a function '" +
                             std::string(kBlockPluginFunction) +
                             "' (GRAYBOX_BLOCK_PLUGIN in graybox/models/block_plugin.h), got none");
  }
  BlockRegistry& registry = BlockRegistry::Global();
  const std::vector<std::string> before = registry.Types();
  try {
    registration(registry);
  } catch (const std::exception& e) {
    throw std::runtime_error("block plugin '" + path + "': its registration failed: " + e.what());
  }
  std::vector<std::string> added;
  for (const std::string& t : registry.Types()) {
    if (!std::binary_search(before.begin(), before.end(), t)) added.push_back(t);
  }
  // The handle stays open for the program's lifetime: the registry holds its factories.
  loaded[canonical.string()] = added;
  return added;
}

}  // namespace graybox::models
