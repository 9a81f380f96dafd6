// Embedded neural networks: dense multilayer perceptrons (MLPs), per-joint networks and a gated
// recurrent unit (GRU), written as ordinary generic scalar code. On Scalar = graybox::expr::Expr a
// network is a libexpr graph whose weights are ordinary block parameters, so every estimator sees
// exact gradients and exact Hessians of the network output with respect to the weights (and to the
// inputs), with no separate deep-learning framework and no finite differences.
//
// ---- Dense MLP (seed 000, Sec. 2.1 and 2.4) -------------------------------------------------
// Sizes {n_0 = n_in, n_1, ..., n_{L-1}, n_L = n_out}: L layers numbered k = 0 .. L-1, the first
// L-1 hidden. With the input normalised per channel,
//     x~ = (x - input_mean) / input_std,                                            (1)
// the layers are
//     a_0     = x~,
//     a_{k+1} = act_k(W_k a_k + b_k),        k = 0 .. L-2   (hidden, act_k in tanh/relu/softplus)
//     y~      = W_{L-1} a_{L-1} + b_{L-1} + W_lin x~        (linear output layer + residual path)
// and the output is de-normalised,
//     y = output_std o y~,                                                           (2)
// where the output mean enters as the NOMINAL value of the output bias, b_{L-1} = output_mean /
// output_std, so that at the nominal bias (2) is the usual de-normalisation
// y = output_std o y~' + output_mean, y~' being the network without that offset. Folding the mean
// into a parameter rather than adding a constant keeps the neutral output exactly 0 whatever the
// statistics (see "Neutral values" below). relu(v) = max(v, 0) (derivative at 0 as in libexpr's
// max: the first argument, i.e. 1); softplus(v) = log(1 + exp(v)), evaluated without overflow.
//
// The linear residual path W_lin x~ (seed 000: "MLPs that have a residual connection (an
// additional linear layer directly between the inputs and outputs)") is on by default; it needs at
// least one hidden layer (without one it duplicates the output layer and makes the problem
// singular) and is rejected otherwise.
//
// Normalisation statistics are data statistics (seed 000: normalised "to standard deviation 1 and
// mean 0 ... calculated from the data"): compute them with NormalizationFromSamples() over the
// signals the network will see, and pass them with SetNormalizationOptions(). They are options,
// not parameters: fixed during identification. Default: mean 0, std 1 (no normalisation).
//
// ---- Parameter layout and naming -------------------------------------------------------------
// Layer k ("l<k>", W_k and b_k above) maps a vector of n_k to n_{k+1} entries: "l0" is the first
// hidden layer, "l<L-1>" the output layer. Indices i, j are 0-based; i is the row (the unit
// the weight feeds), j the column (the unit or input it reads):
//     "l<k>.w<i>_<j>"   weight W_k(i, j)        [1]
//     "l<k>.b<i>"       bias   b_k(i)           [1]
//     "lin.w<i>_<j>"    residual weight W_lin(i, j) from input j to output i   [1]
// Order: layer by layer; within a layer all weights row-major, then the biases; the residual
// weights last (row-major). All are dimensionless: they act on normalised signals, and physical
// units enter only through the statistics of (1) and (2). Bounds are infinite.
//
// ---- Initialisation (deterministic Glorot/Xavier uniform) ------------------------------------
// Nominal weight values are drawn, in parameter order, from one std::mt19937 seeded with the block
// option "seed" (default 0): each weight of a matrix with fan_in columns and fan_out rows is
//     w = limit (2 u - 1),   limit = sqrt(6 / (fan_in + fan_out)),   u in [0, 1)
// (Glorot and Bengio, AISTATS 2010, eq. 16; seed 000 cites it for normalised inputs and
// outputs), with u formed from two raw 32-bit engine outputs a, b as
//     u = ((a >> 5) 2^26 + (b >> 6)) / 2^53
// (genrand_res53 of the reference Mersenne Twister). std::mt19937's output sequence is fixed by
// the C++ standard, and this mapping is plain integer arithmetic plus one exact division, so the
// same seed gives bit-identical weights on every platform (std::uniform_real_distribution is not
// used: its algorithm is implementation-defined). The residual path uses fan_in = n_in, fan_out =
// n_out. Biases are 0 except the output bias, output_mean / output_std (0 by default). Blocks that
// hold several networks (per-joint) draw all of them from one engine, joint after joint, so the
// networks differ.
//
// ---- Neutral values --------------------------------------------------------------------------
// Output-layer weights and biases and the residual weights have neutral value 0: a network added
// at neutral (Model::Augment, the sim-to-real diagnosis) outputs exactly 0.0 for every finite
// input, so the augmented model is unchanged. Hidden-layer weights and biases have NO neutral
// (NaN): they keep their nominal (random) values. That is enough because with W_{L-1} = 0,
// b_{L-1} = 0 and W_lin = 0 the output does not depend on them at all, and it is also what makes
// re-fitting work: the gradient of the output with respect to W_{L-1} is the hidden activation
// a_{L-1}, which is nonzero and different for every unit only because the hidden weights are
// random. Setting them to 0 as well would put tanh networks at a saddle where every hidden unit is
// identical and all first derivatives but those of b_{L-1} vanish.
//
// ---- Block types -----------------------------------------------------------------------------
// Options common to every network block (numbers unless noted):
//     "seed"            one integer in [0, 2^32); default 0
//     "activation"      word: "tanh" (default; seed 000), "relu" or "softplus" for every hidden
//                       layer, or a comma-separated list with one name per hidden layer
//     "linear_residual" {1} (default) or {0}: the residual path W_lin x~
//     "input_mean", "input_std", "output_mean", "output_std": one value per block input / output
//                       signal, in signal order (std > 0); defaults 0 and 1
// The typical range of every input and output signal is mean -+ 2 std of its statistics (with the
// defaults, [-2, 2] in the signal's unit), the range of about 95% of normalised data.
//
// "network.mlp": one MLP from n_in inputs "in0".."in<n_in-1>" to n_out outputs "out0"..
//     "out<n_out-1>" (seed 000 Models 0.b-3: one network on chosen signals). Options: "sizes"
//     (required) {n_in, n_1, ..., n_out}; words "input_unit", "output_unit" (default "1"), the unit
//     of every input / output signal. Parameters as above.
//
// "network.per_joint": seed 000 Model 4, "vel. -> ANN per joint": for each joint j = 1..n one
//     single-input single-output MLP from the joint velocity qd_j to a joint torque tau_j,
//         tau_j = f_ann(qd_j; theta_j),
//     since friction torque mainly depends on the velocity of its own joint (seed 000 Table 2; the
//     seed multiplies the vector by M^-1(q) inside the forward dynamics: connect tau_j to the joint
//     torque sum). Inputs "qd1".."qd<n>" [rad/s], outputs "tau1".."tau<n>" [N m] (read m/s and N
//     for a prismatic joint). Options: "joints" (required) {n}; "hidden" (required) hidden sizes
//     of every joint network, e.g. {100, 100} in seed 000. Parameters of joint j are prefixed
//     "j<j>." (1-based joint numbers, as q1..q6 in the seeds): "j2.l0.w3_0", ...
//
// "network.velocity_positions": seed 000 Model 5, "(vel., all pos.) -> ANN per joint": for each
//     joint one MLP from (qd_j, q_1, ..., q_n) to tau_j (n + 1 inputs, one output), since the load
//     on a joint depends on the whole configuration. Inputs "qd1".."qd<n>" then "q1".."q<n>" [rad]
//     (the normalisation options follow this order, 2n values); outputs "tau1".."tau<n>". In joint
//     j's first layer, column 0 reads qd_j and column c = 1..n reads q_c. Options as per_joint.
//
// "network.gru": a GRU cell (seed 001 Sec. 2.3, Fig. 2) as a continuous-time state-space block,
//     see below. Inputs "in<i>", states "h<i>" [1], outputs "out<i>". Options: "sizes" (required)
//     {n_in, n_h, n_out}; "tau" {time constant [s]}, default 0.004 s; "input_unit", "output_unit";
//     seed, normalisation (no "activation", no "linear_residual").
//
// ---- GRU: discrete cell and continuous-time block (decision) ---------------------------------
// Seed 001 uses the GRU as a discrete sequence model: sequences of 128 samples at 250 Hz pass
// through stacked GRU layers and a fully connected layer predicts the residual torque. The cell
// (PyTorch's convention; Chung et al. 2014, seed 001's ref. [1], swap z and 1 - z) is, with sigma
// the logistic function,
//     z  = sigma(W_z x + U_z h + b_z)                         update gate
//     r  = sigma(W_r x + U_r h + b_r)                         reset gate
//     n  = tanh(W_n x + b_n + r o (U_n h + b_hn))             candidate state
//     h+ = (1 - z) o n + z o h                                                      (3)
// Blocks are continuous-time (xdot = f(x, u, p)), so both forms are provided:
//   - GruCellStep(): the discrete step (3), a reusable template for discrete sequence models
//     (one call per sample, stacked layers by feeding h+ of one cell as x of the next);
//   - block "network.gru": the continuous-time GRU (De Brouwer et al., "GRU-ODE-Bayes", NeurIPS
//     2019, here with a time constant tau),
//         h_dot = (1 - z) o (n - h) / tau,                                          (4)
//     and the fully connected read-out y = output_std o (W_out h + b_out) of seed 001, whose
//     parameters follow the MLP naming with prefix "out." ("out.l0.w<i>_<j>", "out.l0.b<i>"),
//     neutral 0.
// (3) is exactly one explicit Euler step of (4) with step tau: h + tau h_dot = h+. So a GRU trained
// on data sampled every T_s maps to the block with tau = T_s (default 4 ms = seed 000's T_s and
// seed 001's 250 Hz), and the block keeps the GRU's property that h stays in (-1, 1): for h in
// [-1, 1]^n_h, n is in (-1, 1) and 1 - z in (0, 1), so (4) points into the box on its faces, and
// any explicit Euler step with dt <= tau is a convex combination of h and n. The continuous form
// lets the GRU's state be integrated by the same solvers, at any step, together with the physics.
// The rates of (4) are of order (1 + |U|)/tau, so with tau = T_s the block is not stiff
// for an integrator that samples at T_s (RK4 is stable for |lambda| dt < 2.78).
// Parameter layout: for each gate g in z, r, n: "<g>.w<i>_<j>" (W_g, n_h x n_in), "<g>.u<i>_<k>"
// (U_g, n_h x n_h), "<g>.b<i>"; then "n.bh<i>" (b_hn); then the read-out. PyTorch's separate input
// and hidden biases of z and r only enter as their sum (import them as b_ir + b_hr, b_iz + b_hz):
// keeping both would make the identification problem singular. Glorot per matrix (W_g with fan_in
// n_in, U_g with fan_in = fan_out = n_h); biases 0. GRU cell parameters have no neutral (the
// read-out at 0 already removes the block's effect; the state still evolves, unobserved).
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/expr/expr.h"
#include "graybox/expr/ops.h"
#include "graybox/models/block.h"

namespace graybox::models {

// ---- Activations -------------------------------------------------------------------------------

enum class Activation { kTanh, kRelu, kSoftplus };

/// "tanh", "relu" or "softplus"; throws std::invalid_argument with a did-you-mean suggestion.
Activation ParseActivation(const std::string& name);
const char* ActivationName(Activation activation);

namespace internal {
// Double versions through libexpr's op table, so that doubles and expressions agree bit for bit.
inline double Sigmoid(double v) { return expr::EvaluateOp(expr::Op::kSigmoid, &v); }
inline double Softplus(double v) { return expr::EvaluateOp(expr::Op::kSoftplus, &v); }
inline double Relu(double v) {
  const double a[2] = {v, 0.0};
  return expr::EvaluateOp(expr::Op::kMax, a);
}
inline expr::Expr Sigmoid(const expr::Expr& v) { return expr::sigmoid(v); }
inline expr::Expr Softplus(const expr::Expr& v) { return expr::softplus(v); }
inline expr::Expr Relu(const expr::Expr& v) { return expr::max(v, expr::Expr(0.0)); }
}  // namespace internal

/// act(v) for Scalar = double or expr::Expr.
template <typename Scalar>
Scalar Activate(Activation activation, const Scalar& v) {
  using std::tanh;
  switch (activation) {
    case Activation::kTanh:
      return tanh(v);
    case Activation::kRelu:
      return internal::Relu(v);
    case Activation::kSoftplus:
      return internal::Softplus(v);
  }
  return v;  // unreachable
}

// ---- Normalisation -----------------------------------------------------------------------------

/// Per-channel statistics: x~ = (x - mean) / stddev on inputs, y = stddev o y~ (+ mean, through the
/// output bias) on outputs. Empty vectors mean "no normalisation" (mean 0, stddev 1).
struct Normalization {
  Eigen::VectorXd mean;
  Eigen::VectorXd stddev;
  int size() const { return static_cast<int>(mean.size()); }
  bool empty() const { return mean.size() == 0 && stddev.size() == 0; }
  /// Mean 0 and stddev 1 over n channels.
  static Normalization Identity(int n);
  /// Throws std::invalid_argument "<what>: expected ..., got ..." unless the statistics are empty
  /// or both have `n` entries, every mean is finite and every stddev finite and > 0.
  void Check(const std::string& what, int n) const;
};

/// Column statistics of `samples` (one row per sample, one column per signal): the mean and the
/// population standard deviation (divisor N, as numpy's std and deepSI). A constant column gets
/// stddev 1 (it carries no information; dividing by 0 would not help). Throws
/// std::invalid_argument for no rows or a non-finite entry.
Normalization NormalizationFromSamples(const Eigen::MatrixXd& samples);

/// Writes "input_mean", "input_std", "output_mean", "output_std" into `options` (empty statistics
/// are skipped).
void SetNormalizationOptions(const Normalization& input, const Normalization& output,
                             BlockOptions* options);

// ---- Deterministic Glorot initialisation ------------------------------------------------------

/// A double in [0, 1) from two raw outputs of `engine` (53 random bits; see the header comment).
double UniformUnit(std::mt19937* engine);
/// sqrt(6 / (fan_in + fan_out)).
double GlorotLimit(int fan_in, int fan_out);
/// A Glorot uniform draw in [-GlorotLimit, GlorotLimit).
double GlorotUniform(int fan_in, int fan_out, std::mt19937* engine);

// ---- Dense MLP ---------------------------------------------------------------------------------

struct MlpOptions {
  /// {n_in, hidden sizes..., n_out}; at least 2 entries, all >= 1.
  std::vector<int> sizes;
  /// One per hidden layer (sizes.size() - 2 entries).
  std::vector<Activation> activations;
  /// y~ += W_lin x~ (needs at least one hidden layer).
  bool linear_residual = true;
  /// Input statistics (n_in channels) and output statistics (n_out channels); empty = none.
  Normalization input;
  Normalization output;
  /// Throws std::invalid_argument explaining the first problem found.
  void Check() const;
};

/// A dense MLP: the layout of its parameters and its evaluation, generic over the scalar.
/// Immutable; usable by any block or hybrid structure that places the network's parameters
/// somewhere in its own parameter vector.
class Mlp {
 public:
  /// Checks the options (std::invalid_argument).
  explicit Mlp(MlpOptions options);

  const MlpOptions& options() const { return options_; }
  int NumInputs() const { return options_.sizes.front(); }
  int NumOutputs() const { return options_.sizes.back(); }
  /// Number of layers L (hidden layers + the output layer).
  int NumLayers() const { return static_cast<int>(options_.sizes.size()) - 1; }
  int NumParameters() const { return num_parameters_; }

  /// Positions in the parameter vector (see the layout in the header comment).
  int WeightIndex(int layer, int row, int col) const;
  int BiasIndex(int layer, int row) const;
  int ResidualIndex(int row, int col) const;

  /// Metadata of the parameters in order, names prefixed by `prefix` (e.g. "j1."). Nominal weights
  /// are drawn from `engine` in parameter order (Glorot uniform); neutral values as documented.
  std::vector<ParameterInfo> Parameters(const std::string& prefix, std::mt19937* engine) const;
  /// The same with a fresh engine seeded with `seed` and no prefix.
  std::vector<ParameterInfo> Parameters(std::uint32_t seed) const;

  /// y = MLP(x; p): p points to NumParameters() values, x to NumInputs(), y to NumOutputs().
  template <typename Scalar>
  void Evaluate(const Scalar* p, const Scalar* x, Scalar* y) const;

 private:
  MlpOptions options_;
  std::vector<int> layer_offsets_;  // start of layer k's weights in p
  int residual_offset_ = 0;
  int num_parameters_ = 0;
};

template <typename Scalar>
void Mlp::Evaluate(const Scalar* p, const Scalar* x, Scalar* y) const {
  const std::vector<int>& sizes = options_.sizes;
  const int n_in = NumInputs();
  const int n_out = NumOutputs();
  const int num_layers = NumLayers();
  std::vector<Scalar> normalized(x, x + n_in);
  if (!options_.input.empty()) {
    for (int j = 0; j < n_in; ++j) {
      normalized[j] = (x[j] - options_.input.mean[j]) / options_.input.stddev[j];
    }
  }
  std::vector<Scalar> a = normalized;
  std::vector<Scalar> next;
  for (int k = 0; k < num_layers; ++k) {
    const int rows = sizes[k + 1];
    const int cols = sizes[k];
    const Scalar* w = p + layer_offsets_[k];
    const Scalar* b = w + rows * cols;
    next.assign(rows, Scalar(0.0));
    for (int i = 0; i < rows; ++i) {
      Scalar sum = b[i];
      for (int j = 0; j < cols; ++j) sum += w[i * cols + j] * a[j];
      next[i] = k + 1 < num_layers ? Activate(options_.activations[k], sum) : sum;
    }
    a.swap(next);
  }
  if (options_.linear_residual) {
    const Scalar* w = p + residual_offset_;
    for (int i = 0; i < n_out; ++i) {
      for (int j = 0; j < n_in; ++j) a[i] += w[i * n_in + j] * normalized[j];
    }
  }
  for (int i = 0; i < n_out; ++i) {
    y[i] = options_.output.empty() ? a[i] : a[i] * options_.output.stddev[i];
  }
}

// ---- GRU ---------------------------------------------------------------------------------------

/// The layout of a GRU cell's parameters (see the header comment for names and order).
class GruCell {
 public:
  /// Throws std::invalid_argument unless both sizes are >= 1.
  GruCell(int num_inputs, int num_hidden);

  int NumInputs() const { return num_inputs_; }
  int NumHidden() const { return num_hidden_; }
  int NumParameters() const { return 3 * GateSize() + num_hidden_; }

  enum Gate { kUpdate = 0, kReset = 1, kCandidate = 2 };
  /// W_g(i, j), U_g(i, k), b_g(i), b_hn(i).
  int InputWeightIndex(Gate g, int i, int j) const { return g * GateSize() + i * num_inputs_ + j; }
  int RecurrentWeightIndex(Gate g, int i, int k) const {
    return g * GateSize() + num_hidden_ * num_inputs_ + i * num_hidden_ + k;
  }
  int BiasIndex(Gate g, int i) const {
    return g * GateSize() + num_hidden_ * (num_inputs_ + num_hidden_) + i;
  }
  int HiddenCandidateBiasIndex(int i) const { return 3 * GateSize() + i; }

  /// Metadata in order, names prefixed by `prefix`; Glorot nominal weights from `engine`, biases 0,
  /// no neutral values.
  std::vector<ParameterInfo> Parameters(const std::string& prefix, std::mt19937* engine) const;

 private:
  int GateSize() const { return num_hidden_ * (num_inputs_ + num_hidden_ + 1); }
  int num_inputs_;
  int num_hidden_;
};

/// The gates z and candidate n of a GRU cell at (x, h) (z and n point to NumHidden() values).
template <typename Scalar>
void GruGates(const GruCell& cell, const Scalar* p, const Scalar* x, const Scalar* h, Scalar* z,
              Scalar* n) {
  using std::tanh;
  const int n_in = cell.NumInputs();
  const int n_h = cell.NumHidden();
  auto affine = [&](GruCell::Gate g, int i, bool with_input_bias) {
    Scalar s = with_input_bias ? p[cell.BiasIndex(g, i)] : Scalar(0.0);
    for (int j = 0; j < n_in; ++j) s += p[cell.InputWeightIndex(g, i, j)] * x[j];
    return s;
  };
  auto recurrent = [&](GruCell::Gate g, int i) {
    Scalar s(0.0);
    for (int k = 0; k < n_h; ++k) s += p[cell.RecurrentWeightIndex(g, i, k)] * h[k];
    return s;
  };
  for (int i = 0; i < n_h; ++i) {
    z[i] = internal::Sigmoid(affine(GruCell::kUpdate, i, true) + recurrent(GruCell::kUpdate, i));
    const Scalar r =
        internal::Sigmoid(affine(GruCell::kReset, i, true) + recurrent(GruCell::kReset, i));
    n[i] = tanh(affine(GruCell::kCandidate, i, true) +
                r * (recurrent(GruCell::kCandidate, i) + p[cell.HiddenCandidateBiasIndex(i)]));
  }
}

/// The discrete GRU step (3): h_next = (1 - z) o n + z o h. `h_next` may alias `h`.
template <typename Scalar>
void GruCellStep(const GruCell& cell, const Scalar* p, const Scalar* x, const Scalar* h,
                 Scalar* h_next) {
  std::vector<Scalar> z(cell.NumHidden()), n(cell.NumHidden());
  GruGates(cell, p, x, h, z.data(), n.data());
  for (int i = 0; i < cell.NumHidden(); ++i) h_next[i] = (1.0 - z[i]) * n[i] + z[i] * h[i];
}

/// The continuous-time GRU (4): h_dot = (1 - z) o (n - h) / tau.
template <typename Scalar>
void GruCellDerivative(const GruCell& cell, const Scalar* p, const Scalar* x, const Scalar* h,
                       double tau, Scalar* h_dot) {
  std::vector<Scalar> z(cell.NumHidden()), n(cell.NumHidden());
  GruGates(cell, p, x, h, z.data(), n.data());
  for (int i = 0; i < cell.NumHidden(); ++i) h_dot[i] = (1.0 - z[i]) * (n[i] - h[i]) / tau;
}

}  // namespace graybox::models
