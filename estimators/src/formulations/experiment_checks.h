// Checks shared by the simulation formulations (multiple and single shooting): the experiments'
// sizes and values against the model, and the output weights.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/data/dataset.h"
#include "graybox/estimators/formulations/experiment_setup.h"
#include "graybox/models/model.h"

namespace graybox::estimators::internal {

/// Throws std::invalid_argument naming `caller` or the experiment, expected versus got: no
/// experiment, dt <= 0 or different from the first experiment's, u/y sizes, NaN/Inf data, an
/// initial state of the wrong size or not finite, a state guess of the wrong size.
void CheckExperiments(const models::StateSpaceModel& model,
                      const std::vector<Experiment>& experiments,
                      const std::vector<ExperimentSetup>& setups, const std::string& caller);

/// "input 'force' at sample 12 (t = 0.12 s) is inf" for the first sample of ex.u or ex.y that is
/// not finite (inputs first), "" when every sample is finite: the place for a data error.
std::string NonFiniteSample(const Experiment& ex);

/// `weights` when given (size ny, else std::invalid_argument naming `field`), otherwise
/// 1 / std of each output channel over all experiments.
Eigen::VectorXd ResolveOutputWeights(const Eigen::VectorXd& weights, int ny,
                                     const std::vector<Experiment>& experiments,
                                     const std::string& field);

}  // namespace graybox::estimators::internal
