// Bench suites (suite.h): the suite file, its folder form, and the cases.
#include "graybox/bench/suite.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "graybox/estimators/problem/toml_section.h"

namespace graybox::bench {

namespace fs = std::filesystem;
namespace est = graybox::estimators;
using est::ProblemFileError;
using est::SourceLocation;
using est::toml_io::Section;

namespace {

// Problem files named by one entry of `problems`: the file, or a folder's *.toml sorted.
std::vector<std::string> ProblemFiles(const Section& s, const std::string& entry,
                                      const std::string& directory) {
  const fs::path p = fs::path(entry).is_absolute() ? fs::path(entry) : fs::path(directory) / entry;
  std::vector<std::string> out;
  std::error_code ec;
  if (fs::is_directory(p, ec)) {
    for (const auto& f : fs::directory_iterator(p, ec)) {
      if (f.is_regular_file() && f.path().extension() == ".toml") out.push_back(f.path().string());
    }
    std::sort(out.begin(), out.end());
    if (out.empty()) s.Fail("problems", "'problems': the folder '" + entry + "' has no .toml file");
    return out;
  }
  if (!fs::is_regular_file(p, ec)) {
    s.Fail("problems", "'problems': no problem file or folder '" + entry + "' (looked for '" +
                           p.string() + "')");
  }
  out.push_back(p.string());
  return out;
}

// The text of a TOML value as an override takes it.
std::string ValueToml(const toml::node& n) {
  std::ostringstream o;
  if (const auto* s = n.as_string()) {
    o << toml::value<std::string>(s->get());
  } else if (const auto* a = n.as_array()) {
    o << *a;
  } else if (const auto* t = n.as_table()) {
    o << toml::toml_formatter(*t, toml::format_flags::none);
  } else {
    n.visit([&o](const auto& v) { o << v; });
  }
  return o.str();
}

// A value as a case id shows it: a string without its quotes, anything else as written.
std::string Label(const std::string& value) {
  if (value.size() >= 2 && (value.front() == '\'' || value.front() == '"') &&
      value.back() == value.front()) {
    return value.substr(1, value.size() - 2);
  }
  return value;
}

// A [tolerances] entry: a table of absolute / relative / digits / compare.
Tolerance ParseTolerance(const Section& s, const std::string& key) {
  const std::optional<Section> t = s.Sub(key);
  if (!t) return {};
  t->Allow({"absolute", "relative", "digits", "compare"});
  Tolerance tol;
  tol.absolute = t->Number("absolute").value_or(0.0);
  tol.relative = t->Number("relative").value_or(0.0);
  if (tol.absolute < 0.0) {
    t->Fail("absolute",
            "'absolute': expected a number >= 0, got " + est::toml_io::Format(tol.absolute));
  }
  if (tol.relative < 0.0) {
    t->Fail("relative",
            "'relative': expected a number >= 0, got " + est::toml_io::Format(tol.relative));
  }
  if (const std::optional<double> d = t->Number("digits")) {
    if (t->Has("relative")) t->Fail("digits", "'digits': give either 'digits' or 'relative'");
    if (!(*d >= 1.0 && *d <= 16.0)) {
      t->Fail("digits", "'digits': expected a number in [1, 16], got " + est::toml_io::Format(*d));
    }
    tol.relative = std::pow(10.0, -*d);
  }
  tol.compared = t->Bool("compare").value_or(true);
  return tol;
}

// The [tolerances] table: a metric's table replaces its default whole, the others keep theirs.
Tolerances ParseTolerances(const Section& t) {
  t.Allow({"nrmse", "fit_percent", "r2", "cost", "iterations", "parameters", "time"});
  Tolerances tol;
  for (const auto& [key, field] :
       std::vector<std::pair<std::string, Tolerance*>>{{"nrmse", &tol.nrmse},
                                                       {"fit_percent", &tol.fit_percent},
                                                       {"r2", &tol.r2},
                                                       {"cost", &tol.cost},
                                                       {"iterations", &tol.iterations},
                                                       {"parameters", &tol.parameters}}) {
    if (t.Has(key)) *field = ParseTolerance(t, key);
  }
  if (const std::optional<Section> time = t.Sub("time")) {
    time->Allow({"factor", "min_seconds"});
    tol.time_factor = time->Number("factor").value_or(tol.time_factor);
    if (!(tol.time_factor >= 1.0)) {
      time->Fail("factor",
                 "'factor': expected a number >= 1, got " + est::toml_io::Format(tol.time_factor));
    }
    tol.time_min_seconds = time->Number("min_seconds").value_or(tol.time_min_seconds);
    if (!(tol.time_min_seconds >= 0.0)) {
      time->Fail("min_seconds", "'min_seconds': expected a number >= 0, got " +
                                    est::toml_io::Format(tol.time_min_seconds));
    }
  }
  return tol;
}

}  // namespace

bool Tolerance::Admits(double baseline, double value) const {
  if (!compared) return true;
  if (std::isnan(baseline) || std::isnan(value)) return std::isnan(baseline) && std::isnan(value);
  if (baseline == value) return true;  // equal infinities
  return std::abs(value - baseline) <= absolute + relative * std::abs(baseline);
}

std::string Tolerance::ToString() const {
  if (!compared) return "not compared";
  std::string s;
  if (absolute > 0.0 || relative == 0.0) s = "absolute " + est::toml_io::Format(absolute);
  if (relative > 0.0)
    s += (s.empty() ? "" : " + ") + std::string("relative ") + est::toml_io::Format(relative);
  return s;
}

Suite ParseSuite(const std::string& text, const std::string& path) {
  const toml::table root = est::toml_io::ParseToml(text, path);
  Suite suite;
  suite.path = path;
  suite.name = fs::path(path).stem().string();
  std::string directory = fs::path(path).parent_path().string();
  if (directory.empty()) directory = ".";
  const Section top(path, root, "");
  top.Allow({"suite", "variations", "perturbation", "tolerances"});
  const std::optional<Section> s = top.Sub("suite");
  if (!s) top.Fail("", "missing table [suite] (with at least 'problems')");
  s->Allow({"name", "description", "problems", "time_limit", "exclude"});
  suite.name = s->String("name").value_or(suite.name);
  suite.description = s->String("description").value_or("");
  suite.time_limit = s->PositiveNumber("time_limit").value_or(suite.time_limit);
  suite.exclude = s->Strings("exclude");
  const std::vector<std::string> entries = s->Strings("problems");
  if (entries.empty()) s->Fail("problems", "'problems': expected at least one problem file");
  for (const std::string& e : entries) {
    for (std::string& f : ProblemFiles(*s, e, directory)) {
      if (std::find(suite.problems.begin(), suite.problems.end(), f) == suite.problems.end()) {
        suite.problems.push_back(std::move(f));
      }
    }
  }
  if (const std::optional<Section> v = top.Sub("variations")) {
    for (auto&& [k, node] : v->table()) {
      Variation var;
      var.key = std::string(k.str());
      var.where = v->Location(k.source());
      const toml::array* a = node.as_array();
      if (a == nullptr || a->empty()) {
        throw ProblemFileError(var.where, "'" + var.key +
                                              "': expected a non-empty array of the values to "
                                              "run, got " +
                                              est::toml_io::ValueText(node));
      }
      for (const toml::node& value : *a) var.values.push_back(ValueToml(value));
      suite.variations.push_back(std::move(var));
    }
  }
  if (const std::optional<Section> p = top.Sub("perturbation")) {
    p->Allow({"relative", "seeds"});
    suite.relative_perturbation = p->Number("relative").value_or(0.0);
    if (!(suite.relative_perturbation >= 0.0)) {
      p->Fail("relative", "'relative': expected a number >= 0, got " +
                              est::toml_io::Format(suite.relative_perturbation));
    }
    if (const toml::node* n = p->Get("seeds")) {
      const toml::array* a = n->as_array();
      if (a == nullptr || a->empty()) {
        p->Fail("seeds",
                "'seeds': expected a non-empty array of integers in [0, 4294967295], "
                "got " +
                    est::toml_io::ValueText(*n));
      }
      suite.seeds.clear();
      suite.seeds_stated = true;
      for (const toml::node& e : *a) {
        const auto* i = e.as_integer();
        if (i == nullptr || i->get() < 0 || i->get() > 4294967295LL) {
          throw ProblemFileError(
              p->Location(e.source()),
              "'seeds': expected integers in [0, 4294967295], got " + est::toml_io::ValueText(e));
        }
        suite.seeds.push_back(static_cast<unsigned>(i->get()));
      }
    }
  }
  if (const std::optional<Section> t = top.Sub("tolerances"))
    suite.tolerances = ParseTolerances(*t);
  return suite;
}

Suite LoadSuite(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    // A folder: each problem file in it once, as written.
    Suite suite;
    suite.path = path;
    suite.name = fs::path(path).filename().string();
    if (suite.name.empty()) suite.name = fs::path(path).parent_path().filename().string();
    for (const auto& f : fs::directory_iterator(path, ec)) {
      if (f.is_regular_file() && f.path().extension() == ".toml") {
        suite.problems.push_back(f.path().string());
      }
    }
    std::sort(suite.problems.begin(), suite.problems.end());
    if (suite.problems.empty()) {
      SourceLocation where;
      where.file = path;
      throw ProblemFileError(where, "the suite folder has no .toml problem file");
    }
    return suite;
  }
  return ParseSuite(est::toml_io::ReadFileText(path, "suite file"), path);
}

std::vector<Case> ExpandCases(const Suite& suite) {
  std::vector<Case> cases;
  // Problem names for the ids: the file stem, with its parent folder when two stems clash.
  std::map<std::string, int> stems;
  for (const std::string& p : suite.problems) ++stems[fs::path(p).stem().string()];
  const bool seeded = suite.relative_perturbation > 0.0 || suite.seeds_stated;
  std::vector<bool> used(suite.exclude.size(), false);
  for (const std::string& problem : suite.problems) {
    std::string name = fs::path(problem).stem().string();
    if (stems[name] > 1) name = fs::path(problem).parent_path().filename().string() + "/" + name;
    // Odometer over the variations' values.
    std::vector<std::size_t> at(suite.variations.size(), 0);
    for (bool more = true; more;) {
      for (const unsigned seed : suite.seeds) {
        Case c;
        c.problem = problem;
        c.problem_name = name;
        c.seed = seed;
        c.seeded = seeded;
        c.relative_perturbation = suite.relative_perturbation;
        c.id = name;
        std::string parts;
        for (std::size_t i = 0; i < at.size(); ++i) {
          const Variation& v = suite.variations[i];
          est::ProblemOverride o;
          o.key = v.key;
          o.value = v.values[at[i]];
          o.origin = v.where;
          c.overrides.push_back(o);
          parts += (parts.empty() ? "" : ",") + v.key + "=" + Label(v.values[at[i]]);
        }
        if (!parts.empty()) c.id += "/" + parts;
        const std::string unseeded = c.id;
        if (seeded) c.id += "/seed=" + std::to_string(seed);
        // A glob excludes by the whole id or by the id without its seed part (so that an
        // exclusion holds whatever the seeds, --seed included).
        bool excluded = false;
        for (std::size_t e = 0; e < suite.exclude.size(); ++e) {
          if (est::toml_io::GlobMatch(suite.exclude[e], c.id) ||
              est::toml_io::GlobMatch(suite.exclude[e], unseeded)) {
            excluded = used[e] = true;
          }
        }
        if (excluded) continue;
        c.index = cases.size();
        cases.push_back(std::move(c));
      }
      more = false;
      for (std::size_t i = at.size(); i-- > 0;) {
        if (++at[i] < suite.variations[i].values.size()) {
          more = true;
          break;
        }
        at[i] = 0;
      }
    }
  }
  for (std::size_t e = 0; e < suite.exclude.size(); ++e) {
    if (!used[e]) {
      SourceLocation where;
      where.file = suite.path;
      where.table = "suite";
      throw ProblemFileError(where, "'exclude': '" + suite.exclude[e] +
                                        "' matches no case (a case id is "
                                        "<problem>/<key>=<value>,.../seed=<s>)");
    }
  }
  std::set<std::string> ids;
  for (const Case& c : cases) {
    if (!ids.insert(c.id).second) {
      SourceLocation where;
      where.file = suite.path;
      throw ProblemFileError(where, "two cases have the id '" + c.id +
                                        "' (a problem named twice, or a repeated value)");
    }
  }
  return cases;
}

std::vector<Case> FilterCases(const std::vector<Case>& cases, const std::string& pattern) {
  if (pattern.empty()) return cases;
  std::vector<Case> out;
  for (const Case& c : cases) {
    if (est::toml_io::GlobMatch(pattern, c.id)) out.push_back(c);
  }
  return out;
}

}  // namespace graybox::bench
