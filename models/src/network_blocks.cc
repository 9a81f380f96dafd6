#include "builtin_blocks.h"

namespace graybox::models::internal {

void RegisterNetworkBlocks(BlockRegistry& /*registry*/) {}

}  // namespace graybox::models::internal
