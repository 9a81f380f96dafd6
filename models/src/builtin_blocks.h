// Private: registration of the built-in block families into the global registry.
#pragma once

#include "graybox/models/block.h"

namespace graybox::models::internal {

/// Called once by BlockRegistry::Global(); calls every family's function below.
void RegisterBuiltinBlocks(BlockRegistry& registry);

void RegisterFrictionBlocks(BlockRegistry& registry);       // src/friction_blocks.cc
void RegisterDriveBlocks(BlockRegistry& registry);          // src/drive_blocks.cc
void RegisterPneumaticBlocks(BlockRegistry& registry);      // src/pneumatic_blocks.cc
void RegisterNetworkBlocks(BlockRegistry& registry);        // src/network_blocks.cc
void RegisterRobotBlocks(BlockRegistry& registry);          // src/robot_blocks.cc
void RegisterMechanicsBlocks(BlockRegistry& registry);      // src/mechanics_blocks.cc
void RegisterSensorBlocks(BlockRegistry& registry);         // src/sensor_blocks.cc
void RegisterLoadBlocks(BlockRegistry& registry);           // src/load_blocks.cc
void RegisterChamberEffectBlocks(BlockRegistry& registry);  // src/chamber_effect_blocks.cc
void RegisterEquationBlocks(BlockRegistry& registry);       // src/equation_block.cc
void RegisterTransmissionEffectBlocks(
    BlockRegistry& registry);  // src/transmission_effect_blocks.cc

}  // namespace graybox::models::internal
