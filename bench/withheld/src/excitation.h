// Excitation signals and the portable random numbers of the withheld-effect cases.
//
// Every draw comes from Rng (std::mt19937_64 with the uniform and normal transforms written out
// here, so the numbers are the same with every standard library).
#pragma once

#include <cstdint>
#include <random>
#include <string>

#include <Eigen/Core>

namespace graybox::bench::internal {

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}
  /// Uniform in [0, 1) with 53 random bits.
  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  /// Standard normal (Box-Muller).
  double Normal();

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

/// FNV-1a of `text` mixed with `seed`: the seed of one case.
std::uint64_t CaseSeed(const std::string& text, unsigned seed);

/// Sum of `count` sines with log-spaced frequencies in [f_lo, f_hi] Hz and random phases, scaled
/// to the RMS `rms` and faded in over the first 0.3 s (raised cosine), N samples at dt.
Eigen::VectorXd Multisine(int n, double dt, double f_lo, double f_hi, int count, double rms,
                          Rng* rng);

/// White Gaussian noise through two first-order low-passes at `f_cut` Hz, scaled to `rms`,
/// faded in over 0.3 s.
Eigen::VectorXd FilteredRandom(int n, double dt, double f_cut, double rms, Rng* rng);

/// Trapezoidal pulses: amplitude +-[0.5, 1] amp, ramps of 0.1 s, plateaus of 0.2 .. 0.6 s, gaps of
/// 0.2 .. 0.8 s.
Eigen::VectorXd TrapezoidalPulses(int n, double dt, double amp, Rng* rng);

/// Velocity profile [m/s] of point-to-point moves with trapezoidal speed (acceleration `acc`,
/// cruise speeds drawn in [v_lo, v_hi]) between targets drawn in [q_lo, q_hi], starting at q0,
/// separated by dwells of 0.1 .. 0.4 s. Integrating it gives the reference position.
Eigen::VectorXd TrapezoidalMoves(int n, double dt, double q0, double q_lo, double q_hi, double v_lo,
                                 double v_hi, double acc, Rng* rng);

}  // namespace graybox::bench::internal
