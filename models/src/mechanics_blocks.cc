#include "builtin_blocks.h"

namespace graybox::models::internal {

void RegisterMechanicsBlocks(BlockRegistry& /*registry*/) {}

}  // namespace graybox::models::internal
