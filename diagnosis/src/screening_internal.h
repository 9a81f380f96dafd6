// Private to the screening (screening.cc: the candidates of a round, the ranking, the reports;
// score_test.cc: the efficient score test of one candidate at its neutral value; refit.cc: the
// two-stage re-fit of one candidate): what the three files share.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "graybox/diagnosis/screening.h"

namespace graybox::diagnosis::internal {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// The score test of `candidate` on `problem` (screening.h, "Screening"), with its shape and
/// option grids.
CandidateScore Score(const estimators::Problem& problem,
                     const std::vector<estimators::SplitData>& splits,
                     const estimators::FitResult& nominal, const Candidate& candidate);

/// AIC and BIC of a fit from its cost (RSS = 2 cost) and free parameters; NaN without residuals.
void InformationCriteria(const estimators::FitResult& fit, double* aic, double* bic);

/// The re-fit of one screened candidate (screening.h, "Re-fits"), within `max_seconds` of CPU
/// time of the calling thread over all its solves.
RefitResult Refit(const estimators::Problem& problem,
                  const std::vector<estimators::SplitData>& splits,
                  const estimators::FitResult& nominal, const CandidateScore& screened,
                  const std::string& role, double before, double max_seconds);

}  // namespace graybox::diagnosis::internal
