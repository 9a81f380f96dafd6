#include "graybox/estimators/nlp/parameter_map.h"

#include <cmath>
#include <stdexcept>

namespace graybox::estimators {

Eigen::VectorXd ParameterMap::Values(const Eigen::VectorXd& w) const {
  Eigen::VectorXd p = values;
  for (int i = 0; i < NumFree(); ++i) p[free[i]] = scale[i] * w[i];
  return p;
}

void ParameterMap::AppendVariables(std::vector<double>* w0, std::vector<double>* lbw,
                                   std::vector<double>* ubw,
                                   std::vector<std::string>* names) const {
  for (int i = 0; i < NumFree(); ++i) {
    const models::ModelParameter& par = source[free[i]];
    w0->push_back(par.value / scale[i]);
    lbw->push_back(par.lower / scale[i]);
    ubw->push_back(par.upper / scale[i]);
    names->push_back(par.name);
  }
}

int ParameterMap::FixedSlot(int parameter) const {
  for (int j = 0; j < NumFixed(); ++j) {
    if (fixed[j] == parameter) return j;
  }
  return -1;
}

std::vector<expr::Expr> ParameterMap::ParameterExprs(const std::vector<expr::Expr>& theta,
                                                     const std::vector<expr::Expr>& q) const {
  if (static_cast<int>(theta.size()) != NumFree() || static_cast<int>(q.size()) != NumFixed()) {
    throw std::invalid_argument("ParameterMap::ParameterExprs: expected " +
                                std::to_string(NumFree()) + " free and " +
                                std::to_string(NumFixed()) + " fixed symbols, got " +
                                std::to_string(theta.size()) + " and " + std::to_string(q.size()));
  }
  std::vector<expr::Expr> p(static_cast<std::size_t>(values.size()));
  for (int i = 0; i < NumFree(); ++i) p[free[i]] = scale[i] * theta[i];
  for (int j = 0; j < NumFixed(); ++j) p[fixed[j]] = q[j];
  return p;
}

int ParameterMap::SetFixedValue(int parameter, double value) {
  const int slot = FixedSlot(parameter);
  if (slot < 0) {
    throw std::invalid_argument("SetFixedValue: parameter " + std::to_string(parameter) +
                                " is not a fixed parameter of this problem");
  }
  if (!std::isfinite(value)) {
    throw std::invalid_argument("SetFixedValue: expected a finite value, got " +
                                std::to_string(value));
  }
  values[parameter] = value;
  return slot;
}

Eigen::VectorXd ParameterMap::FixedValues() const {
  Eigen::VectorXd q(NumFixed());
  for (int j = 0; j < NumFixed(); ++j) q[j] = values[fixed[j]];
  return q;
}

ParameterMap ParameterMap::FromModel(const std::vector<models::ModelParameter>& parameters) {
  ParameterMap map;
  map.source = parameters;
  map.values.resize(static_cast<Eigen::Index>(parameters.size()));
  for (std::size_t i = 0; i < parameters.size(); ++i) {
    const models::ModelParameter& par = parameters[i];
    map.values[static_cast<Eigen::Index>(i)] = par.value;
    if (!std::isfinite(par.value)) {
      throw std::invalid_argument("parameter '" + par.name + "': expected a finite value, got " +
                                  std::to_string(par.value));
    }
    if (!par.free) {
      map.fixed.push_back(static_cast<int>(i));
      continue;
    }
    if (!(par.lower <= par.upper)) {
      throw std::invalid_argument(
          "parameter '" + par.name + "': infeasible bounds: expected lower <= upper, got [" +
          std::to_string(par.lower) + ", " + std::to_string(par.upper) + "]");
    }
    if (par.value < par.lower || par.value > par.upper) {
      throw std::invalid_argument("parameter '" + par.name + "': expected an initial value in [" +
                                  std::to_string(par.lower) + ", " + std::to_string(par.upper) +
                                  "], got " + std::to_string(par.value));
    }
    if (!(par.scale > 0.0) || !std::isfinite(par.scale)) {
      throw std::invalid_argument("parameter '" + par.name + "': expected a scale > 0, got " +
                                  std::to_string(par.scale));
    }
    map.free.push_back(static_cast<int>(i));
  }
  if (map.free.empty()) throw std::invalid_argument("no free parameter to estimate");
  map.scale.resize(map.NumFree());
  for (int i = 0; i < map.NumFree(); ++i) map.scale[i] = parameters[map.free[i]].scale;
  return map;
}

}  // namespace graybox::estimators
