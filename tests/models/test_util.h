// Helpers shared by the models tests: seeded random chains and an explicit RK4 step.
#pragma once

#include <cstdint>
#include <cstdlib>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <gtest/gtest.h>

#include "graybox/expr/derivative_check.h"
#include "graybox/expr/function.h"
#include "graybox/models/block.h"
#include "graybox/models/model.h"
#include "graybox/models/rigid_body_dynamics.h"
#include "graybox/models/serial_chain.h"

namespace graybox::models::testing {

/// The seed of every random draw: GRAYBOX_TEST_SEED from the environment, else `fallback`. Printed
/// so a failure can be replayed.
inline std::uint32_t TestSeed(std::uint32_t fallback = 20240601u) {
  std::uint32_t seed = fallback;
  if (const char* env = std::getenv("GRAYBOX_TEST_SEED")) {
    seed = static_cast<std::uint32_t>(std::strtoul(env, nullptr, 10));
  }
  std::cout << "[ seed     ] " << seed << " (override with GRAYBOX_TEST_SEED)\n";
  return seed;
}

inline double Uniform(std::mt19937& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

inline Eigen::VectorXd RandomVector(std::mt19937& rng, int n, double lo, double hi) {
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = Uniform(rng, lo, hi);
  return v;
}

/// A random rotation (uniform enough for tests: normalised random quaternion).
inline Eigen::Matrix3d RandomRotation(std::mt19937& rng) {
  Eigen::Quaterniond q(Uniform(rng, -1, 1), Uniform(rng, -1, 1), Uniform(rng, -1, 1),
                       Uniform(rng, -1, 1));
  q.normalize();
  return q.toRotationMatrix();
}

/// A random, physically consistent chain of `dof` links. `prismatic_every` > 0 makes every
/// prismatic_every-th joint (1-based) prismatic. Inertias are given about the centre of mass.
inline SerialChain RandomChain(std::mt19937& rng, int dof, DhConvention convention,
                               int prismatic_every = 0) {
  std::vector<Link> links(static_cast<std::size_t>(dof));
  for (int i = 0; i < dof; ++i) {
    Link& l = links[static_cast<std::size_t>(i)];
    l.joint_type = (prismatic_every > 0 && (i + 1) % prismatic_every == 0) ? JointType::kPrismatic
                                                                           : JointType::kRevolute;
    l.alpha = Uniform(rng, -3.0, 3.0);
    l.a = Uniform(rng, -0.5, 0.5);
    l.d = Uniform(rng, -0.5, 0.5);
    l.theta = Uniform(rng, -3.0, 3.0);
    l.mass = Uniform(rng, 0.5, 5.0);
    l.center_of_mass = RandomVector(rng, 3, -0.2, 0.2);
    const Eigen::Matrix3d r = RandomRotation(rng);
    const Eigen::Vector3d principal = RandomVector(rng, 3, 0.05, 0.1);  // triangle inequality holds
    l.inertia = r * principal.asDiagonal() * r.transpose();
    l.inertia = 0.5 * (l.inertia + l.inertia.transpose()).eval();
    l.inertia_reference = InertiaReference::kCenterOfMass;
    l.gear_ratio = Uniform(rng, 10.0, 100.0);
    l.rotor_inertia = Uniform(rng, 0.0, 0.5);
  }
  const Eigen::Vector3d gravity = 9.81 * RandomVector(rng, 3, -1.0, 1.0).normalized();
  return SerialChain("random", convention, std::move(links), gravity);
}

/// The same mechanism as a standard-DH chain, described with modified DH parameters and link-frame
/// (origin) inertias: modified row i = (alpha_{i-1}, a_{i-1}, d_i, theta_i), and the modified link
/// frame {i} is the standard chain's joint frame {J_i}, whose parameters SerialChain::body() holds.
inline SerialChain ToModifiedDh(const SerialChain& standard) {
  std::vector<Link> links = standard.links();
  for (int i = 0; i < standard.dof(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    Link& l = links[k];
    l.alpha = i > 0 ? standard.link(i - 1).alpha : 0.0;
    l.a = i > 0 ? standard.link(i - 1).a : 0.0;
    const BodyParameters<double>& b = standard.body(i);
    l.mass = b.mass;
    l.center_of_mass = b.first_moment / b.mass;
    l.inertia = b.inertia;
    l.inertia_reference = InertiaReference::kLinkOrigin;
  }
  return SerialChain(standard.name() + " (modified)", DhConvention::kModified, std::move(links),
                     standard.gravity());
}

/// One classical Runge-Kutta step of x' = f(x) for x = [q; qd] with qdd = accel(q, qd); `Vector`
/// is Eigen::VectorXd or JointVector<double> (allocation-free).
template <typename Vector, typename Accel>
void Rk4Step(const Accel& accel, double h, Vector* q, Vector* qd) {
  const Vector q0 = *q, v0 = *qd;
  const Vector a1 = accel(q0, v0);
  const Vector q2 = q0 + 0.5 * h * v0, v2 = v0 + 0.5 * h * a1;
  const Vector a2 = accel(q2, v2);
  const Vector q3 = q0 + 0.5 * h * v2, v3 = v0 + 0.5 * h * a2;
  const Vector a3 = accel(q3, v3);
  const Vector q4 = q0 + h * v3, v4 = v0 + h * a3;
  const Vector a4 = accel(q4, v4);
  *q = q0 + (h / 6.0) * (v0 + 2.0 * v2 + 2.0 * v3 + v4);
  *qd = v0 + (h / 6.0) * (a1 + 2.0 * a2 + 2.0 * a3 + a4);
}

// Derivatives of a block's xdot and y with respect to states, inputs and parameters against
// central differences (expr::CheckJacobian, default tolerance) at three random points, in scaled
// coordinates x = s_x x~, u = s_u u~, p = s_p p~ with s the typical magnitude of each entry
// (max(|typical_min|, |typical_max|) for signals, DefaultParameterScale for parameters), so the
// checker's step is relative to each quantity's size (an inertia of 1e-4 kg m^2 included).
inline void ExpectBlockDerivativesMatch(const Block& b, std::uint32_t seed) {
  auto scales = [](const std::vector<SignalInfo>& signals) {
    Eigen::VectorXd s(static_cast<int>(signals.size()));
    for (std::size_t i = 0; i < signals.size(); ++i) {
      s[static_cast<int>(i)] =
          std::max(std::fabs(signals[i].typical_min), std::fabs(signals[i].typical_max));
    }
    return s;
  };
  const Eigen::VectorXd sx = scales(b.info().states), su = scales(b.info().inputs);
  Eigen::VectorXd sp(b.NumParameters());
  for (int i = 0; i < b.NumParameters(); ++i) {
    sp[i] = DefaultParameterScale(b.info().parameters[i]);
  }
  const std::vector<expr::Expr> xs = expr::Expr::Symbols("x", b.NumStates());
  const std::vector<expr::Expr> us = expr::Expr::Symbols("u", b.NumInputs());
  const std::vector<expr::Expr> ps = expr::Expr::Symbols("p", b.NumParameters());
  auto scaled = [](const std::vector<expr::Expr>& v, const Eigen::VectorXd& s) {
    std::vector<expr::Expr> out;
    for (std::size_t i = 0; i < v.size(); ++i) out.push_back(s[static_cast<int>(i)] * v[i]);
    return out;
  };
  const std::vector<expr::Expr> x = scaled(xs, sx), u = scaled(us, su), p = scaled(ps, sp);
  std::vector<expr::Expr> xdot(b.NumStates()), y(b.NumOutputs());
  b.Evaluate(BlockArgs<expr::Expr>{x.data(), u.data(), p.data(), xdot.data(), y.data()});
  const expr::Function f(b.info().type, {{"x", xs}, {"u", us}, {"p", ps}},
                         {{"xdot", xdot}, {"y", y}});
  std::mt19937 rng(seed);
  auto sample = [&](const std::vector<SignalInfo>& signals, const Eigen::VectorXd& s) {
    Eigen::VectorXd v(static_cast<int>(signals.size()));
    for (std::size_t i = 0; i < signals.size(); ++i) {
      const int k = static_cast<int>(i);
      v[k] = Uniform(rng, signals[i].typical_min, signals[i].typical_max) / s[k];
    }
    return v;
  };
  for (int trial = 0; trial < 3; ++trial) {
    const Eigen::VectorXd xt = sample(b.info().states, sx), ut = sample(b.info().inputs, su);
    Eigen::VectorXd pt(b.NumParameters());
    for (int i = 0; i < b.NumParameters(); ++i) {
      const ParameterInfo& par = b.info().parameters[i];
      double v = par.nominal * (1.0 + 0.1 * Uniform(rng, -1.0, 1.0));
      if (par.nominal == 0.0) v = 0.1 * Uniform(rng, -1.0, 1.0);
      pt[i] = std::min(par.upper, std::max(par.lower, v)) / sp[i];
    }
    for (const char* out : {"xdot", "y"}) {
      for (const char* in : {"x", "u", "p"}) {
        if (f.OutputSize(f.OutputIndex(out)) == 0 || f.InputSize(f.InputIndex(in)) == 0) continue;
        const auto check = expr::CheckJacobian(f, out, in, {xt, ut, pt});
        EXPECT_TRUE(check.ok) << b.info().type << ": " << check.FullReport();
      }
    }
  }
}

}  // namespace graybox::models::testing
