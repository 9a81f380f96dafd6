// Test support: the synthetic sliding mass the diagnosis tests share. A slide of mass `mass` with
// viscous friction, driven by a three-tone multisine force, and a withheld friction force given as
// a function of the velocity; its velocity is measured with white noise. The truth is integrated
// by RK4 with `substeps` steps per sample (input held over the sample), far finer than the
// nominal model's 4.
#pragma once

#include <cmath>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <random>
#include <string>

#include <Eigen/Core>

#include "graybox/estimators/fit/fit.h"
#include "graybox/models/model.h"

namespace graybox::diagnosis::testing {

inline constexpr double kPi = 3.14159265358979323846;

/// `fallback` unless GRAYBOX_TEST_SEED says otherwise; printed either way.
inline unsigned TestSeed(unsigned fallback) {
  const char* s = std::getenv("GRAYBOX_TEST_SEED");
  const unsigned seed = s ? static_cast<unsigned>(std::strtoul(s, nullptr, 10)) : fallback;
  std::cout << "seed " << seed << " (GRAYBOX_TEST_SEED overrides)\n";
  return seed;
}

/// The drive force [N]; `phase` makes the validation record differ from the estimation one.
inline double MultisineForce(double t, double phase) {
  return 2.5 * std::sin(2.0 * kPi * 0.3 * t + phase) +
         1.5 * std::sin(2.0 * kPi * 0.9 * t + 1.0 + 2.0 * phase) +
         0.8 * std::sin(2.0 * kPi * 1.7 * t + 2.0 + 3.0 * phase);
}

struct SlideTruth {
  double mass = 2.0;        // [kg]
  double viscous = 3.0;     // [N s/m]
  double dt = 0.01;         // [s]
  int samples = 1000;       // per split
  int substeps = 40;        // RK4 steps per sample
  double noise_std = 0.01;  // [m/s], on the measured velocity
  std::function<double(double)> friction = [](double) { return 0.0; };  // [N] of v [m/s]
};

/// One split of the truth's measured velocity (input: the force; x0 = 0 for q and v).
inline estimators::SplitData SlideSplit(const SlideTruth& truth, const std::string& name,
                                        estimators::SplitRole role, double phase,
                                        std::mt19937* rng) {
  estimators::Experiment e;
  e.name = name;
  e.dt = truth.dt;
  e.u.resize(truth.samples, 1);
  e.y.resize(truth.samples, 1);
  std::normal_distribution<double> noise(0.0, truth.noise_std);
  double v = 0.0;
  const double h = truth.dt / truth.substeps;
  for (int k = 0; k < truth.samples; ++k) {
    const double u = MultisineForce(k * truth.dt, phase);
    e.u(k, 0) = u;
    e.y(k, 0) = v + noise(*rng);
    auto f = [&](double vv) { return (u - truth.viscous * vv - truth.friction(vv)) / truth.mass; };
    for (int s = 0; s < truth.substeps; ++s) {
      const double k1 = f(v), k2 = f(v + 0.5 * h * k1), k3 = f(v + 0.5 * h * k2),
                   k4 = f(v + h * k3);
      v += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
  }
  return estimators::MakeSplit(name, role, e, Eigen::VectorXd::Zero(2));
}

/// The nominal model: the slide with viscous friction only, its velocity the output, started at
/// m = 1 kg and fv = 1 N s/m, 4 RK4 steps per sample.
inline estimators::Problem NominalSlideProblem() {
  models::Model m("slide");
  m.AddInput("force", "N", "drive force", -5.0, 5.0);
  models::BlockOptions prismatic;
  prismatic.words["motion"] = "prismatic";
  m.AddBlock("load", "mechanics.mass", prismatic, {"force"}, {});
  m.AddBlock("friction", "friction.viscous", prismatic, {"load.qd"}, {"-force"});
  m.SetParameter("load.mass", 1.0);
  m.SetParameter("friction.fv", 1.0);
  m.AddOutput("load.qd");
  estimators::EstimationSpec spec;
  spec.step.substeps = 4;
  return estimators::MakeProblem("slide", m, spec);
}

}  // namespace graybox::diagnosis::testing
