#include "builtin_blocks.h"

namespace graybox::models::internal {

void RegisterPneumaticBlocks(BlockRegistry& /*registry*/) {}

}  // namespace graybox::models::internal
