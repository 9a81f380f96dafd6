// diagnosis.json: a DiagnosisReport (diagnose.h) as one JSON document, the schema of
// docs/diagnosis-json.md. Keys are in a fixed order; NaN and Inf are written as null.
//
//   const DiagnosisReport d = Diagnose(problem, splits);
//   const std::string json = DiagnosisJson(d, {{"revision", GitRevision()}, {"seed", "1"}});
//
// Failure behaviour: none beyond std::bad_alloc; every field of the report is written as it is.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "graybox/diagnosis/diagnose.h"

namespace graybox::diagnosis {

/// The schema version written as "schema": bumped when a key changes meaning or disappears.
inline constexpr int kDiagnosisJsonSchema = 1;

/// The JSON document of `report`, pretty-printed with two spaces. `run` (command line, revision,
/// seed, ...) is written as the object "run", in the given order.
std::string DiagnosisJson(const DiagnosisReport& report,
                          const std::vector<std::pair<std::string, std::string>>& run = {});

}  // namespace graybox::diagnosis
