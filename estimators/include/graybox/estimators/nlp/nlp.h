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
//
// A residual block (AddResidualBlock) is the one exception to "everything is a libexpr
// Function": residuals computed by user code with their dense Jacobian, such as a whole
// simulation by an Integrator with forward sensitivities (single_shooting.h). Its objective term
// is 1/2 |r|^2 like any residual; its contribution to the Hessian of the Lagrangian is the
// Gauss-Newton matrix J^T J (second derivatives of r are not formed).
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

/// What one residual row measures: experiment e (the formulation's order), sample k of that
/// experiment (after any decimation of the formulation; -1 when the row has no sample) and a
/// channel (an index into Nlp::residual_channels(), e.g. "load.q", "continuity.load.qd",
/// "regularization.decay"). Rows nobody labelled keep -1 everywhere.
struct ResidualLabel {
  int experiment = -1;
  int sample = -1;
  int channel = -1;
};

/// Numerical status of an evaluation: false when a value is NaN/Inf (the solver then backs off).
struct NlpEvalStatus {
  bool ok = true;
  std::string message;
};

/// Residuals r(z) computed by user code, with their dense Jacobian d r / d z.
class ResidualBlock {
 public:
  virtual ~ResidualBlock() = default;
  virtual int NumResiduals() const = 0;
  /// Fills r (resized to NumResiduals()) and, when `jacobian` is not null, the dense
  /// NumResiduals() x z.size() Jacobian. A numerical failure (a diverged simulation) returns
  /// ok = false with a message; it must not throw. Called from one thread at a time.
  virtual NlpEvalStatus Evaluate(const Eigen::VectorXd& z, Eigen::VectorXd* r,
                                 Eigen::MatrixXd* jacobian) const = 0;
};

class Nlp {
 public:
  /// Variables with initial values, bounds and names (names for reports; may be empty strings).
  Nlp(Eigen::VectorXd w0, Eigen::VectorXd lbw, Eigen::VectorXd ubw,
      std::vector<std::string> names = {});
  /// Move-only: an Nlp owns evaluation workspaces, so a copy would share them between two
  /// owners that may evaluate concurrently. Build one Nlp per thread (or per fit) instead.
  Nlp(const Nlp&) = delete;
  Nlp& operator=(const Nlp&) = delete;
  Nlp(Nlp&&) = default;
  Nlp& operator=(Nlp&&) = default;

  /// Adds a group. Validates sizes and indices (std::invalid_argument naming the group, expected
  /// versus got) and prepares the derivative Functions. Returns the offset of the group's first
  /// constraint in the global constraint vector.
  int AddGroup(ElementGroup group);

  /// Adds a residual block reading w[variables[k]] (distinct, in range; std::invalid_argument
  /// naming the block otherwise). Its residuals follow those already added.
  void AddResidualBlock(std::string name, std::vector<int> variables,
                        std::shared_ptr<const ResidualBlock> block);

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

  // ---- residual labels (filled by the formulations; see ResidualLabel) -------------------------
  const std::vector<ResidualLabel>& residual_labels() const { return labels_; }
  const std::vector<std::string>& residual_channels() const { return channels_; }
  /// The index of channel `name`, added when new.
  int ResidualChannel(const std::string& name);
  /// Labels row `row` (std::invalid_argument when out of range).
  void LabelResidual(int row, ResidualLabel label);

  // ---- changes that keep the structure (no symbolic work; for cheap re-solves) ----------------
  /// Sets entry `row` of "d" of every instance of group `group` to `value` (a quantity held as
  /// data, such as a fixed model parameter). std::invalid_argument on a bad group or row or a
  /// non-finite value.
  void SetGroupDataRow(std::size_t group, int row, double value);
  /// Sets the starting point (size NumVariables(), finite).
  void SetInitialPoint(const Eigen::VectorXd& w0);
  /// Sets the bounds of variable i (lower == upper holds it fixed: Ipopt treats it as a parameter,
  /// Ceres holds its block constant).
  void SetVariableBounds(int i, double lower, double upper);
  /// Forgets cached residual-block results; call after changing what a ResidualBlock reads
  /// besides w (its owner does this when it changes a value the block shares).
  void ClearCaches();

  // ---- evaluation (allocation-free after the first call; not thread-safe per Nlp) -------------
  // A group's instances are evaluated in batches of 128 on the batch tape
  // (expr::Function::EvaluateBatch: several instances per instruction), which equals evaluating
  // them one by one up to rounding; a failure names the group and the first failing instance.
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
  /// (The Hessian Functions are built on the first call of these or of HessianValues, the
  /// objective's on the first Objective or Gradient: a least-squares backend never pays for them.)
  const std::vector<int>& HessianRows() const;
  const std::vector<int>& HessianCols() const;
  NlpEvalStatus HessianValues(const double* w, double sigma, const double* lambda,
                              double* values) const;

  const std::vector<ElementGroup>& groups() const { return groups_; }
  /// Group g's residual Function (z, d -> r) and its Jacobian (z, d -> the nonzeros of d r / d z,
  /// pattern OutputSparsity(0)), for backends that evaluate element by element.
  const expr::Function& GroupResiduals(std::size_t g) const;
  const expr::Function& GroupResidualJacobian(std::size_t g) const;

  struct ExternalBlock {
    std::string name;
    std::vector<int> variables;
    std::shared_ptr<const ResidualBlock> block;
    int residual_offset = 0;
  };
  const std::vector<ExternalBlock>& residual_blocks() const { return external_; }

 private:
  struct Prepared;
  struct ExternalCache;
  // Evaluates residual block b at w (cached per point); jacobian only when `with_jacobian`.
  NlpEvalStatus EvaluateExternal(std::size_t b, const double* w, bool with_jacobian) const;
  void EnsureObjective() const;
  void EnsureHessian() const;
  void BuildHessianStructure() const;

  Eigen::VectorXd w0_, lbw_, ubw_;
  std::vector<std::string> names_;
  std::vector<ElementGroup> groups_;
  std::vector<std::shared_ptr<Prepared>> prepared_;
  std::vector<ExternalBlock> external_;
  std::vector<std::shared_ptr<ExternalCache>> external_cache_;
  mutable std::vector<std::vector<int>>
      external_hess_slot_;  // lower-triangle pairs -> global entry
  std::vector<ResidualLabel> labels_;
  std::vector<std::string> channels_;
  int num_constraints_ = 0;
  int num_residuals_ = 0;
  std::vector<int> jac_rows_, jac_cols_;
  std::vector<int> rjac_rows_, rjac_cols_;
  mutable bool hessian_ready_ = true;
  mutable std::vector<int> hess_rows_, hess_cols_;
};

}  // namespace graybox::estimators
