// The flexible reference: how far ANY effect of a static force shape could shrink the gap. The
// nominal model is augmented on every mechanical axis (candidates.h FindAxes) with small networks
// that add a force learned from the data, fitted with the physics, and the validation error it
// reaches is the reference against which each candidate effect's shrinkage is measured:
//
//   gap        = e_nominal - e_reference          (validation NRMSE, diagnose.h)
//   gap_closed = (e_before - e_after) / gap       (per accepted effect)
//
// The reference is independent of the candidate library: it knows no friction law, delay or
// ripple, only that a force acts on the axis as a smooth function of the axis' velocity (and,
// separately, of its position). It is seed 000's Model 4 ("vel. -> ANN per joint") with a second
// network on the position:
//
//   F_axis += f_v(v) + f_q(q),   f_v, f_q: network.mlp 1-H-1 (tanh, linear residual path),
//
// each added by Model::Augment at its neutral value (zero output weights: the augmented model
// equals the nominal one before the fit), its input normalised by the mean and standard deviation
// of v (or q) along the nominal fit's simulation of the estimation splits and its output scaled by
// the standard deviation of the axis force there (models/networks.h). The position network is
// added (position_network) when a position state of the same block as v exists (the state whose
// derivative is v). The nominal free parameters are free.
//
// Hidden layer. By default the hidden layer is not trained but holds fixed features, so that the
// learned force is linear in its free parameters (output weights and bias, linear residual path)
// and the exact Hessian stays as small as the physics' (training a 1-8-1 pair on the EMPS closed
// loop took 205 s against 1 s for the nominal fit). The features are a generic basis, not the
// candidates' shapes:
//   f_v: odd steps tanh(w_i v / std(v)), i = 0 .. H-1, with steepness w_i log-spaced from 1 to
//        max_steepness: any odd, monotone-or-not static velocity law with transitions no sharper
//        than std(v) / max_steepness (Coulomb, Stribeck, power laws, viscous by the linear path);
//        an even or offset part comes from the output bias and the linear path.
//   f_q: smooth steps tanh(w (q - c_i)) at the quantiles c_i = (i + 1/2) / H of q, each as wide as
//        the spacing of the quantiles: a smooth staircase basis for any force varying with position
//        at the scale of the motion (gravity, a spring, a slow ripple).
// max_steepness bounds the stiffness the reference can add to a fixed-step simulation; a steeper
// law is approximated by the steepest feature. train_hidden_layer fits the hidden layer too (from
// these values), for a reference that is not limited by the basis, at the cost above.
//
// A weight-decay term of weight `weight_decay` on the free network parameters
// (regularization.h) keeps the networks from fitting noise. The fit is the problem's own method,
// started from the nominal values. Multiple shooting is solved by Ceres (Gauss-Newton, continuity
// as residuals of weight 1e3, ten times the default: near-exact continuity) whatever the problem's
// solver: Ipopt's exact Hessian of the Lagrangian is costly to build symbolically through the
// networks (28 s of derivative-graph construction for a 1000-sample slide that Ceres fits in
// 2.5 s; on the EMPS closed loop Ceres reaches test NRMSE 0.0494 in 6 s, Ipopt 0.0486 in 28 s).
// The other methods use the problem's solver.
//
// What the reference cannot represent is not in the gap either: dynamics (a delay, a presliding
// state, elasticity), time-varying effects (a drifting friction), or effects on the sensor. For
// those the reference may be no better than the nominal model; Diagnose then falls back to the
// nominal error (gap_closed is NaN, the share of the nominal error is reported instead). Where
// the accepted effects end below the reference's error, gap_closed passes 1 over them and the
// verdict gives the shares of the nominal error too ("the whole gap closed").
//
// Failure behaviour. Invalid options throw std::invalid_argument (ReferenceOptions::Validate). A
// model without a mechanical axis, a failed solve or a diverged validation simulation gives
// ok = false and the reason in `failure`; nothing is thrown for them.
#pragma once

#include <string>
#include <vector>

#include "graybox/diagnosis/candidates.h"
#include "graybox/estimators/fit/fit.h"

namespace graybox::diagnosis {

struct ReferenceOptions {
  /// Hidden tanh units of each network (>= 1).
  int hidden = 8;
  /// Largest steepness of the velocity features, in units of 1 / std(v) (>= 1).
  double max_steepness = 100.0;
  /// Fit the hidden layer's weights and biases too (else they keep their seeded values).
  bool train_hidden_layer = false;
  /// Weight lambda of the weight decay on the network parameters (>= 0).
  double weight_decay = 1.0;
  /// Add the position network f_q as well as the velocity network f_v.
  bool position_network = true;
  /// Seed of the networks' hidden-layer initialisation.
  unsigned seed = 1;
  /// Throws std::invalid_argument naming the first invalid field and its value.
  void Validate() const;
};

struct FlexibleReference {
  bool ok = false;
  std::string failure;  // why not ok
  /// The validation NRMSE the reference reaches (diagnose.h's metric; NaN when not ok).
  double validation_nrmse = 0.0;
  /// "network.mlp on load.qd -> force", one per network added.
  std::vector<std::string> networks;
  int num_network_parameters = 0;
  /// Per network (parallel to `networks`): its block instance and the axis whose force it adds
  /// to (sparse_regression.h reads the learned force from these).
  std::vector<std::string> network_instances;
  std::vector<MechanicalAxis> network_axes;
  /// The augmented model that was fitted (its parameter values are fit.values).
  models::StateSpaceModel model;
  estimators::FitResult fit;
  /// "flexible reference (2 networks, 52 parameters): validation NRMSE 0.041".
  std::string BriefReport() const;
};

/// The solver FitFlexibleReference solves `problem`'s reference with: Ceres under multiple
/// shooting (its continuity then penalised), else the problem's own.
std::string FlexibleReferenceSolver(const estimators::Problem& problem);

/// Fits the flexible reference of `problem` from the nominal fit `nominal` (see the file comment).
FlexibleReference FitFlexibleReference(const estimators::Problem& problem,
                                       const std::vector<estimators::SplitData>& splits,
                                       const estimators::FitResult& nominal,
                                       const ReferenceOptions& options = {});

}  // namespace graybox::diagnosis
