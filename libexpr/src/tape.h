// Private: the compiled instruction tape behind Function.
//
// Registers [0, num_pinned) hold inputs and constants and are never reused; constants are written
// once when a workspace is created. Registers from num_pinned on are work registers, reused as
// soon as the value they hold is dead (linear-scan allocation over the topological order). An
// instruction may write the register of one of its arguments: arguments are read first.
#pragma once

#include <cstdint>
#include <vector>

#include "graybox/expr/expr.h"
#include "graybox/expr/function.h"

namespace graybox::expr {

struct Instruction {
  Op op;
  std::int32_t out;
  std::int32_t a;
  std::int32_t b;
  std::int32_t c;
};

class Tape {
 public:
  Tape(const std::vector<std::vector<Expr>>& inputs, const std::vector<std::vector<Expr>>& outputs);

  int num_registers() const { return num_registers_; }
  const std::vector<Instruction>& code() const { return code_; }
  /// Register holding input i entry k, or -1 if the function does not use it.
  const std::vector<std::vector<int>>& input_registers() const { return input_registers_; }
  const std::vector<std::vector<int>>& output_registers() const { return output_registers_; }
  /// (register, value) of every constant.
  const std::vector<std::pair<int, double>>& constants() const { return constants_; }

  /// Runs the tape on one point; `r` has num_registers() entries with inputs and constants set.
  void Run(double* r) const;
  /// Runs the tape on kLanes points at once; register k of lane l is r[k * kLanes + l].
  void RunBatch(double* r) const;
  static constexpr int kLanes = 8;

 private:
  int num_registers_ = 0;
  std::vector<Instruction> code_;
  std::vector<std::vector<int>> input_registers_;
  std::vector<std::vector<int>> output_registers_;
  std::vector<std::pair<int, double>> constants_;
};

}  // namespace graybox::expr
