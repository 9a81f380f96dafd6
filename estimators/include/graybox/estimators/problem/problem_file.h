// Problem files: one TOML file says WHAT to identify (the model, from registered blocks), FROM
// WHAT (the data files and how their variables map onto the model's inputs and outputs, cut into
// estimation, validation and test ranges) and HOW (the formulation, the solver and their
// options). docs/problem-format.md is the reference of every key, with a complete example per
// shipped problem; this header is the C++ side.
//
//   Problem problem = LoadProblem("problems/emps/emps_idim.toml");  // parse, build, check names
//   std::vector<SplitData> splits = LoadData(problem);               // read, validate, cut
//
// Sections (one per concern):
//   [problem]      name, description
//   [model]        name, plugins (shared libraries of blocks, models/block_plugin.h), inputs
//                  (name, unit), [[model.blocks]] (instance, type, options, inputs,
//                  outputs: exactly models::Model::AddBlock), outputs (signal names),
//                  [[model.augment]] (instance, type, options and one placement: inputs +
//                  outputs, on_signal, on_output + readers, or for_readers = {signal, readers,
//                  extra_inputs}: exactly models::Augmentation, applied by ApplyAugmentation;
//                  augmentation_toml.h writes one), [model.parameters."<instance>.<param>"]
//                  value / lower / upper / free / scale
//   [[data]]       name, file (relative to the problem file), format (mat | csv), sample_time or
//                  time (a variable), inputs / outputs: model signal -> variable (with scale,
//                  column / row, rate = forward difference, or a constant), splits with roles,
//                  initial_state (numbers or a variable's first sample)
//   [estimation]   method, solver, seed, scheme, substeps, newton_iterations, and one table
//                  per formulation ([estimation.multiple_shooting], [estimation.collocation],
//                  [estimation.equation_error], [estimation.n_step]), the integrator
//                  ([estimation.integrator]), per solver ([estimation.ipopt],
//                  [estimation.ceres]), and [[estimation.regularization]] terms
//   [metrics]      the N-step NRMS
//   [diagnosis]    effects (and add_effects, remove_effects), ripple_periods, lugre_presliding,
//                  sensors, metadata_axes, [[diagnosis.axes]] (velocity, force, position,
//                  motion, sign, inputs): what the gap diagnosis proposes and where
//
// Errors. Every defect is reported before anything is computed or written, as a ProblemFileError
// (a std::invalid_argument) whose message starts with the place,
//     "problems/emps/emps_idim.toml:42:1: [estimation.equation_error] unknown key 'lowpas_hz';
//      did you mean 'lowpass_hz'?"
// and says what was expected and what was found. Unknown keys are errors anywhere (with the
// closest known key), as are TOML syntax errors (toml++'s message and position), wrong value
// types, unknown block types, signals or parameters (with suggestions), infeasible bounds
// (lower > upper, a value outside its bounds), a solver/formulation mismatch and unknown Ipopt
// options (checked against Ipopt's registered options when the file is loaded). LoadData adds the
// data defects: missing files or variables (with suggestions), variables of different lengths,
// NaN/Inf samples, non-monotone or non-uniform time, split ranges outside the record, and too
// few samples for the preprocessing.
#pragma once

#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/data/dataset.h"
#include "graybox/estimators/formulations/collocation.h"
#include "graybox/estimators/formulations/experiment_setup.h"
#include "graybox/estimators/formulations/multiple_shooting.h"
#include "graybox/estimators/formulations/n_step_loss.h"
#include "graybox/estimators/integrators/integrator_factory.h"
#include "graybox/estimators/nlp/regularization.h"
#include "graybox/estimators/solvers/solvers.h"
#include "graybox/models/augmentation.h"
#include "graybox/models/model.h"

namespace graybox::estimators {

/// A place in a problem file: the file, the TOML table path ("estimation.ipopt", "data[1]"), and
/// the 1-based line and column (0 when unknown).
struct SourceLocation {
  std::string file;
  std::string table;
  int line = 0;
  int column = 0;
  /// "file:line:column: [table]" (parts that are unknown are left out).
  std::string ToString() const;
};

/// A defect in a problem file or in the data it names. what() is "<location> <message>".
class ProblemFileError : public std::invalid_argument {
 public:
  ProblemFileError(SourceLocation where, const std::string& message);
  const SourceLocation& where() const { return where_; }
  /// The message without the location.
  const std::string& message() const { return message_; }

 private:
  SourceLocation where_;
  std::string message_;
};

/// Where one model signal comes from in a data file: signal = scale * variable, where `variable`
/// is a .mat variable or dotted struct path ("rec.act_pos_mot_deg") or a CSV column name.
struct ChannelSource {
  std::string signal;    // the model input or output
  std::string variable;  // the variable, struct path or column
  double scale = 1.0;
  /// A scalar variable of the same file multiplying `scale` ("gtau"), or empty.
  std::string scale_variable;
  /// For a 2-D variable: the column (N x m, sample-major) or the row (m x N, channel-major) to
  /// read, 0-based; -1 when the variable is a vector.
  int column = -1;
  int row = -1;
  /// Use the forward difference (v[k+1] - v[k]) / dt of the (scaled) variable instead, the last
  /// sample repeating the one before: held over each sample and integrated (signal.integrator)
  /// it reproduces v exactly at the samples and linearly in between (a first-order hold).
  bool rate = false;
  /// hold = "foh" (inputs only): the input is linear between its samples instead of held over
  /// each (ParseProblem inserts a signal.first_order_hold on it; mechanics.h).
  bool first_order_hold = false;
  /// A signal that is constant over the record (`constant = 0.0`, e.g. an input the file did not
  /// record because it was zero); `variable` is then empty.
  std::optional<double> constant;
  SourceLocation where;
};

enum class SplitRole { kEstimation, kValidation, kTest };
/// "estimation", "validation", "test".
const char* SplitRoleName(SplitRole role);

/// Samples [begin, end) of one data file (end = -1: to the last sample) with a role.
struct SplitSpec {
  std::string name;
  SplitRole role = SplitRole::kEstimation;
  int begin = 0;
  int end = -1;
  SourceLocation where;
};

struct DataSpec {
  std::string name;
  std::string file;    // as written in the problem file
  std::string path;    // resolved against the problem file's folder
  std::string format;  // "mat" or "csv"
  /// Uniform sample time [s] (> 0), or 0 when `time_variable` gives the instants.
  double sample_time = 0.0;
  std::string time_variable;
  // CSV only.
  char csv_delimiter = ',';
  bool csv_header = true;
  std::vector<std::string> csv_column_names;
  /// One source per model input and per model output, in the model's order.
  std::vector<ChannelSource> inputs;
  std::vector<ChannelSource> outputs;
  /// At least one; by default one estimation split named like the data over all samples.
  std::vector<SplitSpec> splits;
  /// Explicit initial state values by state name, as numbers or as the first sample of a variable
  /// of the file (`initial_state_variables`). A state not listed starts at the first sample of
  /// the measured output of the same name when there is one, else at 0.
  std::map<std::string, double> initial_state;
  std::map<std::string, std::string> initial_state_variables;
  /// Per state: estimated (true) or held at its value (false) whatever the method's default
  /// (`{ free = true }`); states not listed follow the method (fix_initial_state).
  std::map<std::string, bool> initial_state_free;
  /// Per state: the initial state estimated on another split (`{ from_split = "name" }`): for
  /// validation and test splits of records that share an unknown initial state with an
  /// estimation split; the named split must be an estimation split of another [[data]].
  std::map<std::string, std::string> initial_state_from_split;
  SourceLocation where;
};

/// How equation error obtains states and their derivatives from data (see problem-format.md):
/// each state is a measured output of the same name (low-pass filtered when `lowpass_hz` > 0) or
/// the time derivative (central differences) of another state or measured output; the state
/// derivatives are central differences of the states. Then `skip_samples` rows are dropped and
/// every signal is decimated by `decimate` (zero-phase Chebyshev-I anti-aliasing, MATLAB's
/// convention of ending at the last sample).
struct EquationErrorSpec {
  /// "inverse": residuals in the units of `inverse_inputs` (the input values that reproduce the
  /// measured state derivatives; IDIM-LS for a mechanical model driven by a force) or
  /// "state_derivative": residuals f_c(x, u, theta) - xdot_c.
  std::string form = "inverse";
  /// The states whose equations give residuals (default: every state whose derivative is not
  /// simply another state, e.g. the velocity of a mass).
  std::vector<std::string> residual_states;
  /// Inverse form: one model input per residual state (default: the only input, when the model
  /// has one input and one residual state).
  std::vector<std::string> inverse_inputs;
  /// state -> the signal it is the time derivative of (default: inferred from the kinematic
  /// equations dq/dt = qd of the model).
  std::map<std::string, std::string> differentiate;
  /// state -> the model input whose samples it equals (the state of a hold = "foh" input's
  /// signal.first_order_hold, Problem::first_order_holds): from data, never a residual state.
  std::map<std::string, std::string> from_inputs;
  /// "central": Butterworth low-pass (lowpass_hz) and central differences; "fft": seed 000's
  /// eq. 8 for periodic records: outputs, inputs and every derivative through the ideal FFT
  /// low-pass keeping the bins |m| < fft_cutoff_bin (preprocessing.h FftLowPass, FftDerivative).
  std::string differentiation = "central";
  int fft_cutoff_bin = 201;  // seed 000 keeps the bins i <= 200
  double lowpass_hz = 0.0;   // zero-phase Butterworth cut-off; 0 = no filtering
  int lowpass_order = 4;     // filter order (applied forward and backward)
  int lowpass_padding = -1;  // odd-reflection samples at each end; -1 = 3 * order
  int skip_samples = 0;      // dropped after differentiation
  int decimate = 1;          // integer decimation factor
  /// "auto", "parallel" or "signals": with parallel decimation the regressor columns
  /// d target / d theta and the measured target are decimated (IDIM-LS's parallel filtering;
  /// needs a model affine in its free parameters), with "signals" the states, derivatives and
  /// inputs are decimated before the model is evaluated. "auto": parallel when affine.
  std::string decimation = "auto";
  /// How an input sample pairs with the derivative at t_k (central difference over
  /// [t_{k-1}, t_{k+1}]): "sampled" takes u_k as recorded (an input measured at the sample, such
  /// as a logged force; the EMPS IDIM-LS recipe); "held" takes (u_{k-1} + u_k) / 2, the mean of
  /// a zero-order-hold input over that interval (inputs applied as held commands, the convention
  /// of every simulation here), without which the pairing is half a sample late and biases
  /// dynamic parameters (13 % on a viscous coefficient at 2 ms in the family-matrix test).
  std::string input_timing = "sampled";
  /// Residual weights by residual channel name (default 1 / std of the target).
  std::map<std::string, double> weights;
};

struct EstimationSpec {
  /// "multiple_shooting", "single_shooting", "collocation", "equation_error" or "n_step".
  std::string method = "multiple_shooting";
  /// "ipopt" or "ceres" (default: ceres for equation error, ipopt otherwise).
  std::string solver;
  /// Seed of every random draw of a fit (recorded in result.json; the current formulations
  /// draw nothing).
  unsigned seed = 1;
  /// Wall-time limit [s] of each solve ([estimation] max_seconds; 0: none): a solve that reaches
  /// it stops at its last iterate and reports it (SolverResult::success false; `graybox fit`
  /// exits 3 with its outputs written). FitOptions::max_solve_seconds, when smaller, wins.
  double max_seconds = 0.0;
  /// The fixed-step map of every fixed-step simulation: multiple shooting's segments, the
  /// fixed-step integrator, the N-step metric and loss, `graybox simulate` (keys `scheme`:
  /// rk4 | backward_euler | trapezoidal | radau_iia, `substeps`, `newton_iterations`).
  FixedStepOptions step;
  /// The integrator of single shooting, of the N-step loss, of the reported simulations, of
  /// `graybox simulate` and of the output-error covariance ([estimation.integrator]: method
  /// "fixed_step" with `step`, or "cvodes" with its tolerances). Multiple shooting and collocation
  /// keep their own discretisation (the `step` map, collocation polynomials) inside the NLP.
  IntegratorOptions integrator;
  MultipleShootingOptions multiple_shooting;
  /// Output weights by output name (default 1 / std of the channel).
  std::map<std::string, double> output_weights;
  /// Initial guess of the shooting nodes: "simulation" (from x0 with the initial parameters) or
  /// "data" (the states derived from the measurements as for equation error).
  std::string node_guess = "simulation";
  CollocationOptions collocation;
  EquationErrorSpec equation_error;
  /// [estimation.n_step]: the N-step-ahead loss (n_step_loss.h); its `channels` are state
  /// indices and `weights` follow them (empty: 1 / std). The measured states come from the data
  /// as for node_guess = "data"; `integrator` is set from [estimation.integrator].
  NStepLossOptions n_step;
  /// [[estimation.regularization]]: penalties on free parameters selected by name or pattern.
  RegularizationOptions regularization;
  IpoptOptions ipopt;
  CeresOptions ceres;
  SourceLocation where;
};

/// [metrics]: evaluations beyond the whole-split simulation metrics.
struct MetricsSpec {
  /// N of the N-step-ahead NRMS (seed 000 eq. 7: the mean over steps 1..N, analysis/metrics.h)
  /// reported for every split: from the measured state at every start, N samples simulated with
  /// the `step` map and compared with the measured states. 0 = off. Needs the states from the
  /// data (as `node_guess = "data"`).
  int n_step = 0;
  int n_step_stride = 1;  // every stride-th start
  /// The states the N-step NRMS scores (key `n_step_channels`: model state names, distinct, in
  /// the file's order; an unknown name is an error with the place and a suggestion). Always
  /// filled by the parser, also when n_step = 0. Default: the states that are measured outputs,
  /// a state being measured when a model output has the same name ("load.q" of a model with
  /// outputs = ["load.q"]), in state order. When no state is a measured output (every output is
  /// computed from the states, e.g. a sensor block), the default is every state: the states are
  /// then all derived from the data alike and none is closer to the measurement than another.
  /// Seed 000 scores the positions; with velocities measured as well they are scored by default
  /// and usually dominate the figure, so list the positions to reproduce eq. 7.
  std::vector<std::string> n_step_channels;
  /// The same states as indices into Problem::built.states (what NStepOptions::channels takes).
  std::vector<int> n_step_channel_indices;
  /// True when `n_step_channels` was given in the file, false when it is the default.
  bool n_step_channels_given = false;
  SourceLocation where;
};

/// One [[diagnosis.axes]] entry: a mechanical axis named by hand, for models whose blocks do not
/// declare one (an equation block, a block without signal roles) or where the metadata picks
/// another force than the engineer means. The diagnosis (diagnosis/candidates.h) attaches the
/// friction family, ripple, input_delay, deadzone and load candidates there.
struct DiagnosisAxisSpec {
  /// A state signal: the axis velocity (its derivative is the acceleration the force produces).
  std::string velocity;
  /// The signal the candidates add their force to (a block output or a model input, not a
  /// state); it must change d(velocity)/dt (checked by the diagnosis).
  std::string force;
  /// Optional: a state signal whose derivative is `velocity` (ripple and payload attach there);
  /// empty: found as for a metadata axis (a state in m or rad with that derivative).
  std::string position;
  /// "linear" (units m, m/s, N) or "rotary" (rad, rad/s, N m); empty: from the velocity's unit,
  /// required when that is neither m/s nor rad/s.
  std::string motion;
  /// How a friction force enters `force`: "subtract" (friction blocks write "-force", the usual
  /// convention) or "add"; empty: found by a probe (a viscous term must decelerate the axis).
  std::string sign;
  /// The actuator commands of the axis (model inputs or signals): input_delay and deadzone
  /// attach there and nowhere else on this axis. Not given (`inputs_given` false): the model
  /// inputs that change d(velocity)/dt, and for deadzone also the commands of the non-friction
  /// blocks that write `force`.
  std::vector<std::string> inputs;
  bool inputs_given = false;
  SourceLocation where;
};

/// [diagnosis]: what `graybox diagnose` (diagnosis/, docs/diagnosis.md) may propose and where.
/// Signals are checked when the file is loaded; effect names are checked by the diagnosis, which
/// owns the list (diagnosis::CheckDiagnosisSpec), with the places recorded here.
struct DiagnosisSpec {
  /// The effects to screen (replaces the default set; `effects_given`), then `add_effects`
  /// added to it and `remove_effects` taken out. A command-line --effects list replaces
  /// `effects` (add and remove still apply).
  std::vector<std::string> effects;
  bool effects_given = false;
  std::vector<std::string> add_effects;
  std::vector<std::string> remove_effects;
  /// Ripple periods [m or rad] on every axis with a position (replaces the periodogram's).
  std::vector<double> ripple_periods;
  /// Also propose LuGre presliding (off by default, see diagnosis/candidates.h).
  bool lugre_presliding = false;
  /// Output channels that get sensor_offset and sensor_scale candidates (`sensors_given`);
  /// default every output channel.
  std::vector<std::string> sensors;
  bool sensors_given = false;
  /// Axes named by hand. An axis named on a velocity replaces the metadata's axis on it.
  std::vector<DiagnosisAxisSpec> axes;
  /// false: only the named axes (no axis from the blocks' metadata).
  bool metadata_axes = true;
  /// Places of the keys, for messages: "effects", "add_effects", "remove_effects", "sensors",
  /// "ripple_periods" and each element "effects[i]" and so on; the table itself under "".
  std::map<std::string, SourceLocation> where;
};

struct Problem {
  std::string path;       // as given to LoadProblem
  std::string directory;  // folder of the file, against which data paths resolve
  std::string name;
  std::string description;
  /// The model with the file's parameter settings applied, and its built form.
  models::Model model = models::Model("model");
  models::StateSpaceModel built;
  /// The block plugins of [model] plugins (resolved against the problem file's folder), loaded
  /// into the registry before the blocks were created (models/block_plugin.h).
  std::vector<std::string> plugins;
  /// Block instance -> registered type, in file order: the [[model.blocks]], then the
  /// [[model.augment]] instances.
  std::vector<std::pair<std::string, std::string>> blocks;
  /// The [[model.augment]] tables, in file order, as applied to `model` (after every block and
  /// output, before [model.parameters]).
  std::vector<models::Augmentation> augmentations;
  std::vector<DataSpec> data;
  /// The inputs mapped with hold = "foh": (index of the sampled model input, the state of its
  /// signal.first_order_hold), which LoadData starts at the input's first sample of each split
  /// and holds there.
  std::vector<std::pair<int, std::string>> first_order_holds;
  EstimationSpec estimation;
  MetricsSpec metrics;
  /// [diagnosis] (empty when the file has none).
  DiagnosisSpec diagnosis;
};

/// One key of a problem file set from outside the file (a bench suite's variation, bench/runner).
///   key    a dotted path of tables to the key: "estimation.method",
///          "estimation.multiple_shooting.segment_length"; a part that is not a bare TOML key is
///          written in double quotes: model.parameters."load.mass".
///   value  a TOML value: "\"collocation\"", "20", "1e-6", "true", "[1, 2]", "{ value = 80.0 }".
///   origin where the override comes from, for messages (the suite file's line).
struct ProblemOverride {
  std::string key;
  std::string value;
  SourceLocation origin;
  /// "key = value".
  std::string ToString() const { return key + " = " + value; }
};

/// Reads, parses and checks a problem file (no data is read). Throws ProblemFileError.
Problem LoadProblem(const std::string& path);
/// The same with `overrides` applied (see ParseProblem).
Problem LoadProblem(const std::string& path, const std::vector<ProblemOverride>& overrides);
/// The same from text; `path` names the file in messages and anchors relative data paths.
Problem ParseProblem(const std::string& text, const std::string& path);
/// ParseProblem with `overrides` set in the file's tables, in order, before they are read: a key
/// the file has is replaced, one it lacks is added (with the tables on its path), and the result
/// is checked as a file that said so. A key whose path runs through a value that is not a table,
/// or a value that is not TOML, throws ProblemFileError at the override's origin; any other
/// defect the overrides cause throws as in the file, its message ending with the overrides
/// applied ("... (overrides: estimation.method = \"collocation\")").
Problem ParseProblem(const std::string& text, const std::string& path,
                     const std::vector<ProblemOverride>& overrides);

/// One split of one data file, ready for the formulations.
struct SplitData {
  std::string name;
  std::string data_name;
  SplitRole role = SplitRole::kEstimation;
  int begin = 0;  // first sample in the file
  /// Uniformly sampled; u and y in the model's input and output order, named and with units.
  Experiment experiment;
  /// The initial state x0 (see DataSpec::initial_state); Fit adds the state guess when
  /// node_guess = "data".
  ExperimentSetup setup;
  /// State index -> the estimation split whose estimated initial state this split starts from
  /// (DataSpec::initial_state_from_split); InitialStateOf applies it.
  std::map<int, std::string> x0_from_split;
  SourceLocation where;
};

/// Reads every data file, validates it and cuts it into splits, in file order. Throws
/// ProblemFileError naming the [[data]] entry (and the mapping) for every defect.
std::vector<SplitData> LoadData(const Problem& problem);

}  // namespace graybox::estimators
