// libFuzzer harness: the MAT-file reader (estimators::MatFile on matio, v4, v5 and v7.3): opens
// the input, lists its variables and reads every one as a matrix, a scalar and text. Seeds:
// small files written by graybox's own MatWriter (make_mat_seeds).
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_common.h"
#include "graybox/estimators/data/mat_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  static graybox::fuzz::ScratchFile file(".mat");
  const std::string& path = file.Write(data, size);
  graybox::fuzz::ExpectCleanRejection([&] {
    const graybox::estimators::MatFile mat(path);
    for (const std::string& name : mat.VariableNames()) {
      graybox::fuzz::ExpectCleanRejection([&] { mat.Info(name); });
      graybox::fuzz::ExpectCleanRejection([&] { mat.ReadMatrix(name); });
      graybox::fuzz::ExpectCleanRejection([&] { mat.ReadScalar(name); });
      graybox::fuzz::ExpectCleanRejection([&] { mat.ReadString(name); });
    }
    graybox::fuzz::ExpectCleanRejection([&] { mat.ReadMatrix("s.x"); });
  });
  return 0;
}
