#include "builtin_blocks.h"

namespace graybox::models::internal {

void RegisterRobotBlocks(BlockRegistry& /*registry*/) {}

}  // namespace graybox::models::internal
