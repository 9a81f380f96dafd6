#include "builtin_blocks.h"

namespace graybox::models::internal {

void RegisterDriveBlocks(BlockRegistry& /*registry*/) {}

}  // namespace graybox::models::internal
