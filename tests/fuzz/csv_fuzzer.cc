// libFuzzer harness: the CSV reader (estimators::ParseCsv) with the default options and with a
// ';' delimiter and no header. Seeds: problems/equations/tank.csv.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_common.h"
#include "graybox/estimators/data/csv_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  graybox::fuzz::ExpectCleanRejection([&] { graybox::estimators::ParseCsv(text); });
  graybox::fuzz::ExpectCleanRejection([&] {
    graybox::estimators::CsvOptions options;
    options.delimiter = ';';
    options.has_header = false;
    graybox::estimators::ParseCsv(text, options);
  });
  return 0;
}
