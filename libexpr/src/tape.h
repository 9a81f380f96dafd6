// Private: the compiled instruction tape behind Function.
//
// A multiplication whose only user is an addition or subtraction is fused with it into one
// instruction (a*b + c, a*b - c, c - a*b), which halves dispatch and memory traffic on the sums of
// products that dominate dynamics models; the two roundings are kept, so results are identical.
//
// Registers [0, num_pinned) hold inputs and constants and are never reused; constants are written
// once when a workspace is created. Registers from num_pinned on are work registers, reused as
// soon as the value they hold is dead (linear-scan allocation over the schedule). An
// instruction may write the register of one of its arguments: arguments are read first.
#pragma once

#include <cstdint>
#include <vector>

#include "graybox/expr/expr.h"
#include "graybox/expr/function.h"

namespace graybox::expr {

/// Tape opcodes: every graph operation (its Op value), then fused forms of two graph operations
/// (each evaluates exactly as the two operations in sequence, same rounding), then the end marker.
namespace tape_code {
constexpr std::uint8_t kMulAdd = kNumOps;      // out = a*b + c
constexpr std::uint8_t kMulSub = kNumOps + 1;  // out = a*b - c
constexpr std::uint8_t kSubMul = kNumOps + 2;  // out = c - a*b
constexpr std::uint8_t kEnd = kNumOps + 3;
constexpr int kCount = kNumOps + 4;
}  // namespace tape_code

struct Instruction {
  std::uint8_t code;  // an Op value or a tape_code constant
  std::int32_t out;
  std::int32_t a;
  std::int32_t b;
  std::int32_t c;
};

class Tape {
 public:
  struct Span {
    const Instruction* first;
    std::size_t count;
    const Instruction* begin() const { return first; }
    const Instruction* end() const { return first + count; }
    std::size_t size() const { return count; }
  };
  /// How instructions are ordered.
  enum class Schedule {
    /// Depth-first topological order: fewest live registers. Used for batches (whose registers
    /// are kLanes wide) and for generated code.
    kDepthFirst,
    /// Ready-list order that emits runs of the same opcode: Run() executes a run with one
    /// well-predicted loop instead of one indirect jump per instruction, which keeps long tapes
    /// as fast per instruction as short ones. Uses more registers.
    kGroupedByOpcode,
  };

  Tape(const std::vector<std::vector<Expr>>& inputs, const std::vector<std::vector<Expr>>& outputs,
       Schedule schedule = Schedule::kDepthFirst);

  int num_registers() const { return num_registers_; }
  /// The instructions, in execution order.
  Span code() const { return {code_.data(), code_.size() - 1}; }
  /// Register holding input i entry k, or -1 if the function does not use it.
  const std::vector<std::vector<int>>& input_registers() const { return input_registers_; }
  const std::vector<std::vector<int>>& output_registers() const { return output_registers_; }
  /// (register, value) of every constant.
  const std::vector<std::pair<int, double>>& constants() const { return constants_; }

  /// Runs the tape on one point; `r` has num_registers() entries with inputs and constants set.
  void Run(double* r) const;
  /// Runs the tape on kLanes points at once; register k of lane l is r[k * kLanes + l].
  void RunBatch(double* r) const;
  static constexpr int kLanes = 16;

 private:
  int num_registers_ = 0;
  std::vector<Instruction> code_;
  std::vector<std::vector<int>> input_registers_;
  std::vector<std::vector<int>> output_registers_;
  std::vector<std::pair<int, double>> constants_;
};

}  // namespace graybox::expr
