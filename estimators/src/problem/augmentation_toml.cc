#include "graybox/estimators/problem/augmentation_toml.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <stdexcept>
#include <vector>

namespace graybox::estimators {
namespace {

// A TOML basic string.
std::string Quote(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      case '\r':
        out += "\\r";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(c));
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

// A bare key when TOML allows one (A-Z a-z 0-9 _ -), else a quoted key.
std::string Key(const std::string& k) {
  bool bare = !k.empty();
  for (const char c : k) {
    bare = bare && (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-');
  }
  return bare ? k : Quote(k);
}

// The %g text with the fewest significant digits (at most 17) that reads back to v, with whole
// numbers below 1e16 written out ("1000", not "1e+03"); "-0.0" for -0.
std::string Number(double v) {
  if (v == 0.0) return std::signbit(v) ? "-0.0" : "0";
  char buf[40];
  int digits = 1;
  for (; digits < 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  std::snprintf(buf, sizeof buf, "%.*e", digits - 1, v);
  const int exponent = std::atoi(std::strchr(buf, 'e') + 1);
  if (exponent >= digits && exponent < 16) digits = exponent + 1;
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

std::string Array(const std::vector<std::string>& items) {
  std::string s = "[";
  for (std::size_t i = 0; i < items.size(); ++i) s += (i ? ", " : "") + Quote(items[i]);
  return s + "]";
}

std::string Options(const models::BlockOptions& options) {
  std::map<std::string, std::string> values;  // key -> TOML value, sorted by key
  for (const auto& [key, numbers] : options.numbers) {
    std::string text;
    for (const double v : numbers) {
      if (!std::isfinite(v)) {
        throw std::invalid_argument("AugmentationToml: option '" + key +
                                    "': expected finite numbers, got " + std::to_string(v));
      }
      text += (text.empty() ? "" : ", ") + Number(v);
    }
    values[key] = numbers.size() == 1 ? text : "[" + text + "]";
  }
  for (const auto& [key, word] : options.words) {
    if (values.count(key)) {
      throw std::invalid_argument("AugmentationToml: option '" + key +
                                  "': expected a number or a word, got both");
    }
    values[key] = Quote(word);
  }
  std::string s;
  for (const auto& [key, value] : values) s += (s.empty() ? "" : ", ") + Key(key) + " = " + value;
  return "{ " + s + " }";
}

}  // namespace

std::string AugmentationToml(const models::Augmentation& a) {
  using Kind = models::Augmentation::Kind;
  a.Validate();
  std::string s = "[[model.augment]]\n";
  s += "instance = " + Quote(a.instance) + "\n";
  s += "type = " + Quote(a.type) + "\n";
  if (!a.options.numbers.empty() || !a.options.words.empty()) {
    s += "options = " + Options(a.options) + "\n";
  }
  switch (a.kind) {
    case Kind::kAdd:
      s += "inputs = " + Array(a.inputs) + "\n";
      s += "outputs = " + Array(a.outputs) + "\n";
      break;
    case Kind::kOnSignal:
      s += "on_signal = " + Quote(a.signal) + "\n";
      break;
    case Kind::kOnInput:
      s += "on_input = " + Quote(a.signal) + "\n";
      break;
    case Kind::kOnOutput:
      s += "on_output = " + Quote(a.signal) + "\n";
      if (!a.readers.empty()) s += "readers = " + Array(a.readers) + "\n";
      break;
    case Kind::kForReaders:
      s += "for_readers = { signal = " + Quote(a.signal) + ", readers = " + Array(a.readers);
      if (!a.extra_inputs.empty()) s += ", extra_inputs = " + Array(a.extra_inputs);
      s += " }\n";
      break;
  }
  return s;
}

}  // namespace graybox::estimators
