// ScanPeriods (period_scan.h).
#include "graybox/diagnosis/period_scan.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <stdexcept>
#include <string>
#include <vector>

namespace graybox::diagnosis {
namespace {

namespace est = graybox::estimators;

constexpr double kTwoPi = 6.28318530717958647692;

// The splits the scan reads: the estimation splits, or every split when there is none.
std::vector<const est::SplitEvaluation*> ScannedSplits(const est::FitResult& nominal) {
  std::vector<const est::SplitEvaluation*> out;
  for (const auto& e : nominal.evaluations) {
    if (e.role == est::SplitRole::kEstimation) out.push_back(&e);
  }
  if (out.empty()) {
    for (const auto& e : nominal.evaluations) out.push_back(&e);
  }
  return out;
}

}  // namespace

void PeriodScanOptions::Validate() const {
  if (num_peaks < 1) {
    throw std::invalid_argument("PeriodScanOptions.num_peaks: expected >= 1, got " +
                                std::to_string(num_peaks));
  }
  if (max_frequencies < 3) {
    throw std::invalid_argument("PeriodScanOptions.max_frequencies: expected >= 3, got " +
                                std::to_string(max_frequencies));
  }
  if (!(oversampling >= 1.0) || !std::isfinite(oversampling)) {
    throw std::invalid_argument(
        "PeriodScanOptions.oversampling: expected a finite value >= 1, "
        "got " +
        std::to_string(oversampling));
  }
  if (!(min_samples_per_period >= 2.0) || !std::isfinite(min_samples_per_period)) {
    throw std::invalid_argument(
        "PeriodScanOptions.min_samples_per_period: expected a finite value >= 2, got " +
        std::to_string(min_samples_per_period));
  }
}

PeriodScan ScanPeriods(const models::StateSpaceModel& built, const est::FitResult& nominal,
                       const std::string& position, bool rotational,
                       const PeriodScanOptions& options) {
  options.Validate();
  const int state = built.StateIndex(position);  // throws with a did-you-mean
  PeriodScan scan;
  const std::vector<const est::SplitEvaluation*> splits = ScannedSplits(nominal);
  // The visited span and the RMS motion per sample, over finished simulations only.
  double q_min = INFINITY, q_max = -INFINITY, step_sum = 0.0;
  long steps = 0;
  for (const est::SplitEvaluation* e : splits) {
    if (!e->simulation_ok || e->states.cols() <= state) continue;
    const Eigen::VectorXd q = e->states.col(state);
    if (!q.allFinite()) continue;
    q_min = std::min(q_min, q.minCoeff());
    q_max = std::max(q_max, q.maxCoeff());
    for (Eigen::Index t = 1; t < q.size(); ++t) {
      step_sum += (q[t] - q[t - 1]) * (q[t] - q[t - 1]);
      ++steps;
    }
  }
  const double span = q_max - q_min;
  if (!(span > 0.0) || steps == 0) return scan;
  scan.visited_span = span;
  scan.min_period = options.min_samples_per_period * std::sqrt(step_sum / steps);
  if (!(scan.min_period > 0.0)) return scan;
  // The grid of spatial frequencies k [1/m or 1/rad], lowest first.
  const double k_max = 1.0 / scan.min_period;
  const double k0 = rotational ? 1.0 / kTwoPi : 1.0 / span;
  const double dk = rotational ? 1.0 / kTwoPi : 1.0 / (options.oversampling * span);
  if (k0 > k_max) return scan;
  const int count =
      std::min(options.max_frequencies, 1 + static_cast<int>(std::floor((k_max - k0) / dk)));
  std::vector<double> power(count, 0.0);
  // For each sample, exp(i 2 pi k q) along the grid by one complex rotation per step.
  std::vector<std::complex<double>> sums(count);
  for (const est::SplitEvaluation* e : splits) {
    if (!e->simulation_ok || e->states.cols() <= state || !e->states.col(state).allFinite()) {
      continue;
    }
    const Eigen::Index n = e->measured.rows();
    for (Eigen::Index c = 0; c < e->measured.cols(); ++c) {
      const Eigen::VectorXd r = e->measured.col(c) - e->simulated.col(c);
      if (!r.allFinite() || n < 3) continue;
      const double mean_measured = e->measured.col(c).mean();
      const double scale = std::sqrt((e->measured.col(c).array() - mean_measured).square().sum() /
                                     static_cast<double>(n));
      if (!(scale > 0.0)) continue;
      const double r_mean = r.mean();
      std::fill(sums.begin(), sums.end(), std::complex<double>(0.0, 0.0));
      for (Eigen::Index t = 0; t < n; ++t) {
        const double value = (r[t] - r_mean) / scale;
        const double q = e->states(t, state);
        std::complex<double> z = std::polar(1.0, kTwoPi * k0 * q);
        const std::complex<double> rotation = std::polar(1.0, kTwoPi * dk * q);
        for (int j = 0; j < count; ++j) {
          sums[j] += value * z;
          z *= rotation;
        }
      }
      for (int j = 0; j < count; ++j) power[j] += std::norm(sums[j]) / static_cast<double>(n);
    }
  }
  // Longest period first.
  scan.periods.resize(count);
  scan.power = power;
  for (int j = 0; j < count; ++j) scan.periods[j] = 1.0 / (k0 + j * dk);
  // Local maxima, refined by a parabola in k, at least 2 grid steps apart, strongest first.
  std::vector<std::pair<double, double>> maxima;  // (power, k)
  for (int j = 0; j < count; ++j) {
    const double left = j > 0 ? power[j - 1] : -1.0;
    const double right = j + 1 < count ? power[j + 1] : -1.0;
    if (!(power[j] > left && power[j] >= right)) continue;
    double offset = 0.0;
    if (j > 0 && j + 1 < count) {
      const double curvature = left - 2.0 * power[j] + right;
      if (curvature < 0.0) offset = 0.5 * (left - right) / curvature;
    }
    // A rotational period stays a whole number per turn.
    const double k = rotational ? k0 + j * dk : k0 + (j + std::clamp(offset, -0.5, 0.5)) * dk;
    maxima.emplace_back(power[j], k);
  }
  std::sort(maxima.begin(), maxima.end(),
            [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<double> taken_k;
  for (const auto& [p, k] : maxima) {
    if (static_cast<int>(scan.peaks.size()) >= options.num_peaks) break;
    bool near = false;
    for (const double other : taken_k) near = near || std::fabs(other - k) < 2.0 * dk - 1e-12;
    if (near) continue;
    taken_k.push_back(k);
    scan.peaks.push_back(1.0 / k);
  }
  return scan;
}

}  // namespace graybox::diagnosis
