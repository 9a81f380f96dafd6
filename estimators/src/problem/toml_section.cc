// The TOML reader's helpers (toml_section.h).
#include "graybox/estimators/problem/toml_section.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "graybox/util/did_you_mean.h"
#include "graybox/util/read_file.h"

namespace graybox::estimators::toml_io {

toml::table ParseToml(const std::string& text, const std::string& path) {
  try {
    return toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    SourceLocation where;
    where.file = path;
    where.line = static_cast<int>(e.source().begin.line);
    where.column = static_cast<int>(e.source().begin.column);
    throw ProblemFileError(where, "TOML syntax error: " + std::string(e.description()));
  }
}

std::string ReadFileText(const std::string& path, const std::string& what) {
  std::string why;
  std::optional<std::string> text = util::ReadWholeFile(path, &why);
  if (!text) {
    SourceLocation where;
    where.file = path;
    throw ProblemFileError(where, "cannot read the " + what + ": " + why);
  }
  return std::move(*text);
}

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
  const std::string hint = util::DidYouMean(word, candidates);
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

}  // namespace graybox::estimators::toml_io
