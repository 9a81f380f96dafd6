// ExperimentSetup: the per-fit settings of one experiment, kept apart from its measurements.
//
// Measurements are an `Experiment` (data/dataset.h: name, uniform sample time dt, inputs u,
// outputs y, optionally measured states x). What a formulation needs beyond them, and what a
// caller may change from one fit to the next without touching the data, is here: the initial
// state and an optional guess of the state trajectory. The formulations take the experiments and
// one setup per experiment, in the same order:
//
//   std::vector<Experiment> data = {train};
//   std::vector<ExperimentSetup> setup(1);
//   setup[0].x0 = Eigen::Vector2d(0.0, 0.0);
//   ShootingProblem p = BuildMultipleShooting(model, data, setup, options);
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/data/dataset.h"

namespace graybox::estimators {

inline constexpr int kInitialStateDefault = -1;
inline constexpr int kInitialStateFixed = 0;
inline constexpr int kInitialStateFree = 1;

struct ExperimentSetup {
  /// Initial state (nx): its value when the formulation keeps it fixed, else the starting guess
  /// of the free initial state.
  Eigen::VectorXd x0;
  /// Per state (empty: every state as the formulation's default, fix_initial_state): whether
  /// the formulation estimates the state's initial value (kInitialStateFree), holds it at x0
  /// (kInitialStateFixed) or follows its default (kInitialStateDefault). Multiple and single
  /// shooting and collocation honour it; a held state of an estimated initial state is a
  /// variable with equal bounds.
  std::vector<int> x0_free;
  /// Optional N x nx guess of the state trajectory (shooting nodes, collocation states), e.g.
  /// measured positions and differentiated velocities; empty: simulated from x0 with the initial
  /// parameters.
  Eigen::MatrixXd state_guess;

  /// Whether state i's initial value is estimated, given the formulation's default for all.
  bool InitialStateFree(int i, bool default_free) const {
    if (i < 0 || i >= static_cast<int>(x0_free.size()) || x0_free[i] == kInitialStateDefault) {
      return default_free;
    }
    return x0_free[i] == kInitialStateFree;
  }
  /// Whether any state's initial value is estimated, given the formulation's default.
  bool AnyInitialStateFree(int num_states, bool default_free) const {
    for (int i = 0; i < num_states; ++i) {
      if (InitialStateFree(i, default_free)) return true;
    }
    return false;
  }
};

}  // namespace graybox::estimators
