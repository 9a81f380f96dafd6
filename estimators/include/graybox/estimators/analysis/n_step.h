// N-step-ahead simulation error of a StateSpaceModel on a measured state trajectory (seed 000
// eq. 7): from the measured state at every start k, simulate N samples with the measured inputs
// and compare with the measured states, eta_N as defined in metrics.h (NStepNrms).
//
// The simulation is the fixed-step map of integrators.h (MakeStepFunction with options.step: RK4
// by default, an implicit scheme for stiff models). The name says "simulated" to set it apart from
// NStepNrms of metrics.h, which scores predictions the caller computed.
//
// The starts are independent: chunks of starts are spread over threads. With a C compiler (the
// default, options.generated_code) the step is generated C compiled at run time
// (expr::CompiledFunction, cached on disk across runs) and each start is simulated on its own;
// otherwise, or when compiling fails, each step is one batched tape evaluation over the chunk
// (SIMD lanes, see Function::EvaluateBatch), each thread with its own workspace. Both give the
// same numbers (the generated code evaluates the tape's operations with the same formulas);
// NStepResult::evaluation says which ran and, for the tape, why. Predictions are never stored for
// all starts at once (14850 starts x 150 steps x 12 states would be 214 MB); each chunk is scored
// and the sums are combined, which gives exactly the eta_N of NStepNrms over all starts.
#pragma once

#include <Eigen/Core>

#include "graybox/estimators/analysis/metrics.h"
#include "graybox/estimators/integrators/integrators.h"
#include "graybox/expr/codegen.h"
#include "graybox/models/model.h"

namespace graybox::estimators {

struct NStepSimulationOptions {
  /// Horizon, starts and the scored channels: scoring.channels are state indices of the model
  /// (empty scores every state; seed 000 scores the positions, and a problem file defaults to
  /// the measured states, MetricsSpec::n_step_channels). scoring.names defaults to the model's
  /// state names, so NStepResult::channel_names names the scored states.
  NStepOptions scoring;
  FixedStepOptions step;  // the one-step map: scheme, substeps per sample, Newton iterations
  int num_threads = 2;    // 0 means std::thread::hardware_concurrency()
  int chunk = 1024;       // starts simulated together
  /// Evaluate the step as generated C when a compiler is present (else the batched tape).
  bool generated_code = true;
  expr::JitOptions jit;  // compiler, flags and cache of the generated code
  /// Throws std::invalid_argument naming the invalid fields.
  void Validate() const;
};

/// x: N x nx measured states (row k at sample k), u: N x nu inputs (u_k held over the sample),
/// p: model parameters. Every state is simulated; only options.scoring.channels are scored.
/// Throws std::invalid_argument on size mismatches, bad options, or channel indices out of
/// range or repeated (checked before anything is simulated).
NStepResult NStepNrmsSimulated(const models::StateSpaceModel& model, const Eigen::MatrixXd& x,
                               const Eigen::MatrixXd& u, const Eigen::VectorXd& p, double dt,
                               const NStepSimulationOptions& options = {});

}  // namespace graybox::estimators
