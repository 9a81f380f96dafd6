// The TOML reader of problem files, public so that files of the same style (bench suites,
// bench/runner) read with the same messages: a Section is one table being read, with typed
// access whose errors name the file, the table path and the line (ProblemFileError), and a check
// that rejects unknown keys with a did-you-mean suggestion and the list of known keys.
//
//   const toml_io::Section top(path, root, "");
//   top.Allow({"suite", "variations"});
//   if (auto s = top.Sub("suite")) { name = s->RequiredString("name"); ... }
#pragma once

#include <toml++/toml.h>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "graybox/estimators/problem/problem_file.h"

namespace graybox::estimators::toml_io {

/// v with 10 significant digits (%.10g), for messages.
std::string Format(double v);
std::string Quoted(const std::vector<std::string>& words);
/// "; did you mean 'x'?" or "".
std::string Suggestion(const std::string& word, const std::vector<std::string>& candidates);
/// "a string", "an integer", ... for messages.
std::string TypeName(const toml::node& n);
/// The type and the value of a node for messages ("a string 'abc'").
std::string ValueText(const toml::node& n);
/// '*' matches any run of characters (possibly empty); every other character matches itself.
bool GlobMatch(const std::string& pattern, const std::string& text);

/// The TOML document `text`; `path` names it in messages. A syntax error throws
/// ProblemFileError at its line and column ("TOML syntax error: ...").
toml::table ParseToml(const std::string& text, const std::string& path);
/// The bytes of the file `path`; one that cannot be read throws ProblemFileError naming it:
/// "cannot read the <what>: file not found" (or "permission denied or not a regular file").
std::string ReadFileText(const std::string& path, const std::string& what);

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

}  // namespace graybox::estimators::toml_io
