// Problem files: the [[data]] entries (problem_file.h, docs/problem-format.md) and LoadData, which
// reads, validates and cuts the data files.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <utility>

#include "graybox/estimators/data/csv_file.h"
#include "graybox/estimators/data/mat_file.h"
#include "graybox/estimators/problem/problem_file.h"
#include "graybox/models/block.h"
#include "graybox/models/mechanics.h"
#include "problem/problem_file_internal.h"

namespace graybox::estimators {

namespace fs = std::filesystem;

namespace internal {

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
    t.Allow({"variable", "scale", "column", "row", "rate", "constant", "hold"});
    c.rate = t.Bool("rate").value_or(false);
    if (const std::optional<std::string> hold = t.String("hold")) {
      if (*hold != "zoh" && *hold != "foh") {
        t.Fail("hold",
               "expected 'zoh' or 'foh', got '" + *hold + "'" + Suggestion(*hold, {"zoh", "foh"}));
      }
      c.first_order_hold = *hold == "foh";
      if (c.first_order_hold && c.rate) {
        t.Fail("hold", "hold = 'foh' of a rate signal: map the variable itself with hold = 'foh'");
      }
    }
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
    for (const ChannelSource& c : spec.outputs) {
      if (c.first_order_hold) {
        throw ProblemFileError(c.where, "output '" + c.signal +
                                            "': hold = 'foh' applies to inputs (an output is "
                                            "compared at its samples)");
      }
    }
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
          } else if (v.is_table()) {
            // { value = x | variable = "name", free = true | false } or { from_split = "name" }.
            const Section st(t.file(), *v.as_table(), t.Join(state));
            st.Allow({"value", "variable", "free", "from_split"});
            const std::optional<double> value = st.Number("value");
            const std::optional<std::string> variable = st.String("variable");
            const std::optional<bool> free = st.Bool("free");
            const std::optional<std::string> from = st.String("from_split");
            if (value && variable) {
              st.Fail("variable", "give 'value' or 'variable', not both");
            }
            if (from && (value || variable || free)) {
              st.Fail("from_split",
                      "'from_split' starts the state at another split's estimate: it takes no "
                      "'value', 'variable' or 'free'");
            }
            if (!from && !value && !variable && !free) {
              st.Fail("", "expected 'value', 'variable', 'free' or 'from_split'");
            }
            if (variable) {
              if (variable->empty()) st.Fail("variable", "expected a variable name, got ''");
              spec.initial_state_variables[state] = *variable;
            }
            if (value) spec.initial_state[state] = *value;
            if (free) spec.initial_state_free[state] = *free;
            if (from) {
              if (from->empty()) st.Fail("from_split", "expected a split name, got ''");
              spec.initial_state_from_split[state] = *from;
            }
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

void ApplyFirstOrderHolds(Problem* problem) {
  if (problem->data.empty()) return;
  const models::StateSpaceModel& m = problem->built;
  const int nu = m.NumInputs();
  bool any = false;
  for (int j = 0; j < nu; ++j) {
    // One model for every record: the same hold in every [[data]].
    const ChannelSource& first = problem->data.front().inputs.at(j);
    for (const DataSpec& spec : problem->data) {
      const ChannelSource& c = spec.inputs.at(j);
      if (c.first_order_hold != first.first_order_hold) {
        throw ProblemFileError(
            c.where, "input '" + c.signal + "': hold = '" + (c.first_order_hold ? "foh" : "zoh") +
                         "' here but '" + (first.first_order_hold ? "foh" : "zoh") +
                         "' in [[data]] '" + problem->data.front().name +
                         "': every record of one model holds an input the same way");
      }
    }
    if (!first.first_order_hold) continue;
    any = true;
    const models::SignalInfo& input = m.inputs[j];
    const std::string instance = input.name + "_foh";
    const std::string rate = instance + "_rate";
    models::BlockOptions options;
    options.words["unit"] = input.unit.empty() ? "1" : input.unit;
    try {
      const auto block = std::shared_ptr<const models::Block>(
          models::BlockRegistry::Global().Create(models::kFirstOrderHold, options));
      const double span = input.typical_max - input.typical_min;
      problem->model.AddInput(rate, block->info().inputs[1].unit,
                              "forward difference of " + input.name + " (hold = 'foh')", -span,
                              span);
      problem->model.InsertOnInput(input.name, instance, block, {rate});
    } catch (const std::invalid_argument& e) {
      throw ProblemFileError(first.where, "input '" + input.name + "': hold = 'foh': " + e.what());
    }
    problem->blocks.emplace_back(instance, models::kFirstOrderHold);
    problem->first_order_holds.emplace_back(j, instance + ".y");
    // Its rate: the forward difference of the same (scaled) variable, in every record.
    for (DataSpec& spec : problem->data) {
      ChannelSource r = spec.inputs.at(j);
      r.signal = rate;
      r.first_order_hold = false;
      if (r.constant) {
        r.constant = 0.0;
      } else {
        r.rate = true;
      }
      spec.inputs.push_back(r);
    }
  }
  if (any) problem->built = problem->model.Build();
}

}  // namespace internal

using internal::Format;
using internal::Quoted;
using internal::Suggestion;

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
      d.setup.x0 = Eigen::VectorXd::Zero(m.NumStates());
      if (!spec.initial_state_free.empty()) {
        d.setup.x0_free.assign(m.NumStates(), kInitialStateDefault);
        for (int i = 0; i < m.NumStates(); ++i) {
          auto it = spec.initial_state_free.find(m.states[i].name);
          if (it != spec.initial_state_free.end()) {
            d.setup.x0_free[i] = it->second ? kInitialStateFree : kInitialStateFixed;
          }
        }
      }
      for (const auto& [input, state] : problem.first_order_holds) {
        // A first-order hold starts at its input's first sample of the split, held there.
        const int i = m.StateIndex(state);
        d.setup.x0_free.resize(m.NumStates(), kInitialStateDefault);
        d.setup.x0_free[i] = kInitialStateFixed;
      }
      for (int i = 0; i < m.NumStates(); ++i) {
        auto from = spec.initial_state_from_split.find(m.states[i].name);
        if (from != spec.initial_state_from_split.end()) d.x0_from_split[i] = from->second;
      }
      for (int i = 0; i < m.NumStates(); ++i) {
        auto it = spec.initial_state.find(m.states[i].name);
        if (it != spec.initial_state.end()) {
          d.setup.x0[i] = it->second;
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
          d.setup.x0[i] = values[s.begin];
          continue;
        }
        for (int j = 0; j < m.NumOutputs(); ++j) {
          if (m.outputs[j].name == m.states[i].name) d.setup.x0[i] = d.experiment.y(0, j);
        }
      }
      for (const auto& [input, state] : problem.first_order_holds) {
        d.setup.x0[m.StateIndex(state)] = d.experiment.u(0, input);
      }
      splits.push_back(std::move(d));
    }
  }
  // from_split: an estimation split of another [[data]], for a split that is not one.
  for (const SplitData& d : splits) {
    for (const auto& [state, from] : d.x0_from_split) {
      const std::string what = "data '" + d.data_name + "': initial_state of '" +
                               m.states[state].name + "': from_split = '" + from + "'";
      if (d.role == SplitRole::kEstimation) {
        throw ProblemFileError(d.where, what + " on the estimation split '" + d.name +
                                            "': an estimation split estimates its own initial "
                                            "state; from_split is for validation and test splits");
      }
      const SplitData* source = nullptr;
      std::vector<std::string> names;
      for (const SplitData& o : splits) {
        names.push_back(o.name);
        if (o.name == from) source = &o;
      }
      if (source == nullptr) {
        throw ProblemFileError(d.where, what + ": no such split" + Suggestion(from, names));
      }
      if (source->role != SplitRole::kEstimation) {
        throw ProblemFileError(d.where, what +
                                            ": expected an estimation split (whose initial "
                                            "state is estimated), got a " +
                                            SplitRoleName(source->role) + " split");
      }
    }
  }
  return splits;
}

}  // namespace graybox::estimators
