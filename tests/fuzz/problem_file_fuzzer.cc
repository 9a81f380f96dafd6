// libFuzzer harness: a problem file (estimators::ParseProblem: TOML, the model with its blocks,
// equation blocks and augmentations, [[data]] mappings, [estimation], [metrics], [diagnosis]).
// No data file is read. Seeds: problems/**/*.toml.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_common.h"
#include "graybox/estimators/problem/problem_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  graybox::fuzz::ExpectCleanRejection([&] {
    // Relative data paths resolve beside the shipped problems; nothing is read.
    graybox::estimators::ParseProblem(text, GRAYBOX_SOURCE_DIR "/problems/fuzz/problem.toml");
  });
  return 0;
}
