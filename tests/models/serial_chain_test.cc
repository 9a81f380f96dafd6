// Tests of the SerialChain description: validation messages, the two inertia reference points,
// and the change of frame of body parameters.
#include "graybox/models/serial_chain.h"

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "graybox/models/body_parameters.h"
#include "graybox/models/kuka_kr300.h"
#include "graybox/models/rigid_body_dynamics.h"
#include "test_util.h"

namespace graybox::models {
namespace {

using testing::RandomVector;
using testing::TestSeed;

// Parameter conversions are a handful of flops on O(1) numbers.
constexpr double kConversionTol = 1e-12;

Link SimpleLink() {
  Link l;
  l.a = 0.5;
  l.mass = 2.0;
  l.center_of_mass = Eigen::Vector3d(-0.25, 0.0, 0.0);
  l.inertia = Eigen::Vector3d(0.01, 0.05, 0.05).asDiagonal();
  return l;
}

// Expects the constructor to throw std::invalid_argument whose message contains every fragment.
void ExpectInvalid(const std::vector<Link>& links, const std::vector<std::string>& fragments,
                   const Eigen::Vector3d& gravity = Eigen::Vector3d(0.0, 0.0, -9.81)) {
  try {
    SerialChain chain("test", DhConvention::kStandard, links, gravity);
    ADD_FAILURE() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    for (const std::string& f : fragments) {
      EXPECT_NE(what.find(f), std::string::npos) << "'" << f << "' not in: " << what;
    }
  }
}

TEST(SerialChain, ValidateRejectsBadInput) {
  ExpectInvalid({}, {"SerialChain 'test'", "expected 1 to 8 links, got 0"});
  ExpectInvalid(std::vector<Link>(kMaxDof + 1, SimpleLink()), {"expected 1 to 8 links, got 9"});

  std::vector<Link> links(3, SimpleLink());
  links[1].mass = -1.0;
  ExpectInvalid(links, {"link 2", "expected a mass >= 0 kg, got -1"});

  links = std::vector<Link>(3, SimpleLink());
  links[2].inertia(0, 1) = 0.003;
  ExpectInvalid(links, {"link 3", "expected a symmetric inertia tensor", "I(0,1) = 0.003"});

  links = std::vector<Link>(3, SimpleLink());
  links[0].rotor_inertia = -0.1;
  ExpectInvalid(links, {"link 1", "expected a rotor inertia >= 0, got -0.1"});

  links = std::vector<Link>(3, SimpleLink());
  links[0].gear_ratio = 0.0;
  ExpectInvalid(links, {"expected a nonzero gear ratio, got 0"});

  links = std::vector<Link>(3, SimpleLink());
  links[1].alpha = std::nan("");
  ExpectInvalid(links, {"link 2", "expected a finite alpha, got nan"});

  ExpectInvalid(std::vector<Link>(2, SimpleLink()), {"expected a finite gravity vector"},
                Eigen::Vector3d(0.0, 0.0, INFINITY));

  EXPECT_THROW(KukaKr300R2500(-1.0), std::invalid_argument);

  // A valid chain validates again without throwing.
  const SerialChain ok("ok", DhConvention::kModified, std::vector<Link>(3, SimpleLink()),
                       Eigen::Vector3d(0.0, 0.0, -9.81));
  EXPECT_NO_THROW(ok.Validate());
  EXPECT_EQ(ok.dof(), 3);
}

TEST(BodyParameters, CenterOfMassAndOriginReferencesDescribeTheSameBody) {
  std::mt19937 rng(TestSeed());
  const SerialChain com_chain = testing::RandomChain(rng, 5, DhConvention::kStandard, 2);
  // The same chain with every tensor given about the link-frame origin.
  std::vector<Link> links = com_chain.links();
  for (Link& l : links) {
    l.inertia = l.inertia + l.mass * (l.center_of_mass.squaredNorm() * Eigen::Matrix3d::Identity() -
                                      l.center_of_mass * l.center_of_mass.transpose());
    l.inertia_reference = InertiaReference::kLinkOrigin;
  }
  const SerialChain origin_chain("origin", DhConvention::kStandard, links, com_chain.gravity());
  for (int i = 0; i < 5; ++i) {
    EXPECT_LT((com_chain.body(i).inertia - origin_chain.body(i).inertia).cwiseAbs().maxCoeff(),
              kConversionTol);
    EXPECT_LT(
        (com_chain.body(i).first_moment - origin_chain.body(i).first_moment).cwiseAbs().maxCoeff(),
        kConversionTol);
  }
  const Eigen::VectorXd q = RandomVector(rng, 5, -3, 3), qd = RandomVector(rng, 5, -2, 2);
  const Eigen::VectorXd qdd = RandomVector(rng, 5, -5, 5);
  EXPECT_LT((InverseDynamics<double>(com_chain, q, qd, qdd) -
             InverseDynamics<double>(origin_chain, q, qd, qdd))
                .cwiseAbs()
                .maxCoeff(),
            kConversionTol * 100.0);
  EXPECT_EQ(com_chain.PhysicalConsistencyReport(), "");
  EXPECT_EQ(origin_chain.PhysicalConsistencyReport(), "");
}

TEST(BodyParameters, ChangeOfFrameRoundTripsAndMatchesPointMasses) {
  std::mt19937 rng(TestSeed());
  // A body made of point masses: parameters computed directly in {P} must equal the parameters
  // computed in {B} and transformed.
  const Eigen::Matrix3d r = testing::RandomRotation(rng);
  const Eigen::Vector3d p = RandomVector(rng, 3, -1, 1);
  BodyParameters<double> in_b, in_p_direct;
  in_b.mass = in_p_direct.mass = 0.0;
  in_b.first_moment.setZero();
  in_p_direct.first_moment.setZero();
  in_b.inertia.setZero();
  in_p_direct.inertia.setZero();
  for (int k = 0; k < 4; ++k) {
    const double m = testing::Uniform(rng, 0.5, 2.0);
    const Eigen::Vector3d x = RandomVector(rng, 3, -1, 1);
    const Eigen::Vector3d y = r * x + p;
    in_b.mass += m;
    in_p_direct.mass += m;
    in_b.first_moment += m * x;
    in_p_direct.first_moment += m * y;
    in_b.inertia += m * (x.squaredNorm() * Eigen::Matrix3d::Identity() - x * x.transpose());
    in_p_direct.inertia += m * (y.squaredNorm() * Eigen::Matrix3d::Identity() - y * y.transpose());
  }
  const BodyParameters<double> in_p = TransformBodyParameters(r, Vector3<double>(p), in_b);
  EXPECT_LT((in_p.inertia - in_p_direct.inertia).cwiseAbs().maxCoeff(), kConversionTol);
  EXPECT_LT((in_p.first_moment - in_p_direct.first_moment).cwiseAbs().maxCoeff(), kConversionTol);
  // Inverse transform: rotation R^T, origin -R^T p.
  const BodyParameters<double> back = TransformBodyParameters(
      Matrix3<double>(r.transpose()), Vector3<double>(-r.transpose() * p), in_p);
  EXPECT_LT((back.inertia - in_b.inertia).cwiseAbs().maxCoeff(), kConversionTol);
  EXPECT_LT((back.first_moment - in_b.first_moment).cwiseAbs().maxCoeff(), kConversionTol);
}

// The KUKA CAD tensors read about the link origin (roblue's reading) are not physically consistent;
// read about the centre of mass they are. This documents the finding of kuka_kr300.h.
TEST(SerialChain, KukaInertiaReadingsPhysicalConsistency) {
  const std::string origin_report =
      KukaKr300R2500(150.0, InertiaReference::kLinkOrigin).PhysicalConsistencyReport();
  std::cout << "[ report   ] origin reading:\n" << origin_report;
  EXPECT_NE(origin_report.find("link 1"), std::string::npos);
  EXPECT_NE(origin_report.find("link 2"), std::string::npos);
  EXPECT_EQ(KukaKr300R2500(150.0, InertiaReference::kCenterOfMass).PhysicalConsistencyReport(), "");
}

}  // namespace
}  // namespace graybox::models
