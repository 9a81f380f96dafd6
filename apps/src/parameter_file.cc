// Parameter values for `graybox simulate --params FILE`: a result.json or a TOML table.
#include <toml++/toml.h>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "app.h"
#include "graybox/models/block.h"
#include "graybox/util/did_you_mean.h"

namespace graybox::app {

using estimators::ProblemFileError;
using estimators::SourceLocation;

namespace {

SourceLocation At(const std::string& file, int line = 0, const std::string& table = "") {
  SourceLocation w;
  w.file = file;
  w.line = line;
  w.table = table;
  return w;
}

void CheckName(const std::string& file, const std::string& name, int line,
               const models::StateSpaceModel& model) {
  std::vector<std::string> names;
  for (const auto& p : model.parameters) {
    if (p.name == name) return;
    names.push_back(p.name);
  }
  const std::string hint = util::DidYouMean(name, names);
  throw ProblemFileError(At(file, line),
                         "'" + name + "' is not a parameter of model '" + model.name + "'" +
                             (hint.empty() ? "" : "; did you mean '" + hint + "'?"));
}

std::map<std::string, double> FromJson(const std::string& path, const std::string& text,
                                       const models::StateSpaceModel& model) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw ProblemFileError(At(path), std::string("JSON syntax error: ") + e.what());
  }
  if (!doc.is_object() || !doc.contains("parameters") || !doc["parameters"].is_object()) {
    throw ProblemFileError(At(path),
                           "expected a graybox result.json with a \"parameters\" object, "
                           "got a JSON document without one");
  }
  std::map<std::string, double> values;
  for (const auto& [name, entry] : doc["parameters"].items()) {
    CheckName(path, name, 0, model);
    const nlohmann::json& v = entry.is_object() && entry.contains("value") ? entry["value"] : entry;
    if (!v.is_number() || !std::isfinite(v.get<double>())) {
      throw ProblemFileError(At(path, 0, "parameters." + name),
                             "expected a finite number as the value, got " + v.dump());
    }
    values[name] = v.get<double>();
  }
  return values;
}

std::map<std::string, double> FromToml(const std::string& path, const std::string& text,
                                       const models::StateSpaceModel& model) {
  toml::table doc;
  try {
    doc = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    throw ProblemFileError(At(path, static_cast<int>(e.source().begin.line)),
                           "TOML syntax error: " + std::string(e.description()));
  }
  const toml::table* table = &doc;
  std::string prefix;
  if (doc.size() == 1 && doc.contains("parameters") && doc["parameters"].is_table()) {
    table = doc["parameters"].as_table();
    prefix = "parameters";
  }
  std::map<std::string, double> values;
  for (auto&& [k, v] : *table) {
    const std::string name(k.str());
    const int line = static_cast<int>(k.source().begin.line);
    CheckName(path, name, line, model);
    double value = std::nan("");
    if (const auto* i = v.as_integer()) value = static_cast<double>(i->get());
    if (const auto* f = v.as_floating_point()) value = f->get();
    if (!std::isfinite(value)) {
      throw ProblemFileError(At(path, line, prefix),
                             "'" + name + "': expected a finite number, got " +
                                 (v.is_number() ? std::to_string(value) : "a non-number"));
    }
    values[name] = value;
  }
  return values;
}

}  // namespace

std::map<std::string, double> LoadParameterValues(const std::string& path,
                                                  const models::StateSpaceModel& model) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ProblemFileError(At(path), "cannot read the parameter file: file not found");
  std::ostringstream text;
  text << in.rdbuf();
  const std::string s = text.str();
  const auto first = s.find_first_not_of(" \t\r\n");
  const bool json = path.size() >= 5 && path.compare(path.size() - 5, 5, ".json") == 0;
  if (json || (first != std::string::npos && s[first] == '{')) return FromJson(path, s, model);
  return FromToml(path, s, model);
}

}  // namespace graybox::app
