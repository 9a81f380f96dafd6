// The base systems of the withheld-effect cases: for one base and a set of withheld effects, the
// truth model, the nominal model (the truth without the effects), the excitation, the
// measurement and the estimation settings. Values and shapes are listed in
// problems/withheld/README.md.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "excitation.h"
#include "graybox/estimators/fit/fit.h"
#include "graybox/models/model.h"

namespace graybox::bench::internal {

struct BaseBuild {
  models::Model nominal = models::Model("nominal");
  models::Model truth = models::Model("truth");
  std::string detail;                          // the truth's effect shapes in words
  std::map<std::string, double> truth_values;  // the effects' true values
  std::map<std::string, double> x0;            // initial states of the truth by name (else 0)
  /// Exact transport delay of the truth's input [s]; when > 0 the truth is simulated on a grid
  /// kFineFactor times finer than dt, where the held command shifted by the delay is exact.
  double delay_seconds = 0.0;
  double dt = 0.0;
  int samples = 0;
  std::vector<double> quantum;    // per output: quantisation step (0: none)
  std::vector<double> noise_std;  // per output: Gaussian noise before quantisation
  estimators::EstimationSpec spec;
  /// The input (samples x 1) of the estimation (validation = false) or validation split.
  Eigen::MatrixXd (*excite)(bool validation, double dt, int n, Rng* rng) = nullptr;
};

/// The effects each base can withhold (the catalog draws from these).
bool BaseSupports(const std::string& base, const std::string& effect);

/// The pneumatic arm (pneumatic_base.cc); called by BuildBase.
BaseBuild BuildPneumatic(const std::vector<std::string>& withheld);

/// Builds base `base` ("drive_closed_loop", "sea", "pendulum", "pneumatic") with `withheld` left
/// out of the nominal model. Throws std::invalid_argument for an effect the base does not support.
BaseBuild BuildBase(const std::string& base, const std::vector<std::string>& withheld);

}  // namespace graybox::bench::internal
