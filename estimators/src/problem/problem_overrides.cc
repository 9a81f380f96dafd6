// ProblemOverride (problem_file.h): keys of a problem file set from outside it, applied to the
// parsed TOML tables before the sections are read.
#include <toml++/toml.h>
#include <string>
#include <vector>

#include "graybox/estimators/problem/problem_file.h"
#include "problem/problem_file_internal.h"

namespace graybox::estimators::internal {

namespace {

// The parts of a dotted key: bare parts split at dots, quoted parts ("load.mass") kept whole.
std::vector<std::string> KeyParts(const ProblemOverride& o) {
  std::vector<std::string> parts;
  std::string part;
  bool quoted = false, was_quoted = false;
  auto fail = [&o](const std::string& why) {
    throw ProblemFileError(o.origin, "override '" + o.key + "': " + why);
  };
  for (const char c : o.key) {
    if (c == '"') {
      if (!quoted && !part.empty()) fail("a quote inside a key part");
      quoted = !quoted;
      was_quoted = true;
    } else if (c == '.' && !quoted) {
      if (part.empty() && !was_quoted) fail("expected a dotted key such as estimation.method");
      parts.push_back(part);
      part.clear();
      was_quoted = false;
    } else {
      part += c;
    }
  }
  if (quoted) fail("an unclosed quote");
  if (part.empty() && !was_quoted) fail("expected a dotted key such as estimation.method");
  parts.push_back(part);
  return parts;
}

}  // namespace

void ApplyOverrides(const std::vector<ProblemOverride>& overrides, toml::table* root) {
  for (const ProblemOverride& o : overrides) {
    const std::vector<std::string> parts = KeyParts(o);
    toml::table value_table;
    try {
      value_table = toml::parse("v = " + o.value, o.origin.file);
    } catch (const toml::parse_error& e) {
      throw ProblemFileError(o.origin, "override '" + o.key + "': expected a TOML value, got '" +
                                           o.value + "' (" + std::string(e.description()) + ")");
    }
    if (value_table.size() != 1 || !value_table.contains("v")) {
      throw ProblemFileError(
          o.origin, "override '" + o.key + "': expected one TOML value, got '" + o.value + "'");
    }
    toml::table* t = root;
    std::string path;
    for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
      path += (path.empty() ? "" : ".") + parts[i];
      toml::node* n = t->get(parts[i]);
      if (n == nullptr) {
        t->insert(parts[i], toml::table{});
        n = t->get(parts[i]);
      }
      if (!n->is_table()) {
        throw ProblemFileError(o.origin, "override '" + o.key + "': '" + path +
                                             "' is not a table in the problem file but " +
                                             ValueText(*n));
      }
      t = n->as_table();
    }
    t->insert_or_assign(parts.back(), std::move(*value_table.get("v")));
  }
}

std::string OverridesText(const std::vector<ProblemOverride>& overrides) {
  std::string s;
  for (const ProblemOverride& o : overrides) s += (s.empty() ? "" : ", ") + o.ToString();
  return s;
}

}  // namespace graybox::estimators::internal
