// The sparse regression of the flexible reference's learned force onto the candidates' shapes
// (SINDy-style, seed 003): a second, independent proposal of which effects close the gap, beside
// the score tests and re-fits of the screening.
//
//   const FlexibleReference ref = FitFlexibleReference(problem, splits, nominal);
//   const SparseRegression s = RegressLearnedForce(ref);
//   for (const SparseEffect& e : s.effects) ...   // largest share of the learned force first
//
// ---- The learned force
// -------------------------------------------------------------------------- On every axis the
// reference added networks to (reference.h), the learned force is what the networks write into the
// axis force, along the reference's own simulation of the estimation splits (its fitted states and
// the measured inputs):
//   f(t) = F(x(t), u(t), theta_ref) - F(x(t), u(t), theta_ref with the networks at neutral),
// sign-corrected to the friction blocks' convention (a force that opposes positive motion is
// positive when the axis' friction blocks write "-F"). Samples where the simulation diverged are
// skipped.
//
// ---- The library of shapes, per axis (v the velocity, q the position, s = RMS(v))
// ---------------- Each column is named by the effect it stands for (candidates.h's names):
//   asymmetric_friction  1                              (a constant force)
//   asymmetric_friction  tanh(30 v / s)^2               (levels that differ by direction)
//   coulomb              tanh(30 v / s)
//   viscous              v
//   stribeck             exp(-(v / (c s))^2) tanh(150 v / s),  c = 0.03, 0.1, 0.3
//   power_law_viscous    sign(v) |v / s|^k,             k = 0.3, 0.6, 2
//   ripple               sin(2 pi q / P), cos(2 pi q / P) for every period P of
//                        SparseRegressionOptions::ripple_periods_by_position (the periodogram's,
//                        period_scan.h), else span / 1, 2, 4, 8 (2 pi / 1, 2, 4, 8 on a rotary
//                        axis)
//   payload              sin q, cos q on a rotary axis (gravity; the ripple of period 2 pi is
//                        this column, named payload)
// Position columns need the axis' position (MechanicalAxis::position).
//
// ---- The nominal parameters first
// ------------------------------------------------------------- The reference refits the
// nominal parameters beside its networks, and a learned force along a direction the physics has
// (a viscous network term beside a free viscous coefficient) is not an effect. So the
// sensitivities dF/dtheta of the axis force to every free nominal parameter (central differences
// at the same samples) are regressors first, and the library explains what they cannot:
//   r0 = f - P_nominal f,   absorbed_by_nominal = 1 - |r0|^2 / |f|^2.
//
// ---- Greedy forward selection (orthogonal matching pursuit)
// ------------------------------------ Starting from the nominal columns, the library column
// that most lowers the least-squares residual energy (all chosen columns re-fitted together,
// column-pivoted QR on unit-RMS columns) is added, while its reduction is at least `threshold` x
// |r0|^2 and fewer than max_terms columns are chosen. A column's share is its reduction / |r0|^2
// (the shares of the chosen columns add up to r_squared = 1 - |r_final|^2 / |r0|^2); an effect's
// share is the sum of its columns'. Unlike thresholded least squares on the whole library (SINDy's
// STLSQ), this stays meaningful when columns are nearly collinear: a column that only cancels
// another is never chosen. Coefficients are those of the final fit.
//
// What it cannot say: the shapes overlap (a hard Coulomb, a narrow Stribeck hump and a small-k
// power law are nearly collinear over a record that spends little time near v = 0), so the
// proposal is a family, and the networks' own limits (reference.h: static force shapes only) are
// its limits: a delay, a presliding state or elasticity leave no static learned force to regress.
// Diagnose reports where this proposal and forward selection agree (DiagnosisReport::agreement).
//
// Failure behaviour. Invalid options throw std::invalid_argument. A reference that is not ok, or
// an axis without finite samples, gives ok = false with the reason (axes that work are kept).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "graybox/diagnosis/reference.h"

namespace graybox::diagnosis {

struct SparseRegressionOptions {
  /// Smallest share of |r0|^2 a column must remove to be chosen, in (0, 1).
  double threshold = 0.05;
  /// Most library columns chosen per axis (>= 1).
  int max_terms = 6;
  /// Ripple periods per position state; empty for an axis: the default grid of the file comment.
  std::map<std::string, std::vector<double>> ripple_periods_by_position;
  /// Throws std::invalid_argument naming the first invalid field and its value.
  void Validate() const;
};

/// One kept column of the library.
struct SparseTerm {
  std::string effect;        // candidates.h's name
  std::string shape;         // "tanh(30 v / s)", "sin(2 pi q / 0.02)", ...
  double coefficient = 0.0;  // in the axis force's unit per unit of the shape
  double share = 0.0;        // its reduction of the residual energy / |r0|^2
};

/// One effect, its columns together.
struct SparseEffect {
  std::string effect;
  double share = 0.0;  // the sum of its columns' shares
};

struct AxisRegression {
  std::string velocity, force;  // the axis
  int samples = 0;
  double learned_force_rms = 0.0;  // RMS(f), in the force's unit
  /// 1 - |r0|^2 / |f|^2: the part of the learned force the nominal parameters can absorb.
  double absorbed_by_nominal = 0.0;
  double r_squared = 0.0;             // 1 - |r_final|^2 / |r0|^2
  std::vector<SparseTerm> terms;      // chosen columns, in the order chosen
  std::vector<SparseEffect> effects;  // by share
};

struct SparseRegression {
  bool ok = false;
  std::string failure;
  std::vector<AxisRegression> axes;
  /// Every axis' proposed effects merged, by largest share (an effect named once). Diagnose
  /// empties it (and says so in `note`) when the reference does not lower the validation NRMSE by
  /// DiagnoseOptions::min_relative_gain: a learned force that does not help on new data is noise.
  std::vector<SparseEffect> effects;
  std::string note;
  /// "sparse regression of the learned force: coulomb 0.82, viscous 0.11 (share of the learned
  /// force beyond the nominal parameters; R^2 0.97 on load.qd)".
  std::string BriefReport() const;
};

/// The sparse regression of `reference`'s learned force (see the file comment).
SparseRegression RegressLearnedForce(const FlexibleReference& reference,
                                     const SparseRegressionOptions& options = {});

}  // namespace graybox::diagnosis
