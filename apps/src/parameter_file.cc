// Parameter values for `graybox simulate --params FILE`: a result.json or a TOML table.
#include <toml++/toml.h>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "app.h"
#include "graybox/models/block.h"
#include "graybox/util/did_you_mean.h"
#include "graybox/util/read_file.h"

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
  } catch (const nlohmann::json::exception& e) {
    // Syntax errors and numbers out of range (1e999) alike.
    throw ProblemFileError(At(path), std::string("JSON error: ") + e.what());
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

std::map<std::string, double> LoadParameterValues(const std::string& given,
                                                  const models::StateSpaceModel& model) {
  namespace fs = std::filesystem;
  std::error_code ec;
  std::string path = given;
  // A run folder: its result.json.
  if (fs::is_directory(given, ec)) {
    path = (fs::path(given) / "result.json").string();
    if (!fs::is_regular_file(path, ec)) {
      throw ProblemFileError(At(given),
                             "expected a parameter file (result.json or TOML) or a "
                             "run folder with a result.json, got a folder without one");
    }
  }
  std::string why;
  const std::optional<std::string> text = util::ReadWholeFile(path, &why);
  if (!text) throw ProblemFileError(At(path), "cannot read the parameter file: " + why);
  const std::string& s = *text;
  const auto first = s.find_first_not_of(" \t\r\n");
  const bool json = path.size() >= 5 && path.compare(path.size() - 5, 5, ".json") == 0;
  const std::map<std::string, double> values =
      json || (first != std::string::npos && s[first] == '{') ? FromJson(path, s, model)
                                                              : FromToml(path, s, model);
  if (values.empty()) {
    throw ProblemFileError(
        At(path), "expected at least one parameter value of model '" + model.name + "', got none");
  }
  // Values outside the problem's bounds are refused (a fixed parameter's bounds included: they
  // are the physical range the problem file states).
  for (const auto& [name, value] : values) {
    const models::ModelParameter& p = model.parameters[model.ParameterIndex(name)];
    if (value < p.lower || value > p.upper) {
      char line[256];
      std::snprintf(line, sizeof line,
                    "'%s' = %.6g: expected a value within the problem's bounds "
                    "[%.6g, %.6g]",
                    name.c_str(), value, p.lower, p.upper);
      throw ProblemFileError(At(path, 0, "parameters"), line);
    }
  }
  return values;
}

}  // namespace graybox::app
