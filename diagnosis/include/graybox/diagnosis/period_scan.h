// ScanPeriods: the periods of a position-dependent force (cogging, a pole pitch, a screw lead, a
// gear mesh) in the nominal fit's residuals, which propose the ripple candidates' periods.
//
//   const PeriodScan s = ScanPeriods(problem.built, nominal, "load.q", /*rotational=*/false);
//   s.peaks   // e.g. {0.02, 0.01, ...} m: the strongest first
//
// The residual of every output channel, r_c(t) = (measured - simulated) / std(measured_c), mean
// removed per split, is projected on cos and sin of 2 pi k q(t) for a dense grid of spatial
// frequencies k (q the position state of the nominal simulation), on the estimation splits (all
// splits when there is none):
//
//   power(k) = sum over splits and channels of |sum_t r_c(t) exp(i 2 pi k q(t))|^2 / N,
//
// a Lomb-Scargle periodogram against position rather than time. A force periodic in q reaches
// every output through the dynamics, whose gain and phase vary along the record, so the power is
// a screen, not a test: the peaks become candidates, and the score test and the re-fits judge them.
// The grid:
//   rotational  k = n / (2 pi) rad^-1, n = 1, 2, ...: periods 2 pi / n, a whole number per turn
//               (a ripple of a rotating machine repeats every revolution);
//   prismatic   k from 1 / S (one period over the visited span S = max q - min q) up, in steps
//               of 1 / (oversampling S) (the main lobe of a period over S is 2 / S wide);
// both up to 1 / P_min, P_min = min_samples_per_period times the RMS of the position's change per
// sample (a shorter period is not resolved by the sampling), and at most max_frequencies values.
// Peaks are local maxima of the power, refined by a parabola through the three grid values
// around each, at least 2 grid steps apart, strongest first.
#pragma once

#include <string>
#include <vector>

#include "graybox/estimators/fit/fit.h"
#include "graybox/models/model.h"

namespace graybox::diagnosis {

struct PeriodScanOptions {
  int num_peaks = 4;                    // periods returned
  int max_frequencies = 8000;           // grid size cap
  double oversampling = 4.0;            // prismatic grid: steps of 1 / (oversampling S)
  double min_samples_per_period = 4.0;  // P_min in samples of the RMS motion per sample
  /// Throws std::invalid_argument naming the field when a value is out of range.
  void Validate() const;
};

struct PeriodScan {
  std::vector<double> periods;  // the grid [m or rad], longest first
  std::vector<double> power;    // power(k) at each grid period
  std::vector<double> peaks;    // the strongest local maxima [m or rad], strongest first
  double visited_span = 0.0;    // S [m or rad]
  double min_period = 0.0;      // P_min [m or rad]
};

/// The periodogram of `nominal`'s residuals against the position state `position` of `built`
/// (see the file comment). Empty (no grid, no peaks) when the position does not move, the
/// simulations did not finish, or the span holds less than one period of P_min. Throws
/// std::invalid_argument for an unknown state name.
PeriodScan ScanPeriods(const models::StateSpaceModel& built, const estimators::FitResult& nominal,
                       const std::string& position, bool rotational,
                       const PeriodScanOptions& options = {});

}  // namespace graybox::diagnosis
