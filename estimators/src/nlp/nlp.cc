#include "graybox/estimators/nlp/nlp.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <unordered_map>

#include "graybox/expr/derivatives.h"

namespace graybox::estimators {

using expr::EvalStatus;
using expr::Expr;
using expr::Function;
using expr::FunctionIo;
using expr::Sparsity;
using expr::Workspace;

namespace {
// The inputs and outputs of one Function::EvaluateBatch call.
struct BatchScratch {
  std::vector<Eigen::MatrixXd> in, out;
};
// What evaluating one Function needs, kept per Function so that repeated evaluations do not
// allocate: its workspace, and the batch inputs and outputs for chunks of kBatch instances and
// for the last, shorter chunk.
struct FunctionScratch {
  Workspace ws;
  BatchScratch full, tail;
};
}  // namespace

// Per-group derivative Functions, workspaces and scatter maps.
struct Nlp::Prepared {
  int nz = 0, nd = 0, nc = 0, nr = 0;
  bool has_objective = false;
  Function combined;  // z, d -> f (objective contribution), c, r; source of the lazy ones
  bool objective_ready = false, hessian_ready = false;
  Function objective;  // z, d -> f_e + 1/2 |r_e|^2
  Function gradient;   // z, d -> d objective / dz
  Function constraints;
  Function jac_c;  // z, d -> nonzeros of dc/dz
  Function residuals;
  Function jac_r;
  Function hessian;  // z, d, sigma, lambda -> lower triangle
  Sparsity jac_c_sp, jac_r_sp, hess_sp;
  int constraint_offset = 0;
  int residual_offset = 0;
  std::size_t rjac_offset = 0;  // first entry of this group's residual Jacobian triplets
  std::vector<int> hess_slot;   // nnz(hess_sp) x instances -> global Hessian entry
  // Mutable scratch (evaluation is not thread-safe per Nlp).
  mutable FunctionScratch s_obj, s_grad, s_c, s_jc, s_r, s_jr, s_h;
  mutable Eigen::VectorXd z, buffer;
};

namespace {

NlpEvalStatus Fail(const ElementGroup& g, int instance, const EvalStatus& s) {
  return {false,
          "element group '" + g.name + "' instance " + std::to_string(instance) + ": " + s.message};
}

}  // namespace

Nlp::Nlp(Eigen::VectorXd w0, Eigen::VectorXd lbw, Eigen::VectorXd ubw,
         std::vector<std::string> names)
    : w0_(std::move(w0)), lbw_(std::move(lbw)), ubw_(std::move(ubw)), names_(std::move(names)) {
  if (lbw_.size() != w0_.size() || ubw_.size() != w0_.size()) {
    throw std::invalid_argument("Nlp: expected bounds of size " + std::to_string(w0_.size()) +
                                ", got " + std::to_string(lbw_.size()) + " and " +
                                std::to_string(ubw_.size()));
  }
  if (names_.empty()) names_.assign(w0_.size(), "");
  if (names_.size() != static_cast<std::size_t>(w0_.size())) {
    throw std::invalid_argument("Nlp: expected " + std::to_string(w0_.size()) + " names, got " +
                                std::to_string(names_.size()));
  }
}

int Nlp::AddGroup(ElementGroup group) {
  const Function& fn = group.fn;
  const std::string where = "Nlp group '" + group.name + "'";
  const int iz = fn.InputIndex("z");
  const int id = fn.InputIndex("d");
  auto p = std::make_shared<Prepared>();
  p->nz = fn.InputSize(iz);
  p->nd = fn.InputSize(id);
  if (group.index.rows() != p->nz) {
    throw std::invalid_argument(where + ": expected index with " + std::to_string(p->nz) +
                                " rows (size of z), got " + std::to_string(group.index.rows()));
  }
  if (group.data.rows() != p->nd || group.data.cols() != group.index.cols()) {
    throw std::invalid_argument(where + ": expected data of size " + std::to_string(p->nd) + "x" +
                                std::to_string(group.index.cols()) + ", got " +
                                std::to_string(group.data.rows()) + "x" +
                                std::to_string(group.data.cols()));
  }
  if (!group.data.allFinite()) {
    throw std::invalid_argument(where + ": data contains NaN or Inf");
  }
  for (int e = 0; e < group.index.cols(); ++e) {
    for (int k = 0; k < p->nz; ++k) {
      const int v = group.index(k, e);
      if (v < 0 || v >= NumVariables()) {
        throw std::invalid_argument(where + ": instance " + std::to_string(e) + " entry " +
                                    std::to_string(k) + ": expected a variable index in [0, " +
                                    std::to_string(NumVariables()) + "), got " + std::to_string(v));
      }
      for (int j = 0; j < k; ++j) {
        if (group.index(j, e) == v) {
          throw std::invalid_argument(where + ": instance " + std::to_string(e) +
                                      " reads variable " + std::to_string(v) + " twice");
        }
      }
    }
  }
  auto output = [&](const char* name) -> int {
    for (int j = 0; j < fn.NumOutputs(); ++j) {
      if (fn.OutputName(j) == name) return j;
    }
    return -1;
  };
  const int jf = output("f"), jr = output("r"), jc = output("c");
  for (int j = 0; j < fn.NumOutputs(); ++j) {
    const std::string& n = fn.OutputName(j);
    if (n != "f" && n != "r" && n != "c") {
      throw std::invalid_argument(where + ": unknown output '" + n +
                                  "'; expected \"f\", \"r\" or \"c\"");
    }
  }
  if (jf >= 0 && fn.OutputSize(jf) != 1) {
    throw std::invalid_argument(where + ": expected output 'f' with 1 entry, got " +
                                std::to_string(fn.OutputSize(jf)));
  }
  p->nc = jc >= 0 ? fn.OutputSize(jc) : 0;
  p->nr = jr >= 0 ? fn.OutputSize(jr) : 0;
  if (group.lbc.size() != p->nc || group.ubc.size() != p->nc) {
    throw std::invalid_argument(
        where + ": expected constraint bounds of size " + std::to_string(p->nc) + ", got " +
        std::to_string(group.lbc.size()) + " and " + std::to_string(group.ubc.size()));
  }
  const std::vector<FunctionIo> ins = {{"z", fn.InputSymbols(iz)}, {"d", fn.InputSymbols(id)}};
  // Objective contribution f_e + 1/2 |r_e|^2.
  Expr obj(0.0);
  if (jf >= 0) obj += fn.OutputExprs(jf)[0];
  if (jr >= 0) {
    Expr ss(0.0);
    for (const Expr& r : fn.OutputExprs(jr)) ss += r * r;
    obj += 0.5 * ss;
  }
  p->has_objective = jf >= 0 || jr >= 0;
  std::vector<Expr> cons = jc >= 0 ? fn.OutputExprs(jc) : std::vector<Expr>{};
  std::vector<Expr> res = jr >= 0 ? fn.OutputExprs(jr) : std::vector<Expr>{};
  p->combined = Function(group.name, ins, {{"f", {obj}}, {"c", cons}, {"r", res}});
  const Function& combined = p->combined;
  // Built now: what the sparsity structures need (and all a least-squares backend uses). The
  // objective, its gradient and the Hessian of the Lagrangian follow on first use.
  p->constraints = Function(group.name + "_c", ins, {{"c", cons}});
  p->jac_c = combined.Jacobian("c", "z");
  p->jac_c_sp = p->jac_c.OutputSparsity(0);
  p->residuals = Function(group.name + "_r", ins, {{"r", res}});
  p->jac_r = combined.Jacobian("r", "z");
  p->jac_r_sp = p->jac_r.OutputSparsity(0);
  p->s_c.ws = p->constraints.MakeWorkspace();
  p->s_jc.ws = p->jac_c.MakeWorkspace();
  p->s_r.ws = p->residuals.MakeWorkspace();
  p->s_jr.ws = p->jac_r.MakeWorkspace();
  p->z.resize(p->nz);
  p->buffer.resize(std::max({p->nz, p->nc, p->nr, p->jac_c_sp.nnz(), p->jac_r_sp.nnz(), 1}));
  p->constraint_offset = num_constraints_;
  p->residual_offset = num_residuals_;
  // Jacobian triplets.
  const int instances = group.NumInstances();
  p->rjac_offset = rjac_rows_.size();
  const std::vector<int> c_col = p->jac_c_sp.ColumnOfNonzeros();
  const std::vector<int> r_col = p->jac_r_sp.ColumnOfNonzeros();
  for (int e = 0; e < instances; ++e) {
    for (int k = 0; k < p->jac_c_sp.nnz(); ++k) {
      jac_rows_.push_back(p->constraint_offset + e * p->nc + p->jac_c_sp.row()[k]);
      jac_cols_.push_back(group.index(c_col[k], e));
    }
    for (int k = 0; k < p->jac_r_sp.nnz(); ++k) {
      rjac_rows_.push_back(p->residual_offset + e * p->nr + p->jac_r_sp.row()[k]);
      rjac_cols_.push_back(group.index(r_col[k], e));
    }
  }
  num_constraints_ += instances * p->nc;
  num_residuals_ += instances * p->nr;
  labels_.resize(static_cast<std::size_t>(num_residuals_));
  const int offset = p->constraint_offset;
  groups_.push_back(std::move(group));
  prepared_.push_back(std::move(p));
  hessian_ready_ = false;
  return offset;
}

void Nlp::EnsureObjective() const {
  for (const auto& pp : prepared_) {
    Prepared& p = *pp;
    if (p.objective_ready) continue;
    const std::vector<FunctionIo> ins = {{"z", p.combined.InputSymbols(0)},
                                         {"d", p.combined.InputSymbols(1)}};
    p.objective = Function(p.combined.name() + "_f", ins, {{"f", p.combined.OutputExprs(0)}});
    p.gradient = p.combined.Gradient("f", "z");
    p.s_obj.ws = p.objective.MakeWorkspace();
    p.s_grad.ws = p.gradient.MakeWorkspace();
    p.objective_ready = true;
  }
}

void Nlp::EnsureHessian() const {
  if (hessian_ready_) return;
  for (const auto& pp : prepared_) {
    Prepared& p = *pp;
    if (p.hessian_ready) continue;
    p.hessian = expr::HessianOfLagrangian(p.combined, "z", "f", "c");
    p.hess_sp = p.hessian.OutputSparsity(0);
    p.s_h.ws = p.hessian.MakeWorkspace();
    if (p.buffer.size() < p.hess_sp.nnz()) p.buffer.resize(p.hess_sp.nnz());
    p.hessian_ready = true;
  }
  BuildHessianStructure();
  hessian_ready_ = true;
}

const Function& Nlp::GroupResiduals(std::size_t g) const { return prepared_.at(g)->residuals; }

const Function& Nlp::GroupResidualJacobian(std::size_t g) const { return prepared_.at(g)->jac_r; }

const std::vector<int>& Nlp::HessianRows() const {
  EnsureHessian();
  return hess_rows_;
}

const std::vector<int>& Nlp::HessianCols() const {
  EnsureHessian();
  return hess_cols_;
}

// The last point a residual block was evaluated at, and what was computed there.
struct Nlp::ExternalCache {
  std::size_t rjac_offset = 0;
  Eigen::VectorXd z, r;
  Eigen::MatrixXd jacobian;
  bool has_r = false, has_jacobian = false;
  NlpEvalStatus status;
};

void Nlp::AddResidualBlock(std::string name, std::vector<int> variables,
                           std::shared_ptr<const ResidualBlock> block) {
  const std::string where = "Nlp residual block '" + name + "'";
  if (block == nullptr) throw std::invalid_argument(where + ": expected a block, got null");
  const int nr = block->NumResiduals();
  if (nr < 0) {
    throw std::invalid_argument(where + ": expected >= 0 residuals, got " + std::to_string(nr));
  }
  for (std::size_t k = 0; k < variables.size(); ++k) {
    const int v = variables[k];
    if (v < 0 || v >= NumVariables()) {
      throw std::invalid_argument(where + ": entry " + std::to_string(k) +
                                  ": expected a variable index in [0, " +
                                  std::to_string(NumVariables()) + "), got " + std::to_string(v));
    }
    for (std::size_t j = 0; j < k; ++j) {
      if (variables[j] == v) {
        throw std::invalid_argument(where + ": reads variable " + std::to_string(v) + " twice");
      }
    }
  }
  auto cache = std::make_shared<ExternalCache>();
  cache->rjac_offset = rjac_rows_.size();
  for (std::size_t k = 0; k < variables.size(); ++k) {
    for (int i = 0; i < nr; ++i) {
      rjac_rows_.push_back(num_residuals_ + i);
      rjac_cols_.push_back(variables[k]);
    }
  }
  external_.push_back({std::move(name), std::move(variables), std::move(block), num_residuals_});
  external_cache_.push_back(std::move(cache));
  num_residuals_ += nr;
  labels_.resize(static_cast<std::size_t>(num_residuals_));
  hessian_ready_ = false;
}

int Nlp::ResidualChannel(const std::string& name) {
  for (std::size_t i = 0; i < channels_.size(); ++i) {
    if (channels_[i] == name) return static_cast<int>(i);
  }
  channels_.push_back(name);
  return static_cast<int>(channels_.size()) - 1;
}

void Nlp::LabelResidual(int row, ResidualLabel label) {
  if (row < 0 || row >= num_residuals_) {
    throw std::invalid_argument("Nlp::LabelResidual: expected a residual row in [0, " +
                                std::to_string(num_residuals_) + "), got " + std::to_string(row));
  }
  if (label.channel < -1 || label.channel >= static_cast<int>(channels_.size())) {
    throw std::invalid_argument("Nlp::LabelResidual: expected a channel index below " +
                                std::to_string(channels_.size()) + ", got " +
                                std::to_string(label.channel));
  }
  labels_[static_cast<std::size_t>(row)] = label;
}

void Nlp::SetGroupDataRow(std::size_t group, int row, double value) {
  if (group >= groups_.size()) {
    throw std::invalid_argument("Nlp::SetGroupDataRow: expected a group index below " +
                                std::to_string(groups_.size()) + ", got " + std::to_string(group));
  }
  ElementGroup& g = groups_[group];
  if (row < 0 || row >= g.data.rows()) {
    throw std::invalid_argument("Nlp group '" + g.name + "': expected a data row in [0, " +
                                std::to_string(g.data.rows()) + "), got " + std::to_string(row));
  }
  if (!std::isfinite(value)) {
    throw std::invalid_argument("Nlp group '" + g.name + "' data row " + std::to_string(row) +
                                ": expected a finite value, got " + std::to_string(value));
  }
  g.data.row(row).setConstant(value);  // in place: backends keep pointers to the columns
}

void Nlp::SetInitialPoint(const Eigen::VectorXd& w0) {
  if (w0.size() != w0_.size() || !w0.allFinite()) {
    throw std::invalid_argument("Nlp::SetInitialPoint: expected " + std::to_string(w0_.size()) +
                                " finite values, got " + std::to_string(w0.size()) +
                                (w0.allFinite() ? "" : " with NaN or Inf"));
  }
  w0_ = w0;
}

void Nlp::SetVariableBounds(int i, double lower, double upper) {
  if (i < 0 || i >= NumVariables()) {
    throw std::invalid_argument("Nlp::SetVariableBounds: expected a variable index in [0, " +
                                std::to_string(NumVariables()) + "), got " + std::to_string(i));
  }
  if (std::isnan(lower) || std::isnan(upper) || lower > upper) {
    throw std::invalid_argument("variable '" + names_[i] + "': infeasible bounds [" +
                                std::to_string(lower) + ", " + std::to_string(upper) + "]");
  }
  lbw_[i] = lower;
  ubw_[i] = upper;
}

void Nlp::ClearCaches() {
  for (auto& c : external_cache_) {
    c->z.resize(0);
    c->has_r = c->has_jacobian = false;
  }
}

NlpEvalStatus Nlp::EvaluateExternal(std::size_t b, const double* w, bool with_jacobian) const {
  const ExternalBlock& x = external_[b];
  ExternalCache& c = *external_cache_[b];
  const Eigen::Index nz = static_cast<Eigen::Index>(x.variables.size());
  bool same = c.z.size() == nz && (c.has_r || !c.status.ok);
  for (Eigen::Index k = 0; same && k < nz; ++k) same = c.z[k] == w[x.variables[k]];
  if (same && (!c.status.ok || !with_jacobian || c.has_jacobian)) return c.status;
  c.z.resize(nz);
  for (Eigen::Index k = 0; k < nz; ++k) c.z[k] = w[x.variables[k]];
  c.has_r = c.has_jacobian = false;
  c.status = x.block->Evaluate(c.z, &c.r, with_jacobian ? &c.jacobian : nullptr);
  if (c.status.ok && c.r.size() != x.block->NumResiduals()) {
    c.status = {false, "expected " + std::to_string(x.block->NumResiduals()) + " residuals, got " +
                           std::to_string(c.r.size())};
  }
  if (c.status.ok && with_jacobian &&
      (c.jacobian.rows() != c.r.size() || c.jacobian.cols() != nz)) {
    c.status = {false, "expected a " + std::to_string(c.r.size()) + "x" + std::to_string(nz) +
                           " Jacobian, got " + std::to_string(c.jacobian.rows()) + "x" +
                           std::to_string(c.jacobian.cols())};
  }
  if (c.status.ok && !c.r.allFinite()) c.status = {false, "non-finite residual"};
  if (c.status.ok && with_jacobian && !c.jacobian.allFinite()) {
    c.status = {false, "non-finite Jacobian"};
  }
  if (!c.status.ok) {
    c.status.message = "residual block '" + x.name + "': " + c.status.message;
    return c.status;
  }
  c.has_r = true;
  c.has_jacobian = with_jacobian;
  return c.status;
}

void Nlp::BuildHessianStructure() const {
  std::unordered_map<std::int64_t, int> slot;
  hess_rows_.clear();
  hess_cols_.clear();
  const std::int64_t n = NumVariables();
  for (std::size_t g = 0; g < groups_.size(); ++g) {
    Prepared& p = *prepared_[g];
    const ElementGroup& group = groups_[g];
    const std::vector<int> col = p.hess_sp.ColumnOfNonzeros();
    const int nnz = p.hess_sp.nnz();
    p.hess_slot.assign(static_cast<std::size_t>(nnz) * group.NumInstances(), 0);
    for (int e = 0; e < group.NumInstances(); ++e) {
      for (int k = 0; k < nnz; ++k) {
        int a = group.index(p.hess_sp.row()[k], e);
        int b = group.index(col[k], e);
        if (a < b) std::swap(a, b);
        const std::int64_t key = a * n + b;
        auto [it, inserted] = slot.emplace(key, static_cast<int>(hess_rows_.size()));
        if (inserted) {
          hess_rows_.push_back(a);
          hess_cols_.push_back(b);
        }
        p.hess_slot[static_cast<std::size_t>(e) * nnz + k] = it->second;
      }
    }
  }
  external_hess_slot_.assign(external_.size(), {});
  for (std::size_t b = 0; b < external_.size(); ++b) {
    const std::vector<int>& v = external_[b].variables;
    for (std::size_t i = 0; i < v.size(); ++i) {
      for (std::size_t j = 0; j <= i; ++j) {  // pairs (i, j), j <= i, in this order
        int a = v[i], c = v[j];
        if (a < c) std::swap(a, c);
        auto [it, inserted] = slot.emplace(a * n + c, static_cast<int>(hess_rows_.size()));
        if (inserted) {
          hess_rows_.push_back(a);
          hess_cols_.push_back(c);
        }
        external_hess_slot_[b].push_back(it->second);
      }
    }
  }
}

Eigen::VectorXd Nlp::lbg() const {
  Eigen::VectorXd lb(num_constraints_);
  for (std::size_t g = 0; g < groups_.size(); ++g) {
    const Prepared& p = *prepared_[g];
    for (int e = 0; e < groups_[g].NumInstances(); ++e) {
      lb.segment(p.constraint_offset + e * p.nc, p.nc) = groups_[g].lbc;
    }
  }
  return lb;
}

Eigen::VectorXd Nlp::ubg() const {
  Eigen::VectorXd ub(num_constraints_);
  for (std::size_t g = 0; g < groups_.size(); ++g) {
    const Prepared& p = *prepared_[g];
    for (int e = 0; e < groups_[g].NumInstances(); ++e) {
      ub.segment(p.constraint_offset + e * p.nc, p.nc) = groups_[g].ubc;
    }
  }
  return ub;
}

void Nlp::CheckBounds() const {
  for (int i = 0; i < NumVariables(); ++i) {
    const std::string name = names_[i].empty() ? "w[" + std::to_string(i) + "]" : names_[i];
    if (!std::isfinite(w0_[i])) {
      throw std::invalid_argument("variable '" + name + "': expected a finite initial value, got " +
                                  std::to_string(w0_[i]));
    }
    if (std::isnan(lbw_[i]) || std::isnan(ubw_[i]) || lbw_[i] > ubw_[i]) {
      throw std::invalid_argument("variable '" + name +
                                  "': infeasible bounds: expected lower <= "
                                  "upper, got [" +
                                  std::to_string(lbw_[i]) + ", " + std::to_string(ubw_[i]) + "]");
    }
  }
  for (const ElementGroup& g : groups_) {
    for (int i = 0; i < g.lbc.size(); ++i) {
      if (std::isnan(g.lbc[i]) || std::isnan(g.ubc[i]) || g.lbc[i] > g.ubc[i]) {
        throw std::invalid_argument("constraint " + std::to_string(i) + " of group '" + g.name +
                                    "': infeasible bounds [" + std::to_string(g.lbc[i]) + ", " +
                                    std::to_string(g.ubc[i]) + "]");
      }
    }
  }
}

namespace {

// Instances per batched call: enough to amortise a call, few enough for the inputs and outputs
// to stay in cache.
constexpr int kBatch = 128;

// Gathers z for instance e and evaluates `fn` into `out` (one output).
EvalStatus EvalInstance(const Function& fn, const ElementGroup& g, int e, const double* w,
                        Eigen::VectorXd* z, Workspace* ws, double* out,
                        const double* extra0 = nullptr, const double* extra1 = nullptr) {
  for (int k = 0; k < z->size(); ++k) (*z)[k] = w[g.index(k, e)];
  const double* in[4] = {z->data(), g.data.col(e).data(), extra0, extra1};
  double* outs[1] = {out};
  return fn.Evaluate(in, outs, ws);
}

// Evaluates `fn` (inputs z, d and, when it has them, sigma and lambda) for every instance of
// `g` with Function::EvaluateBatch, kBatch instances per call, and calls sink(e, out) with
// instance e's output (OutputSize(0) doubles) in instance order. `lambda` points to the first
// instance's nc multipliers. The instances run on the batch tape (several points per
// instruction), which gives the single-point results up to rounding. On a non-finite output the
// chunk is evaluated again point by point to name the first failing instance, as EvalInstance
// does. `scratch` is this Function's own (its sizes stay put between calls).
template <typename Sink>
EvalStatus EvalBatched(const Function& fn, const ElementGroup& g, const double* w, int nc,
                       double sigma, const double* lambda, FunctionScratch* scratch,
                       Eigen::VectorXd* z, double* single_out, int* failed_instance, Sink&& sink) {
  const int n = g.NumInstances();
  const int ni = fn.NumInputs();
  const int nz = static_cast<int>(g.index.rows());
  for (int e0 = 0; e0 < n; e0 += kBatch) {
    const int m = std::min(kBatch, n - e0);
    BatchScratch& b = m == kBatch ? scratch->full : scratch->tail;
    b.in.resize(ni);
    b.in[0].resize(nz, m);
    for (int e = 0; e < m; ++e) {
      for (int k = 0; k < nz; ++k) b.in[0](k, e) = w[g.index(k, e0 + e)];
    }
    b.in[1] = g.data.middleCols(e0, m);
    if (ni > 2) b.in[2].setConstant(1, m, sigma);
    if (ni > 3) {
      b.in[3].resize(nc, m);
      for (int e = 0; e < m; ++e) {
        for (int k = 0; k < nc; ++k) {
          b.in[3](k, e) = lambda[static_cast<std::size_t>(e0 + e) * nc + k];
        }
      }
    }
    const EvalStatus s = fn.EvaluateBatch(b.in, &b.out, &scratch->ws);
    if (!s.ok) {
      for (int e = e0; e < e0 + m; ++e) {
        const EvalStatus one = EvalInstance(fn, g, e, w, z, &scratch->ws, single_out, &sigma,
                                            lambda + static_cast<std::size_t>(e) * nc);
        if (!one.ok) {
          *failed_instance = e;
          return one;
        }
      }
      *failed_instance = e0;
      return s;
    }
    for (int e = 0; e < m; ++e) sink(e0 + e, b.out[0].col(e).data());
  }
  return {};
}

}  // namespace

NlpEvalStatus Nlp::Objective(const double* w, double* f) const {
  EnsureObjective();
  double sum = 0.0;
  for (std::size_t g = 0; g < groups_.size(); ++g) {
    const Prepared& p = *prepared_[g];
    if (!p.has_objective) continue;
    int failed = -1;
    const EvalStatus s =
        EvalBatched(p.objective, groups_[g], w, 0, 0.0, nullptr, &p.s_obj, &p.z, p.buffer.data(),
                    &failed, [&sum](int, const double* v) { sum += *v; });
    if (!s.ok) return Fail(groups_[g], failed, s);
  }
  for (std::size_t b = 0; b < external_.size(); ++b) {
    const NlpEvalStatus s = EvaluateExternal(b, w, false);
    if (!s.ok) return s;
    sum += 0.5 * external_cache_[b]->r.squaredNorm();
  }
  *f = sum;
  return {};
}

NlpEvalStatus Nlp::Gradient(const double* w, double* grad) const {
  EnsureObjective();
  Eigen::Map<Eigen::VectorXd>(grad, NumVariables()).setZero();
  for (std::size_t g = 0; g < groups_.size(); ++g) {
    const Prepared& p = *prepared_[g];
    if (!p.has_objective) continue;
    const ElementGroup& group = groups_[g];
    int failed = -1;
    const EvalStatus s = EvalBatched(p.gradient, group, w, 0, 0.0, nullptr, &p.s_grad, &p.z,
                                     p.buffer.data(), &failed, [&](int e, const double* v) {
                                       for (int k = 0; k < p.nz; ++k)
                                         grad[group.index(k, e)] += v[k];
                                     });
    if (!s.ok) return Fail(group, failed, s);
  }
  for (std::size_t b = 0; b < external_.size(); ++b) {
    const NlpEvalStatus s = EvaluateExternal(b, w, true);
    if (!s.ok) return s;
    const ExternalCache& c = *external_cache_[b];
    const Eigen::VectorXd jtr = c.jacobian.transpose() * c.r;
    for (Eigen::Index k = 0; k < jtr.size(); ++k) grad[external_[b].variables[k]] += jtr[k];
  }
  return {};
}

NlpEvalStatus Nlp::Constraints(const double* w, double* c) const {
  for (std::size_t g = 0; g < groups_.size(); ++g) {
    const Prepared& p = *prepared_[g];
    if (p.nc == 0) continue;
    int failed = -1;
    const EvalStatus s = EvalBatched(
        p.constraints, groups_[g], w, 0, 0.0, nullptr, &p.s_c, &p.z, p.buffer.data(), &failed,
        [&](int e, const double* v) {
          std::copy(v, v + p.nc, c + p.constraint_offset + static_cast<std::size_t>(e) * p.nc);
        });
    if (!s.ok) return Fail(groups_[g], failed, s);
  }
  return {};
}

NlpEvalStatus Nlp::Residuals(const double* w, double* r) const {
  for (std::size_t g = 0; g < groups_.size(); ++g) {
    const Prepared& p = *prepared_[g];
    if (p.nr == 0) continue;
    int failed = -1;
    const EvalStatus s = EvalBatched(
        p.residuals, groups_[g], w, 0, 0.0, nullptr, &p.s_r, &p.z, p.buffer.data(), &failed,
        [&](int e, const double* v) {
          std::copy(v, v + p.nr, r + p.residual_offset + static_cast<std::size_t>(e) * p.nr);
        });
    if (!s.ok) return Fail(groups_[g], failed, s);
  }
  for (std::size_t b = 0; b < external_.size(); ++b) {
    const NlpEvalStatus s = EvaluateExternal(b, w, false);
    if (!s.ok) return s;
    const Eigen::VectorXd& rb = external_cache_[b]->r;
    std::copy(rb.data(), rb.data() + rb.size(), r + external_[b].residual_offset);
  }
  return {};
}

NlpEvalStatus Nlp::JacobianValues(const double* w, double* values) const {
  std::size_t offset = 0;
  for (std::size_t g = 0; g < groups_.size(); ++g) {
    const Prepared& p = *prepared_[g];
    const int nnz = p.jac_c_sp.nnz();
    if (nnz == 0) continue;
    int failed = -1;
    const EvalStatus s = EvalBatched(p.jac_c, groups_[g], w, 0, 0.0, nullptr, &p.s_jc, &p.z,
                                     p.buffer.data(), &failed, [&](int, const double* v) {
                                       std::copy(v, v + nnz, values + offset);
                                       offset += nnz;
                                     });
    if (!s.ok) return Fail(groups_[g], failed, s);
  }
  return {};
}

NlpEvalStatus Nlp::ResidualJacobianValues(const double* w, double* values) const {
  for (std::size_t g = 0; g < groups_.size(); ++g) {
    const Prepared& p = *prepared_[g];
    const int nnz = p.jac_r_sp.nnz();
    std::size_t offset = p.rjac_offset;
    if (nnz == 0) continue;
    int failed = -1;
    const EvalStatus s = EvalBatched(p.jac_r, groups_[g], w, 0, 0.0, nullptr, &p.s_jr, &p.z,
                                     p.buffer.data(), &failed, [&](int, const double* v) {
                                       std::copy(v, v + nnz, values + offset);
                                       offset += nnz;
                                     });
    if (!s.ok) return Fail(groups_[g], failed, s);
  }
  for (std::size_t b = 0; b < external_.size(); ++b) {
    const NlpEvalStatus s = EvaluateExternal(b, w, true);
    if (!s.ok) return s;
    const Eigen::MatrixXd& j = external_cache_[b]->jacobian;  // column-major = triplet order
    std::copy(j.data(), j.data() + j.size(), values + external_cache_[b]->rjac_offset);
  }
  return {};
}

NlpEvalStatus Nlp::HessianValues(const double* w, double sigma, const double* lambda,
                                 double* values) const {
  EnsureHessian();
  Eigen::Map<Eigen::VectorXd>(values, static_cast<Eigen::Index>(hess_rows_.size())).setZero();
  for (std::size_t g = 0; g < groups_.size(); ++g) {
    const Prepared& p = *prepared_[g];
    const int nnz = p.hess_sp.nnz();
    if (nnz == 0) continue;
    int failed = -1;
    const EvalStatus s =
        EvalBatched(p.hessian, groups_[g], w, p.nc, sigma, lambda + p.constraint_offset, &p.s_h,
                    &p.z, p.buffer.data(), &failed, [&](int e, const double* v) {
                      const int* slot = p.hess_slot.data() + static_cast<std::size_t>(e) * nnz;
                      for (int k = 0; k < nnz; ++k) values[slot[k]] += v[k];
                    });
    if (!s.ok) return Fail(groups_[g], failed, s);
  }
  for (std::size_t b = 0; b < external_.size(); ++b) {
    if (sigma == 0.0) break;
    const NlpEvalStatus s = EvaluateExternal(b, w, true);
    if (!s.ok) return s;
    const Eigen::MatrixXd& j = external_cache_[b]->jacobian;
    const Eigen::MatrixXd gn = j.transpose() * j;  // Gauss-Newton
    const std::vector<int>& slot = external_hess_slot_[b];
    std::size_t k = 0;
    for (Eigen::Index i = 0; i < gn.rows(); ++i) {
      for (Eigen::Index c = 0; c <= i; ++c) values[slot[k++]] += sigma * gn(i, c);
    }
  }
  return {};
}

}  // namespace graybox::estimators
