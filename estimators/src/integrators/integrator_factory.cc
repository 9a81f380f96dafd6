#include "graybox/estimators/integrators/integrator_factory.h"
#include "graybox/util/did_you_mean.h"

#include <stdexcept>
#include <string>

#include "graybox/models/block.h"  // DidYouMean

namespace graybox::estimators {

const char* IntegrationMethodName(IntegrationMethod method) {
  switch (method) {
    case IntegrationMethod::kFixedStep:
      return "fixed_step";
    case IntegrationMethod::kCvodes:
      return "cvodes";
  }
  return "unknown";
}

IntegrationMethod ParseIntegrationMethod(const std::string& name) {
  for (IntegrationMethod m : {IntegrationMethod::kFixedStep, IntegrationMethod::kCvodes}) {
    if (name == IntegrationMethodName(m)) return m;
  }
  const std::string hint = util::DidYouMean(name, {"fixed_step", "cvodes"});
  throw std::invalid_argument("integration method: expected 'fixed_step' or 'cvodes', got '" +
                              name + "'" + (hint.empty() ? "" : "; did you mean '" + hint + "'?"));
}

void IntegratorOptions::Validate() const {
  switch (method) {
    case IntegrationMethod::kFixedStep:
      fixed_step.Validate();
      return;
    case IntegrationMethod::kCvodes:
      cvodes.Validate();
      return;
  }
  throw std::invalid_argument("IntegratorOptions.method: expected kFixedStep or kCvodes, got " +
                              std::to_string(static_cast<int>(method)));
}

std::unique_ptr<Integrator> MakeIntegrator(const models::StateSpaceModel& model, double dt,
                                           const IntegratorOptions& options) {
  options.Validate();
  if (options.method == IntegrationMethod::kCvodes) {
    return std::make_unique<CvodesIntegrator>(model, dt, options.cvodes);
  }
  return std::make_unique<FixedStepIntegrator>(model, dt, options.fixed_step);
}

}  // namespace graybox::estimators
