// The `equations` table of a [[model.blocks]] entry of type "equations" (models/equation_block.h,
// docs/problem-format.md): read into the block's options, and the block's defects reported at the
// place in the file (inside an equation string: its line and the column of the character).
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "graybox/models/equation_block.h"
#include "problem_file_internal.h"

namespace graybox::estimators::internal {
namespace {

// Where each option key came from, to place the block's errors.
struct Places {
  std::map<std::string, SourceLocation> key;
  // Expression keys: the location of the string's first character (after the quote).
  std::map<std::string, SourceLocation> text;
};

// The entries of `list` ("inputs", "states" or "outputs"): names, units, ranges, roles and, for
// states and outputs, their equations.
void Signals(const Section& eq, const std::string& list, models::BlockOptions* o, Places* places) {
  const std::string expression = list == "states" ? "derivative" : list == "outputs" ? "value" : "";
  std::string names;
  for (const Section& s : eq.SubArray(list)) {
    std::vector<std::string> keys = {"name", "unit", "description", "min", "max", "role"};
    if (!expression.empty()) keys.push_back(expression);
    s.Allow(keys);
    const std::string name = s.RequiredString("name");
    names += (names.empty() ? "" : ",") + name;
    for (const char* k : {"unit", "description", "role", "range"}) {
      places->key[std::string(k) + "." + name] = s.Where(std::string(k) == "range" ? "min" : k);
    }
    for (const char* k : {"unit", "description", "role"}) {
      if (auto v = s.String(k)) o->words[std::string(k) + "." + name] = *v;
    }
    if (s.Has("min") || s.Has("max")) {
      o->numbers["range." + name] = {s.Number("min").value_or(-1.0), s.Number("max").value_or(1.0)};
    }
    if (expression.empty()) continue;
    const std::string key = (list == "states" ? "derivative." : "value.") + name;
    places->key[key] = s.Where(expression);
    if (auto text = s.String(expression)) {
      o->words[key] = *text;
      // The string's first character: one column after the opening quote.
      for (auto&& [k, v] : s.table()) {
        if (k.str() != expression) continue;
        SourceLocation at = s.Where(expression);
        at.line = static_cast<int>(v.source().begin.line);
        at.column = static_cast<int>(v.source().begin.column) + 1;
        places->text[key] = at;
      }
    }
  }
  if (eq.Has(list)) {
    o->words[list] = names;
    places->key[list] = eq.Where(list);
  }
}

}  // namespace

std::shared_ptr<const models::Block> EquationBlock(const Section& b) {
  const auto eq = b.Sub("equations");
  if (!eq) {
    b.Fail("",
           "a block of type 'equations' needs its table 'equations' (inputs, states, "
           "outputs, parameters, constants: docs/problem-format.md), got none");
  }
  eq->Allow({"inputs", "states", "outputs", "parameters", "constants", "description"});
  models::BlockOptions o;
  Places places;
  if (auto d = eq->String("description")) o.words["description"] = *d;
  Signals(*eq, "inputs", &o, &places);
  Signals(*eq, "states", &o, &places);
  Signals(*eq, "outputs", &o, &places);
  std::string names;
  for (const Section& p : eq->SubArray("parameters")) {
    p.Allow({"name", "unit", "description", "nominal", "lower", "upper", "neutral"});
    const std::string name = p.RequiredString("name");
    names += (names.empty() ? "" : ",") + name;
    if (auto v = p.String("unit")) o.words["unit." + name] = *v;
    if (auto v = p.String("description")) o.words["description." + name] = *v;
    if (auto v = p.Number("nominal")) o.numbers["nominal." + name] = {*v};
    if (auto v = p.Number("neutral")) o.numbers["neutral." + name] = {*v};
    if (p.Has("lower") || p.Has("upper")) {
      auto bound = [&](const char* key, double fallback) {
        const toml::node* n = p.Get(key);
        if (!n) return fallback;
        if (n->is_floating_point() && std::isinf(n->as_floating_point()->get())) {
          return n->as_floating_point()->get();
        }
        return p.NumberOf(*n, key);
      };
      o.numbers["bounds." + name] = {bound("lower", -std::numeric_limits<double>::infinity()),
                                     bound("upper", std::numeric_limits<double>::infinity())};
    }
    for (const char* k : {"unit.", "description.", "nominal.", "neutral.", "bounds."}) {
      places.key[k + name] = p.Where();
    }
  }
  if (eq->Has("parameters")) {
    o.words["parameters"] = names;
    places.key["parameters"] = eq->Where("parameters");
  }
  if (auto c = eq->Sub("constants")) {
    std::string constants;
    for (auto&& [k, v] : c->table()) {
      const std::string name(k.str());
      constants += (constants.empty() ? "" : ",") + name;
      o.numbers["constant." + name] = {c->NumberOf(v, name)};
      places.key["constant." + name] = c->Where(name);
    }
    o.words["constants"] = constants;
    places.key["constants"] = eq->Where("constants");
  }
  try {
    return models::MakeEquationBlock(o);
  } catch (const models::EquationError& e) {
    const auto text = places.text.find(e.field());
    if (text != places.text.end() && e.offset() >= 0) {
      SourceLocation at = text->second;
      at.column += e.offset();
      throw ProblemFileError(at, "equation '" + e.field() + "', column " +
                                     std::to_string(e.offset() + 1) +
                                     " of the equation: " + e.reason());
    }
    const auto key = places.key.find(e.field());
    throw ProblemFileError(key != places.key.end() ? key->second : eq->Where(),
                           "equations: " + std::string(e.what()));
  }
}

}  // namespace graybox::estimators::internal
