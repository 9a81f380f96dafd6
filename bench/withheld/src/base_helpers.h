// Helpers shared by the base builders of the withheld-effect cases (bases.cc,
// pneumatic_base.cc): setting true values in the truth and settings in the nominal model.
#pragma once

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "bases.h"
#include "graybox/models/block.h"
#include "graybox/models/model.h"

namespace graybox::bench::internal {

inline bool Has(const std::vector<std::string>& w, const std::string& e) {
  return std::find(w.begin(), w.end(), e) != w.end();
}

inline bool HasParameter(const models::Model& m, const std::string& name) {
  for (const models::ModelParameter& p : m.parameters()) {
    if (p.name == name) return true;
  }
  return false;
}

// A base parameter: its true value, its bounds and scale in the nominal problem, free or fixed.
struct BaseParameter {
  std::string name;
  double value;
  double lower, upper;
  bool free;
};

// Sets the true value in the truth and the setting in the nominal model, where they have it.
inline void Apply(const std::vector<BaseParameter>& table, BaseBuild* b) {
  for (const BaseParameter& p : table) {
    if (HasParameter(b->truth, p.name)) b->truth.SetParameter(p.name, p.value);
    if (!HasParameter(b->nominal, p.name)) continue;
    models::ModelParameter& q = b->nominal.Parameter(p.name);
    q.value = p.value;
    q.lower = p.lower;
    q.upper = p.upper;
    q.free = p.free;
    q.scale = std::max(std::fabs(p.value), 1e-6);
  }
}

// Sets the truth's effect parameters and records them.
inline void SetTruth(const std::string& instance, const std::map<std::string, double>& values,
                     BaseBuild* b) {
  for (const auto& [name, value] : values) {
    b->truth.SetParameter(instance + "." + name, value);
    b->truth_values[instance + "." + name] = value;
  }
}

inline void AddDetail(const std::string& text, BaseBuild* b) {
  if (!b->detail.empty()) b->detail += "; ";
  b->detail += text;
}

template <typename BlockT, typename... Args>
std::shared_ptr<const models::Block> Make(Args&&... args) {
  return std::make_shared<const BlockT>(std::forward<Args>(args)...);
}

inline models::BlockOptions Motion(const std::string& motion) {
  models::BlockOptions o;
  o.words["motion"] = motion;
  return o;
}

inline models::BlockOptions CoulombOptions(const std::string& motion, double steepness) {
  models::BlockOptions o = Motion(motion);
  o.numbers["steepness"] = {steepness};
  return o;
}

inline std::string Num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

}  // namespace graybox::bench::internal
