// Data access: Experiment/Dataset validation and splitting, the .mat reader (the real files in
// ../shared/data, read in place, and v5 / v7.3 round trips written to a temporary directory) and
// the CSV reader (the geared DC motor and pneumatic muscle arm recordings, malformed input).
//
// The facts asserted on the shared data come from the SOURCE.md next to each file and were
// re-measured here; where the two differ the test says so.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "graybox/estimators/data/csv_file.h"
#include "graybox/estimators/data/dataset.h"
#include "graybox/estimators/data/mat_file.h"

namespace graybox::estimators {
namespace {

// Time stamps in the EMPS files are stored rounded: consecutive differences deviate from 1 ms by
// up to 3.2e-8 s (measured), so sample spacing is compared to this bound.
constexpr double kEmpsTimeStampTolerance = 1e-7;
// The DC motor CSV stores time with 8-9 significant digits (0.039999999): spacing deviates from
// 0.02 s by up to 1.96e-5 s (measured).
constexpr double kCsvTimeRounding = 5e-5;
// Printed values in SOURCE.md are rounded to the digits shown; compare at half a unit of the
// last digit (plus rounding of the stored double).
constexpr double kTwoDecimals = 0.005 + 1e-12;

std::string DataDir() { return std::string(GRAYBOX_SHARED_DATA_DIR); }

bool HaveData(const std::string& relative) {
  return std::filesystem::exists(DataDir() + "/" + relative);
}

#define REQUIRE_DATA(relative)                                                   \
  do {                                                                           \
    if (!HaveData(relative))                                                     \
      GTEST_SKIP() << "shared data missing: " << DataDir() << "/" << (relative); \
  } while (0)

// A fresh directory under the system temporary directory, removed with its content at the end.
class TempDir {
 public:
  TempDir() {
    const std::filesystem::path base = std::filesystem::temp_directory_path();
    for (int attempt = 0; attempt < 100 && path_.empty(); ++attempt) {
      const std::filesystem::path p = base / ("graybox_data_test_" + std::to_string(::getpid()) +
                                              "_" + std::to_string(attempt));
      if (std::filesystem::create_directory(p)) path_ = p.string();
    }
  }
  ~TempDir() {
    std::error_code ec;
    if (!path_.empty()) std::filesystem::remove_all(path_, ec);
  }
  std::string File(const std::string& name) const { return path_ + "/" + name; }
  bool ok() const { return !path_.empty(); }

 private:
  std::string path_;
};

// Runs `f` and returns the std::invalid_argument message ("" when nothing was thrown).
template <typename F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

#define EXPECT_CONTAINS(text, piece) \
  EXPECT_NE(std::string(text).find(piece), std::string::npos) << "text: " << (text)

// ---- Experiment / Dataset --------------------------------------------------------------------

Experiment SmallExperiment() {
  Experiment e;
  e.name = "small";
  e.dt = 0.01;
  e.u = Eigen::MatrixXd::Zero(10, 1);
  e.y = Eigen::MatrixXd::Zero(10, 2);
  for (int k = 0; k < 10; ++k) {
    e.u(k, 0) = k;
    e.y(k, 0) = 2.0 * k;
    e.y(k, 1) = -k;
  }
  e.u_names = {"voltage"};
  e.u_units = {"V"};
  e.y_names = {"position", "velocity"};
  e.y_units = {"m", "m/s"};
  return e;
}

TEST(ExperimentTest, ValidExperimentPassesAndReportsTime) {
  const Experiment e = SmallExperiment();
  EXPECT_NO_THROW(e.Validate());
  EXPECT_EQ(e.NumSamples(), 10);
  EXPECT_EQ(e.NumInputs(), 1);
  EXPECT_EQ(e.NumOutputs(), 2);
  EXPECT_FALSE(e.HasStates());
  EXPECT_DOUBLE_EQ(e.SampleTime(), 0.01);
  EXPECT_DOUBLE_EQ(e.Time()(9), 0.09);
  EXPECT_EQ(e.ChannelName(ChannelGroup::kOutput, 1), "velocity");
  EXPECT_EQ(e.ChannelUnit(ChannelGroup::kOutput, 1), "m/s");
  EXPECT_EQ(e.ChannelIndex(ChannelGroup::kOutput, "velocity"), 1);
  EXPECT_CONTAINS(ErrorOf([&] { e.ChannelIndex(ChannelGroup::kOutput, "velocty"); }),
                  "did you mean 'velocity'?");
}

TEST(ExperimentTest, NanIsReportedWithChannelAndSample) {
  Experiment e = SmallExperiment();
  e.y(7, 1) = std::numeric_limits<double>::quiet_NaN();
  const std::string message = ErrorOf([&] { e.Validate(); });
  EXPECT_CONTAINS(message, "experiment 'small'");
  EXPECT_CONTAINS(message, "output 'velocity' (column 1) sample 7");
  EXPECT_CONTAINS(message, "t = 0.07 s");
  EXPECT_CONTAINS(message, "expected a finite value, got nan");

  Experiment f = SmallExperiment();
  f.u(3, 0) = -std::numeric_limits<double>::infinity();
  EXPECT_CONTAINS(ErrorOf([&] { f.Validate(); }), "input 'voltage' (column 0) sample 3");
}

TEST(ExperimentTest, TimeVectorMustIncreaseStrictly) {
  Experiment e = SmallExperiment();
  e.dt = 0.0;
  e.time = Eigen::VectorXd::LinSpaced(10, 0.0, 0.9);
  EXPECT_NO_THROW(e.Validate());
  EXPECT_NEAR(e.SampleTime(), 0.1, 1e-15);
  e.time(5) = e.time(4);
  const std::string message = ErrorOf([&] { e.Validate(); });
  EXPECT_CONTAINS(message, "time[5]");
  EXPECT_CONTAINS(message, "expected strictly increasing time");

  Experiment both = SmallExperiment();
  both.time = Eigen::VectorXd::LinSpaced(10, 0.0, 0.9);
  EXPECT_CONTAINS(ErrorOf([&] { both.Validate(); }), "got both");

  Experiment neither = SmallExperiment();
  neither.dt = 0.0;
  EXPECT_CONTAINS(ErrorOf([&] { neither.Validate(); }), "expected a sample time dt > 0 s");

  Experiment short_time = SmallExperiment();
  short_time.dt = 0.0;
  short_time.time = Eigen::VectorXd::LinSpaced(9, 0.0, 0.8);
  EXPECT_CONTAINS(ErrorOf([&] { short_time.Validate(); }), "time has 9 entries: expected 10");
}

TEST(ExperimentTest, LengthAndLabelMismatchesAreRejected) {
  Experiment rows = SmallExperiment();
  rows.u = Eigen::MatrixXd::Zero(9, 1);
  EXPECT_CONTAINS(ErrorOf([&] { rows.Validate(); }), "u has 9 rows: expected 10");

  Experiment names = SmallExperiment();
  names.y_names = {"position"};
  EXPECT_CONTAINS(ErrorOf([&] { names.Validate(); }), "y_names: expected 2 entries");

  Experiment dx_only = SmallExperiment();
  dx_only.dx = Eigen::MatrixXd::Zero(10, 2);
  EXPECT_CONTAINS(ErrorOf([&] { dx_only.Validate(); }), "dx is given without x");

  Experiment dx_cols = SmallExperiment();
  dx_cols.x = Eigen::MatrixXd::Zero(10, 2);
  dx_cols.dx = Eigen::MatrixXd::Zero(10, 3);
  EXPECT_CONTAINS(ErrorOf([&] { dx_cols.Validate(); }), "dx has 3 columns: expected 2");

  Experiment empty;
  empty.name = "empty";
  empty.dt = 1.0;
  EXPECT_CONTAINS(ErrorOf([&] { empty.Validate(); }), "expected at least 1 sample, got 0");
}

TEST(ExperimentTest, SliceAndSplit) {
  const Experiment e = SmallExperiment();
  const Experiment s = Slice(e, 3, 7);
  EXPECT_EQ(s.NumSamples(), 4);
  EXPECT_DOUBLE_EQ(s.t0, 0.03);
  EXPECT_DOUBLE_EQ(s.y(0, 0), 6.0);
  EXPECT_EQ(s.name, "small[3:7]");
  EXPECT_EQ(s.y_names, e.y_names);
  EXPECT_NO_THROW(s.Validate());
  EXPECT_CONTAINS(ErrorOf([&] { Slice(e, 5, 11); }),
                  "expected 0 <= begin < end <= 10, got [5, 11)");
  EXPECT_CONTAINS(ErrorOf([&] { Slice(e, 5, 5); }), "got [5, 5)");

  const Dataset d = Split(e, {{"train", 0, 6}, {"test", 7, 10}});
  ASSERT_EQ(d.NumExperiments(), 2);
  EXPECT_EQ(d.NumSamples(), 9);
  EXPECT_EQ(d.Find("test").NumSamples(), 3);
  EXPECT_DOUBLE_EQ(d.Find("test").u(0, 0), 7.0);
  EXPECT_NO_THROW(d.Validate());
  EXPECT_CONTAINS(ErrorOf([&] { d.Find("tset"); }), "did you mean 'test'?");

  const std::string overlap = ErrorOf([&] { Split(e, {{"a", 0, 6}, {"b", 5, 10}}); });
  EXPECT_CONTAINS(overlap, "range 'b' [5, 10) overlaps range 'a' [0, 6)");
  EXPECT_CONTAINS(ErrorOf([&] { Split(e, {{"a", 0, 3}, {"a", 3, 6}}); }), "used twice");
  EXPECT_CONTAINS(ErrorOf([&] { Split(e, {{"a", 0, 30}}); }), "range 'a'");
}

TEST(DatasetTest, ChannelCountsMustAgree) {
  Dataset d;
  d.name = "rig";
  d.experiments = {SmallExperiment(), SmallExperiment()};
  d.experiments[1].name = "other";
  d.experiments[1].y = Eigen::MatrixXd::Zero(10, 1);
  d.experiments[1].y_names.clear();
  d.experiments[1].y_units.clear();
  const std::string message = ErrorOf([&] { d.Validate(); });
  EXPECT_CONTAINS(message, "experiment 'other' has (nu, ny, nx) = (1, 1, 0): expected (1, 2, 0)");
  EXPECT_CONTAINS(ErrorOf([] { Dataset().Validate(); }), "expected at least 1 experiment");
}

// ---- .mat files: the shared data -------------------------------------------------------------

TEST(MatFileDataTest, EmpsVariablesSizesAndConstants) {
  REQUIRE_DATA("emps/DATA_EMPS.mat");
  for (const std::string file : {"DATA_EMPS.mat", "DATA_EMPS_PULSES.mat"}) {
    SCOPED_TRACE(file);
    const MatFile mat(DataDir() + "/emps/" + file);
    EXPECT_EQ(mat.version(), MatVersion::kV5);
    std::vector<std::string> expected = {"gtau", "kp", "kv", "qg", "qm", "t", "vir"};
    if (file == "DATA_EMPS_PULSES.mat") expected.insert(expected.begin() + 3, "pulses_N");
    EXPECT_EQ(mat.VariableNames(), expected);
    // SOURCE.md: 24841 samples, t = 0 .. 24.84 s, dt = 0.001 s.
    for (const char* name : {"t", "qm", "qg", "vir"}) {
      const Eigen::MatrixXd v = mat.ReadMatrix(name);
      EXPECT_EQ(v.rows(), 24841) << name;
      EXPECT_EQ(v.cols(), 1) << name;
    }
    const Eigen::VectorXd t = mat.ReadMatrix("t");
    EXPECT_EQ(t(0), 0.0);
    EXPECT_NEAR(t(t.size() - 1), 24.84, 1e-9);
    const Eigen::VectorXd spacing = t.tail(t.size() - 1) - t.head(t.size() - 1);
    EXPECT_LT((spacing.array() - 1e-3).abs().maxCoeff(), kEmpsTimeStampTolerance);
    // Controller constants (SOURCE.md: gtau = 35.15065188248547, kp = 160.18, kv = 243.45).
    EXPECT_DOUBLE_EQ(mat.ReadScalar("gtau"), 35.15065188248547);
    EXPECT_NEAR(mat.ReadScalar("kp"), 160.18, kTwoDecimals);
    EXPECT_NEAR(mat.ReadScalar("kv"), 243.45, kTwoDecimals);
    // Position range: SOURCE.md gives -2.2e-5 .. 0.24638 m (train) and -2.09e-5 .. 0.24651 m.
    const Eigen::VectorXd qm = mat.ReadMatrix("qm");
    const double qm_max = file == "DATA_EMPS.mat" ? 0.24638 : 0.24651;
    EXPECT_NEAR(qm.maxCoeff(), qm_max, 5e-6);
    EXPECT_LT(qm.minCoeff(), 0.0);
    EXPECT_GT(qm.minCoeff(), -2.3e-5);
  }
  // The pulses: 0 .. 5 N, only in the validation file. SOURCE.md calls the variable uint8 (the
  // storage type scipy reports); its MATLAB class is double, which is what matio returns.
  const MatFile pulses(DataDir() + "/emps/DATA_EMPS_PULSES.mat");
  EXPECT_EQ(pulses.Info("pulses_N").class_name, "double");
  const Eigen::VectorXd p = pulses.ReadMatrix("pulses_N");
  EXPECT_EQ(p.minCoeff(), 0.0);
  EXPECT_EQ(p.maxCoeff(), 5.0);
}

TEST(MatFileDataTest, EmpsAsExperimentAndSplit) {
  REQUIRE_DATA("emps/DATA_EMPS.mat");
  const MatFile mat(DataDir() + "/emps/DATA_EMPS.mat");
  Experiment e;
  e.name = "emps_train";
  e.dt = 1e-3;
  e.u = mat.ReadMatrix("vir");
  e.y = mat.ReadMatrix("qm");
  e.u_names = {"vir"};
  e.u_units = {"V"};
  e.y_names = {"qm"};
  e.y_units = {"m"};
  EXPECT_NO_THROW(e.Validate());
  // The recorded time vector (not exactly uniform) is accepted as well.
  Experiment timed = e;
  timed.dt = 0.0;
  timed.time = mat.ReadMatrix("t");
  EXPECT_NO_THROW(timed.Validate());
  EXPECT_NEAR(timed.SampleTime(), 1e-3, 1e-12);

  const Dataset parts = Split(e, {{"fit", 0, 20000}, {"check", 20000, 24841}});
  EXPECT_EQ(parts.Find("fit").NumSamples(), 20000);
  EXPECT_EQ(parts.Find("check").NumSamples(), 4841);
  EXPECT_DOUBLE_EQ(parts.Find("check").t0, 20.0);
  EXPECT_EQ(parts.Find("check").y(0, 0), e.y(20000, 0));
}

TEST(MatFileDataTest, KukaIrosRecordStructFields) {
  REQUIRE_DATA("kuka_kr300_iros2021/rec_2020-10-21_10s_FF_A_08ms.mat");
  const std::vector<std::string> fields = {"time_cont",
                                           "time_disc",
                                           "act_pos_se_deg",
                                           "act_pos_mot_deg",
                                           "act_vel_se_deg_per_s",
                                           "act_vel_mot_deg_per_s",
                                           "act_torque_abs_nm",
                                           "act_torque_rel_nm",
                                           "ref_pos_deg",
                                           "ref_vel_simple_deg_per_s",
                                           "error_pos_deg",
                                           "error_vel_deg_per_s"};
  const std::vector<std::pair<std::string, std::string>> files = {
      {"A", "d3d4boundandzero_F2_v16_grids20_T10_ts50"},
      {"B", "d3d4boundandzero_F2_v17_grids20_T10_ts120"},
      {"C", "d3d4bound_d3zero_F2_vest_grids20_T10_ts60"}};
  for (const auto& [letter, trajectory] : files) {
    SCOPED_TRACE(letter);
    const MatFile mat(DataDir() + "/kuka_kr300_iros2021/rec_2020-10-21_10s_FF_" + letter +
                      "_08ms.mat");
    // The opaque __function_workspace__ entry is not listed.
    for (const std::string& name : mat.VariableNames()) EXPECT_FALSE(name.empty());
    EXPECT_EQ(mat.VariableNames().size(), 19u);
    const MatVariableInfo rec = mat.Info("rec");
    EXPECT_EQ(rec.class_name, "struct");
    EXPECT_EQ(rec.fields, fields);
    for (const std::string& field : fields) {
      const Eigen::MatrixXd m = mat.ReadMatrix("rec." + field);
      const bool is_time = field == "time_cont" || field == "time_disc";
      EXPECT_EQ(m.rows(), is_time ? 1 : 6) << field;
      EXPECT_EQ(m.cols(), 2501) << field;
    }
    // 2501 samples at dt = 0.004 s over 0 .. 10 s (time_cont ends at 9.99999975: float-rounded).
    EXPECT_DOUBLE_EQ(mat.ReadScalar("time_data.dt"), 0.004);
    EXPECT_EQ(mat.ReadScalar("time_data.nt"), 2501.0);
    const Eigen::RowVectorXd time = mat.ReadMatrix("rec.time_cont");
    EXPECT_EQ(time(0), 0.0);
    EXPECT_NEAR(time(2500), 9.99999975, 1e-8);
    const Eigen::RowVectorXd index = mat.ReadMatrix("rec.time_disc");
    EXPECT_EQ(index(0), 1.0);
    EXPECT_EQ(index(2500), 2501.0);
    // Axes 4-6 have no secondary encoder; the velocity-error field is all zeros.
    const Eigen::MatrixXd se = mat.ReadMatrix("rec.act_pos_se_deg");
    EXPECT_EQ(se.bottomRows(3).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_GT(se.topRows(3).cwiseAbs().maxCoeff(), 1.0);
    EXPECT_EQ(mat.ReadMatrix("rec.error_vel_deg_per_s").cwiseAbs().maxCoeff(), 0.0);
    // Motor-side minus secondary position on axes 1-3 stays within about +-0.2 deg (SOURCE.md).
    const Eigen::MatrixXd deflection =
        mat.ReadMatrix("rec.act_pos_mot_deg").topRows(3) - se.topRows(3);
    EXPECT_LT(deflection.cwiseAbs().maxCoeff(), 0.22);
    // SOURCE.md says the absolute and relative torques are identical; measured, they differ by a
    // constant offset per axis (A: 0.39, -4.35, -8.33, -0.22, -2.06, -0.0009 Nm).
    const Eigen::MatrixXd offset =
        mat.ReadMatrix("rec.act_torque_abs_nm") - mat.ReadMatrix("rec.act_torque_rel_nm");
    for (int axis = 0; axis < 6; ++axis) {
      EXPECT_LT(offset.row(axis).maxCoeff() - offset.row(axis).minCoeff(), 1e-9) << axis;
    }
    // traj_name holds the trajectory file name under a "Trajektorien/" folder prefix.
    EXPECT_EQ(mat.ReadString("traj_name"), "Trajektorien/" + trajectory);
    // Nominal gear ratios in para.u (SOURCE.md: 256.857143, ..., 154.323134).
    const Eigen::VectorXd gear = mat.ReadMatrix("para.u").reshaped();
    ASSERT_EQ(gear.size(), 6);
    EXPECT_NEAR(gear(0), 1798.0 / 7.0, 1e-9);
    EXPECT_NEAR(gear(5), 154.323134, 5e-7);
    EXPECT_EQ(mat.Info("ref_kin.phi_r_all").dims, (std::vector<std::size_t>{2501, 6}));
  }
}

TEST(MatFileDataTest, KukaIrosRecordAsExperiment) {
  REQUIRE_DATA("kuka_kr300_iros2021/rec_2020-10-21_10s_FF_A_08ms.mat");
  const MatFile mat(DataDir() + "/kuka_kr300_iros2021/rec_2020-10-21_10s_FF_A_08ms.mat");
  Experiment e;
  e.name = "kuka_A";
  e.dt = mat.ReadScalar("time_data.dt");
  e.u = mat.ReadMatrix("rec.act_torque_abs_nm").transpose();  // channel-major in the file
  e.y = mat.ReadMatrix("rec.act_pos_mot_deg").transpose();
  e.u_units.assign(6, "Nm");
  e.y_units.assign(6, "deg");
  EXPECT_NO_THROW(e.Validate());
  EXPECT_EQ(e.NumSamples(), 2501);
  EXPECT_EQ(e.NumInputs(), 6);
  EXPECT_NEAR(e.TimeAt(2500), 10.0, 1e-12);
}

TEST(MatFileDataTest, RoblueFloat32Matrices) {
  REQUIRE_DATA("roblue_elabee/elabee_robot_ftsd.mat");
  const MatFile mat(DataDir() + "/roblue_elabee/elabee_robot_ftsd.mat");
  EXPECT_EQ(mat.VariableNames(),
            (std::vector<std::string>{"u_training", "y_training", "u_validation", "y_validation",
                                      "u_test", "y_test", "ftsd_file_version_counter"}));
  struct Expect {
    const char* name;
    int cols;
    double lo, hi;  // SOURCE.md ranges, two decimals
  };
  for (const Expect& x :
       {Expect{"u_training", 6, -18.33, 9.10}, Expect{"y_training", 12, -1.62, 1.79},
        Expect{"u_validation", 6, -18.21, 7.61}, Expect{"y_validation", 12, -1.44, 1.59},
        Expect{"u_test", 6, -20.51, 12.78}, Expect{"y_test", 12, -1.62, 2.05}}) {
    SCOPED_TRACE(x.name);
    const MatVariableInfo info = mat.Info(x.name);
    EXPECT_EQ(info.class_name, "single");
    EXPECT_EQ(info.Describe(), "single 15000x" + std::to_string(x.cols));
    const Eigen::MatrixXd m = mat.ReadMatrix(x.name);
    ASSERT_EQ(m.rows(), 15000);
    ASSERT_EQ(m.cols(), x.cols);
    EXPECT_NEAR(m.minCoeff(), x.lo, kTwoDecimals);
    EXPECT_NEAR(m.maxCoeff(), x.hi, kTwoDecimals);
    // Converted from float32 exactly: every value is a float.
    for (Eigen::Index i = 0; i < m.size(); ++i) {
      ASSERT_EQ(static_cast<double>(static_cast<float>(m.data()[i])), m.data()[i]);
    }
  }
  EXPECT_EQ(mat.Info("ftsd_file_version_counter").class_name, "int64");
  EXPECT_EQ(mat.ReadScalar("ftsd_file_version_counter"), 20.0);
}

TEST(MatFileDataTest, KukaBenchmarkForwardFile) {
  REQUIRE_DATA("kuka_kr300_robot/forward_identification_without_raw_data_shifted.mat");
  const MatFile mat(DataDir() +
                    "/kuka_kr300_robot/forward_identification_without_raw_data_shifted.mat");
  for (const char* name : {"u_train", "y_train"}) {
    EXPECT_EQ(mat.Info(name).dims, (std::vector<std::size_t>{6, 36300})) << name;
  }
  for (const char* name : {"u_val", "y_val", "u_test", "y_test"}) {
    EXPECT_EQ(mat.Info(name).dims, (std::vector<std::size_t>{6, 3630})) << name;
  }
  // 60 training blocks of 605 samples.
  EXPECT_EQ(36300 % 605, 0);
}

TEST(MatFileDataTest, ClearErrors) {
  REQUIRE_DATA("emps/DATA_EMPS.mat");
  const std::string emps = DataDir() + "/emps/DATA_EMPS.mat";
  EXPECT_CONTAINS(ErrorOf([&] { MatFile(DataDir() + "/emps/DATA_EMPS_missing.mat"); }),
                  "file not found");
  EXPECT_CONTAINS(ErrorOf([&] { MatFile(DataDir() + "/emps/SOURCE.md"); }),
                  "expected a MATLAB .mat file");
  const MatFile mat(emps);
  const std::string missing = ErrorOf([&] { mat.ReadMatrix("qmm"); });
  EXPECT_CONTAINS(missing, "has no variable 'qmm'; did you mean 'qm'?");
  EXPECT_CONTAINS(missing, "(variables: gtau, kp, kv, qg, qm, t, vir)");
  EXPECT_CONTAINS(missing, emps);
  EXPECT_CONTAINS(ErrorOf([&] { mat.ReadMatrix("qm.position"); }),
                  "'qm' is double 24841x1, not a struct");
  EXPECT_CONTAINS(ErrorOf([&] { mat.ReadScalar("qm"); }), "expected a scalar (1x1), got 24841x1");
  EXPECT_CONTAINS(ErrorOf([&] { ReadMatMatrix(emps, "vri"); }), "did you mean 'vir'?");
  EXPECT_FALSE(mat.Has("qmm"));
  EXPECT_TRUE(mat.Has("qm"));

  REQUIRE_DATA("kuka_kr300_iros2021/rec_2020-10-21_10s_FF_A_08ms.mat");
  const MatFile kuka(DataDir() + "/kuka_kr300_iros2021/rec_2020-10-21_10s_FF_A_08ms.mat");
  EXPECT_CONTAINS(ErrorOf([&] { kuka.ReadMatrix("rec.act_pos_mot_dg"); }),
                  "struct 'rec' has no field 'act_pos_mot_dg'; did you mean 'act_pos_mot_deg'?");
  EXPECT_CONTAINS(ErrorOf([&] { kuka.ReadMatrix("traj_name"); }),
                  "variable 'traj_name': expected a real numeric 2-D array, got char 1x53");
  EXPECT_CONTAINS(ErrorOf([&] { kuka.ReadMatrix("rec"); }), "got struct 1x1 (12 fields)");
  EXPECT_TRUE(kuka.Has("rec.act_pos_mot_deg"));
  EXPECT_FALSE(kuka.Has("rec.nothing"));
}

// ---- .mat files: round trips -------------------------------------------------------------------

class MatRoundTripTest : public ::testing::TestWithParam<std::pair<MatVersion, bool>> {};

TEST_P(MatRoundTripTest, NumericClassesStructsAndStrings) {
  const auto [version, compress] = GetParam();
  TempDir dir;
  ASSERT_TRUE(dir.ok());
  const std::string path = dir.File("round_trip.mat");

  std::mt19937 rng(20240917u);  // fixed seed: the values only need to be arbitrary
  std::normal_distribution<double> normal(0.0, 1e3);
  Eigen::MatrixXd doubles(7, 3);
  for (Eigen::Index i = 0; i < doubles.size(); ++i) doubles.data()[i] = normal(rng);
  doubles(0, 0) = 1e-300;
  doubles(1, 0) = -1e300;
  doubles(2, 0) = std::numeric_limits<double>::quiet_NaN();
  doubles(3, 0) = std::numeric_limits<double>::infinity();
  Eigen::MatrixXd floats(2, 2);
  floats << 0.5, -1.25, 3.0e30, 1.0 / 3.0;
  const double two53 = 9007199254740992.0;  // 2^53, exact in double and in 64-bit integers
  Eigen::MatrixXd int8(1, 2), uint8(1, 2), int16(1, 2), uint16(1, 2), int32(1, 2), uint32(1, 2),
      int64(1, 2), uint64(1, 2);
  int8 << -128, 127;
  uint8 << 0, 255;
  int16 << -32768, 32767;
  uint16 << 0, 65535;
  int32 << -2147483648.0, 2147483647.0;
  uint32 << 0, 4294967295.0;
  int64 << -two53, two53;
  uint64 << 0, two53;
  Eigen::MatrixXd column = Eigen::VectorXd::LinSpaced(5, 0.0, 1.0);

  {
    MatWriter w(path, version, compress);
    w.WriteMatrix("doubles", doubles);
    w.WriteMatrix("floats", floats, MatNumericClass::kSingle);
    w.WriteMatrix("i8", int8, MatNumericClass::kInt8);
    w.WriteMatrix("u8", uint8, MatNumericClass::kUInt8);
    w.WriteMatrix("i16", int16, MatNumericClass::kInt16);
    w.WriteMatrix("u16", uint16, MatNumericClass::kUInt16);
    w.WriteMatrix("i32", int32, MatNumericClass::kInt32);
    w.WriteMatrix("u32", uint32, MatNumericClass::kUInt32);
    w.WriteMatrix("i64", int64, MatNumericClass::kInt64);
    w.WriteMatrix("u64", uint64, MatNumericClass::kUInt64);
    w.WriteStruct("rec", {{"q", doubles.leftCols(2)}, {"t", column}});
    w.WriteStruct("rec32", {{"u", floats}}, MatNumericClass::kSingle);
    w.WriteString("label", "graybox round trip");
    w.Close();
  }

  const MatFile mat(path);
  EXPECT_EQ(mat.version(), version);
  // v5 keeps the order of writing; v7.3 (HDF5) lists the variables sorted by name.
  std::vector<std::string> names = {"doubles", "floats", "i8",  "u8",  "i16",   "u16",  "i32",
                                    "u32",     "i64",    "u64", "rec", "rec32", "label"};
  if (version == MatVersion::kV73) std::sort(names.begin(), names.end());
  EXPECT_EQ(mat.VariableNames(), names);
  const Eigen::MatrixXd d = mat.ReadMatrix("doubles");
  ASSERT_EQ(d.rows(), 7);
  ASSERT_EQ(d.cols(), 3);
  for (Eigen::Index i = 0; i < d.size(); ++i) {
    if (std::isnan(doubles.data()[i])) {
      EXPECT_TRUE(std::isnan(d.data()[i]));
    } else {
      EXPECT_EQ(d.data()[i], doubles.data()[i]) << i;
    }
  }
  EXPECT_EQ(mat.Info("floats").class_name, "single");
  const Eigen::MatrixXd f = mat.ReadMatrix("floats");
  for (Eigen::Index i = 0; i < f.size(); ++i) {
    EXPECT_EQ(f.data()[i], static_cast<double>(static_cast<float>(floats.data()[i])));
  }
  const std::vector<std::pair<const char*, const Eigen::MatrixXd*>> ints = {
      {"i8", &int8},   {"u8", &uint8},   {"i16", &int16}, {"u16", &uint16},
      {"i32", &int32}, {"u32", &uint32}, {"i64", &int64}, {"u64", &uint64}};
  const std::vector<std::string> classes = {"int8",  "uint8",  "int16", "uint16",
                                            "int32", "uint32", "int64", "uint64"};
  for (size_t i = 0; i < ints.size(); ++i) {
    EXPECT_EQ(mat.Info(ints[i].first).class_name, classes[i]);
    EXPECT_EQ(mat.ReadMatrix(ints[i].first), *ints[i].second) << ints[i].first;
  }
  EXPECT_EQ(mat.Info("rec").fields, (std::vector<std::string>{"q", "t"}));
  const Eigen::MatrixXd q = mat.ReadMatrix("rec.q");
  EXPECT_EQ(q.rows(), 7);
  EXPECT_EQ(q.cols(), 2);
  EXPECT_EQ(q(1, 0), -1e300);
  EXPECT_TRUE(std::isnan(q(2, 0)));
  EXPECT_EQ(q(3, 0), std::numeric_limits<double>::infinity());
  EXPECT_EQ(q.bottomRows(3), doubles.block(4, 0, 3, 2));
  EXPECT_EQ(mat.ReadMatrix("rec.t"), column);
  EXPECT_EQ(mat.Info("rec32.u").class_name, "single");
  EXPECT_EQ(mat.ReadMatrix("rec32.u"), f);
  EXPECT_EQ(mat.ReadString("label"), "graybox round trip");
}

INSTANTIATE_TEST_SUITE_P(Versions, MatRoundTripTest,
                         ::testing::Values(std::make_pair(MatVersion::kV5, false),
                                           std::make_pair(MatVersion::kV5, true),
                                           std::make_pair(MatVersion::kV73, false),
                                           std::make_pair(MatVersion::kV73, true)),
                         [](const auto& info) {
                           return std::string(info.param.first == MatVersion::kV5 ? "v5" : "v73") +
                                  (info.param.second ? "_compressed" : "");
                         });

TEST(MatWriterTest, RejectsUnrepresentableValuesAndBadNames) {
  TempDir dir;
  ASSERT_TRUE(dir.ok());
  MatWriter w(dir.File("bad.mat"));
  Eigen::MatrixXd m(1, 2);
  m << 1.0, 256.0;
  EXPECT_CONTAINS(ErrorOf([&] { w.WriteMatrix("m", m, MatNumericClass::kUInt8); }),
                  "variable 'm' element 1 (row 0, column 1)");
  m << 1.5, 2.0;
  EXPECT_CONTAINS(ErrorOf([&] { w.WriteMatrix("m", m, MatNumericClass::kInt32); }), "got 1.5");
  m << 1e39, 0.0;
  EXPECT_CONTAINS(ErrorOf([&] { w.WriteMatrix("m", m, MatNumericClass::kSingle); }), "got 1e+39");
  EXPECT_CONTAINS(ErrorOf([&] { w.WriteMatrix("1abc", m); }), "expected a MATLAB identifier");
  EXPECT_CONTAINS(ErrorOf([&] { w.WriteStruct("s", {{"bad field", m}}); }), "'bad field'");
  EXPECT_CONTAINS(ErrorOf([&] { MatWriter(dir.File("no/such/dir.mat")); }),
                  "cannot create the file");
  w.Close();
  EXPECT_THROW(w.WriteMatrix("late", m), std::logic_error);
}

// ---- CSV ---------------------------------------------------------------------------------------

TEST(CsvDataTest, GearedDcMotorFilesWithoutHeader) {
  REQUIRE_DATA("geared_dc_motor_ayankoso/DC_Motor_experimental_data_training.csv");
  CsvOptions options;
  options.has_header = false;
  options.column_names = {"time", "pwm", "speed"};
  const std::string dir = DataDir() + "/geared_dc_motor_ayankoso/";
  const CsvTable train = ReadCsv(dir + "DC_Motor_experimental_data_training.csv", options);
  const CsvTable test = ReadCsv(dir + "DC_Motor_experimental_data_testing.csv", options);
  for (const CsvTable* t : {&train, &test}) {
    // SOURCE.md: 25001 rows x 3 columns, time 0 .. 500 s in steps of 0.02 s, PWM 40.5 .. 255.
    ASSERT_EQ(t->NumRows(), 25001);
    ASSERT_EQ(t->NumColumns(), 3);
    const Eigen::VectorXd time = t->Column("time");
    EXPECT_EQ(time(0), 0.0);
    EXPECT_EQ(time(25000), 500.0);
    const Eigen::VectorXd spacing = time.tail(25000) - time.head(25000);
    EXPECT_LT((spacing.array() - 0.02).abs().maxCoeff(), kCsvTimeRounding);
    EXPECT_EQ(t->Column("pwm").minCoeff(), 40.5);
    EXPECT_EQ(t->Column("pwm").maxCoeff(), 255.0);
    EXPECT_EQ(t->Column("speed").minCoeff(), 0.0);
    EXPECT_NEAR(t->Column("speed").maxCoeff(), 303.4, 0.15);
    EXPECT_EQ(t->lines.back(), 25001);
  }
  // The input column is identical in the two runs (SOURCE.md).
  EXPECT_EQ(train.Column("pwm"), test.Column("pwm"));
  // Without names the columns are c0, c1, c2.
  CsvOptions unnamed;
  unnamed.has_header = false;
  EXPECT_EQ(ReadCsv(dir + "DC_Motor_experimental_data_training.csv", unnamed).names,
            (std::vector<std::string>{"c0", "c1", "c2"}));

  Experiment e;
  e.name = "dc_motor_train";
  e.dt = 0.02;
  e.u = train.Columns({"pwm"});
  e.y = train.Columns({"speed"});
  e.u_units = {"counts"};
  e.y_units = {"rpm"};
  EXPECT_NO_THROW(e.Validate());
}

TEST(CsvDataTest, PneumaticMuscleArmExport) {
  REQUIRE_DATA("pneumatic_muscle_arm_laas/simwithinitpres1multisine.csv");
  const std::string path = DataDir() + "/pneumatic_muscle_arm_laas/simwithinitpres1multisine.csv";
  const std::string angle = "/joint_states/position[3]_y";
  const std::string angle_time = "/joint_states/position[3]_x";
  const std::string p6 = "/joint_states/effort[6]_y";
  const std::string p7 = "/joint_states/effort[7]_y";

  // Reading every column stops at the first empty cell: line 17194 has no effort[7] sample (the
  // ROS topics end at different times).
  const std::string all = ErrorOf([&] { ReadCsv(path); });
  EXPECT_CONTAINS(all, "line 17194, column 9 ('/joint_states/effort[7]_x')");
  EXPECT_CONTAINS(all, "got an empty cell");

  CsvOptions options;
  options.columns = {angle_time, angle, p6, p7};
  options.empty_cells = CsvEmptyCells::kDropTrailingRows;
  const CsvTable t = ReadCsv(path, options);
  // SOURCE.md: 17194 data rows; the last complete one for these columns is file line 17193.
  EXPECT_EQ(t.NumRows(), 17192);
  EXPECT_EQ(t.lines.front(), 2);
  EXPECT_EQ(t.lines.back(), 17193);
  // Elbow angle -0.33 .. 1.27 rad, pressures up to 3.23 and 4.0 bar (SOURCE.md).
  EXPECT_NEAR(t.Column(angle).minCoeff(), -0.33, kTwoDecimals);
  EXPECT_NEAR(t.Column(angle).maxCoeff(), 1.27, kTwoDecimals);
  EXPECT_NEAR(t.Column(p6).maxCoeff(), 3.23, kTwoDecimals);
  EXPECT_EQ(t.Column(p7).maxCoeff(), 4.0);
  // Time step about 0.01 s: 17192 samples span about 172 s.
  const Eigen::VectorXd time = t.Column(angle_time);
  EXPECT_NEAR((time(time.size() - 1) - time(0)) / (time.size() - 1), 0.01, 1e-4);

  // As an experiment with its own time stamps.
  Experiment e;
  e.name = "multisine";
  e.time = time;
  e.u = t.Columns({p6, p7});
  e.y = t.Columns({angle});
  EXPECT_NO_THROW(e.Validate());

  // kNaN keeps all 17194 rows and marks the gaps.
  options.empty_cells = CsvEmptyCells::kNaN;
  const CsvTable with_gaps = ReadCsv(path, options);
  EXPECT_EQ(with_gaps.NumRows(), 17194);
  EXPECT_TRUE(std::isnan(with_gaps.Column(p7)(17192)));
  EXPECT_FALSE(std::isnan(with_gaps.Column(angle)(17192)));

  // The header names and the did-you-mean for a misspelt one.
  CsvOptions misspelt;
  misspelt.columns = {"/joint_states/positon[3]_y"};
  EXPECT_CONTAINS(ErrorOf([&] { ReadCsv(path, misspelt); }),
                  "no column '/joint_states/positon[3]_y'; did you mean "
                  "'/joint_states/position[3]_y'?");
}

TEST(CsvTest, MalformedLinesNameLineAndColumn) {
  const std::string text = "time,speed\n0,1.5\n0.1,2.5\n0.2,2,5\n";
  EXPECT_CONTAINS(ErrorOf([&] { ParseCsv(text); }), "line 4: expected 2 fields, got 3");
  const std::string bad_number = "time,speed\n0,1.5\n\n0.2,fast\n";
  EXPECT_CONTAINS(ErrorOf([&] { ParseCsv(bad_number, {}, "mem.csv"); }),
                  "csv_file: 'mem.csv' line 4, column 2 ('speed'): expected a number, got 'fast'");
  EXPECT_CONTAINS(ErrorOf([&] { ParseCsv("a,b\n1,2x\n"); }), "got '2x'");
  EXPECT_CONTAINS(ErrorOf([&] { ParseCsv("a,b\n1,\n"); }),
                  "line 2, column 2 ('b'): expected a number, got an empty cell");

  TempDir dir;
  ASSERT_TRUE(dir.ok());
  const std::string path = dir.File("broken.csv");
  std::ofstream(path) << "t,u,y\r\n0,1,2\r\n1,2,3\r\n2,x3,4\r\n";
  const std::string message = ErrorOf([&] { ReadCsv(path); });
  EXPECT_CONTAINS(message, path);
  EXPECT_CONTAINS(message, "line 4, column 2 ('u'): expected a number, got 'x3'");
  EXPECT_CONTAINS(ErrorOf([&] { ReadCsv(dir.File("absent.csv")); }), "file not found");
}

TEST(CsvTest, QuotingSelectionAndEmptyCellPolicies) {
  const std::string text =
      "\"time [s]\", \"a,b\" ,c\n"
      "0, 1 ,2,\n"
      "1,\"3\",4,\n";
  CsvTable t = ParseCsv(text);
  EXPECT_EQ(t.names, (std::vector<std::string>{"time [s]", "a,b", "c"}));
  EXPECT_EQ(t.data, (Eigen::MatrixXd(2, 3) << 0, 1, 2, 1, 3, 4).finished());
  CsvOptions select;
  select.columns = {"c", "time [s]"};
  t = ParseCsv(text, select);
  EXPECT_EQ(t.names, (std::vector<std::string>{"c", "time [s]"}));
  EXPECT_EQ(t.data, (Eigen::MatrixXd(2, 2) << 2, 0, 4, 1).finished());
  EXPECT_EQ(t.ColumnIndex("time [s]"), 1);
  EXPECT_CONTAINS(ErrorOf([&] { t.Column("tme [s]"); }), "did you mean 'time [s]'?");

  // Text in an unselected column does no harm.
  select.columns = {"x"};
  EXPECT_EQ(ParseCsv("x,note\n1,hello\n2,world\n", select).NumRows(), 2);

  // Empty cells: only trailing rows may be dropped.
  CsvOptions drop;
  drop.empty_cells = CsvEmptyCells::kDropTrailingRows;
  EXPECT_EQ(ParseCsv("a,b\n1,2\n3,\n,\n", drop).NumRows(), 1);
  EXPECT_CONTAINS(
      ErrorOf([&] { ParseCsv("a,b\n1,2\n3,\n5,6\n", drop); }),
      "line 3, column 2 ('b'): expected a number, got an empty cell (only the last rows");
  CsvOptions nan;
  nan.empty_cells = CsvEmptyCells::kNaN;
  EXPECT_TRUE(std::isnan(ParseCsv("a,b\n1,2\n3,\n5,6\n", nan).data(1, 1)));

  // Renaming a header, and a semicolon delimiter.
  CsvOptions renamed;
  renamed.delimiter = ';';
  renamed.column_names = {"x", "y"};
  EXPECT_EQ(ParseCsv("first;second\n1;2\n", renamed).names, (std::vector<std::string>{"x", "y"}));
  renamed.column_names = {"x"};
  EXPECT_CONTAINS(ErrorOf([&] { ParseCsv("first;second\n1;2\n", renamed); }),
                  "column_names has 1 entries: expected 2");
  EXPECT_CONTAINS(ErrorOf([] { ParseCsv("a,a\n1,2\n"); }), "column name 'a' appears twice");
}

}  // namespace
}  // namespace graybox::estimators
