// ListBlocks and DescribeBlock (block_description.h).
#include "graybox/models/block_description.h"

#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "graybox/expr/expr.h"

namespace graybox::models {
namespace {

std::string Number(double v) {
  if (std::isnan(v)) return "none";
  if (std::isinf(v)) return v > 0.0 ? "inf" : "-inf";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.6g", v);
  return buf;
}

// The first sentence of `text` (up to and including the first ". "), or all of it.
std::string FirstSentence(const std::string& text) {
  const std::size_t end = text.find(". ");
  return end == std::string::npos ? text : text.substr(0, end + 1);
}

std::string OptionsText(const BlockOptions& options) {
  std::string text;
  for (const auto& [key, values] : options.numbers) {
    std::string list;
    for (const double v : values) list += (list.empty() ? "" : ", ") + Number(v);
    text +=
        (text.empty() ? "" : "; ") + key + " = " + (values.size() == 1 ? list : "[" + list + "]");
  }
  for (const auto& [key, word] : options.words) {
    text += (text.empty() ? "" : "; ") + key + " = \"" + word + "\"";
  }
  return text.empty() ? "(none)" : text;
}

void Signals(const char* title, const std::vector<SignalInfo>& signals, std::ostringstream* o) {
  *o << title << ":" << (signals.empty() ? " (none)" : "") << "\n";
  for (const SignalInfo& s : signals) {
    *o << "  " << s.name << " [" << s.unit << "] (" << Number(s.typical_min) << ", "
       << Number(s.typical_max) << ")";
    if (s.role != SignalRole::kNone) *o << " " << SignalRoleName(s.role);
    *o << ": " << s.description << "\n";
  }
}

std::string Equation(const expr::Expr& e, const BlockDescriptionOptions& options) {
  std::string text = e.ToString();
  if (text.size() > options.max_equation_chars) {
    text = "(an expression of " + std::to_string(e.CountNodes()) + " nodes; too long to print)";
  }
  return text;
}

}  // namespace

std::string ListBlocks(const BlockRegistry& registry) {
  std::size_t width = 0;
  for (const std::string& type : registry.Types()) width = std::max(width, type.size());
  std::ostringstream o;
  for (const std::string& type : registry.Types()) {
    std::string description;
    try {
      description =
          FirstSentence(registry.Create(type, registry.TestOptions(type))->info().description);
    } catch (const std::exception& e) {
      description = std::string("(not created with its example options: ") + e.what() + ")";
    }
    o << type << std::string(width + 2 - type.size(), ' ') << description << "\n";
  }
  return o.str();
}

std::string DescribeBlock(const std::string& type, const BlockOptions& options,
                          const BlockDescriptionOptions& description_options,
                          const BlockRegistry& registry) {
  std::unique_ptr<Block> block;
  BlockOptions used = options;
  std::string note;
  try {
    block = registry.Create(type, options);
  } catch (const std::invalid_argument& e) {
    const bool unknown = std::string(e.what()).rfind("unknown block type", 0) == 0;
    if (unknown || !(options.numbers.empty() && options.words.empty())) throw;
    used = registry.TestOptions(type);
    block = registry.Create(type, used);
    note = std::string("  (it needs options: ") + e.what() + "; shown with its example options)\n";
  }
  const BlockInfo& info = block->info();
  std::ostringstream o;
  o << type << ": " << info.description << "\n";
  if (!info.reference.empty()) o << "reference: " << info.reference << "\n";
  o << "options: " << OptionsText(used) << "\n" << note;
  if (info.stiff) o << "stiff at its nominal parameters (integrate with an implicit method)\n";
  Signals("inputs", info.inputs, &o);
  Signals("outputs", info.outputs, &o);
  Signals("states", info.states, &o);
  o << "parameters:" << (info.parameters.empty() ? " (none)" : "") << "\n";
  for (const ParameterInfo& p : info.parameters) {
    o << "  " << p.name << " [" << p.unit << "] nominal " << Number(p.nominal) << ", bounds ("
      << Number(p.lower) << ", " << Number(p.upper) << "), neutral " << Number(p.neutral)
      << (p.fixed_by_default ? ", fixed by default" : "") << ": " << p.description << "\n";
  }
  // The equations: the block evaluated on symbols named as its signals and parameters.
  std::vector<expr::Expr> x, u, p, xdot(info.states.size()), y(info.outputs.size());
  for (const SignalInfo& s : info.states) x.push_back(expr::Expr::Symbol(s.name));
  for (const SignalInfo& s : info.inputs) u.push_back(expr::Expr::Symbol(s.name));
  for (const ParameterInfo& q : info.parameters) p.push_back(expr::Expr::Symbol(q.name));
  BlockArgs<expr::Expr> args;
  args.x = x.data();
  args.u = u.data();
  args.p = p.data();
  args.xdot = xdot.data();
  args.y = y.data();
  block->Evaluate(args);
  o << "equations (the block's own symbolic evaluation):\n";
  for (std::size_t i = 0; i < y.size(); ++i) {
    o << "  " << info.outputs[i].name << " = " << Equation(y[i], description_options) << "\n";
  }
  for (std::size_t i = 0; i < xdot.size(); ++i) {
    o << "  d " << info.states[i].name << "/dt = " << Equation(xdot[i], description_options)
      << "\n";
  }
  return o.str();
}

}  // namespace graybox::models
