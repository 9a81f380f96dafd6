#include "builtin_blocks.h"

namespace graybox::models::internal {

void RegisterFrictionBlocks(BlockRegistry& /*registry*/) {}

}  // namespace graybox::models::internal
