// Choosing an integrator from options: a fixed-step scheme (explicit RK4 or an implicit
// Runge-Kutta scheme, integrators.h) or CVODES BDF, behind the Integrator interface of
// integrators.h.
//
//   IntegratorOptions options;
//   options.method = IntegrationMethod::kCvodes;   // stiff model, error-controlled
//   options.cvodes.relative_tolerance = 1e-8;
//   // or: options.fixed_step.scheme = StepScheme::kRadauIIA;  (stiff model, fixed step)
//   std::unique_ptr<Integrator> integrator = MakeIntegrator(model, dt, options);
//   Trajectory t = integrator->Simulate(x0, u, p);
#pragma once

#include <memory>
#include <string>

#include "graybox/estimators/integrators/cvodes_integrator.h"
#include "graybox/estimators/integrators/integrators.h"

namespace graybox::estimators {

enum class IntegrationMethod {
  kFixedStep,  // FixedStepIntegrator: fixed_step.scheme, fixed_step.substeps steps per sample
  kCvodes,     // CVODES variable-order BDF with Newton iteration and error control (stiff models)
};

/// "fixed_step" or "cvodes".
const char* IntegrationMethodName(IntegrationMethod method);
/// Inverse of IntegrationMethodName; std::invalid_argument with a did-you-mean hint otherwise.
IntegrationMethod ParseIntegrationMethod(const std::string& name);

struct IntegratorOptions {
  IntegrationMethod method = IntegrationMethod::kFixedStep;
  /// Scheme, steps per sample interval and Newton iterations; unused by CVODES.
  FixedStepOptions fixed_step;
  /// CVODES settings; unused by the fixed-step schemes.
  CvodesOptions cvodes;
  /// Throws std::invalid_argument explaining the first invalid field (the chosen method's only).
  void Validate() const;
};

/// The integrator for `model` at sample time dt [s]. Throws std::invalid_argument for invalid
/// options or dt <= 0.
std::unique_ptr<Integrator> MakeIntegrator(const models::StateSpaceModel& model, double dt,
                                           const IntegratorOptions& options = {});

}  // namespace graybox::estimators
