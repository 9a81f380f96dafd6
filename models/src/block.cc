#include "graybox/models/block.h"
#include "graybox/util/did_you_mean.h"

#include <algorithm>
#include <stdexcept>

#include "builtin_blocks.h"

namespace graybox::models {

std::vector<double> Block::NominalParameters() const {
  std::vector<double> p;
  p.reserve(info_.parameters.size());
  for (const auto& par : info_.parameters) p.push_back(par.nominal);
  return p;
}

const char* SignalRoleName(SignalRole role) {
  switch (role) {
    case SignalRole::kNone:
      return "none";
    case SignalRole::kPosition:
      return "position";
    case SignalRole::kVelocity:
      return "velocity";
    case SignalRole::kAcceleration:
      return "acceleration";
    case SignalRole::kForce:
      return "force";
    case SignalRole::kPressure:
      return "pressure";
    case SignalRole::kVoltage:
      return "voltage";
    case SignalRole::kCurrent:
      return "current";
  }
  return "none";
}

BlockRegistry& BlockRegistry::Global() {
  static BlockRegistry* registry = [] {
    auto* r = new BlockRegistry();
    internal::RegisterBuiltinBlocks(*r);
    return r;
  }();
  return *registry;
}

void BlockRegistry::Register(const std::string& type, BlockFactory factory,
                             BlockOptions test_options) {
  if (entries_.count(type)) {
    throw std::logic_error("BlockRegistry: block type '" + type + "' is registered twice");
  }
  entries_[type] = Entry{std::move(factory), std::move(test_options)};
}

std::unique_ptr<Block> BlockRegistry::Create(const std::string& type,
                                             const BlockOptions& options) const {
  auto it = entries_.find(type);
  if (it == entries_.end()) {
    const std::string hint = util::DidYouMean(type, Types());
    throw std::invalid_argument("unknown block type '" + type + "'" +
                                (hint.empty() ? "" : "; did you mean '" + hint + "'?"));
  }
  return it->second.factory(options);
}

std::vector<std::string> BlockRegistry::Types() const {
  std::vector<std::string> types;
  for (const auto& [type, entry] : entries_) types.push_back(type);
  return types;
}

const BlockOptions& BlockRegistry::TestOptions(const std::string& type) const {
  auto it = entries_.find(type);
  if (it == entries_.end()) {
    throw std::invalid_argument("unknown block type '" + type + "'");
  }
  return it->second.test_options;
}

void CheckOptionKeys(const std::string& type, const BlockOptions& options,
                     const std::vector<std::string>& known) {
  auto check = [&](const std::string& key) {
    if (std::find(known.begin(), known.end(), key) != known.end()) return;
    std::string list;
    for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
    const std::string hint = util::DidYouMean(key, known);
    throw std::invalid_argument("block '" + type + "': unknown option '" + key + "'" +
                                (hint.empty() ? "" : "; did you mean '" + hint + "'?") +
                                " (expected one of: " + (list.empty() ? "none" : list) + ")");
  };
  for (const auto& [key, value] : options.numbers) check(key);
  for (const auto& [key, value] : options.words) check(key);
}

}  // namespace graybox::models
