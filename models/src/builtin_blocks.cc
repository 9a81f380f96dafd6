#include "builtin_blocks.h"

namespace graybox::models::internal {

void RegisterBuiltinBlocks(BlockRegistry& registry) {
  RegisterFrictionBlocks(registry);
  RegisterDriveBlocks(registry);
  RegisterPneumaticBlocks(registry);
  RegisterNetworkBlocks(registry);
  RegisterRobotBlocks(registry);
  RegisterMechanicsBlocks(registry);
  RegisterSensorBlocks(registry);
  RegisterLoadBlocks(registry);
  RegisterChamberEffectBlocks(registry);
  RegisterTransmissionEffectBlocks(registry);
  RegisterEquationBlocks(registry);
}

}  // namespace graybox::models::internal
