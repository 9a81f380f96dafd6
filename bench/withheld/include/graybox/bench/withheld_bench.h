// The withheld-effect benchmark: the diagnosis (diagnosis::Diagnose) run on every withheld case
// (withheld.h), scored against what was withheld. `graybox bench withheld --out DIR` calls it and
// writes DIR/bench.json (WithheldBenchJson).
//
//   WithheldBenchOptions options;
//   options.cases.fast_subset = true;                 // the CI subset
//   const WithheldBench b = RunWithheldBench(options);
//   std::cout << b.ConfusionTable() << b.Summary();
//
// ---- One record per case ----------------------------------------------------------------------
//   case, base, withheld (the effect's name; two effects joined by "+"), in_library,
//   truth_detail
//   top        the first accepted effect of the forward selection, or "none"
//   accepted   the accepted effects, in order
//   top_alternatives  the effects the data could not tell apart from the top one
//                     (AcceptedEffect::alternatives, effect names only)
//   named_or_equivalent  one library effect withheld, and it is the top or one of its
//                     alternatives (the same signature on these data)
//   explained  DiagnosisReport::explained; structured_remaining its DiagnosisReport::
//              structured_remaining (the share of the residual's structured energy left)
//   nominal_validation_nrmse, final_validation_nrmse, reference_validation_nrmse, oracle
//   shrinkage            e_nominal - e_final, what the diagnosis says the accepted effects bring
//   achievable_shrinkage e_nominal - e_oracle: the oracle is the truth structure at its true
//                        parameters (withheld.h), an upper bound on what fitting it brings
//   shrinkage_error      |shrinkage / achievable_shrinkage - 1| (NaN when nothing is achievable)
//   pass       in the library, one effect: top is the withheld effect;
//              in the library, two effects: both are among the accepted;
//              outside the library: the diagnosis says the library does not explain the gap
//              (DiagnosisReport::explained false: nothing accepted, or accepted effects that
//              leave more than half of the residual's structured energy, diagnose.h).
//   failure    the exception text when the diagnosis could not run (pass = false)
//
// ---- Summary (the pass marks)
// ------------------------------------------------------------
//   top-ranked rate    of the one-effect library cases, the share whose top is the withheld one
//   named-or-equivalent rate  the same, counting the top's alternatives too
//   both-found rate    of the two-effect cases, the share with both among the accepted
//   unexplained rate   of the cases outside the library, the share not explained (above)
//   shrinkage within   of the passing library cases, the share with shrinkage_error <= 0.25
//
// Cases run one after the other (Ipopt is serialised anyway); each diagnosis screens and re-fits
// on DiagnoseOptions::screening.num_threads threads. Failure behaviour: invalid options throw
// std::invalid_argument; a case whose diagnosis throws is recorded with its failure and counted
// as not passing.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "graybox/bench/withheld.h"
#include "graybox/diagnosis/diagnose.h"

namespace graybox::bench {

struct WithheldBenchOptions {
  /// Which cases (bases, fast subset, seed).
  WithheldOptions cases;
  /// Only the cases whose name contains one of these substrings (empty: all selected).
  std::vector<std::string> name_filters;
  /// The diagnosis' options (their progress callback is replaced by `progress`).
  diagnosis::DiagnoseOptions diagnose;
  /// The pass mark of shrinkage_error.
  double shrinkage_tolerance = 0.25;
  /// Progress lines ("case 3/47 drive_cl/coulomb_atan/s1: top coulomb (pass), 12.1 s").
  std::function<void(const std::string&)> progress;
  void Validate() const;
};

struct WithheldRecord {
  std::string name, base, truth_detail;
  std::vector<std::string> withheld;
  bool in_library = true;
  std::string top = "none";
  std::vector<std::string> accepted;
  std::vector<std::string> top_alternatives;
  bool named_or_equivalent = false;
  bool explained = false;
  double structured_remaining = 1.0;
  double nominal_validation_nrmse = 0.0, final_validation_nrmse = 0.0;
  double reference_validation_nrmse = 0.0, oracle_validation_nrmse = 0.0;
  double shrinkage = 0.0, achievable_shrinkage = 0.0, shrinkage_error = 0.0;
  bool pass = false;
  std::string verdict;
  std::string failure;
  double seconds = 0.0;
  /// The case's whole diagnosis, as diagnosis.json (diagnosis::DiagnosisJson); empty when the
  /// diagnosis could not run. `graybox bench withheld` writes it to DIR/cases/<case>.json (the
  /// case name with '/' as '__').
  std::string diagnosis_json;
};

struct WithheldBench {
  std::vector<WithheldRecord> records;
  double top_ranked_rate = 0.0;
  double named_or_equivalent_rate = 0.0;
  double both_found_rate = 0.0;
  double unexplained_rate = 0.0;
  double shrinkage_within_rate = 0.0;
  int num_one_effect = 0, num_two_effect = 0, num_outside = 0, num_failed = 0;
  double seconds = 0.0;
  /// Rows: the withheld effect (library cases with one effect, and "outside" cases by name);
  /// columns: the top-ranked effect; cell: count.
  std::string ConfusionTable() const;
  /// The pass-mark rates, and one line per case with its shrinkage error.
  std::string Summary() const;
};

/// Runs the diagnosis on every selected case (see the file comment).
WithheldBench RunWithheldBench(const WithheldBenchOptions& options);

/// DIR/bench.json: {"summary": {...}, "records": [...]}, keys as in the file comment; NaN as null.
std::string WithheldBenchJson(const WithheldBench& bench,
                              const std::vector<std::pair<std::string, std::string>>& run = {});

}  // namespace graybox::bench
