// Problem files (problem_file.h, docs/problem-format.md): the entry points, [problem] and [model].
// [[data]] and the data loading are in problem_data.cc, [estimation] and [metrics] in
// problem_estimation.cc; the TOML reader they share is problem_file_internal.h.
#include "graybox/estimators/problem/problem_file.h"
#include "graybox/util/did_you_mean.h"

#include <toml++/toml.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <utility>

#include "graybox/models/augmentation.h"
#include "graybox/models/block.h"
#include "graybox/models/block_plugin.h"
#include "graybox/models/equation_block.h"
#include "problem/problem_file_internal.h"

namespace graybox::estimators {

namespace fs = std::filesystem;

std::string SourceLocation::ToString() const {
  std::string s = file;
  if (line > 0) {
    s += ":" + std::to_string(line);
    if (column > 0) s += ":" + std::to_string(column);
  }
  if (!s.empty()) s += ":";
  if (!table.empty()) s += (s.empty() ? "[" : " [") + table + "]";
  return s;
}

ProblemFileError::ProblemFileError(SourceLocation where, const std::string& message)
    : std::invalid_argument(where.ToString() + " " + message),
      where_(std::move(where)),
      message_(message) {}

const char* SplitRoleName(SplitRole role) {
  switch (role) {
    case SplitRole::kEstimation:
      return "estimation";
    case SplitRole::kValidation:
      return "validation";
    case SplitRole::kTest:
      return "test";
  }
  return "estimation";
}

namespace internal {

// ---- [model] ------------------------------------------------------------------------------------

models::BlockOptions ParseBlockOptions(const Section& s) {
  models::BlockOptions options;
  for (auto&& [k, v] : s.table()) {
    const std::string key(k.str());
    if (v.is_string()) {
      options.words[key] = v.as_string()->get();
    } else if (v.is_boolean()) {
      options.numbers[key] = {v.as_boolean()->get() ? 1.0 : 0.0};
    } else if (v.is_number()) {
      options.numbers[key] = {s.NumberOf(v, key)};
    } else if (const toml::array* a = v.as_array()) {
      std::vector<double> values;
      for (std::size_t i = 0; i < a->size(); ++i) values.push_back(s.NumberOf(*a->get(i), key));
      options.numbers[key] = values;
    } else {
      s.Fail(key, "option '" + key + "': expected a number, an array of numbers or a word, got " +
                      ValueText(v));
    }
  }
  return options;
}

// Applies the entry `key` (a parameter name, or a pattern that matched parameter `name`).
void ApplyParameter(const Section& parameters, const std::string& key, const std::string& name,
                    const toml::node& node, Problem* problem) {
  models::ModelParameter* par = nullptr;
  try {
    par = &problem->model.Parameter(name);
  } catch (const std::invalid_argument& e) {
    parameters.Fail(key, e.what());
  }
  std::optional<double> value, lower, upper, scale;
  std::optional<bool> free;
  if (node.is_number()) {
    value = parameters.NumberOf(node, key);
  } else if (node.is_table()) {
    const Section p(parameters.file(), *node.as_table(), parameters.Join(key));
    p.Allow({"value", "lower", "upper", "free", "scale"});
    value = p.Number("value");
    // Bounds may be infinite (TOML's inf and -inf); values and scales may not.
    auto bound = [&](const char* key) -> std::optional<double> {
      const toml::node* b = p.Get(key);
      if (!b) return std::nullopt;
      if (b->is_floating_point() && std::isinf(b->as_floating_point()->get())) {
        return b->as_floating_point()->get();
      }
      return p.NumberOf(*b, key);
    };
    lower = bound("lower");
    upper = bound("upper");
    scale = p.PositiveNumber("scale");
    free = p.Bool("free");
  } else {
    parameters.Fail(key, "parameter '" + name +
                             "': expected a number or a table {value, lower, "
                             "upper, free, scale}, got " +
                             ValueText(node));
  }
  const double lo = lower.value_or(par->lower), hi = upper.value_or(par->upper);
  if (!(lo <= hi)) {
    parameters.Fail(key, "parameter '" + name +
                             "': infeasible bounds: expected lower <= upper, got lower = " +
                             Format(lo) + " > upper = " + Format(hi));
  }
  const double v = value.value_or(par->value);
  if (v < lo || v > hi) {
    parameters.Fail(key, "parameter '" + name + "': expected a value in [" + Format(lo) + ", " +
                             Format(hi) + "], got " + Format(v) +
                             (value ? "" : " (the block's nominal value)"));
  }
  par->lower = lo;
  par->upper = hi;
  par->value = v;
  if (scale) par->scale = *scale;
  if (free) par->free = *free;
  // A scale far from the parameter's magnitude freezes it for the solver (it moves value / scale:
  // scale = 1e308 leaves it at 1e-308) or blows its variable up: refused for a free parameter.
  if (scale && par->free) {
    double magnitude = std::fabs(v);
    if (std::isfinite(lo)) magnitude = std::max(magnitude, std::fabs(lo));
    if (std::isfinite(hi)) magnitude = std::max(magnitude, std::fabs(hi));
    constexpr double kMaxScaleRatio = 1e8;
    if (magnitude > 0.0 &&
        (*scale > kMaxScaleRatio * magnitude || *scale * kMaxScaleRatio < magnitude)) {
      parameters.Fail(key, "parameter '" + name +
                               "': 'scale': expected a scale within a factor of 1e8 of the " +
                               "parameter's magnitude " + Format(magnitude) +
                               " (its value and finite bounds), got " + Format(*scale) +
                               ": the solver moves value / scale and could not move it");
    }
  }
}

// A block created from the registry for the table `b` (keys "type" and "options"): an unknown
// type is reported at "type" with a suggestion, a bad option at "options".
std::shared_ptr<const models::Block> CreateBlock(const Section& b, const std::string& type,
                                                 const models::BlockOptions& options) {
  try {
    return models::BlockRegistry::Global().Create(type, options);
  } catch (const std::invalid_argument& e) {
    const auto types = models::BlockRegistry::Global().Types();
    const bool known = std::find(types.begin(), types.end(), type) != types.end();
    b.Fail(known && b.Has("options") ? "options" : "type", e.what());
  }
}

// One [[model.augment]] table, applied to problem->model (problem-format.md, "Augmentations").
// The placement is exactly one of inputs + outputs (add), on_signal, on_input, on_output (with
// optional readers) and for_readers = {signal, readers, extra_inputs}.
void ParseAugmentation(const Section& t, Problem* problem) {
  using Kind = models::Augmentation::Kind;
  t.Allow({"instance", "type", "options", "inputs", "outputs", "on_signal", "on_input", "on_output",
           "readers", "for_readers"});
  models::Augmentation a;
  a.instance = t.RequiredString("instance");
  a.type = t.RequiredString("type");
  const std::string label = "augmentation '" + a.instance + "': ";
  if (auto o = t.Sub("options")) a.options = ParseBlockOptions(*o);
  std::vector<std::string> given;
  if (t.Has("inputs") || t.Has("outputs")) given.push_back(t.Has("inputs") ? "inputs" : "outputs");
  for (const char* key : {"on_signal", "on_input", "on_output", "for_readers"}) {
    if (t.Has(key)) given.push_back(key);
  }
  const std::string expected =
      "expected exactly one of 'inputs' and 'outputs' (add the block), 'on_signal', 'on_input', "
      "'on_output' or 'for_readers'";
  if (given.empty()) t.Fail("", label + "missing placement: " + expected + ", got none of them");
  if (given.size() > 1) {
    t.Fail(given[1], label + expected + ", got both '" + given[0] + "' and '" + given[1] + "'");
  }
  if (t.Has("readers") && given[0] != "on_output") {
    t.Fail("readers", label + "'readers' goes with 'on_output'" +
                          (given[0] == "for_readers"
                               ? "; with 'for_readers' the readers are inside its table, "
                                 "for_readers = { signal = ..., readers = [...] }"
                               : ": expected it left out with '" + given[0] + "'"));
  }
  std::optional<Section> fr;
  if (given[0] == "inputs" || given[0] == "outputs") {
    a.kind = Kind::kAdd;
    a.inputs = t.Strings("inputs");
    a.outputs = t.Strings("outputs");
  } else if (given[0] == "on_signal") {
    a.kind = Kind::kOnSignal;
    a.signal = t.RequiredString("on_signal");
  } else if (given[0] == "on_input") {
    a.kind = Kind::kOnInput;
    a.signal = t.RequiredString("on_input");
  } else if (given[0] == "on_output") {
    a.kind = Kind::kOnOutput;
    a.signal = t.RequiredString("on_output");
    a.readers = t.Strings("readers");
  } else {
    a.kind = Kind::kForReaders;
    fr = t.Sub("for_readers");
    fr->Allow({"signal", "readers", "extra_inputs"});
    a.signal = fr->RequiredString("signal");
    if (!fr->Has("readers")) {
      fr->Fail("", label + "missing key 'readers': expected the block instances that read '" +
                       a.signal + "' and are to read the block's output instead");
    }
    a.readers = fr->Strings("readers");
    a.extra_inputs = fr->Strings("extra_inputs");
  }
  try {
    models::ApplyAugmentation(&problem->model, a);
  } catch (const models::AugmentationError& e) {
    // The key the defective field came from.
    const std::string& field = e.field();
    const Section* where = &t;
    std::string key = field;
    if (field == "options" && !t.Has("options")) key = "type";
    if (field == "signal") key = a.kind == Kind::kForReaders ? "signal" : given[0];
    if (a.kind == Kind::kForReaders &&
        (field == "signal" || field == "readers" || field == "extra_inputs")) {
      where = &*fr;
    }
    const std::string shown = where == &t ? key : "for_readers." + key;
    where->Fail(where->Has(key) ? key : "", label + "'" + shown + "': " + e.reason());
  }
  problem->augmentations.push_back(a);
  problem->blocks.emplace_back(a.instance, a.type);
}

void ParseModel(const Section& root, Problem* problem) {
  auto model = root.Sub("model");
  if (!model) root.Fail("", "missing table [model]: expected the model description");
  const Section& m = *model;
  m.Allow({"name", "plugins", "inputs", "blocks", "outputs", "augment", "parameters"});
  // Block plugins first: their types are then known to the blocks below (models/block_plugin.h).
  if (m.Has("plugins")) {
    const std::vector<std::string> plugins = m.Strings("plugins");
    const toml::array* a = m.Get("plugins")->as_array();
    for (std::size_t i = 0; i < plugins.size(); ++i) {
      const std::string path =
          (fs::path(problem->directory) / plugins[i]).lexically_normal().string();
      try {
        models::LoadBlockPlugin(path);
      } catch (const std::exception& e) {
        throw ProblemFileError(m.Location(a->get(i)->source()),
                               "'plugins[" + std::to_string(i) + "]': " + e.what());
      }
      problem->plugins.push_back(path);
    }
  }
  problem->model = models::Model(m.String("name").value_or(problem->name));
  for (const Section& in : m.SubArray("inputs")) {
    in.Allow({"name", "unit", "description", "min", "max"});
    const std::string name = in.RequiredString("name");
    const double lo = in.Number("min").value_or(-1.0), hi = in.Number("max").value_or(1.0);
    if (!(lo < hi))
      in.Fail("max", "expected min < max, got [" + Format(lo) + ", " + Format(hi) + "]");
    try {
      problem->model.AddInput(name, in.String("unit").value_or(""),
                              in.String("description").value_or(""), lo, hi);
    } catch (const std::invalid_argument& e) {
      in.Fail("name", e.what());
    }
  }
  const auto blocks = m.SubArray("blocks");
  if (blocks.empty()) m.Fail("", "missing [[model.blocks]]: expected at least one block");
  for (const Section& b : blocks) {
    const std::string type = b.RequiredString("type");
    const bool equations = type == models::kEquationBlock;
    if (equations) {
      b.Allow({"instance", "type", "equations", "inputs", "outputs"});
    } else {
      b.Allow({"instance", "type", "options", "inputs", "outputs"});
    }
    const std::string instance = b.RequiredString("instance");
    models::BlockOptions options;
    if (auto o = b.Sub("options")) options = ParseBlockOptions(*o);
    const std::shared_ptr<const models::Block> block =
        equations ? EquationBlock(b) : CreateBlock(b, type, options);
    const std::vector<std::string> inputs = b.Strings("inputs");
    const std::vector<std::string> outputs = b.Strings("outputs");
    try {
      problem->model.AddBlock(instance, block, inputs, outputs);
    } catch (const std::invalid_argument& e) {
      b.Fail("instance", e.what());
    }
    problem->blocks.emplace_back(instance, type);
  }
  const std::vector<std::string> outputs = m.Strings("outputs");
  if (outputs.empty()) m.Fail("", "missing key 'outputs': expected the measured output signals");
  for (const auto& o : outputs) problem->model.AddOutput(o);
  // Augmentations after every block and output, before the parameter settings (which may set,
  // free or fix the new parameters).
  for (const Section& a : m.SubArray("augment")) ParseAugmentation(a, problem);
  if (auto parameters = m.Sub("parameters")) {
    // Patterns ('*' matches any run of characters) first, then exact names, which override.
    std::map<std::string, std::string> matched_by;
    for (auto&& [k, v] : parameters->table()) {
      const std::string key(k.str());
      if (key.find('*') == std::string::npos) continue;
      int matches = 0;
      for (const models::ModelParameter& par : problem->model.parameters()) {
        if (!GlobMatch(key, par.name)) continue;
        auto [it, inserted] = matched_by.emplace(par.name, key);
        if (!inserted) {
          parameters->Fail(key, "parameter '" + par.name + "' is matched by the patterns '" +
                                    it->second + "' and '" + key +
                                    "': expected at most one pattern per parameter");
        }
        ApplyParameter(*parameters, key, par.name, v, problem);
        ++matches;
      }
      if (matches == 0) {
        parameters->Fail(key, "pattern '" + key + "' matches no model parameter");
      }
    }
    for (auto&& [k, v] : parameters->table()) {
      const std::string key(k.str());
      if (key.find('*') == std::string::npos) ApplyParameter(*parameters, key, key, v, problem);
    }
  }
  try {
    problem->built = problem->model.Build();
  } catch (const std::invalid_argument& e) {
    m.Fail("", e.what());
  }
}

}  // namespace internal

namespace {

// The sections of a parsed (and overridden) file.
Problem ParseProblemTables(const toml::table& root, const std::string& path, Problem problem) {
  const internal::Section top(path, root, "");
  top.Allow({"problem", "model", "data", "estimation", "metrics", "diagnosis"});
  problem.name = fs::path(path).stem().string();
  if (auto p = top.Sub("problem")) {
    p->Allow({"name", "description"});
    problem.name = p->String("name").value_or(problem.name);
    problem.description = p->String("description").value_or("");
  }
  internal::ParseModel(top, &problem);
  internal::ParseData(top, &problem);
  internal::ApplyFirstOrderHolds(&problem);
  internal::ParseEstimation(top, &problem);
  internal::ParseMetrics(top, &problem);
  internal::ParseDiagnosis(top, &problem);
  // Every model output must be measured in every data entry (ParseMapping) and equation error
  // needs the outputs it differentiates; nothing else to cross-check before the data are read.
  return problem;
}

}  // namespace

Problem ParseProblem(const std::string& text, const std::string& path) {
  return ParseProblem(text, path, {});
}

Problem ParseProblem(const std::string& text, const std::string& path,
                     const std::vector<ProblemOverride>& overrides) {
  Problem problem;
  problem.path = path;
  problem.directory = fs::path(path).parent_path().string();
  if (problem.directory.empty()) problem.directory = ".";
  toml::table root = toml_io::ParseToml(text, path);
  internal::ApplyOverrides(overrides, &root);
  if (!overrides.empty()) {
    // The sections are read below as in a file that said so; a defect the overrides cause is
    // located in the file's tables (an added key has no line): say which overrides were applied.
    try {
      return ParseProblemTables(root, path, std::move(problem));
    } catch (const ProblemFileError& e) {
      throw ProblemFileError(
          e.where(), e.message() + " (overrides: " + internal::OverridesText(overrides) + ")");
    }
  }
  return ParseProblemTables(root, path, std::move(problem));
}

Problem LoadProblem(const std::string& path) { return LoadProblem(path, {}); }

Problem LoadProblem(const std::string& path, const std::vector<ProblemOverride>& overrides) {
  return ParseProblem(toml_io::ReadFileText(path, "problem file"), path, overrides);
}

}  // namespace graybox::estimators
