// Nlp: a structured nonlinear program assembled from repeated elements,
//
//     minimise_w   sum_e f_e(z_e, d_e) + 1/2 sum_e |r_e(z_e, d_e)|^2
//     subject to   lbc <= c_e(z_e, d_e) <= ubc   for every element e,
//                  lbw <= w <= ubw,
//
// where each element reads a few decision variables z_e = w[index_e] and constant data d_e. The
// identification formulations are built this way: a multiple-shooting interval, a collocation
// interval or an equation-error sample is one element, all intervals share one element Function,
// and only the indices and data differ. Derivatives come from libexpr per element (sparse Jacobian,
// exact Hessian of the element Lagrangian) and are scattered into the global sparse matrices, so
// building and evaluating the NLP costs time linear in the number of elements, never a giant
// symbolic graph.
//
// An element Function has inputs "z" and "d" (either may be empty) and any of the outputs
// "f" (1 entry), "r" (residuals) and "c" (constraints). Variables may be shared between elements
// (the model parameters are shared by all of them); one element may not read a variable twice.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/expr/function.h"
#include "graybox/expr/sparsity.h"

namespace graybox::estimators {

/// Many instances of one element Function.
struct ElementGroup {
  std::string name;
  expr::Function fn;
  /// index(k, e): position in w of entry k of "z" for instance e (size nz x instances).
  Eigen::MatrixXi index;
  /// data(k, e): entry k of "d" for instance e (size nd x instances).
  Eigen::MatrixXd data;
  /// Bounds of "c", the same for every instance.
  Eigen::VectorXd lbc;
  Eigen::VectorXd ubc;
  int NumInstances() const { return static_cast<int>(index.cols()); }
};

/// Numerical status of an evaluation: false when a value is NaN/Inf (the solver then backs off).
struct NlpEvalStatus {
  bool ok = true;
  std::string message;
};

class Nlp {
 public:
  /// Variables with initial values, bounds and names (names for reports; may be empty strings).
  Nlp(Eigen::VectorXd w0, Eigen::VectorXd lbw, Eigen::VectorXd ubw,
      std::vector<std::string> names = {});

  /// Adds a group. Validates sizes and indices (std::invalid_argument naming the group, expected
  /// versus got) and prepares the derivative Functions. Returns the offset of the group's first
  /// constraint in the global constraint vector.
  int AddGroup(ElementGroup group);

  int NumVariables() const { return static_cast<int>(w0_.size()); }
  int NumConstraints() const { return num_constraints_; }
  int NumResiduals() const { return num_residuals_; }
  const Eigen::VectorXd& w0() const { return w0_; }
  const Eigen::VectorXd& lbw() const { return lbw_; }
  const Eigen::VectorXd& ubw() const { return ubw_; }
  const std::vector<std::string>& names() const { return names_; }
  Eigen::VectorXd lbg() const;
  Eigen::VectorXd ubg() const;
  /// Throws std::invalid_argument naming the variable when lbw > ubw, w0 is not finite, or a
  /// constraint bound pair is inverted ("infeasible bounds").
  void CheckBounds() const;

  // ---- evaluation (allocation-free after the first call; not thread-safe per Nlp) -------------
  NlpEvalStatus Objective(const double* w, double* f) const;
  NlpEvalStatus Gradient(const double* w, double* grad) const;
  NlpEvalStatus Constraints(const double* w, double* g) const;
  /// Residuals r of all groups stacked (for least squares and covariance).
  NlpEvalStatus Residuals(const double* w, double* r) const;

  /// Structure of d g / d w (triplets, row = constraint, col = variable).
  const std::vector<int>& JacobianRows() const { return jac_rows_; }
  const std::vector<int>& JacobianCols() const { return jac_cols_; }
  NlpEvalStatus JacobianValues(const double* w, double* values) const;

  /// Structure of d r / d w (triplets).
  const std::vector<int>& ResidualJacobianRows() const { return rjac_rows_; }
  const std::vector<int>& ResidualJacobianCols() const { return rjac_cols_; }
  NlpEvalStatus ResidualJacobianValues(const double* w, double* values) const;

  /// Lower triangle (row >= col) of the Hessian of the Lagrangian
  ///   sigma * (sum f_e + 1/2 sum |r_e|^2) + lambda^T g, duplicates merged.
  const std::vector<int>& HessianRows() const { return hess_rows_; }
  const std::vector<int>& HessianCols() const { return hess_cols_; }
  NlpEvalStatus HessianValues(const double* w, double sigma, const double* lambda,
                              double* values) const;

  const std::vector<ElementGroup>& groups() const { return groups_; }

 private:
  struct Prepared;
  void BuildHessianStructure();

  Eigen::VectorXd w0_, lbw_, ubw_;
  std::vector<std::string> names_;
  std::vector<ElementGroup> groups_;
  std::vector<std::shared_ptr<Prepared>> prepared_;
  int num_constraints_ = 0;
  int num_residuals_ = 0;
  std::vector<int> jac_rows_, jac_cols_;
  std::vector<int> rjac_rows_, rjac_cols_;
  std::vector<int> hess_rows_, hess_cols_;
};

}  // namespace graybox::estimators
