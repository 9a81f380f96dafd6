// Private: a Problem's method formulated as an Nlp on its estimation splits, with what Fit needs
// to read a solution (parameters, initial states), compute the method's covariance and change a
// fixed parameter's value without formulating again.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/analysis/covariance.h"
#include "graybox/estimators/fit/fit.h"
#include "graybox/estimators/nlp/nlp.h"
#include "graybox/estimators/nlp/parameter_map.h"
#include "graybox/estimators/problem/problem_file.h"

namespace graybox::estimators::internal {

struct Formulation {
  /// The NLP and its parameter map (owned by `owner`).
  Nlp* nlp = nullptr;
  const ParameterMap* map = nullptr;
  std::shared_ptr<void> owner;
  /// All model parameter values encoded by w.
  std::function<Eigen::VectorXd(const Eigen::VectorXd& w)> parameters;
  /// Initial state per estimation split encoded by w (fixed ones as given).
  std::function<std::map<std::string, Eigen::VectorXd>(const Eigen::VectorXd& w)> initial_states;
  /// The method's covariance at w (p: all parameter values).
  std::function<UncertaintyReport(const Eigen::VectorXd& w, const Eigen::VectorXd& p)> covariance;
  /// Changes a fixed parameter's value in place (model index); null when the method must be
  /// formulated again for that (equation error: its preprocessing evaluates the model).
  std::function<void(int parameter, double value)> set_fixed_value;
  /// Present for equation error: adds the fitted equation's evaluation to a split's.
  std::function<void(const SplitData& split, const Eigen::VectorXd& p, SplitEvaluation* e)>
      evaluate_equation;
  /// Settings in order, for reports.
  std::vector<std::pair<std::string, std::string>> summary;
};

/// Formulates problem.estimation.method on `estimation` (the estimation splits), with the
/// regularisation terms. `progress` may be empty.
Formulation Formulate(const Problem& problem, const std::vector<const SplitData*>& estimation,
                      const std::function<void(const std::string&)>& progress);

}  // namespace graybox::estimators::internal
