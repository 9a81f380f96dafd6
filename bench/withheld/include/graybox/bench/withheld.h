// Withheld-effect cases: synthetic identification problems whose truth has an effect (or two) that
// the nominal model lacks. They are the proof of the diagnosis (diagnosis/): fit the nominal
// model, screen the candidate effects, re-fit the best, and check that the withheld effect is
// named and that the validation error falls towards the oracle's.
//
//   std::vector<WithheldCase> cases = MakeWithheldCases();          // every case, seeds fixed
//   for (const WithheldCase& c : cases) {
//     FitResult nominal = estimators::Fit(c.nominal, c.splits);
//     ... diagnosis::ScreenAndRefit(c.nominal, c.splits, nominal) ...;
//     // pass mark: the re-fit's validation NRMSE against c.oracle_validation_nrmse
//   }
//
// What a case is. A TRUTH model (a graybox Model built from library blocks and from truth-only
// blocks private to this library, src/truth_blocks.h, each documented there with its equations)
// is simulated by CVODES with tight tolerances (relative 1e-9) from rest, driven by a realistic
// excitation (trapezoidal moves, multisines with random phases, low-pass filtered random torques;
// the estimation and validation splits get different kinds of excitation from the same seed
// family). Its outputs are then measured: encoder channels are quantised to their resolution
// (after a small Gaussian jitter where the README says so), analog channels get Gaussian noise.
// The NOMINAL problem is the same system without the withheld effect(s), built from library
// blocks only, with its free parameters started away from the truth (each multiplied by a factor
// drawn in [0.75, 1.25]) inside sensible bounds; it is what the diagnosis starts from.
//
// Not circular. A withheld effect is never the library's candidate block with other numbers: the
// truth uses nearby shapes (a Stribeck curve with exponent 1.4, a hard (atan) sign where the
// library has tanh, hard dead zones and backlash where the library's are smooth, LuGre where the
// candidate is Dahl, an exact transport delay where the candidate is a first-order lag, cogging
// with two harmonics, direction-dependent Coulomb levels where the candidate is an offset).
// problems/withheld/README.md lists every case with its truth shape and the library candidate
// that should find it, the noise and quantisation levels, and the oracle.
//
// The oracle. oracle_validation_nrmse is the overall NRMSE (metrics.h: the mean over output
// channels of RMSE / std of the measurement) of the truth's own noise-free validation outputs,
// i.e. the truth with its true parameters simulated on the validation split, scored against the
// noisy, quantised validation data: the floor that any model structure can reach.
//
// Determinism. Every random draw (excitation, noise, start values) comes from a std::mt19937
// seeded from the case name and WithheldOptions::seed (FNV-1a of the name, mixed with the seed),
// so a case is bitwise the same whichever subset it is generated in; distributions are written
// out here rather than taken from <random> (whose distributions differ between standard
// libraries).
//
// Cost. Generating all 47 cases takes 6 to 10 s on one core (Release; 0.1 to 0.6 s a case, most
// of it CVODES restarting at every sample of the held input); each case's splits have 2,000 to
// 2,500 samples and its nominal model at most 4 states; its nominal fit by multiple shooting
// takes 0.1 to 0.6 s.
//
// Failures. An unknown base or case name throws std::invalid_argument with a did-you-mean
// suggestion; a truth simulation that CVODES cannot finish throws std::runtime_error naming the
// case and CVODES's report (none of the catalog's does).
#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/fit/fit.h"

namespace graybox::bench {

/// One synthetic case: a nominal problem, its data and what was withheld.
struct WithheldCase {
  /// Unique, "<base short name>/<effect label>/s<k>", e.g. "drive_cl/stribeck_exp1.4/s1".
  std::string name;
  /// "drive_closed_loop", "sea" (two-mass series elastic actuator), "pendulum" or "pneumatic"
  /// (seed 004's arm assembled from its parts).
  std::string base;
  /// The effect names (one or two): coulomb, asymmetric_friction, stribeck, viscous,
  /// power_law_viscous, presliding, backlash, deadzone, elasticity, ripple, input_delay, payload,
  /// rotor_inertia, sensor_offset, sensor_scale, leakage, polytropic_index; or an own name outside
  /// the library ("friction_drift", "periodic_disturbance").
  std::vector<std::string> withheld;
  /// True when every withheld effect is in the list above.
  bool in_library = true;
  /// The truth's shape in words ("Stribeck exponent 1.4, vs 0.02 m/s, ...").
  std::string truth_detail;
  /// The model WITHOUT the withheld effect(s), free parameters perturbed from the truth.
  estimators::Problem nominal;
  /// "estimation" (SplitRole::kEstimation) and "validation" (SplitRole::kValidation): the noisy,
  /// quantised measurements in the nominal model's input and output order; x0 in the nominal
  /// model's states (the truth's initial state where the names agree, else 0).
  std::vector<estimators::SplitData> splits;
  /// Overall NRMSE of the truth's noise-free validation outputs against the validation data.
  double oracle_validation_nrmse = 0.0;
  /// The withheld effect's true values by name, for the record (units in the README).
  std::map<std::string, double> truth_parameters;

  /// The truth itself, for checks: the truth model with its true parameters (integrator: CVODES,
  /// relative tolerance 1e-9), and the splits as the truth saw them: its inputs, its noise-free
  /// outputs, its initial state. With an input delay they are on a grid 10 times finer than the
  /// data (dt / 10), holding the command shifted by the delay (an exact transport delay of the
  /// held command, 2.5 or 3.5 samples); the data are every 10th sample of them.
  estimators::Problem truth;
  std::vector<estimators::SplitData> truth_splits;
  /// Seconds spent generating this case (building both models, simulating both splits).
  double seconds = 0.0;
};

struct WithheldOptions {
  /// Bases to generate ("drive_closed_loop", "sea", "pendulum", "pneumatic"); empty = all.
  std::vector<std::string> bases;
  /// A small subset (one in-library and one outside-or-two-effect case per base at least; about
  /// 8 cases) for CI.
  bool fast_subset = false;
  /// Mixed into every case's seed (the same case name and seed give bitwise equal data).
  unsigned seed = 1;
  /// Throws std::invalid_argument for an unknown base (with a did-you-mean suggestion).
  void Validate() const;
};

/// Every case of the selected bases, in catalog order (simulated; see "Cost").
std::vector<WithheldCase> MakeWithheldCases(const WithheldOptions& options = {});

/// The names MakeWithheldCases would make, without simulating.
std::vector<std::string> WithheldCaseNames(const WithheldOptions& options = {});

/// One case by name. Throws std::invalid_argument with a did-you-mean suggestion for an unknown
/// name.
WithheldCase MakeWithheldCase(const std::string& name, unsigned seed = 1);

/// The effect names of the library list (the in_library vocabulary), in the order above.
const std::vector<std::string>& LibraryEffectNames();

}  // namespace graybox::bench
