// The problem-file text of an augmentation: the [[model.augment]] table that states a
// models::Augmentation (augmentation.h; the keys are in docs/problem-format.md, "Augmentations"),
// so that a candidate the diagnosis tried can be appended to the problem file it came from and
// re-run with `graybox fit` (warm-started with `--from result.json`).
//
//   models::Augmentation a;
//   a.kind = models::Augmentation::Kind::kOnSignal;
//   a.instance = "input_delay";
//   a.type = "delay.first_order";
//   a.options.words["unit"] = "N";
//   a.signal = "force";
//   AugmentationToml(a) ==
//       "[[model.augment]]\n"
//       "instance = \"input_delay\"\n"
//       "type = \"delay.first_order\"\n"
//       "options = { unit = \"N\" }\n"
//       "on_signal = \"force\"\n"
#pragma once

#include <string>

#include "graybox/models/augmentation.h"

namespace graybox::estimators {

/// The [[model.augment]] table of `augmentation`, ending with a newline: keys instance, type,
/// options (left out when there are none; words as strings, one number as a number, several as an
/// array, an empty list as []) and the placement of its kind (inputs and outputs, on_signal,
/// on_output with readers when there are any, or for_readers = {signal, readers, extra_inputs}).
/// Numbers are written with the fewest digits that read back to the same double, so the problem
/// parser reads the table back into an equal Augmentation (operator==). Throws
/// models::AugmentationError when Validate() fails, and std::invalid_argument for an option
/// number that is not finite (the parser rejects NaN and infinities) or an option key that is both
/// a number and a word.
std::string AugmentationToml(const models::Augmentation& augmentation);

}  // namespace graybox::estimators
