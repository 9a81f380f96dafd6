// libFuzzer harness: the parameter-file reader of `graybox simulate --params` and `graybox fit
// --from` (app::LoadParameterValues: a result.json or a TOML table), against the model of
// problems/emps/emps_closed_loop.toml, as JSON (.json) and as TOML (.toml). Seeds: the TOML tables
// of parameters in tests/fuzz/seeds/parameters and result.json files a fit writes.
#include <cstddef>
#include <cstdint>
#include <string>

#include "app.h"
#include "fuzz_common.h"
#include "graybox/estimators/problem/problem_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  static const graybox::estimators::Problem problem =
      graybox::estimators::LoadProblem(GRAYBOX_SOURCE_DIR "/problems/emps/emps_closed_loop.toml");
  static graybox::fuzz::ScratchFile json(".json"), toml(".toml");
  for (graybox::fuzz::ScratchFile* file : {&json, &toml}) {
    const std::string& path = file->Write(data, size);
    graybox::fuzz::ExpectCleanRejection(
        [&] { graybox::app::LoadParameterValues(path, problem.built); });
  }
  return 0;
}
