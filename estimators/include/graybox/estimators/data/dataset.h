// Experiment and Dataset: measured signals of identification experiments, one row per sample.
//
//   Experiment e;
//   e.name = "emps_train";
//   e.dt = 1e-3;                       // uniform sampling: t_k = t0 + k dt, k = 0 .. N-1
//   e.u = vir;                         // N x nu inputs
//   e.y = qm;                          // N x ny outputs
//   e.u_names = {"vir"};  e.u_units = {"V"};
//   e.y_names = {"qm"};   e.y_units = {"m"};
//   e.Validate();                      // throws std::invalid_argument on the first defect
//   Dataset parts = Split(e, {{"train", 0, 20000}, {"test", 20000, 24841}});
//
// Signals are stored sample-major (row k is sample k, column j is channel j), the layout of
// MATLAB and numpy recordings with time running down the rows. Files stored channel-major (KUKA
// "rec" fields are 6 x 2501) are transposed by the caller.
//
// Time is either uniform (dt > 0, start time t0, empty `time`) or given explicitly (`time` holds N
// strictly increasing instants in seconds and dt is 0). Exactly one of the two is set.
//
// Optional channels: states x (N x nx) and their time derivatives dx (N x nx, same channels as
// x), for equation-error formulations and for N-step simulation from measured states. A matrix
// with zero columns means "absent", whatever its row count. Names and units are optional per
// group: an empty vector means "unnamed" (reports then use "u0", "y1", ...), otherwise it holds
// one entry per column.
//
// Experiments are plain values: copying one copies its signals.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace graybox::estimators {

/// The channel groups of an Experiment.
enum class ChannelGroup { kInput, kOutput, kState, kStateDerivative };

struct Experiment {
  std::string name;
  /// Uniform sample time [s] (> 0), or 0 when `time` is given.
  double dt = 0.0;
  /// Time of sample 0 [s] for uniform sampling (ignored when `time` is given).
  double t0 = 0.0;
  /// Explicit sample instants [s] (N entries, strictly increasing), or empty for uniform sampling.
  Eigen::VectorXd time;

  Eigen::MatrixXd u;   // N x nu inputs (nu may be 0)
  Eigen::MatrixXd y;   // N x ny outputs (ny >= 1)
  Eigen::MatrixXd x;   // N x nx states, optional (0 columns when absent)
  Eigen::MatrixXd dx;  // N x nx state derivatives, optional; requires x

  std::vector<std::string> u_names, y_names, x_names;  // empty or one per column
  std::vector<std::string> u_units, y_units, x_units;  // empty or one per column (dx: x_units/s)

  /// N, the number of samples (the row count of y).
  int NumSamples() const { return static_cast<int>(y.rows()); }
  int NumInputs() const { return static_cast<int>(u.cols()); }
  int NumOutputs() const { return static_cast<int>(y.cols()); }
  int NumStates() const { return static_cast<int>(x.cols()); }
  bool HasStates() const { return x.cols() > 0; }
  bool HasStateDerivatives() const { return dx.cols() > 0; }
  bool IsUniform() const { return time.size() == 0; }

  /// The N sample instants [s]: t0 + k dt, or `time`.
  Eigen::VectorXd Time() const;
  /// Time of sample k [s]. No range check beyond a debug assert.
  double TimeAt(int k) const;
  /// dt for uniform sampling; for an explicit time vector the mean spacing
  /// (time[N-1] - time[0]) / (N - 1). Throws std::invalid_argument when N < 2 and dt is 0.
  double SampleTime() const;

  /// The signal matrix and the names/units of a group (dx shares the names of x).
  const Eigen::MatrixXd& Signals(ChannelGroup group) const;
  /// Name of column `j` of `group`: the given name, or "u<j>", "y<j>", "x<j>", "dx<j>" when
  /// unnamed; for kStateDerivative a given name n becomes "d(n)/dt".
  std::string ChannelName(ChannelGroup group, int j) const;
  /// Unit of column `j` ("" when none given; for kStateDerivative "<unit>/s").
  std::string ChannelUnit(ChannelGroup group, int j) const;
  /// Column index of the channel called `channel_name` in `group`; throws std::invalid_argument
  /// "experiment 'e': no output channel 'qn'; did you mean 'qm'?" when there is none.
  int ChannelIndex(ChannelGroup group, const std::string& channel_name) const;

  /// Throws std::invalid_argument, naming the experiment, on the first of:
  /// - no samples (y has 0 rows) or no output channel;
  /// - u, x or dx (when present) with a row count different from N; dx without x or with a
  ///   column count different from nx;
  /// - names/units vectors that are neither empty nor one per column;
  /// - both or neither of dt > 0 and `time` given; dt or t0 not finite; `time` of length != N;
  /// - a NaN or Inf sample, naming group, channel, sample index and time
  ///   ("experiment 'train': output 'qm' (column 0) sample 1234 (t = 1.234 s): expected a finite
  ///   value, got nan");
  /// - non-finite or not strictly increasing time ("time[7] = 0.028 s after time[6] = 0.028 s:
  ///   expected strictly increasing time").
  void Validate() const;
};

/// Samples [begin, end) of an experiment (0-based, half open, like Python slices). The result is
/// named "<name>[begin:end]" and keeps channel names/units; with uniform sampling t0 moves to the
/// time of sample `begin`. Throws std::invalid_argument unless 0 <= begin < end <= N.
Experiment Slice(const Experiment& experiment, int begin, int end);

/// A named sample range [begin, end) of one experiment.
struct SampleRange {
  std::string name;
  int begin = 0;
  int end = 0;
};

/// Several experiments with the same channels (for example, the identification and validation
/// runs of one rig).
struct Dataset {
  std::string name;
  std::vector<Experiment> experiments;

  int NumExperiments() const { return static_cast<int>(experiments.size()); }
  /// Total number of samples over all experiments.
  int NumSamples() const;
  /// The experiment called `experiment_name`; std::invalid_argument with a did-you-mean otherwise.
  const Experiment& Find(const std::string& experiment_name) const;
  /// Validates every experiment and checks that all have the same nu, ny and nx (naming the first
  /// experiment that differs, expected versus got). An empty dataset is an error.
  void Validate() const;
};

/// Cuts one experiment into the given disjoint ranges, in the given order. Experiment i of the
/// result is Slice(experiment, ranges[i].begin, ranges[i].end) renamed to ranges[i].name (or to
/// "<experiment name>[begin:end]" when that is empty). Throws std::invalid_argument when a range is
/// outside [0, N], empty or reversed, when two ranges overlap (naming both), or when two names
/// repeat. Gaps between ranges are allowed (roblue leaves 151 samples between its parts).
/// Use Slice directly for deliberately overlapping windows.
Dataset Split(const Experiment& experiment, const std::vector<SampleRange>& ranges);

}  // namespace graybox::estimators
