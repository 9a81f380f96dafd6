// Baselines and regressions (docs/bench.md, "Baselines"): a run compared with a stored baseline
// case by case, each value within the suite's tolerances (suite.h, Tolerances).
//
//   const BenchRun baseline = LoadBenchRun("bench/baselines/golden/fast.json");
//   const Comparison c = CompareRuns(baseline, LoadBenchRun(dir), run.suite.tolerances);
//   std::cout << c.FullReport();
//   return c.HasRegression() ? 4 : 0;
//
// What is compared, case by case (matched by id): the status; the solver's iterations and final
// cost; every free parameter's value (by name); NRMSE, FIT % and R^2 of every split and channel
// of the case's metrics (by split and channel); and the case's wall time (`seconds`). A value
// outside its tolerance is a finding whichever way it moved (a golden value changed: accept it
// with `graybox bench baseline`), except time, which counts only when slower than
// time_factor x the baseline and by more than time_min_seconds. A case of the baseline the run
// lacks, and a status that changed, are findings; a case the baseline lacks is noted only.
//
// Failure behaviour: CompareRuns throws std::invalid_argument when the baseline and the run are
// of different suites (by name).
#pragma once

#include <string>
#include <vector>

#include "graybox/bench/results.h"

namespace graybox::bench {

/// One value outside its tolerance, or a case-level change.
struct Finding {
  std::string case_id;
  /// "status", "missing" (in the baseline, not in the run), "new" (in the run only; not a
  /// regression), "iterations", "cost", "parameter", "nrmse", "fit_percent", "r2", "metrics" (a
  /// split and channel the run has no metrics of), "seconds".
  std::string kind;
  /// What exactly: the parameter's name, "<split>/<channel>" for the metrics, "" otherwise.
  std::string what;
  double baseline = 0.0, value = 0.0;
  std::string baseline_text, value_text;  // statuses, for kind "status"
  std::string tolerance;                  // Tolerance::ToString(), or the time rule
  bool regression = true;                 // counts towards the exit code 4
};

struct Comparison {
  std::vector<Finding> findings;
  int cases_compared = 0;  // cases in both
  int values_compared = 0;
  /// The command that accepts the run as the new baseline (shown in the reports).
  std::string accept_command;

  bool HasRegression() const;
  /// One line: "compare: 12 cases, 340 values: all within their tolerances", or the counts of
  /// values outside them, statuses changed, time regressions, cases missing and new cases.
  std::string BriefReport() const;
  /// Every finding, one line each (case, metric, baseline -> value, difference, relative
  /// difference, tolerance), then the brief line and the command to accept.
  std::string FullReport() const;
};

/// `run` against `baseline` under `tolerances` (file comment). `accept_command` is copied into
/// the result for the reports.
Comparison CompareRuns(const BenchRun& baseline, const BenchRun& run, const Tolerances& tolerances,
                       const std::string& accept_command = "");

/// A baseline file: the run as bench.json holds it, with "run.baseline_of" naming where it came
/// from. Throws std::invalid_argument when the run was interrupted (it is incomplete).
std::string BaselineJson(const BenchRun& run, const std::string& source);

}  // namespace graybox::bench
