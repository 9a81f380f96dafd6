// Acceptance of the KUKA KR300 roblue model against the data set roblue simulated with it,
// elabee_robot_ftsd.mat (see ../shared/data/roblue_elabee/SOURCE.md): recorded motor torques u
// (15000 x 6, N m) and states y = [q, qd] (15000 x 12, rad and rad/s), sampled at dt = 0.004 s,
// stored as float32.
//
// Sample alignment (from roblue's closed-loop simulator, confirmed by the residuals below): y[k] is
// the state at t_k and u[k] is held constant (zero-order hold) over [t_k, t_{k+1}], so
//     y[k+1] = Phi_dt(y[k], u[k]),   Phi = one classical RK4 step of KukaForwardDynamics.
// From every sample s of a split (s = 0 .. N-151) a simulation runs 150 steps with the recorded
// u; the positions are compared, each joint normalised by std_j, the population standard
// deviation of q_j over the split (estimators/analysis/metrics.h). Two figures come out:
//   - the 150-step NRMS (seed 000 eq. 7: the mean over the steps k = 1..150)
//       NRMS_150 = sqrt( mean over s, k = 1..150, j of ((q_sim - q_rec)[s+k, j] / std_j)^2 );
//   - the NRMS at step 150 (step 150 alone)
//       sqrt( mean over s, j of ((q_sim - q_rec)[s+150, j] / std_j)^2 ).
// roblue's own "150-step NRMS" (roblue.py plot_n_step_nrms, the bestmodel_*_150_step_nrms
// column) is the NRMS at step 150 squared (no square root; (N-1)-normalised std; in its case 3
// the first and last stiction_pad starts dropped), not the mean over steps of eq. 7.
#include <matio.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "graybox/models/kuka_kr300.h"
#include "graybox/models/rigid_body_dynamics.h"
#include "test_util.h"

namespace graybox::models {
namespace {

constexpr double kDt = 0.004;  // [s]
constexpr int kNumSamples = 15000;
constexpr int kHorizon = 150;
// The acceptance threshold of the task: the model must reproduce the simulated data to within
// 1e-5 of the position spread over 150 steps, both as the 150-step NRMS (mean over the horizon)
// and at its end (NRMS at step 150). Measured: 2.6e-7 and 3.8e-7 (float32 storage floor;
// estimators' NStepNrmsSimulated gives the same 2.58871e-7 and 3.77338e-7).
constexpr double kAcceptanceNrms = 1e-5;
// One-step residual bounds. The data are float32: a value of magnitude ~1 is rounded by up to
// 6e-8, an RMS of ~2e-8. Measured with the roblue model: 1.35e-8 rad (q) and 7.1e-9 rad/s (qd).
constexpr double kOneStepRmsTol = 1e-7;
// A reading of the model that is NOT the generator's shows a one-step velocity residual at least
// this many times larger (measured: 3.5e3 for the centre-of-mass inertia reading, 2e5 to 3e6 for
// the others).
constexpr double kRejectionFactor = 100.0;

std::string DataPath() {
  return std::string(GRAYBOX_SHARED_DATA_DIR) + "/roblue_elabee/elabee_robot_ftsd.mat";
}

bool FileExists(const std::string& path) { return std::ifstream(path).good(); }

struct Split {
  Eigen::MatrixXd u;  // N x 6
  Eigen::MatrixXd y;  // N x 12
};

Eigen::MatrixXd ReadMatrix(mat_t* mat, const std::string& name, int rows, int cols) {
  std::unique_ptr<matvar_t, void (*)(matvar_t*)> var(Mat_VarRead(mat, name.c_str()), Mat_VarFree);
  if (!var) throw std::runtime_error("variable '" + name + "' not found in " + DataPath());
  if (var->rank != 2 || var->dims[0] != static_cast<size_t>(rows) ||
      var->dims[1] != static_cast<size_t>(cols)) {
    throw std::runtime_error("'" + name + "': expected " + std::to_string(rows) + "x" +
                             std::to_string(cols) + ", got " + std::to_string(var->dims[0]) + "x" +
                             std::to_string(var->dims[1]));
  }
  Eigen::MatrixXd m(rows, cols);  // MATLAB stores column-major, as Eigen does
  if (var->class_type == MAT_C_SINGLE && var->data_type == MAT_T_SINGLE) {
    const float* f = static_cast<const float*>(var->data);
    for (Eigen::Index k = 0; k < m.size(); ++k) m.data()[k] = f[k];
  } else if (var->class_type == MAT_C_DOUBLE && var->data_type == MAT_T_DOUBLE) {
    const double* d = static_cast<const double*>(var->data);
    for (Eigen::Index k = 0; k < m.size(); ++k) m.data()[k] = d[k];
  } else {
    throw std::runtime_error("'" + name + "': expected float32 or float64 data");
  }
  return m;
}

Split LoadSplit(const std::string& split) {
  std::unique_ptr<mat_t, int (*)(mat_t*)> mat(Mat_Open(DataPath().c_str(), MAT_ACC_RDONLY),
                                              Mat_Close);
  if (!mat) throw std::runtime_error("cannot open " + DataPath());
  return {ReadMatrix(mat.get(), "u_" + split, kNumSamples, 6),
          ReadMatrix(mat.get(), "y_" + split, kNumSamples, 12)};
}

const Split& TestSplit() {
  static const Split s = LoadSplit("test");
  return s;
}

using Vec = JointVector<double>;

// State at sample k of a split.
Vec Position(const Split& s, int k) { return s.y.row(k).head(6).transpose(); }
Vec Velocity(const Split& s, int k) { return s.y.row(k).tail(6).transpose(); }
Vec Torque(const Split& s, int k) { return s.u.row(k).transpose(); }

struct OneStepResidual {
  double q_rms = 0.0, qd_rms = 0.0;
};

enum class Integrator { kRk4, kExplicitEuler };

// RMS over all samples and joints of y[k+1] - Phi(y[k], u[k]).
OneStepResidual OneStep(const Split& s, const KukaKr300Model& model, Integrator integrator) {
  const auto accel = [&](const Vec& q, const Vec& qd, const Vec& tau) {
    return KukaForwardDynamics<double>(model, q, qd, tau);
  };
  double sq = 0.0, sv = 0.0;
  for (int k = 0; k + 1 < kNumSamples; ++k) {
    Vec q = Position(s, k), qd = Velocity(s, k);
    const Vec tau = Torque(s, k);
    if (integrator == Integrator::kRk4) {
      testing::Rk4Step([&](const Vec& x, const Vec& v) { return accel(x, v, tau); }, kDt, &q, &qd);
    } else {
      const Vec a = accel(q, qd, tau);
      q += kDt * qd;
      qd += kDt * a;
    }
    sq += (q - Position(s, k + 1)).squaredNorm();
    sv += (qd - Velocity(s, k + 1)).squaredNorm();
  }
  const double count = 6.0 * (kNumSamples - 1);
  return {std::sqrt(sq / count), std::sqrt(sv / count)};
}

class RoblueData : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!FileExists(DataPath())) GTEST_SKIP() << "data set not found: " << DataPath();
  }
};

TEST_F(RoblueData, SplitsHaveTheDocumentedLayout) {
  for (const char* split : {"training", "validation", "test"}) {
    const Split s = LoadSplit(split);
    EXPECT_TRUE(s.u.allFinite() && s.y.allFinite()) << split;
    // SOURCE.md: u in [-20.51, 12.78] N m and y in [-1.62, 2.05] over all splits.
    EXPECT_LT(s.u.cwiseAbs().maxCoeff(), 21.0) << split;
    EXPECT_LT(s.y.cwiseAbs().maxCoeff(), 2.1) << split;
  }
}

TEST_F(RoblueData, OneRk4StepPerSampleReproducesTheRecordedStates) {
  const OneStepResidual r = OneStep(TestSplit(), DefaultKukaKr300Model(), Integrator::kRk4);
  std::cout << "[ one step ] RK4, roblue model: RMS residual q " << r.q_rms << " rad, qd "
            << r.qd_rms << " rad/s\n";
  EXPECT_LT(r.q_rms, kOneStepRmsTol);
  EXPECT_LT(r.qd_rms, kOneStepRmsTol);
}

// Each alternative reading of the model (or integrator) leaves a residual far above the float32
// floor: the data pin down the conventions documented in kuka_kr300.h.
TEST_F(RoblueData, AlternativeConventionsAreRejected) {
  const Split& s = TestSplit();
  const double reference = OneStep(s, DefaultKukaKr300Model(), Integrator::kRk4).qd_rms;
  struct Alternative {
    std::string name;
    KukaKr300Model model;
    Integrator integrator;
  };
  std::vector<Alternative> alternatives;
  {
    KukaKr300Model m = KukaKr300RoblueModel();
    m.chain = KukaKr300R2500(150.0, InertiaReference::kCenterOfMass);
    alternatives.push_back({"inertia about the COM", m, Integrator::kRk4});
  }
  {
    KukaKr300Model m = KukaKr300RoblueModel();
    m.friction_enabled = false;
    alternatives.push_back({"no friction", m, Integrator::kRk4});
  }
  {
    KukaKr300Model m = KukaKr300RoblueModel();
    m.hwc_enabled = false;
    alternatives.push_back({"no counterbalance", m, Integrator::kRk4});
  }
  alternatives.push_back({"payload 200 kg", KukaKr300RoblueModel(200.0), Integrator::kRk4});
  alternatives.push_back({"explicit Euler", KukaKr300RoblueModel(), Integrator::kExplicitEuler});
  for (const Alternative& a : alternatives) {
    const OneStepResidual r = OneStep(s, a.model, a.integrator);
    std::cout << "[ one step ] " << a.name << ": RMS residual qd " << r.qd_rms << " rad/s ("
              << r.qd_rms / reference << " x the roblue model)\n";
    EXPECT_GT(r.qd_rms, kRejectionFactor * reference) << a.name;
  }
}

TEST_F(RoblueData, HundredFiftyStepNrmsAndNrmsAtStep150OnTheTestSplit) {
  const Split& s = TestSplit();
  const KukaKr300Model& model = DefaultKukaKr300Model();
  Eigen::VectorXd sd(6);
  for (int j = 0; j < 6; ++j) {
    const Eigen::ArrayXd c = s.y.col(j).array();
    sd[j] = std::sqrt((c - c.mean()).square().mean());  // population, as metrics.h
  }
  double sum_sq_all_steps = 0.0, sum_sq_at_step_n = 0.0, max_abs = 0.0;
  int starts = 0;
  for (int start = 0; start + kHorizon < kNumSamples; ++start) {
    Vec q = Position(s, start), qd = Velocity(s, start);
    for (int k = start; k < start + kHorizon; ++k) {
      const Vec tau = Torque(s, k);
      testing::Rk4Step(
          [&](const Vec& x, const Vec& v) { return KukaForwardDynamics<double>(model, x, v, tau); },
          kDt, &q, &qd);
      const Eigen::VectorXd e = (q - Position(s, k + 1)).cwiseQuotient(sd);
      sum_sq_all_steps += e.squaredNorm();
      max_abs = std::max(max_abs, e.cwiseAbs().maxCoeff());
      if (k + 1 == start + kHorizon) sum_sq_at_step_n += e.squaredNorm();
    }
    ++starts;
  }
  const double n_step_nrms = std::sqrt(sum_sq_all_steps / (6.0 * kHorizon * starts));
  const double mean_sq_at_step_n = sum_sq_at_step_n / (6.0 * starts);
  const double nrms_at_step_n = std::sqrt(mean_sq_at_step_n);
  std::cout << "[ nrms     ] test split, " << starts << " starts: 150-step NRMS " << n_step_nrms
            << ", NRMS at step 150 " << nrms_at_step_n
            << " (squared, roblue's number: " << mean_sq_at_step_n << "; worst normalised error "
            << max_abs << ")\n";
  EXPECT_LT(n_step_nrms, kAcceptanceNrms);
  EXPECT_LT(nrms_at_step_n, kAcceptanceNrms);
}

}  // namespace
}  // namespace graybox::models
