// Descriptions of the registered block types for people writing problem files: the list of types
// with one line each, and one block's inputs, outputs, states and parameters (units, typical
// ranges, bounds, neutral values) with its equations. The equations are rendered from the block's
// own symbolic evaluation (Block::Evaluate on graybox::expr::Expr symbols named after the block's
// inputs, states and parameters), so they are the exact expressions a model built from the block
// integrates and differentiates, not a hand-written copy that could drift from the code.
//
//   std::cout << models::ListBlocks();
//   //   friction.coulomb      Coulomb friction fc tanh(s qd) ...
//   std::cout << models::DescribeBlock("friction.coulomb", {});
//   //   ... equations:
//   //     tau = fc*tanh(steepness*qd)
//
// A type that needs options (a network's sizes, a robot's joint) cannot be created without them:
// DescribeBlock then describes it with the registry's example options
// (BlockRegistry::TestOptions) and says so in its text. Unknown types throw
// std::invalid_argument with the registry's did-you-mean.
#pragma once

#include <cstddef>
#include <string>

#include "graybox/models/block.h"

namespace graybox::models {

struct BlockDescriptionOptions {
  /// An equation longer than this (characters) is summarised by its size in expression nodes
  /// (rigid-body chains and networks expand to thousands of terms).
  std::size_t max_equation_chars = 600;
};

/// Every registered type, sorted, with the first sentence of its description; one line each.
std::string ListBlocks(const BlockRegistry& registry = BlockRegistry::Global());

/// One block type created with `options`: its description and reference, the options used,
/// inputs, outputs and states (name [unit] (typical range) role: description), parameters
/// (name [unit] nominal, (lower, upper), neutral value, fixed by default) and equations
/// ("y = ..." per output, "d x/dt = ..." per state).
std::string DescribeBlock(const std::string& type, const BlockOptions& options,
                          const BlockDescriptionOptions& description_options = {},
                          const BlockRegistry& registry = BlockRegistry::Global());

}  // namespace graybox::models
