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

struct ExperimentSetup {
  /// Initial state (nx): its value when the formulation keeps it fixed, else the starting guess
  /// of the free initial state.
  Eigen::VectorXd x0;
  /// Optional N x nx guess of the state trajectory (shooting nodes, collocation states), e.g.
  /// measured positions and differentiated velocities; empty: simulated from x0 with the initial
  /// parameters.
  Eigen::MatrixXd state_guess;
};

}  // namespace graybox::estimators
