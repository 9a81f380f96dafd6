#include "graybox/models/regressor.h"

namespace graybox::models {

namespace {

constexpr const char* kLocalNames[kRigidBodyParametersPerLink + 1] = {
    "m", "mcx", "mcy", "mcz", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz", "Ia"};
constexpr const char* kUnits[kRigidBodyParametersPerLink + 1] = {
    "kg",     "kg m",   "kg m",   "kg m",   "kg m^2", "kg m^2",
    "kg m^2", "kg m^2", "kg m^2", "kg m^2", "kg m^2"};

}  // namespace

std::vector<std::string> InertialParameterNames(const SerialChain& chain,
                                                InertialParameterSet set) {
  std::vector<std::string> names;
  for (int i = 0; i < chain.dof(); ++i) {
    for (int k = 0; k < ParametersPerLink(set); ++k) {
      names.push_back("l" + std::to_string(i + 1) + "." + kLocalNames[k]);
    }
  }
  return names;
}

std::vector<std::string> InertialParameterUnits(const SerialChain& chain,
                                                InertialParameterSet set) {
  std::vector<std::string> units;
  for (int i = 0; i < chain.dof(); ++i) {
    for (int k = 0; k < ParametersPerLink(set); ++k) {
      const bool prismatic_rotor =
          k == kRotorInertia && chain.link(i).joint_type == JointType::kPrismatic;
      units.push_back(prismatic_rotor ? "kg" : kUnits[k]);
    }
  }
  return units;
}

Eigen::VectorXd InertialParameters(const SerialChain& chain, InertialParameterSet set) {
  const int per_link = ParametersPerLink(set);
  Eigen::VectorXd theta(NumInertialParameters(chain, set));
  for (int i = 0; i < chain.dof(); ++i) {
    const BodyParameters<double> b = chain.LinkFrameParameters(i);
    double* t = theta.data() + static_cast<std::ptrdiff_t>(i) * per_link;
    t[kMass] = b.mass;
    for (int k = 0; k < 3; ++k) t[kFirstMomentX + k] = b.first_moment[k];
    t[kInertiaXX] = b.inertia(0, 0);
    t[kInertiaXY] = b.inertia(0, 1);
    t[kInertiaXZ] = b.inertia(0, 2);
    t[kInertiaYY] = b.inertia(1, 1);
    t[kInertiaYZ] = b.inertia(1, 2);
    t[kInertiaZZ] = b.inertia(2, 2);
    if (set == InertialParameterSet::kWithRotorInertia) t[kRotorInertia] = b.rotor_inertia;
  }
  return theta;
}

}  // namespace graybox::models
