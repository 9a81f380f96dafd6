#include "graybox/models/kuka_kr300.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace graybox::models {

namespace {

// Inertia tensor from the table order of SOURCE.md (Lxx, Lyy, Lzz, Lxy, Lyz, Lxz).
Eigen::Matrix3d Tensor(double xx, double yy, double zz, double xy, double yz, double xz) {
  Eigen::Matrix3d t;
  t << xx, xy, xz, xy, yy, yz, xz, yz, zz;
  return t;
}

}  // namespace

SerialChain KukaKr300R2500(double payload_kg, InertiaReference cad_inertia_reference) {
  if (!(payload_kg >= 0.0) || !std::isfinite(payload_kg)) {
    throw std::invalid_argument("KukaKr300R2500: expected a payload >= 0 kg, got " +
                                std::to_string(payload_kg));
  }
  constexpr double kPi = kKukaPi;
  // Standard DH rows (alpha, a, d, theta constant part); the joint offsets q_global - q are added
  // to theta so the chain's variable is roblue's q.
  const double alpha[kKukaDof] = {kPi / 2, 0.0, -kPi / 2, kPi / 2, -kPi / 2, kPi};
  const double a[kKukaDof] = {0.35, 1.15, 0.041, 0.0, 0.0, 0.0};
  const double d[kKukaDof] = {-0.675, -0.189, 0.189, -1.0, 0.0, -0.24};
  const double theta_dh[kKukaDof] = {0.0, 0.0, kPi / 2, 0.0, 0.0, 0.0};

  // Link 6: axis-6 mass at -50 mm and the payload at +100 mm along z6.
  constexpr double kAxis6Mass = 17.78;  // [kg]
  const double m6 = payload_kg + kAxis6Mass;
  const double r6_z = (payload_kg * 100.0 + kAxis6Mass * -50.0) / m6 * 1e-3;  // [m]

  const double mass[kKukaDof] = {395.40, 339.12, 105.21, 35.80, 31.46, m6};
  const Eigen::Vector3d com[kKukaDof] = {{-0.353, 0.174, -0.004},  {-0.709, -0.001, 0.023},
                                         {-0.018, -0.018, -0.076}, {0.0, 0.236, 0.001},
                                         {0.0, -0.080, -0.009},    {0.0, 0.0, r6_z}};
  const Eigen::Matrix3d inertia[kKukaDof] = {
      Tensor(16.733765, 29.799119, 32.814954, -1.703664, 0.129384, 4.404062),
      Tensor(7.507819, 88.886691, 88.673761, 0.430046, 0.173157, -4.396607),
      Tensor(10.783798, 10.186135, 1.943179, 0.118474, -0.606384, -0.101950),
      Tensor(0.425035, 0.217993, 0.428465, -4e-6, -0.011353, -27e-6),
      Tensor(0.283826, 0.229562, 0.258266, -4e-6, -0.019521, -120e-6),
      Eigen::Matrix3d::Zero()};

  std::vector<Link> links(kKukaDof);
  for (int i = 0; i < kKukaDof; ++i) {
    const auto k = static_cast<std::size_t>(i);
    Link& l = links[k];
    l.joint_type = JointType::kRevolute;
    l.alpha = alpha[i];
    l.a = a[i];
    l.d = d[i];
    l.theta = theta_dh[i] + kKukaJointOffsets[k];
    l.mass = mass[i];
    l.center_of_mass = com[i];
    l.inertia = inertia[i];
    l.inertia_reference = cad_inertia_reference;
    l.gear_ratio = kKukaGearRatios[k];
    l.rotor_inertia = ReflectedRotorInertia(kKukaMotorInertias[k], kKukaGearRatios[k]);
  }
  return SerialChain("KUKA KR300 R2500", DhConvention::kStandard, std::move(links),
                     Eigen::Vector3d(0.0, 0.0, 9.81));
}

KukaFrictionParameters KukaRoblueFriction() {
  KukaFrictionParameters p;
  p.f_vis = {5000.0, 5000.0, 5000.0, 1000.0, 1000.0, 1000.0};
  p.f_coul = {45.3125, 119.5625, 107.1875, 193.8125, 8.1875, 156.6875};
  p.f_asym = {14.0625, -21.875, -3.125, -40.625, -3.125, -46.875};
  p.tanh_sharpness = 1.0;
  return p;
}

KukaKr300Model KukaKr300RoblueModel(double payload_kg) {
  return KukaKr300Model{KukaKr300R2500(payload_kg, InertiaReference::kLinkOrigin),
                        KukaRoblueFriction(), true, true};
}

const KukaKr300Model& DefaultKukaKr300Model() {
  static const KukaKr300Model model = KukaKr300RoblueModel(150.0);
  return model;
}

}  // namespace graybox::models
