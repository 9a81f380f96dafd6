#include "graybox/estimators/integrator_factory.h"

#include <stdexcept>
#include <string>

#include "graybox/models/block.h"  // DidYouMean

namespace graybox::estimators {

const char* IntegrationMethodName(IntegrationMethod method) {
  switch (method) {
    case IntegrationMethod::kRk4:
      return "rk4";
    case IntegrationMethod::kCvodes:
      return "cvodes";
  }
  return "unknown";
}

IntegrationMethod ParseIntegrationMethod(const std::string& name) {
  for (IntegrationMethod m : {IntegrationMethod::kRk4, IntegrationMethod::kCvodes}) {
    if (name == IntegrationMethodName(m)) return m;
  }
  const std::string hint = models::DidYouMean(name, {"rk4", "cvodes"});
  throw std::invalid_argument("integration method: expected 'rk4' or 'cvodes', got '" + name + "'" +
                              (hint.empty() ? "" : "; did you mean '" + hint + "'?"));
}

void IntegratorOptions::Validate() const {
  switch (method) {
    case IntegrationMethod::kRk4:
      if (rk4_substeps < 1) {
        throw std::invalid_argument("IntegratorOptions.rk4_substeps: expected >= 1, got " +
                                    std::to_string(rk4_substeps));
      }
      return;
    case IntegrationMethod::kCvodes:
      cvodes.Validate();
      return;
  }
  throw std::invalid_argument("IntegratorOptions.method: expected kRk4 or kCvodes, got " +
                              std::to_string(static_cast<int>(method)));
}

std::unique_ptr<Integrator> MakeIntegrator(const models::StateSpaceModel& model, double dt,
                                           const IntegratorOptions& options) {
  options.Validate();
  if (options.method == IntegrationMethod::kCvodes) {
    return std::make_unique<CvodesIntegrator>(model, dt, options.cvodes);
  }
  return std::make_unique<Rk4Integrator>(model, dt, options.rk4_substeps);
}

}  // namespace graybox::estimators
