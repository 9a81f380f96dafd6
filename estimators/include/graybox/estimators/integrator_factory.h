// Choosing an integrator from options: fixed-step RK4 or CVODES BDF behind the Integrator
// interface of integrators.h.
//
//   IntegratorOptions options;
//   options.method = IntegrationMethod::kCvodes;   // stiff model
//   options.cvodes.relative_tolerance = 1e-8;
//   std::unique_ptr<Integrator> integrator = MakeIntegrator(model, dt, options);
//   Trajectory t = integrator->Simulate(x0, u, p);
#pragma once

#include <memory>
#include <string>

#include "graybox/estimators/cvodes_integrator.h"
#include "graybox/estimators/integrators.h"

namespace graybox::estimators {

enum class IntegrationMethod {
  kRk4,     // fixed-step classical RK4, rk4_substeps steps per sample (non-stiff models)
  kCvodes,  // CVODES variable-order BDF with Newton iteration (stiff models)
};

/// "rk4" or "cvodes".
const char* IntegrationMethodName(IntegrationMethod method);
/// Inverse of IntegrationMethodName; std::invalid_argument with a did-you-mean hint otherwise.
IntegrationMethod ParseIntegrationMethod(const std::string& name);

struct IntegratorOptions {
  IntegrationMethod method = IntegrationMethod::kRk4;
  /// RK4 steps per sample interval (>= 1); unused by CVODES.
  int rk4_substeps = 1;
  /// CVODES settings; unused by RK4.
  CvodesOptions cvodes;
  /// Throws std::invalid_argument explaining the first invalid field (the chosen method's only).
  void Validate() const;
};

/// The integrator for `model` at sample time dt [s]. Throws std::invalid_argument for invalid
/// options or dt <= 0.
std::unique_ptr<Integrator> MakeIntegrator(const models::StateSpaceModel& model, double dt,
                                           const IntegratorOptions& options = {});

}  // namespace graybox::estimators
