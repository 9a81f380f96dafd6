// Shared by the libFuzzer harnesses (tests/fuzz/README in docs/fuzzing.md): what counts as a
// clean rejection of bad input, and a scratch file for readers that take a path.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <stdexcept>
#include <string>
#include <typeinfo>

namespace graybox::fuzz {

/// Runs fn(); a std::invalid_argument or std::runtime_error (and what derives from them: the
/// loaders' located errors) is a clean rejection. Any other exception is a finding: the harness
/// aborts, so libFuzzer saves the input (std::bad_alloc from a declared size, std::out_of_range
/// from an unchecked index, std::length_error, ...).
template <typename Fn>
void ExpectCleanRejection(Fn&& fn) {
  try {
    fn();
  } catch (const std::invalid_argument&) {
  } catch (const std::runtime_error&) {
  } catch (const std::exception& e) {
    std::fprintf(stderr, "finding: uncaught %s: %s\n", typeid(e).name(), e.what());
    std::abort();
  } catch (...) {
    std::fprintf(stderr, "finding: a non-std exception\n");
    std::abort();
  }
}

/// A file in $TMPDIR (or /tmp) unique to this process, rewritten with every input, for readers
/// that take a path (matio, the parameter-file reader).
class ScratchFile {
 public:
  explicit ScratchFile(const std::string& suffix) {
    const char* dir = std::getenv("TMPDIR");
    path_ = std::string(dir != nullptr && *dir != '\0' ? dir : "/tmp") + "/graybox_fuzz_" +
            std::to_string(::getpid()) + suffix;
  }
  ~ScratchFile() { std::remove(path_.c_str()); }
  const std::string& Write(const uint8_t* data, std::size_t size) {
    std::FILE* f = std::fopen(path_.c_str(), "wb");
    if (f == nullptr) std::abort();
    if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
    std::fclose(f);
    return path_;
  }

 private:
  std::string path_;
};

}  // namespace graybox::fuzz
