// libFuzzer harness: the MAT-file reader (estimators::MatFile on matio, v4 and v5/v7; v7.3 is
// skipped, see IsV73): opens the input, lists its variables and reads every one as a matrix, a
// scalar and text. Seeds: small files written by graybox's own MatWriter (make_mat_seeds).
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_common.h"
#include "graybox/estimators/data/mat_file.h"

// A v7.3 file is an HDF5 file: its parsing is HDF5's (fuzzed by that project), and a corrupt one
// can make HDF5 allocate without bound (H5C_protect asked for 777 GB on a 2 kB input), which
// graybox cannot check beforehand. Such inputs (the header's version 0x0200) are skipped.
bool IsV73(const uint8_t* data, std::size_t size) {
  if (size < 128) return false;
  const bool im = data[126] == 'I' && data[127] == 'M', mi = data[126] == 'M' && data[127] == 'I';
  const unsigned version = im ? (data[125] << 8 | data[124]) : (data[124] << 8 | data[125]);
  return (im || mi) && version == 0x0200;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  if (IsV73(data, size)) return 0;
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
