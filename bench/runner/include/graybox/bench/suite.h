// Bench suites: which problems to run and over which variations (docs/bench.md). A suite is a
// TOML file in the style of the problem files (the same located errors: unknown keys with a
// suggestion, file:line:column), or a folder, which runs every problem file in it once.
//
//   [suite]
//   name = "emps"                  # default: the file's stem
//   description = "..."
//   problems = ["../problems/emps/emps_idim.toml", "../problems/emps"]   # files or folders,
//                                  # relative to the suite file; a folder: its *.toml, sorted
//   time_limit = 600               # [s] wall time of one case (default 1800); the case's process
//                                  # is killed past it and recorded as timed out
//   exclude = ["*ceres*collocation*"]   # globs over case ids: combinations not to run
//
//   [variations]                   # keys of the problem files (ProblemOverride) and the values
//   "estimation.method" = ["multiple_shooting", "collocation"]        # to run: the cases are
//   "estimation.multiple_shooting.segment_length" = [10, 20]          # every combination
//
//   [perturbation]                 # start values of the free parameters, per seed:
//   relative = 0.1                 #   value * (1 + relative * z), z ~ N(0, 1) from the seed,
//   seeds = [1, 2, 3]              #   clamped to the bounds; one case per seed (default [1])
//
//   [tolerances]                   # how far `graybox bench compare` lets a value move from
//   nrmse = { relative = 1e-3 }    # its baseline (compare.h): |value - baseline| <= absolute +
//   iterations = { absolute = 5, relative = 0.5 }    # relative |baseline|; digits = d is
//   parameters = { digits = 2 }    # relative = 10^-d; compare = false skips the metric;
//   time = { factor = 3, min_seconds = 1 }           # a metric not named keeps its default
//
// Cases: problems x variations (in key order, values in file order) x seeds, in that order. A
// case's id is "<problem>/<key>=<value>,.../seed=<s>" (the parts that apply: no variation part
// without variations, no seed part unless the suite states seeds or a perturbation; a string value
// without its quotes), unique in the suite; --filter selects cases by a glob on it ('*' any run of
// characters).
//
// Failure behaviour: ParseSuite and LoadSuite throw estimators::ProblemFileError with the place
// (a missing problem file, an empty variation, a value that is not TOML, duplicate ids).
#pragma once

#include <string>
#include <vector>

#include "graybox/estimators/problem/problem_file.h"

namespace graybox::bench {

/// How far a value may move from its baseline and still agree: |value - baseline| <= absolute +
/// relative * |baseline| (two NaNs agree; a NaN and a number do not). `compared = false` skips
/// the metric.
struct Tolerance {
  double absolute = 0.0;
  double relative = 0.0;
  bool compared = true;
  bool Admits(double baseline, double value) const;
  /// "absolute 0.1 + relative 0.001", or "not compared".
  std::string ToString() const;
};

/// The tolerances of `graybox bench compare`, per metric: the suite's [tolerances] (defaults
/// here, documented in docs/bench.md). Metrics are compared per split and channel, parameters
/// by name (free ones only), iterations and cost per case.
struct Tolerances {
  Tolerance nrmse{1e-6, 1e-3};        // NRMSE = RMSE / std of the measured channel
  Tolerance fit_percent{0.1, 0.0};    // FIT % (absolute percentage points)
  Tolerance r2{1e-3, 0.0};            // R^2
  Tolerance cost{1e-12, 1e-3};        // the solver's final objective
  Tolerance iterations{5.0, 0.5};     // solver iterations: a band, not an exact count
  Tolerance parameters{1e-12, 1e-2};  // free parameters' values
  /// A time regression: the case's seconds exceed time_factor x the baseline's and by more
  /// than time_min_seconds (short cases are noise-bound).
  double time_factor = 3.0;
  double time_min_seconds = 1.0;
};

/// One key and the values it takes over the suite's cases.
struct Variation {
  std::string key;                  // dotted problem-file key (estimators::ProblemOverride)
  std::vector<std::string> values;  // TOML values, as written ("\"collocation\"", "20")
  estimators::SourceLocation where;
};

struct Suite {
  std::string name;
  std::string description;
  std::string path;                   // the suite file (or folder)
  std::vector<std::string> problems;  // problem files, resolved against the suite's folder
  std::vector<Variation> variations;
  double relative_perturbation = 0.0;
  std::vector<unsigned> seeds = {1};
  /// [perturbation] seeds was given (or `graybox bench --seed`): the seeds are the fits' seeds.
  bool seeds_stated = false;
  double time_limit = 1800.0;        // [s] per case
  std::vector<std::string> exclude;  // globs over case ids
  Tolerances tolerances;
};

/// One run: a problem with one value of every variation and one seed.
struct Case {
  std::string id;
  /// The case's place in ExpandCases (0-based), kept through filters and shards: its records
  /// and logs are cases/<index>.json and .log, and merged shards are ordered by it.
  std::size_t index = 0;
  std::string problem;  // path of the problem file
  std::string problem_name;
  std::vector<estimators::ProblemOverride> overrides;
  unsigned seed = 1;
  /// The suite states seeds or a perturbation (Suite::seeds_stated): `seed` is the fit's seed
  /// (EstimationSpec::seed); otherwise the problem file's own seed stays.
  bool seeded = false;
  double relative_perturbation = 0.0;
};

/// Reads a suite file, or a folder of problem files (default tolerances). Throws
/// estimators::ProblemFileError.
Suite LoadSuite(const std::string& path);
/// A suite from text; `path` names it in messages and anchors relative problem paths.
Suite ParseSuite(const std::string& text, const std::string& path);

/// Every case of the suite, in the suite's order, without the excluded ones (file comment).
std::vector<Case> ExpandCases(const Suite& suite);

/// The cases whose id matches the glob `pattern` (every case when it is empty).
std::vector<Case> FilterCases(const std::vector<Case>& cases, const std::string& pattern);

}  // namespace graybox::bench
