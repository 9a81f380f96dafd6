// ParameterMap: how the free model parameters appear among an NLP's decision variables.
//
// Every formulation puts the free parameters first, scaled: variable_i = parameter_{free[i]} /
// scale_i, with scale from the model (ModelParameter::scale, by default |nominal|), so the
// optimiser works with numbers of order one whatever the units. Fixed parameters keep `values`.
//
// Fixed parameters are data, not constants: a formulation's symbolic graph reads them as symbols
// (ParameterExprs) whose values sit in its element data, in the order of `fixed`, so changing a
// fixed value (SetFixedValue of the formulation's problem) costs no symbolic work.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/models/model.h"

namespace graybox::estimators {

struct ParameterMap {
  std::vector<int> free;   // indices into the model's parameter vector, in variable order
  Eigen::VectorXd scale;   // per free parameter, > 0
  Eigen::VectorXd values;  // all model parameters (fixed ones stay at these)

  int NumFree() const { return static_cast<int>(free.size()); }
  std::vector<int> fixed;  // indices of the other parameters, ascending

  int NumFixed() const { return static_cast<int>(fixed.size()); }
  /// Position of model parameter `parameter` in `fixed`, or -1 when it is free.
  int FixedSlot(int parameter) const;
  /// Expressions of all model parameters for a symbolic graph: free parameter free[i] is
  /// scale_i * theta[i], fixed parameter fixed[j] is q[j] (symbols whose values the formulation
  /// stores as data). theta has NumFree() entries, q NumFixed().
  std::vector<expr::Expr> ParameterExprs(const std::vector<expr::Expr>& theta,
                                         const std::vector<expr::Expr>& q) const;
  /// Sets fixed parameter `parameter` (model index) to `value` in `values` and returns its slot
  /// in `fixed`; std::invalid_argument when it is free or the value is not finite. A
  /// formulation's SetFixedValue calls this, then writes the value where its graph reads it.
  int SetFixedValue(int parameter, double value);
  /// The values of the fixed parameters, in the order of `fixed`.
  Eigen::VectorXd FixedValues() const;
  /// All model parameter values encoded by the decision vector w (its first NumFree() entries).
  Eigen::VectorXd Values(const Eigen::VectorXd& w) const;
  /// Appends the scaled free parameters (initial values, bounds, names) to variable lists.
  void AppendVariables(std::vector<double>* w0, std::vector<double>* lbw, std::vector<double>* ubw,
                       std::vector<std::string>* names) const;

  /// Throws std::invalid_argument when no parameter is free, a scale is not positive, or a
  /// value lies outside its bounds (naming the parameter, expected versus got).
  static ParameterMap FromModel(const std::vector<models::ModelParameter>& parameters);

  std::vector<models::ModelParameter> source;  // the model's parameters (names, units, bounds)
};

}  // namespace graybox::estimators
