#include "graybox/models/serial_chain.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <Eigen/Eigenvalues>

namespace graybox::models {

const char* ToString(DhConvention convention) {
  return convention == DhConvention::kStandard ? "standard" : "modified";
}
const char* ToString(JointType type) {
  return type == JointType::kRevolute ? "revolute" : "prismatic";
}
const char* ToString(InertiaReference reference) {
  return reference == InertiaReference::kCenterOfMass ? "center of mass" : "link origin";
}

namespace {

// cos/sin of a constant angle, rounded to exact 0 and +-1 (see serial_chain.h).
double Snap(double v) {
  constexpr double kSnap = 1e-15;
  if (std::fabs(v) < kSnap) return 0.0;
  if (std::fabs(v - 1.0) < kSnap) return 1.0;
  if (std::fabs(v + 1.0) < kSnap) return -1.0;
  return v;
}

Eigen::Matrix3d RotX(double cos_a, double sin_a) {
  Eigen::Matrix3d r;
  r << 1.0, 0.0, 0.0, 0.0, cos_a, -sin_a, 0.0, sin_a, cos_a;
  return r;
}

std::string Num(double v) {
  std::ostringstream os;
  os.precision(6);
  os << v;
  return os.str();
}

}  // namespace

SerialChain::SerialChain(std::string name, DhConvention convention, std::vector<Link> links,
                         const Eigen::Vector3d& gravity)
    : name_(std::move(name)), convention_(convention), links_(std::move(links)), gravity_(gravity) {
  Validate();
  const int n = dof();
  for (int i = 0; i < n; ++i) {
    const Link& l = links_[static_cast<std::size_t>(i)];
    JointGeometry& g = geometry_[static_cast<std::size_t>(i)];
    g.joint_type = l.joint_type;
    g.theta = l.theta;
    g.d = l.d;
    g.cos_theta = Snap(std::cos(l.theta));
    g.sin_theta = Snap(std::sin(l.theta));
    const Link* pre = nullptr;  // whose (alpha, a) precede the joint motion
    if (convention_ == DhConvention::kModified) {
      pre = &l;
    } else if (i > 0) {
      pre = &links_[static_cast<std::size_t>(i - 1)];
    }
    if (pre != nullptr) {
      g.cos_alpha = Snap(std::cos(pre->alpha));
      g.sin_alpha = Snap(std::sin(pre->alpha));
      g.a = pre->a;
    }
    if (convention_ == DhConvention::kStandard) {
      g.link_rotation = RotX(Snap(std::cos(l.alpha)), Snap(std::sin(l.alpha)));
      g.link_origin = Eigen::Vector3d(l.a, 0.0, 0.0);
    }
    bodies_[static_cast<std::size_t>(i)] = TransformBodyParameters(
        g.link_rotation, Vector3<double>(g.link_origin), LinkFrameParameters(i));
  }
}

BodyParameters<double> SerialChain::LinkFrameParameters(int i) const {
  const Link& l = links_.at(static_cast<std::size_t>(i));
  BodyParameters<double> b;
  if (l.inertia_reference == InertiaReference::kCenterOfMass) {
    b = BodyFromCenterOfMassInertia(l.mass, l.center_of_mass, l.inertia, l.rotor_inertia);
  } else {
    b.mass = l.mass;
    b.first_moment = l.mass * l.center_of_mass;
    b.inertia = l.inertia;
    b.rotor_inertia = l.rotor_inertia;
  }
  return b;
}

void SerialChain::Validate() const {
  const std::string who = "SerialChain '" + name_ + "': ";
  if (links_.empty() || dof() > kMaxDof) {
    throw std::invalid_argument(who + "expected 1 to " + std::to_string(kMaxDof) + " links, got " +
                                std::to_string(links_.size()) +
                                "; hint: kMaxDof in serial_chain.h bounds the chain length");
  }
  if (!gravity_.allFinite()) {
    throw std::invalid_argument(who + "expected a finite gravity vector, got (" + Num(gravity_[0]) +
                                ", " + Num(gravity_[1]) + ", " + Num(gravity_[2]) + ")");
  }
  for (int i = 0; i < dof(); ++i) {
    const Link& l = links_[static_cast<std::size_t>(i)];
    const std::string at = who + "link " + std::to_string(i + 1) + ": ";
    const auto finite = [&](double v, const char* what) {
      if (!std::isfinite(v)) {
        throw std::invalid_argument(at + "expected a finite " + what + ", got " + Num(v));
      }
    };
    finite(l.alpha, "alpha");
    finite(l.a, "a");
    finite(l.d, "d");
    finite(l.theta, "theta");
    finite(l.mass, "mass");
    finite(l.rotor_inertia, "rotor inertia");
    finite(l.gear_ratio, "gear ratio");
    if (!l.center_of_mass.allFinite()) {
      throw std::invalid_argument(at + "expected a finite centre of mass, got a NaN or Inf entry");
    }
    if (!l.inertia.allFinite()) {
      throw std::invalid_argument(at + "expected a finite inertia tensor, got a NaN or Inf entry");
    }
    if (l.mass < 0.0) {
      throw std::invalid_argument(at + "expected a mass >= 0 kg, got " + Num(l.mass));
    }
    if (l.rotor_inertia < 0.0) {
      throw std::invalid_argument(at + "expected a rotor inertia >= 0, got " +
                                  Num(l.rotor_inertia) + "; hint: I_a = J_m * u^2");
    }
    if (l.gear_ratio == 0.0) {
      throw std::invalid_argument(at + "expected a nonzero gear ratio, got 0");
    }
    const double scale = std::max(1.0, l.inertia.cwiseAbs().maxCoeff());
    for (int r = 0; r < 3; ++r) {
      for (int c = r + 1; c < 3; ++c) {
        const double asym = std::fabs(l.inertia(r, c) - l.inertia(c, r));
        if (asym > 1e-9 * scale) {
          throw std::invalid_argument(
              at + "expected a symmetric inertia tensor, got I(" + std::to_string(r) + "," +
              std::to_string(c) + ") = " + Num(l.inertia(r, c)) + " but I(" + std::to_string(c) +
              "," + std::to_string(r) + ") = " + Num(l.inertia(c, r)));
        }
      }
    }
  }
}

std::string SerialChain::PhysicalConsistencyReport() const {
  std::ostringstream os;
  for (int i = 0; i < dof(); ++i) {
    const Eigen::Matrix3d ic = InertiaAboutCenterOfMass(LinkFrameParameters(i));
    const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(ic).eigenvalues();
    const double tol = 1e-9 * std::max(1.0, ev.cwiseAbs().maxCoeff());
    const bool psd = ev.minCoeff() >= -tol;
    const bool triangle = ev[0] + ev[1] >= ev[2] - tol;  // eigenvalues are sorted increasingly
    if (!psd || !triangle) {
      os << "link " << (i + 1) << ": inertia about the COM has eigenvalues (" << Num(ev[0]) << ", "
         << Num(ev[1]) << ", " << Num(ev[2]) << ")"
         << (!psd ? ", not positive semi-definite" : ", violates the triangle inequality") << "\n";
    }
  }
  return os.str();
}

}  // namespace graybox::models
