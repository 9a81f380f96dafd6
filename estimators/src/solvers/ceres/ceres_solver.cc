// Ceres backend: the residual groups of an Nlp as residual blocks with analytic Jacobians from
// libexpr; every variable is a one-dimensional parameter block (so shared variables, bounds and
// sparsity need no bookkeeping), solved by sparse normal Cholesky through SuiteSparse.
#include <ceres/ceres.h>

#include <chrono>
#include <cstdio>
#include <stdexcept>

#include "graybox/estimators/solvers/solvers.h"
#include "graybox/expr/derivatives.h"

namespace graybox::estimators {

namespace {

using expr::Function;
using expr::Sparsity;

// Residual and Jacobian Functions of one group, shared by its residual blocks.
struct GroupFunctions {
  Function residual;  // z, d -> r
  Function jacobian;  // z, d -> nonzeros of dr/dz
  Sparsity pattern;
  std::vector<int> pattern_col;
};

class ElementCost : public ceres::CostFunction {
 public:
  ElementCost(const GroupFunctions* fns, const double* data, int nz, int nr)
      : fns_(fns),
        data_(data),
        ws_r_(fns->residual.MakeWorkspace()),
        ws_j_(fns->jacobian.MakeWorkspace()),
        z_(nz),
        jac_(fns->pattern.nnz()) {
    set_num_residuals(nr);
    for (int k = 0; k < nz; ++k) mutable_parameter_block_sizes()->push_back(1);
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    for (int k = 0; k < z_.size(); ++k) z_[k] = parameters[k][0];
    const double* in[2] = {z_.data(), data_};
    double* out_r[1] = {residuals};
    if (!fns_->residual.Evaluate(in, out_r, &ws_r_).ok) return false;
    if (jacobians == nullptr) return true;
    double* out_j[1] = {jac_.data()};
    if (!fns_->jacobian.Evaluate(in, out_j, &ws_j_).ok) return false;
    const int nr = num_residuals();
    for (int k = 0; k < z_.size(); ++k) {
      if (jacobians[k] != nullptr) std::fill(jacobians[k], jacobians[k] + nr, 0.0);
    }
    for (int e = 0; e < fns_->pattern.nnz(); ++e) {
      double* column = jacobians[fns_->pattern_col[e]];
      if (column != nullptr) column[fns_->pattern.row()[e]] = jac_[e];
    }
    return true;
  }

 private:
  const GroupFunctions* fns_;
  const double* data_;
  mutable expr::Workspace ws_r_, ws_j_;
  mutable Eigen::VectorXd z_, jac_;
};

// A residual block of the Nlp computed by user code (nlp.h ResidualBlock).
class ExternalCost : public ceres::CostFunction {
 public:
  explicit ExternalCost(const Nlp::ExternalBlock* block)
      : block_(block), z_(static_cast<Eigen::Index>(block->variables.size())) {
    set_num_residuals(block->block->NumResiduals());
    for (std::size_t k = 0; k < block->variables.size(); ++k) {
      mutable_parameter_block_sizes()->push_back(1);
    }
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    for (Eigen::Index k = 0; k < z_.size(); ++k) z_[k] = parameters[k][0];
    if (!block_->block->Evaluate(z_, &r_, jacobians != nullptr ? &j_ : nullptr).ok) return false;
    const int nr = num_residuals();
    if (r_.size() != nr || !r_.allFinite()) return false;
    std::copy(r_.data(), r_.data() + nr, residuals);
    if (jacobians == nullptr) return true;
    if (j_.rows() != nr || j_.cols() != z_.size() || !j_.allFinite()) return false;
    for (Eigen::Index k = 0; k < z_.size(); ++k) {
      if (jacobians[k] != nullptr) std::copy(j_.col(k).data(), j_.col(k).data() + nr, jacobians[k]);
    }
    return true;
  }

 private:
  const Nlp::ExternalBlock* block_;
  mutable Eigen::VectorXd z_, r_;
  mutable Eigen::MatrixXd j_;
};

ceres::LossFunction* MakeLoss(const CeresOptions& o) {
  if (o.loss == "trivial") return nullptr;
  if (o.loss == "huber") return new ceres::HuberLoss(o.loss_scale);
  if (o.loss == "cauchy") return new ceres::CauchyLoss(o.loss_scale);
  if (o.loss == "soft_l1") return new ceres::SoftLOneLoss(o.loss_scale);
  if (o.loss == "arctan") return new ceres::ArctanLoss(o.loss_scale);
  return nullptr;  // rejected by Validate
}

}  // namespace

void CeresOptions::Validate() const {
  const std::vector<std::string> losses = {"trivial", "huber", "cauchy", "soft_l1", "arctan"};
  if (std::find(losses.begin(), losses.end(), loss) == losses.end()) {
    throw std::invalid_argument(
        "CeresOptions.loss: expected one of trivial, huber, cauchy, "
        "soft_l1, arctan, got '" +
        loss + "'");
  }
  if (!(loss_scale > 0.0)) {
    throw std::invalid_argument("CeresOptions.loss_scale: expected > 0, got " +
                                std::to_string(loss_scale));
  }
  if (max_iterations < 0 || num_threads < 1) {
    throw std::invalid_argument("CeresOptions: expected max_iterations >= 0 and num_threads >= 1");
  }
}

// Forwards Ceres' per-iteration summaries to the caller's IterationCallback.
class ForwardingCallback final : public ceres::IterationCallback {
 public:
  explicit ForwardingCallback(const estimators::IterationCallback& callback)
      : callback_(callback) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& it) override {
    estimators::IterationSummary s;
    s.iteration = it.iteration;
    s.cost = it.cost;
    s.optimality = it.gradient_max_norm;
    s.seconds = it.cumulative_time_in_seconds;
    // A stop keeps the iterate: Ceres copies its state back only on SOLVER_TERMINATE_SUCCESSFULLY
    // (SOLVER_ABORT leaves the parameters at the start while final_cost is the iterate's).
    return callback_(s) ? ceres::SOLVER_CONTINUE : ceres::SOLVER_TERMINATE_SUCCESSFULLY;
  }

 private:
  const estimators::IterationCallback& callback_;
};

SolverResult SolveWithCeres(const Nlp& nlp, const CeresOptions& options, const WarmStart* start) {
  options.Validate();
  nlp.CheckBounds();
  if (start != nullptr && start->w.size() != nlp.NumVariables()) {
    throw std::invalid_argument("SolveWithCeres: warm start with " +
                                std::to_string(start->w.size()) + " variables, expected " +
                                std::to_string(nlp.NumVariables()));
  }
  if (nlp.NumConstraints() > 0) {
    throw std::invalid_argument(
        "SolveWithCeres: expected a least-squares problem without "
        "constraints, got " +
        std::to_string(nlp.NumConstraints()) +
        " constraints; use SolveWithIpopt or penalise them as residuals");
  }
  std::vector<GroupFunctions> fns(nlp.groups().size());
  for (std::size_t g = 0; g < nlp.groups().size(); ++g) {
    const ElementGroup& group = nlp.groups()[g];
    for (int j = 0; j < group.fn.NumOutputs(); ++j) {
      if (group.fn.OutputName(j) == "f") {
        throw std::invalid_argument("SolveWithCeres: group '" + group.name +
                                    "' has a general objective term 'f'; expected residuals 'r' "
                                    "only");
      }
    }
    fns[g].residual = nlp.GroupResiduals(g);
    fns[g].jacobian = nlp.GroupResidualJacobian(g);
    fns[g].pattern = fns[g].jacobian.OutputSparsity(0);
    fns[g].pattern_col = fns[g].pattern.ColumnOfNonzeros();
  }
  SolverResult result;
  result.solver = "ceres";
  const Eigen::VectorXd& w_start = start != nullptr ? start->w : nlp.w0();
  std::vector<double> w(w_start.data(), w_start.data() + nlp.NumVariables());
  for (int i = 0; i < nlp.NumVariables(); ++i) {
    w[i] = std::min(std::max(w[i], nlp.lbw()[i]), nlp.ubw()[i]);  // Ceres needs a feasible start
  }
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  for (int i = 0; i < nlp.NumVariables(); ++i) {
    problem.AddParameterBlock(&w[i], 1);
    if (std::isfinite(nlp.lbw()[i])) problem.SetParameterLowerBound(&w[i], 0, nlp.lbw()[i]);
    if (std::isfinite(nlp.ubw()[i])) problem.SetParameterUpperBound(&w[i], 0, nlp.ubw()[i]);
    if (nlp.lbw()[i] == nlp.ubw()[i]) problem.SetParameterBlockConstant(&w[i]);
  }
  for (std::size_t g = 0; g < nlp.groups().size(); ++g) {
    const ElementGroup& group = nlp.groups()[g];
    const int nz = static_cast<int>(group.index.rows());
    const int nr = fns[g].residual.OutputSize(0);
    if (nr == 0) continue;
    for (int e = 0; e < group.NumInstances(); ++e) {
      std::vector<double*> blocks(nz);
      for (int k = 0; k < nz; ++k) blocks[k] = &w[group.index(k, e)];
      problem.AddResidualBlock(new ElementCost(&fns[g], group.data.col(e).data(), nz, nr),
                               MakeLoss(options), blocks);
    }
  }
  for (const Nlp::ExternalBlock& block : nlp.residual_blocks()) {
    if (block.block->NumResiduals() == 0) continue;
    std::vector<double*> blocks;
    for (int v : block.variables) blocks.push_back(&w[v]);
    problem.AddResidualBlock(new ExternalCost(&block), MakeLoss(options), blocks);
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.gradient_tolerance = options.gradient_tolerance;
  solver_options.parameter_tolerance = options.parameter_tolerance;
  solver_options.num_threads = options.num_threads;
  solver_options.minimizer_progress_to_stdout = options.print_progress;
  ForwardingCallback forward(options.callback);
  if (options.callback) solver_options.callbacks.push_back(&forward);
  ceres::Solver::Summary summary;
  const auto start_time = std::chrono::steady_clock::now();
  ceres::Solve(solver_options, &problem, &summary);
  result.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  result.w = Eigen::Map<Eigen::VectorXd>(w.data(), static_cast<Eigen::Index>(w.size()));
  result.cost = summary.final_cost;
  result.iterations = static_cast<int>(summary.iterations.size()) - 1;
  result.status = ceres::TerminationTypeToString(summary.termination_type);
  result.success = summary.termination_type == ceres::CONVERGENCE;
  switch (summary.termination_type) {
    case ceres::CONVERGENCE:
      result.status_code = SolverStatus::kConverged;
      break;
    case ceres::NO_CONVERGENCE:
      result.status_code = SolverStatus::kMaxIterations;
      break;
    case ceres::USER_SUCCESS:
    case ceres::USER_FAILURE:
      result.status_code = SolverStatus::kUserInterrupt;
      break;
    default:
      result.status_code =
          summary.initial_cost == summary.initial_cost && std::isfinite(summary.initial_cost)
              ? SolverStatus::kNumericalFailure
              : SolverStatus::kEvaluationError;
  }
  if (!result.success) result.message = summary.message;
  for (const auto& it : summary.iterations) {
    IterationSummary s;
    s.iteration = it.iteration;
    s.cost = it.cost;
    s.optimality = it.gradient_max_norm;
    s.seconds = it.cumulative_time_in_seconds;
    result.history.push_back(s);
  }
  return result;
}

}  // namespace graybox::estimators
