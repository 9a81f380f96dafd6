// Problem files (problem_file.h, docs/problem-format.md): TOML parsing with toml++, checks with
// file, table and line in every message, and the data loading of the [[data]] entries.
#include "graybox/estimators/problem_file.h"

#include <toml++/toml.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <utility>

#include "graybox/estimators/csv_file.h"
#include "graybox/estimators/mat_file.h"
#include "graybox/models/block.h"
#include "graybox/models/mechanics.h"

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

namespace {

std::string Format(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

std::string Quoted(const std::vector<std::string>& words) {
  std::string s;
  for (const auto& w : words) s += (s.empty() ? "'" : ", '") + w + "'";
  return s.empty() ? "(none)" : s;
}

std::string Suggestion(const std::string& word, const std::vector<std::string>& candidates) {
  const std::string hint = models::DidYouMean(word, candidates);
  return hint.empty() ? "" : "; did you mean '" + hint + "'?";
}

std::string TypeName(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::string:
      return "a string";
    case toml::node_type::integer:
      return "an integer";
    case toml::node_type::floating_point:
      return "a float";
    case toml::node_type::boolean:
      return "a boolean";
    case toml::node_type::array:
      return "an array";
    case toml::node_type::table:
      return "a table";
    case toml::node_type::date:
    case toml::node_type::time:
    case toml::node_type::date_time:
      return "a date/time";
    default:
      return "nothing";
  }
}

std::string ValueText(const toml::node& n) {
  if (const auto* s = n.as_string()) return TypeName(n) + " '" + s->get() + "'";
  if (const auto* i = n.as_integer()) return TypeName(n) + " " + std::to_string(i->get());
  if (const auto* f = n.as_floating_point()) return TypeName(n) + " " + Format(f->get());
  if (const auto* b = n.as_boolean()) return TypeName(n) + (b->get() ? " true" : " false");
  return TypeName(n);
}

// A TOML table being read: typed access with messages that name the file, the table path and the
// line, and a check that rejects unknown keys with a suggestion.
class Section {
 public:
  Section(std::string file, const toml::table& table, std::string path)
      : file_(std::move(file)), table_(&table), path_(std::move(path)) {}

  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }
  const toml::table& table() const { return *table_; }

  SourceLocation Where() const { return Location(table_->source()); }
  SourceLocation Where(const std::string& key) const {
    for (auto&& [k, v] : *table_) {
      if (k.str() == key) return Location(k.source().begin.line > 0 ? k.source() : v.source());
    }
    return Where();
  }
  SourceLocation Location(const toml::source_region& region) const {
    SourceLocation w;
    w.file = file_;
    w.table = path_;
    w.line = static_cast<int>(region.begin.line);
    w.column = static_cast<int>(region.begin.column);
    return w;
  }
  [[noreturn]] void Fail(const std::string& key, const std::string& message) const {
    throw ProblemFileError(key.empty() ? Where() : Where(key), message);
  }

  void Allow(const std::vector<std::string>& known) const {
    for (auto&& [k, v] : *table_) {
      const std::string key(k.str());
      if (std::find(known.begin(), known.end(), key) == known.end()) {
        throw ProblemFileError(Location(k.source()), "unknown key '" + key + "'" +
                                                         Suggestion(key, known) +
                                                         " (known keys: " + Quoted(known) + ")");
      }
    }
  }

  bool Has(const std::string& key) const { return table_->contains(key); }
  const toml::node* Get(const std::string& key) const { return table_->get(key); }

  std::optional<std::string> String(const std::string& key) const {
    const toml::node* n = Get(key);
    if (!n) return std::nullopt;
    if (!n->is_string()) Fail(key, "'" + key + "': expected a string, got " + ValueText(*n));
    return n->as_string()->get();
  }
  std::string RequiredString(const std::string& key) const {
    auto s = String(key);
    if (!s) Fail("", "missing key '" + key + "': expected a string");
    if (s->empty()) Fail(key, "'" + key + "': expected a non-empty string, got ''");
    return *s;
  }
  std::optional<double> Number(const std::string& key) const {
    const toml::node* n = Get(key);
    if (!n) return std::nullopt;
    return NumberOf(*n, key);
  }
  double NumberOf(const toml::node& n, const std::string& key) const {
    double v = 0.0;
    if (const auto* i = n.as_integer()) {
      v = static_cast<double>(i->get());
    } else if (const auto* f = n.as_floating_point()) {
      v = f->get();
    } else {
      Fail(key, "'" + key + "': expected a number, got " + ValueText(n));
    }
    if (!std::isfinite(v)) Fail(key, "'" + key + "': expected a finite number, got " + Format(v));
    return v;
  }
  std::optional<double> PositiveNumber(const std::string& key) const {
    auto v = Number(key);
    if (v && !(*v > 0.0)) Fail(key, "'" + key + "': expected a number > 0, got " + Format(*v));
    return v;
  }
  std::optional<long> Integer(const std::string& key, long lo, long hi) const {
    const toml::node* n = Get(key);
    if (!n) return std::nullopt;
    if (!n->is_integer()) {
      Fail(key, "'" + key + "': expected an integer in [" + std::to_string(lo) + ", " +
                    std::to_string(hi) + "], got " + ValueText(*n));
    }
    const long v = static_cast<long>(n->as_integer()->get());
    if (v < lo || v > hi) {
      Fail(key, "'" + key + "': expected an integer in [" + std::to_string(lo) + ", " +
                    std::to_string(hi) + "], got " + std::to_string(v));
    }
    return v;
  }
  std::optional<bool> Bool(const std::string& key) const {
    const toml::node* n = Get(key);
    if (!n) return std::nullopt;
    if (!n->is_boolean()) Fail(key, "'" + key + "': expected true or false, got " + ValueText(*n));
    return n->as_boolean()->get();
  }
  std::optional<std::string> Choice(const std::string& key,
                                    const std::vector<std::string>& allowed) const {
    auto s = String(key);
    if (s && std::find(allowed.begin(), allowed.end(), *s) == allowed.end()) {
      Fail(key, "'" + key + "': expected one of " + Quoted(allowed) + ", got '" + *s + "'" +
                    Suggestion(*s, allowed));
    }
    return s;
  }
  std::vector<std::string> Strings(const std::string& key) const {
    std::vector<std::string> out;
    const toml::node* n = Get(key);
    if (!n) return out;
    const toml::array* a = n->as_array();
    if (!a) Fail(key, "'" + key + "': expected an array of strings, got " + ValueText(*n));
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node& e = *a->get(i);
      if (!e.is_string()) {
        throw ProblemFileError(
            Location(e.source()),
            "'" + key + "[" + std::to_string(i) + "]': expected a string, got " + ValueText(e));
      }
      out.push_back(e.as_string()->get());
    }
    return out;
  }
  std::optional<Section> Sub(const std::string& key) const {
    const toml::node* n = Get(key);
    if (!n) return std::nullopt;
    if (!n->is_table()) Fail(key, "'" + key + "': expected a table, got " + ValueText(*n));
    return Section(file_, *n->as_table(), Join(key));
  }
  std::vector<Section> SubArray(const std::string& key) const {
    std::vector<Section> out;
    const toml::node* n = Get(key);
    if (!n) return out;
    if (n->is_table()) {
      out.emplace_back(file_, *n->as_table(), Join(key));
      return out;
    }
    const toml::array* a = n->as_array();
    if (!a) Fail(key, "'" + key + "': expected an array of tables, got " + ValueText(*n));
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node& e = *a->get(i);
      if (!e.is_table()) {
        throw ProblemFileError(
            Location(e.source()),
            "'" + key + "[" + std::to_string(i) + "]': expected a table, got " + ValueText(e));
      }
      out.emplace_back(file_, *e.as_table(), Join(key) + "[" + std::to_string(i) + "]");
    }
    return out;
  }
  std::string Join(const std::string& key) const {
    const bool plain = std::all_of(key.begin(), key.end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
    });
    const std::string k = plain ? key : "\"" + key + "\"";
    return path_.empty() ? k : path_ + "." + k;
  }

 private:
  std::string file_;
  const toml::table* table_;
  std::string path_;
};

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

// '*' matches any run of characters (possibly empty); every other character matches itself.
bool GlobMatch(const std::string& pattern, const std::string& text) {
  std::size_t p = 0, t = 0, star = std::string::npos, mark = 0;
  while (t < text.size()) {
    if (p < pattern.size() && pattern[p] == '*') {
      star = p++;
      mark = t;
    } else if (p < pattern.size() && pattern[p] == text[t]) {
      ++p;
      ++t;
    } else if (star != std::string::npos) {
      p = star + 1;
      t = ++mark;
    } else {
      return false;
    }
  }
  while (p < pattern.size() && pattern[p] == '*') ++p;
  return p == pattern.size();
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
}

void ParseModel(const Section& root, Problem* problem) {
  auto model = root.Sub("model");
  if (!model) root.Fail("", "missing table [model]: expected the model description");
  const Section& m = *model;
  m.Allow({"name", "inputs", "blocks", "outputs", "parameters"});
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
    b.Allow({"instance", "type", "options", "inputs", "outputs"});
    const std::string instance = b.RequiredString("instance");
    const std::string type = b.RequiredString("type");
    models::BlockOptions options;
    if (auto o = b.Sub("options")) options = ParseBlockOptions(*o);
    std::shared_ptr<const models::Block> block;
    try {
      block = models::BlockRegistry::Global().Create(type, options);
    } catch (const std::invalid_argument& e) {
      const auto types = models::BlockRegistry::Global().Types();
      const bool known = std::find(types.begin(), types.end(), type) != types.end();
      b.Fail(known && b.Has("options") ? "options" : "type", e.what());
    }
    const std::vector<std::string> inputs = b.Strings("inputs");
    const std::vector<std::string> outputs = b.Strings("outputs");
    try {
      problem->model.AddBlock(instance, block, inputs, outputs);
    } catch (const std::invalid_argument& e) {
      b.Fail("instance", e.what());
    }
    problem->blocks.emplace_back(instance, type);
    for (const auto& par : block->info().parameters) {
      if (models::IsFixedByDefault(type, par.name)) problem->model.Fix(instance + "." + par.name);
    }
  }
  const std::vector<std::string> outputs = m.Strings("outputs");
  if (outputs.empty()) m.Fail("", "missing key 'outputs': expected the measured output signals");
  for (const auto& o : outputs) problem->model.AddOutput(o);
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

// ---- [[data]] -----------------------------------------------------------------------------------

ChannelSource ParseSource(const Section& mapping, const std::string& signal, const toml::node& node,
                          bool csv) {
  ChannelSource c;
  c.signal = signal;
  c.where = mapping.Where(signal);
  if (node.is_string()) {
    c.variable = node.as_string()->get();
  } else if (node.is_table()) {
    const Section t(mapping.file(), *node.as_table(), mapping.Join(signal));
    t.Allow({"variable", "scale", "column", "row", "rate", "constant"});
    c.rate = t.Bool("rate").value_or(false);
    if (t.Has("constant")) {
      for (const char* other : {"variable", "scale", "column", "row", "rate"}) {
        if (t.Has(other)) {
          t.Fail(other, "'" + std::string(other) + "' does not apply to a constant signal");
        }
      }
      c.constant = t.Number("constant");
      return c;
    }
    c.variable = t.RequiredString("variable");
    if (const toml::node* s = t.Get("scale")) {
      if (s->is_string()) {
        c.scale_variable = s->as_string()->get();
      } else {
        c.scale = t.NumberOf(*s, "scale");
      }
    }
    c.column = static_cast<int>(t.Integer("column", 0, 1000000).value_or(-1));
    c.row = static_cast<int>(t.Integer("row", 0, 1000000).value_or(-1));
    if (c.column >= 0 && c.row >= 0) t.Fail("row", "give either 'column' or 'row', not both");
    if (csv && (c.column >= 0 || c.row >= 0)) {
      t.Fail(c.column >= 0 ? "column" : "row",
             "'column' and 'row' select a channel of a 2-D .mat variable; a CSV column is named "
             "by 'variable'");
    }
    if (csv && !c.scale_variable.empty()) {
      t.Fail("scale", "expected a number (a scale variable exists only in .mat files), got '" +
                          c.scale_variable + "'");
    }
  } else {
    mapping.Fail(signal, "'" + signal +
                             "': expected a variable name or a table {variable, scale, "
                             "column, row}, got " +
                             ValueText(node));
  }
  if (c.variable.empty())
    mapping.Fail(signal, "'" + signal + "': expected a variable name, got ''");
  return c;
}

std::vector<ChannelSource> ParseMapping(const Section& d, const std::string& key,
                                        const std::vector<models::SignalInfo>& signals,
                                        const char* kind, bool csv) {
  std::vector<std::string> names;
  for (const auto& s : signals) names.push_back(s.name);
  std::vector<ChannelSource> out;
  auto mapping = d.Sub(key);
  if (!mapping) {
    if (names.empty()) return out;
    d.Fail("", "missing table '" + key + "': expected a source for every model " + kind + " (" +
                   Quoted(names) + ")");
  }
  for (auto&& [k, v] : mapping->table()) {
    const std::string signal(k.str());
    if (std::find(names.begin(), names.end(), signal) == names.end()) {
      mapping->Fail(signal, "'" + signal + "' is not a model " + kind + Suggestion(signal, names) +
                                " (model " + kind + "s: " + Quoted(names) + ")");
    }
  }
  for (const auto& name : names) {
    const toml::node* n = mapping->Get(name);
    if (!n) mapping->Fail("", "missing source of model " + std::string(kind) + " '" + name + "'");
    out.push_back(ParseSource(*mapping, name, *n, csv));
  }
  return out;
}

void ParseData(const Section& root, Problem* problem) {
  const auto entries = root.SubArray("data");
  if (entries.empty()) root.Fail("", "missing [[data]]: expected at least one data file");
  std::set<std::string> data_names, split_names;
  std::vector<std::string> state_names;
  for (const auto& s : problem->built.states) state_names.push_back(s.name);
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const Section& d = entries[i];
    d.Allow({"name", "file", "format", "sample_time", "time", "delimiter", "header", "columns",
             "inputs", "outputs", "splits", "initial_state"});
    DataSpec spec;
    spec.where = d.Where();
    spec.name = d.String("name").value_or("data" + std::to_string(i));
    if (!data_names.insert(spec.name).second) {
      d.Fail("name", "data name '" + spec.name + "' is used twice");
    }
    spec.file = d.RequiredString("file");
    fs::path p(spec.file);
    spec.path =
        (p.is_absolute() ? p : fs::path(problem->directory) / p).lexically_normal().string();
    std::string ext = p.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    const auto format = d.Choice("format", {"mat", "csv"});
    if (format) {
      spec.format = *format;
    } else if (ext == ".mat") {
      spec.format = "mat";
    } else if (ext == ".csv" || ext == ".txt") {
      spec.format = "csv";
    } else {
      d.Fail("file", "cannot tell the format from the extension '" + ext +
                         "': expected format = 'mat' or 'csv'");
    }
    const bool csv = spec.format == "csv";
    if (!csv && (d.Has("delimiter") || d.Has("header") || d.Has("columns"))) {
      d.Fail(d.Has("delimiter") ? "delimiter"
             : d.Has("header")  ? "header"
                                : "columns",
             "'delimiter', 'header' and 'columns' apply to CSV files; this file is read as .mat");
    }
    if (auto delim = d.String("delimiter")) {
      if (delim->size() != 1) {
        d.Fail("delimiter", "expected one character, got '" + *delim + "'");
      }
      spec.csv_delimiter = (*delim)[0];
    }
    spec.csv_header = d.Bool("header").value_or(true);
    spec.csv_column_names = d.Strings("columns");
    const auto dt = d.PositiveNumber("sample_time");
    const auto time = d.String("time");
    if (dt.has_value() == time.has_value()) {
      d.Fail(dt ? "time" : "",
             "expected exactly one of 'sample_time' (seconds) and 'time' (a variable), got " +
                 std::string(dt ? "both" : "neither"));
    }
    spec.sample_time = dt.value_or(0.0);
    spec.time_variable = time.value_or("");
    spec.inputs = ParseMapping(d, "inputs", problem->built.inputs, "input", csv);
    spec.outputs = ParseMapping(d, "outputs", problem->built.outputs, "output", csv);
    for (const Section& s : d.SubArray("splits")) {
      s.Allow({"name", "role", "begin", "end"});
      SplitSpec split;
      split.where = s.Where();
      split.name = s.RequiredString("name");
      const std::string role =
          s.Choice("role", {"estimation", "validation", "test"}).value_or("estimation");
      split.role = role == "test"         ? SplitRole::kTest
                   : role == "validation" ? SplitRole::kValidation
                                          : SplitRole::kEstimation;
      split.begin = static_cast<int>(s.Integer("begin", 0, 2000000000).value_or(0));
      split.end = static_cast<int>(s.Integer("end", 1, 2000000000).value_or(-1));
      if (split.end >= 0 && split.end <= split.begin) {
        s.Fail("end", "expected begin < end, got begin = " + std::to_string(split.begin) +
                          ", end = " + std::to_string(split.end));
      }
      spec.splits.push_back(split);
    }
    if (spec.splits.empty()) {
      SplitSpec all;
      all.name = spec.name;
      all.where = spec.where;
      spec.splits.push_back(all);
    }
    for (const auto& split : spec.splits) {
      if (!split_names.insert(split.name).second) {
        throw ProblemFileError(split.where, "split name '" + split.name +
                                                "' is used twice (split names are unique across "
                                                "all [[data]] entries)");
      }
    }
    if (const toml::node* init = d.Get("initial_state")) {
      if (init->is_string()) {
        if (init->as_string()->get() != "from_outputs") {
          d.Fail("initial_state", "expected 'from_outputs' or a table of state values, got '" +
                                      init->as_string()->get() + "'" +
                                      Suggestion(init->as_string()->get(), {"from_outputs"}));
        }
      } else if (init->is_table()) {
        const Section t(d.file(), *init->as_table(), d.Join("initial_state"));
        for (auto&& [k, v] : t.table()) {
          const std::string state(k.str());
          if (std::find(state_names.begin(), state_names.end(), state) == state_names.end()) {
            t.Fail(state, "'" + state + "' is not a model state" + Suggestion(state, state_names) +
                              " (states: " + Quoted(state_names) + ")");
          }
          if (v.is_string()) {
            if (v.as_string()->get().empty()) t.Fail(state, "expected a variable name, got ''");
            spec.initial_state_variables[state] = v.as_string()->get();
          } else {
            spec.initial_state[state] = t.NumberOf(v, state);
          }
        }
      } else {
        d.Fail("initial_state",
               "expected 'from_outputs' or a table of state values, got " + ValueText(*init));
      }
    }
    problem->data.push_back(std::move(spec));
  }
}

// ---- [estimation] -------------------------------------------------------------------------------

std::string NumberText(const toml::node& n) {
  if (const auto* i = n.as_integer()) return std::to_string(i->get());
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", n.as_floating_point()->get());
  return buf;
}

// Checks pass-through Ipopt options against Ipopt's registered options (SolveWithIpopt rejects
// unknown keys and invalid values before iterating) on a one-variable NLP with no iteration.
void CheckIpoptOptions(const Section& s, const IpoptOptions& options) {
  Nlp nlp(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Constant(1, -1.0),
          Eigen::VectorXd::Constant(1, 1.0));
  IpoptOptions probe = options;
  probe.max_iterations = 0;
  probe.print_level = 0;
  probe.pass_through.erase("output_file");  // would create a file
  probe.pass_through.erase("print_level");
  try {
    SolveWithIpopt(nlp, probe);
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    for (const auto& [key, value] : options.pass_through) {
      if (what.find("'" + key + "'") == std::string::npos) continue;
      // Ipopt's own names did not come close: try the IpoptOptions fields of this table.
      const std::string hint =
          what.find("did you mean") == std::string::npos
              ? Suggestion(key, {"max_iterations", "tolerance", "exact_hessian", "print_level"})
              : "";
      s.Fail(key, what + hint);
    }
    s.Fail("", what);
  }
}

void ParseIpopt(const Section& s, IpoptOptions* options) {
  for (auto&& [k, v] : s.table()) {
    const std::string key(k.str());
    if (key == "max_iterations" || key == "max_iter") {
      options->max_iterations = static_cast<int>(*s.Integer(key, 0, 1000000000));
    } else if (key == "tolerance" || key == "tol") {
      options->tolerance = *s.PositiveNumber(key);
    } else if (key == "exact_hessian") {
      options->exact_hessian = *s.Bool(key);
    } else if (key == "print_level") {
      options->print_level = static_cast<int>(*s.Integer(key, 0, 12));
    } else if (v.is_string()) {
      options->pass_through[key] = v.as_string()->get();
    } else if (v.is_number()) {
      s.NumberOf(v, key);
      options->pass_through[key] = NumberText(v);
    } else if (v.is_boolean()) {
      options->pass_through[key] = v.as_boolean()->get() ? "yes" : "no";
    } else {
      s.Fail(key, "Ipopt option '" + key + "': expected a number or a word, got " + ValueText(v));
    }
  }
  try {
    options->Validate();
  } catch (const std::invalid_argument& e) {
    s.Fail("", e.what());
  }
  CheckIpoptOptions(s, *options);
}

void ParseIntegrator(const Section& s, IntegratorOptions* options) {
  s.Allow({"method", "relative_tolerance", "absolute_tolerance", "max_steps", "max_order",
           "linear_solver"});
  if (auto v = s.Choice("method", {"fixed_step", "cvodes"})) {
    options->method = ParseIntegrationMethod(*v);
  }
  CvodesOptions& c = options->cvodes;
  if (auto v = s.PositiveNumber("relative_tolerance")) c.relative_tolerance = *v;
  if (auto v = s.PositiveNumber("absolute_tolerance")) c.absolute_tolerance = *v;
  if (auto v = s.Integer("max_steps", 1, 1000000000)) c.max_steps = *v;
  if (auto v = s.Integer("max_order", 1, 5)) c.max_order = static_cast<int>(*v);
  if (auto v = s.Choice("linear_solver", {"dense", "klu"})) {
    c.linear_solver =
        *v == "dense" ? CvodesOptions::LinearSolver::kDense : CvodesOptions::LinearSolver::kKlu;
  }
  try {
    options->Validate();
  } catch (const std::invalid_argument& e) {
    s.Fail("", e.what());
  }
}

void ParseCeres(const Section& s, CeresOptions* options) {
  s.Allow({"max_iterations", "function_tolerance", "gradient_tolerance", "parameter_tolerance",
           "loss", "loss_scale", "num_threads", "print_progress"});
  if (auto v = s.Integer("max_iterations", 0, 1000000000)) options->max_iterations = *v;
  if (auto v = s.PositiveNumber("function_tolerance")) options->function_tolerance = *v;
  if (auto v = s.PositiveNumber("gradient_tolerance")) options->gradient_tolerance = *v;
  if (auto v = s.PositiveNumber("parameter_tolerance")) options->parameter_tolerance = *v;
  if (auto v = s.Choice("loss", {"trivial", "huber", "cauchy", "soft_l1", "arctan"})) {
    options->loss = *v;
  }
  if (auto v = s.PositiveNumber("loss_scale")) options->loss_scale = *v;
  if (auto v = s.Integer("num_threads", 1, 256)) options->num_threads = *v;
  if (auto v = s.Bool("print_progress")) options->print_progress = *v;
  try {
    options->Validate();
  } catch (const std::invalid_argument& e) {
    s.Fail("", e.what());
  }
}

std::map<std::string, double> ParseWeights(const Section& parent, const std::string& key,
                                           const std::vector<std::string>& channels,
                                           const char* kind) {
  std::map<std::string, double> weights;
  auto t = parent.Sub(key);
  if (!t) return weights;
  for (auto&& [k, v] : t->table()) {
    const std::string name(k.str());
    if (std::find(channels.begin(), channels.end(), name) == channels.end()) {
      t->Fail(name, "'" + name + "' is not " + kind + Suggestion(name, channels) + " (" +
                        Quoted(channels) + ")");
    }
    const double w = t->NumberOf(v, name);
    if (!(w > 0.0)) t->Fail(name, "weight of '" + name + "': expected > 0, got " + Format(w));
    weights[name] = w;
  }
  return weights;
}

// The index of the state whose derivative is exactly state `i` (dq/dt = qd makes q the
// "integral" of qd), or -1.
int IntegralOf(const models::StateSpaceModel& m, int i) {
  const auto& x = m.dynamics.InputSymbols(m.dynamics.InputIndex("x"));
  const auto& f = m.dynamics.OutputExprs(0);
  for (int j = 0; j < m.NumStates(); ++j) {
    if (f[j].IsSame(x[i])) return j;
  }
  return -1;
}

// `states_only`: parsed for node_guess = 'data' of another method (only the state sources matter).
void ParseEquationError(const Section& e, const Problem& problem, EquationErrorSpec* spec,
                        bool states_only) {
  e.Allow({"form", "residual_states", "inverse_inputs", "differentiate", "lowpass_hz",
           "lowpass_order", "lowpass_padding", "skip_samples", "decimate", "decimation",
           "weights"});
  const models::StateSpaceModel& m = problem.built;
  std::vector<std::string> states, inputs, outputs;
  for (const auto& s : m.states) states.push_back(s.name);
  for (const auto& s : m.inputs) inputs.push_back(s.name);
  for (const auto& s : m.outputs) outputs.push_back(s.name);
  spec->form = e.Choice("form", {"inverse", "state_derivative"}).value_or("inverse");
  auto check_names = [&](const std::string& key, const std::vector<std::string>& names,
                         const std::vector<std::string>& known, const char* kind) {
    for (const auto& n : names) {
      if (std::find(known.begin(), known.end(), n) == known.end()) {
        e.Fail(key, "'" + key + "': '" + n + "' is not a model " + kind + Suggestion(n, known) +
                        " (" + Quoted(known) + ")");
      }
    }
  };
  // Kinematic states: their derivative is another state.
  const auto& f = m.dynamics.OutputExprs(0);
  const auto& x = m.dynamics.InputSymbols(m.dynamics.InputIndex("x"));
  auto kinematic = [&](int i) {
    for (int j = 0; j < m.NumStates(); ++j) {
      if (f[i].IsSame(x[j])) return true;
    }
    return false;
  };
  spec->residual_states = e.Strings("residual_states");
  check_names("residual_states", spec->residual_states, states, "state");
  if (spec->residual_states.empty()) {
    for (int i = 0; i < m.NumStates(); ++i) {
      if (!kinematic(i)) spec->residual_states.push_back(states[i]);
    }
  }
  if (spec->residual_states.empty() && !states_only) {
    e.Fail("residual_states",
           "no state equation to fit: every state's derivative is another state");
  }
  if (spec->form == "inverse" && !states_only) {
    spec->inverse_inputs = e.Strings("inverse_inputs");
    check_names("inverse_inputs", spec->inverse_inputs, inputs, "input");
    if (spec->inverse_inputs.empty() && inputs.size() == 1 && spec->residual_states.size() == 1) {
      spec->inverse_inputs = inputs;
    }
    if (spec->inverse_inputs.size() != spec->residual_states.size()) {
      e.Fail("inverse_inputs",
             "the inverse form solves for one input per residual state: expected " +
                 std::to_string(spec->residual_states.size()) + " inverse_inputs, got " +
                 std::to_string(spec->inverse_inputs.size()));
    }
  } else if (e.Has("inverse_inputs") && !states_only) {
    e.Fail("inverse_inputs", "'inverse_inputs' applies to form = 'inverse' only");
  }
  if (auto d = e.Sub("differentiate")) {
    for (auto&& [k, v] : d->table()) {
      const std::string state(k.str());
      if (std::find(states.begin(), states.end(), state) == states.end()) {
        d->Fail(state, "'" + state + "' is not a model state" + Suggestion(state, states));
      }
      if (!v.is_string()) {
        d->Fail(state, "'" + state +
                           "': expected the name of the signal it is the derivative of, "
                           "got " +
                           ValueText(v));
      }
      const std::string source = v.as_string()->get();
      std::vector<std::string> known = states;
      known.insert(known.end(), outputs.begin(), outputs.end());
      if (std::find(known.begin(), known.end(), source) == known.end() || source == state) {
        d->Fail(state, "'" + state + "' = '" + source +
                           "': expected another state or a measured output" +
                           Suggestion(source, known));
      }
      spec->differentiate[state] = source;
    }
  }
  // Every state must come from data: measured (an output of the same name), differentiated, or
  // inferred from a kinematic equation.
  for (int i = 0; i < m.NumStates(); ++i) {
    const std::string& s = states[i];
    if (std::find(outputs.begin(), outputs.end(), s) != outputs.end()) continue;
    if (spec->differentiate.count(s)) continue;
    const int j = IntegralOf(m, i);
    if (j >= 0) {
      spec->differentiate[s] = states[j];
      continue;
    }
    e.Fail("differentiate",
           "state '" + s +
               "' is neither a measured output nor the derivative of a measured "
               "signal: equation error and node_guess = 'data' need every state from data (add it "
               "to 'differentiate' or measure it as an output)");
  }
  // No cycles in the derivative chains.
  for (const auto& [state, source] : spec->differentiate) {
    std::string cur = source;
    for (std::size_t hop = 0; hop <= states.size() && spec->differentiate.count(cur); ++hop) {
      cur = spec->differentiate.at(cur);
      if (cur == state)
        e.Fail("differentiate", "the derivative chain of '" + state + "' is a cycle");
    }
  }
  if (auto v = e.Number("lowpass_hz")) {
    if (*v < 0.0)
      e.Fail("lowpass_hz", "expected a cut-off >= 0 Hz (0: no filter), got " + Format(*v));
    spec->lowpass_hz = *v;
  }
  if (auto v = e.Integer("lowpass_order", 1, 20)) spec->lowpass_order = static_cast<int>(*v);
  if (auto v = e.Integer("lowpass_padding", -1, 100000))
    spec->lowpass_padding = static_cast<int>(*v);
  if (auto v = e.Integer("skip_samples", 0, 1000000000)) spec->skip_samples = static_cast<int>(*v);
  if (auto v = e.Integer("decimate", 1, 1000)) spec->decimate = static_cast<int>(*v);
  spec->decimation = e.Choice("decimation", {"auto", "parallel", "signals"}).value_or("auto");
  const std::vector<std::string>& channels =
      spec->form == "inverse" ? spec->inverse_inputs : spec->residual_states;
  spec->weights = ParseWeights(e, "weights", channels, "a residual channel");
}

void ParseEstimation(const Section& root, Problem* problem) {
  auto est = root.Sub("estimation");
  if (!est) root.Fail("", "missing table [estimation]: expected at least method = '...'");
  const Section& e = *est;
  e.Allow({"method", "solver", "seed", "substeps", "integrator", "multiple_shooting", "collocation",
           "equation_error", "ipopt", "ceres"});
  EstimationSpec& spec = problem->estimation;
  spec.where = e.Where();
  if (!e.Has("method")) e.Fail("", "missing key 'method'");
  spec.method = *e.Choice(
      "method", {"multiple_shooting", "single_shooting", "collocation", "equation_error"});
  spec.solver = e.Choice("solver", {"ipopt", "ceres"})
                    .value_or(spec.method == "equation_error" ? "ceres" : "ipopt");
  spec.seed = static_cast<unsigned>(e.Integer("seed", 0, 4294967295L).value_or(1));
  spec.substeps = static_cast<int>(e.Integer("substeps", 1, 1000).value_or(1));
  spec.integrator.fixed_step.substeps = spec.substeps;
  if (auto in = e.Sub("integrator")) ParseIntegrator(*in, &spec.integrator);
  if (spec.method == "collocation" && spec.solver != "ipopt") {
    e.Fail("solver", "collocation has equality constraints: expected solver = 'ipopt', got '" +
                         spec.solver + "'");
  }
  std::vector<std::string> outputs;
  for (const auto& s : problem->built.outputs) outputs.push_back(s.name);
  spec.multiple_shooting.step.substeps = spec.substeps;
  spec.multiple_shooting.continuity_as_constraints = spec.solver == "ipopt";
  if (auto ms = e.Sub("multiple_shooting")) {
    ms->Allow({"segment_length", "continuity", "continuity_weight", "weights", "fix_initial_state",
               "node_guess"});
    if (auto v = ms->Integer("segment_length", 1, 1000000)) {
      spec.multiple_shooting.segment_length = static_cast<int>(*v);
    }
    if (auto c = ms->Choice("continuity", {"constraints", "residuals"})) {
      if (*c == "constraints" && spec.solver == "ceres") {
        ms->Fail("continuity",
                 "Ceres handles no constraints: expected continuity = 'residuals' "
                 "with solver = 'ceres', got 'constraints'");
      }
      spec.multiple_shooting.continuity_as_constraints = *c == "constraints";
    }
    if (auto v = ms->PositiveNumber("continuity_weight")) {
      spec.multiple_shooting.continuity_weight = *v;
    }
    spec.output_weights = ParseWeights(*ms, "weights", outputs, "a model output");
    spec.multiple_shooting.fix_initial_state = ms->Bool("fix_initial_state").value_or(false);
    spec.node_guess = ms->Choice("node_guess", {"simulation", "data"}).value_or("simulation");
  }
  if (auto c = e.Sub("collocation")) {
    c->Allow({"scheme", "degree", "weights"});
    if (auto s = c->Choice("scheme", {"radau", "legendre"})) {
      spec.collocation.scheme =
          *s == "radau" ? CollocationScheme::kRadau : CollocationScheme::kLegendre;
    }
    if (auto d = c->Integer("degree", 1, 9)) spec.collocation.degree = static_cast<int>(*d);
    if (spec.method == "collocation") {
      spec.output_weights = ParseWeights(*c, "weights", outputs, "a model output");
    }
  }
  const bool states_only = spec.method != "equation_error";
  if (auto ee = e.Sub("equation_error")) {
    ParseEquationError(*ee, *problem, &spec.equation_error, states_only);
  } else if (!states_only || spec.node_guess == "data") {
    const toml::table empty;
    ParseEquationError(Section(e.file(), empty, e.Join("equation_error")), *problem,
                       &spec.equation_error, states_only);
  }
  if (auto i = e.Sub("ipopt")) ParseIpopt(*i, &spec.ipopt);
  if (auto c = e.Sub("ceres")) ParseCeres(*c, &spec.ceres);
}

}  // namespace

Problem ParseProblem(const std::string& text, const std::string& path) {
  Problem problem;
  problem.path = path;
  problem.directory = fs::path(path).parent_path().string();
  if (problem.directory.empty()) problem.directory = ".";
  toml::table root;
  try {
    root = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    SourceLocation where;
    where.file = path;
    where.line = static_cast<int>(e.source().begin.line);
    where.column = static_cast<int>(e.source().begin.column);
    throw ProblemFileError(where, "TOML syntax error: " + std::string(e.description()));
  }
  const Section top(path, root, "");
  top.Allow({"problem", "model", "data", "estimation", "metrics"});
  problem.name = fs::path(path).stem().string();
  if (auto p = top.Sub("problem")) {
    p->Allow({"name", "description"});
    problem.name = p->String("name").value_or(problem.name);
    problem.description = p->String("description").value_or("");
  }
  ParseModel(top, &problem);
  ParseData(top, &problem);
  ParseEstimation(top, &problem);
  if (auto m = top.Sub("metrics")) {
    m->Allow({"n_step", "n_step_stride"});
    problem.metrics.where = m->Where();
    problem.metrics.n_step = static_cast<int>(m->Integer("n_step", 0, 1000000).value_or(0));
    problem.metrics.n_step_stride =
        static_cast<int>(m->Integer("n_step_stride", 1, 1000000).value_or(1));
  }
  // Every model output must be measured in every data entry (ParseMapping) and equation error
  // needs the outputs it differentiates; nothing else to cross-check before the data are read.
  return problem;
}

Problem LoadProblem(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    SourceLocation where;
    where.file = path;
    throw ProblemFileError(where, "cannot read the problem file: " +
                                      std::string(fs::exists(path) ? "permission denied or not a "
                                                                     "regular file"
                                                                   : "file not found"));
  }
  std::ostringstream text;
  text << in.rdbuf();
  return ParseProblem(text.str(), path);
}

// ---- data ---------------------------------------------------------------------------------------

namespace {

// One channel as a column vector.
Eigen::VectorXd ToChannel(const Eigen::MatrixXd& m, const ChannelSource& c,
                          const std::string& what) {
  if (c.column >= 0) {
    if (c.column >= m.cols()) {
      throw ProblemFileError(c.where, what + ": expected column < " + std::to_string(m.cols()) +
                                          ", got column = " + std::to_string(c.column));
    }
    return m.col(c.column);
  }
  if (c.row >= 0) {
    if (c.row >= m.rows()) {
      throw ProblemFileError(c.where, what + ": expected row < " + std::to_string(m.rows()) +
                                          ", got row = " + std::to_string(c.row));
    }
    return m.row(c.row).transpose();
  }
  if (m.cols() == 1) return m.col(0);
  if (m.rows() == 1) return m.row(0).transpose();
  throw ProblemFileError(c.where, what + ": expected a vector (N x 1 or 1 x N), got " +
                                      std::to_string(m.rows()) + " x " + std::to_string(m.cols()) +
                                      "; select a channel with column = j or row = i");
}

struct RawData {
  std::vector<Eigen::VectorXd> inputs, outputs;
  Eigen::VectorXd time;
  std::map<std::string, Eigen::VectorXd> initial_state_variables;  // by variable name
};

RawData ReadMat(const DataSpec& spec) {
  RawData raw;
  std::unique_ptr<MatFile> file;
  try {
    file = std::make_unique<MatFile>(spec.path);
  } catch (const std::invalid_argument& e) {
    throw ProblemFileError(spec.where, "data '" + spec.name + "': " + e.what());
  }
  auto read = [&](const ChannelSource& c) {
    if (c.constant) return Eigen::VectorXd();  // filled in once the length is known
    const std::string what = "variable '" + c.variable + "' for '" + c.signal + "'";
    Eigen::MatrixXd m;
    double scale = c.scale;
    try {
      m = file->ReadMatrix(c.variable);
      if (!c.scale_variable.empty()) scale *= file->ReadScalar(c.scale_variable);
    } catch (const std::invalid_argument& e) {
      throw ProblemFileError(c.where, "data '" + spec.name + "': " + e.what());
    }
    return Eigen::VectorXd(scale * ToChannel(m, c, what));
  };
  for (const auto& c : spec.inputs) raw.inputs.push_back(read(c));
  for (const auto& c : spec.outputs) raw.outputs.push_back(read(c));
  if (!spec.time_variable.empty()) {
    ChannelSource t;
    t.signal = "time";
    t.variable = spec.time_variable;
    t.where = spec.where;
    raw.time = read(t);
  }
  for (const auto& [state, variable] : spec.initial_state_variables) {
    ChannelSource c;
    c.signal = "initial state of '" + state + "'";
    c.variable = variable;
    c.where = spec.where;
    raw.initial_state_variables[variable] = read(c);
  }
  return raw;
}

RawData ReadCsvData(const DataSpec& spec) {
  CsvOptions options;
  options.delimiter = spec.csv_delimiter;
  options.has_header = spec.csv_header;
  options.column_names = spec.csv_column_names;
  std::vector<std::string> wanted;
  auto want = [&](const std::string& v) {
    if (std::find(wanted.begin(), wanted.end(), v) == wanted.end()) wanted.push_back(v);
  };
  for (const auto& c : spec.inputs) {
    if (!c.constant) want(c.variable);
  }
  for (const auto& c : spec.outputs) {
    if (!c.constant) want(c.variable);
  }
  if (!spec.time_variable.empty()) want(spec.time_variable);
  for (const auto& [state, variable] : spec.initial_state_variables) want(variable);
  options.columns = wanted;
  options.empty_cells = CsvEmptyCells::kNaN;  // reported with the channel by Experiment::Validate
  CsvTable table;
  try {
    table = ReadCsv(spec.path, options);
  } catch (const std::invalid_argument& e) {
    throw ProblemFileError(spec.where, "data '" + spec.name + "': " + e.what());
  }
  RawData raw;
  for (const auto& c : spec.inputs) {
    raw.inputs.push_back(c.constant ? Eigen::VectorXd() : c.scale * table.Column(c.variable));
  }
  for (const auto& c : spec.outputs) {
    raw.outputs.push_back(c.constant ? Eigen::VectorXd() : c.scale * table.Column(c.variable));
  }
  if (!spec.time_variable.empty()) raw.time = table.Column(spec.time_variable);
  for (const auto& [state, variable] : spec.initial_state_variables) {
    raw.initial_state_variables[variable] = table.Column(variable);
  }
  return raw;
}

// Relative deviation of a sample spacing from the mean spacing accepted as uniform sampling.
// Recorded time vectors carry rounding of their storage type: EMPS's t deviates by 2.4e-5 of the
// 1 ms step (single-precision instants near 1 s); a genuinely irregular record (a dropped sample
// doubles one spacing) deviates by 100 %.
constexpr double kUniformTolerance = 1e-3;

}  // namespace

std::vector<SplitData> LoadData(const Problem& problem) {
  const models::StateSpaceModel& m = problem.built;
  std::vector<SplitData> splits;
  for (const DataSpec& spec : problem.data) {
    if (!fs::exists(spec.path)) {
      throw ProblemFileError(spec.where, "data '" + spec.name + "': file '" + spec.path +
                                             "' not found (from file = '" + spec.file +
                                             "', relative to the problem file's folder)");
    }
    RawData raw = spec.format == "mat" ? ReadMat(spec) : ReadCsvData(spec);
    // Lengths: every recorded variable has the length of the first one (constants take it).
    const ChannelSource* first = nullptr;
    long n = -1;
    for (std::size_t i = 0; i < spec.outputs.size() && !first; ++i) {
      if (!spec.outputs[i].constant) first = &spec.outputs[i], n = raw.outputs[i].size();
    }
    for (std::size_t i = 0; i < spec.inputs.size() && !first; ++i) {
      if (!spec.inputs[i].constant) first = &spec.inputs[i], n = raw.inputs[i].size();
    }
    if (!first) {
      throw ProblemFileError(spec.where, "data '" + spec.name +
                                             "': every signal is a constant: expected at least "
                                             "one recorded variable");
    }
    for (std::size_t i = 0; i < spec.inputs.size(); ++i) {
      if (spec.inputs[i].constant)
        raw.inputs[i] = Eigen::VectorXd::Constant(n, *spec.inputs[i].constant);
    }
    for (std::size_t i = 0; i < spec.outputs.size(); ++i) {
      if (spec.outputs[i].constant) {
        raw.outputs[i] = Eigen::VectorXd::Constant(n, *spec.outputs[i].constant);
      }
    }
    auto check_length = [&](const Eigen::VectorXd& v, const ChannelSource& c) {
      if (v.size() != n) {
        throw ProblemFileError(c.where, "data '" + spec.name + "': variable '" + c.variable +
                                            "' has " + std::to_string(v.size()) +
                                            " samples, expected " + std::to_string(n) + " like '" +
                                            first->variable + "'");
      }
    };
    for (std::size_t i = 0; i < raw.inputs.size(); ++i) check_length(raw.inputs[i], spec.inputs[i]);
    for (std::size_t i = 0; i < raw.outputs.size(); ++i) {
      check_length(raw.outputs[i], spec.outputs[i]);
    }
    Experiment e;
    e.name = spec.name;
    e.u.resize(n, m.NumInputs());
    e.y.resize(n, m.NumOutputs());
    for (int i = 0; i < m.NumInputs(); ++i) {
      e.u.col(i) = raw.inputs[i];
      e.u_names.push_back(m.inputs[i].name);
      e.u_units.push_back(m.inputs[i].unit);
    }
    for (int i = 0; i < m.NumOutputs(); ++i) {
      e.y.col(i) = raw.outputs[i];
      e.y_names.push_back(m.outputs[i].name);
      e.y_units.push_back(m.outputs[i].unit);
    }
    if (spec.time_variable.empty()) {
      e.dt = spec.sample_time;
    } else {
      if (raw.time.size() != n) {
        throw ProblemFileError(spec.where, "data '" + spec.name + "': time variable '" +
                                               spec.time_variable + "' has " +
                                               std::to_string(raw.time.size()) +
                                               " samples, expected " + std::to_string(n));
      }
      e.time = raw.time;
    }
    try {
      e.Validate();
    } catch (const std::invalid_argument& ex) {
      throw ProblemFileError(spec.where,
                             "data '" + spec.name + "' (" + spec.file + "): " + ex.what());
    }
    if (!spec.time_variable.empty()) {
      if (n < 2) {
        throw ProblemFileError(spec.where, "data '" + spec.name +
                                               "': expected at least 2 samples to tell the sample "
                                               "time, got " +
                                               std::to_string(n));
      }
      const double dt = e.SampleTime();
      for (long k = 1; k < n; ++k) {
        const double h = e.time[k] - e.time[k - 1];
        if (std::fabs(h - dt) > kUniformTolerance * dt) {
          throw ProblemFileError(
              spec.where, "data '" + spec.name + "': time '" + spec.time_variable + "' step " +
                              std::to_string(k) + " is " + Format(h) +
                              " s: expected uniform "
                              "sampling at " +
                              Format(dt) +
                              " s (the formulations integrate with "
                              "a fixed step); resample the data or give sample_time");
        }
      }
      e.t0 = e.time[0];
      e.dt = dt;
      e.time.resize(0);
    }
    // Rates (first-order hold inputs), once the sample time is known.
    auto apply_rate = [&](Eigen::MatrixXd* signals, const std::vector<ChannelSource>& sources) {
      for (std::size_t i = 0; i < sources.size(); ++i) {
        if (!sources[i].rate) continue;
        const Eigen::VectorXd v = signals->col(static_cast<Eigen::Index>(i));
        Eigen::VectorXd r(n);
        for (long k = 0; k + 1 < n; ++k) r[k] = (v[k + 1] - v[k]) / e.dt;
        r[n - 1] = n > 1 ? r[n - 2] : 0.0;
        signals->col(static_cast<Eigen::Index>(i)) = r;
      }
    };
    apply_rate(&e.u, spec.inputs);
    apply_rate(&e.y, spec.outputs);
    for (const auto& [variable, values] : raw.initial_state_variables) {
      if (values.size() != n) {
        throw ProblemFileError(spec.where, "data '" + spec.name + "': initial-state variable '" +
                                               variable + "' has " + std::to_string(values.size()) +
                                               " samples, expected " + std::to_string(n));
      }
    }
    for (const SplitSpec& s : spec.splits) {
      const int end = s.end < 0 ? static_cast<int>(n) : s.end;
      if (s.begin >= n || end > n) {
        throw ProblemFileError(s.where, "split '" + s.name + "': expected 0 <= begin < end <= " +
                                            std::to_string(n) + " (the samples of '" + spec.file +
                                            "'), got begin = " + std::to_string(s.begin) +
                                            ", end = " + std::to_string(end));
      }
      SplitData d;
      d.name = s.name;
      d.data_name = spec.name;
      d.role = s.role;
      d.begin = s.begin;
      d.where = s.where;
      d.experiment = Slice(e, s.begin, end);
      d.experiment.name = s.name;
      d.x0 = Eigen::VectorXd::Zero(m.NumStates());
      for (int i = 0; i < m.NumStates(); ++i) {
        auto it = spec.initial_state.find(m.states[i].name);
        if (it != spec.initial_state.end()) {
          d.x0[i] = it->second;
          continue;
        }
        auto var = spec.initial_state_variables.find(m.states[i].name);
        if (var != spec.initial_state_variables.end()) {
          const Eigen::VectorXd& values = raw.initial_state_variables.at(var->second);
          if (!std::isfinite(values[s.begin])) {
            throw ProblemFileError(spec.where, "data '" + spec.name + "': initial state of '" +
                                                   var->first + "' from variable '" + var->second +
                                                   "' sample " + std::to_string(s.begin) +
                                                   ": expected a finite value, got " +
                                                   Format(values[s.begin]));
          }
          d.x0[i] = values[s.begin];
          continue;
        }
        for (int j = 0; j < m.NumOutputs(); ++j) {
          if (m.outputs[j].name == m.states[i].name) d.x0[i] = d.experiment.y(0, j);
        }
      }
      splits.push_back(std::move(d));
    }
  }
  return splits;
}

}  // namespace graybox::estimators
