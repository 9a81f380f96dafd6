// Equation blocks: a block whose states, inputs, outputs, parameters and equations are written as
// text (in a problem file's [[model.blocks]] entry of type "equations", docs/problem-format.md),
// parsed once into expression trees and evaluated like every block on doubles and on libexpr
// expressions, so its derivatives are exact.
//
//   BlockOptions o;                                        // what the problem-file parser builds
//   o.words["inputs"] = "qin";      o.words["unit.qin"] = "m^3/s";
//   o.words["states"] = "h";        o.words["unit.h"] = "m";
//   o.words["derivative.h"] = "(qin - qout) / area";
//   o.words["outputs"] = "qout";    o.words["unit.qout"] = "m^3/s";
//   o.words["value.qout"] = "a * sqrt(2 * g * smooth_max(h, 0, 1e-4))";
//   o.words["parameters"] = "a";    o.words["unit.a"] = "m^2";
//   o.numbers["nominal.a"] = {1e-4}; o.numbers["bounds.a"] = {0, 1e-2};
//   o.words["constants"] = "g, area"; o.numbers["constant.g"] = {9.81}; ...
//   auto block = BlockRegistry::Global().Create("equations", o);
//
// ---- Options (BlockOptions; the problem file's `equations` table maps onto them)
// -----------------
//   words   inputs, states, outputs, parameters, constants   comma-separated names, in order
//           derivative.<state>       d<state>/dt, required for every state
//           value.<output>           the output, required for every output
//           unit.<name>              every input, state, output and parameter ("1" if left out)
//           role.<name>              signal role of an input, state or output (block.h
//                                    SignalRole: position, velocity, acceleration, force,
//                                    pressure, voltage, current), so the diagnosis finds axes
//           description.<name>, description (of the block)
//   numbers range.<signal> = {min, max}   typical range (default -1, 1)
//           nominal.<parameter>           (default 1), bounds.<parameter> = {lower, upper}
//           (default unbounded), neutral.<parameter> (default none: NaN)
//           constant.<name>               the value of each name in `constants`
// Names are identifiers ([A-Za-z_][A-Za-z0-9_]*), each used once across the five lists and not a
// function name or "pi".
//
// ---- Expressions
// ----------------------------------------------------------------------------------
//   numbers 2, 0.5, .5, 1e-3; names of inputs, states, parameters, constants, outputs (an output
//   may use the outputs listed before it; a derivative may use every output); pi
//   operators  + - * / ^ (power, right-associative, binds tighter than unary minus: -x^2 =
//              -(x^2)), unary + and -, parentheses, comparisons < <= > >= == != (1 or 0; lowest
//              precedence, for if_else conditions)
//   functions (the libexpr op table, expr.h): sqrt exp log sin cos tan atan tanh abs sign erf
//              square sigmoid softplus (1 argument), atan2 min max pow smooth_abs smooth_sign
//              (2), smooth_max smooth_min if_else (3): if_else(c, a, b) is a where c != 0.
//
// Errors. Every defect throws EquationError (a std::invalid_argument) naming the field
// ("derivative.h", "value.qout", "states") and, for an expression, the 0-based character offset
// inside it, with what was expected: "derivative.h: column 9: unknown name 'qoutt'; did you mean
// 'qout'?", "value.qout: column 5: 'atan2' takes 2 arguments, got 1", a state without a derivative,
// a name used twice, an option key that is none of the above.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>

#include "graybox/models/block.h"

namespace graybox::models {

/// The registry key of equation blocks.
inline constexpr char kEquationBlock[] = "equations";

/// A defect in an equation block's options or expressions.
class EquationError : public std::invalid_argument {
 public:
  /// `field`: the option key ("derivative.h"); `offset`: the 0-based character offset in the
  /// expression, or -1 when the defect is not inside an expression.
  EquationError(std::string field, int offset, const std::string& message);
  const std::string& field() const { return field_; }
  int offset() const { return offset_; }
  /// The message without the field and column.
  const std::string& reason() const { return reason_; }

 private:
  std::string field_;
  int offset_;
  std::string reason_;
};

/// Creates an equation block from `options` (see the file comment). Throws EquationError.
std::unique_ptr<Block> MakeEquationBlock(const BlockOptions& options);

}  // namespace graybox::models
