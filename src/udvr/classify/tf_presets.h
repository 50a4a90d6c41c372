#pragma once
// Named transfer-function presets (ParaView-like colour maps with an opacity ramp) spread over a
// value range: what `udvr render` uses when no --tf is given, and what `--tf NAME` picks.
#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "udvr/classify/transfer_function.h"

namespace udvr {

/// The preset names, the default first ("cool-to-warm", ParaView's default colour map).
std::vector<std::string> transferFunctionPresetNames();
/// The names joined by ", " (for help texts and errors).
std::string transferFunctionPresetList();
/// Whether `name` is a preset (exact, lower case).
bool isTransferFunctionPreset(std::string_view name);

/// The preset `name` over [range[0], range[1]] (range[0] < range[1]). Colour: the map's control
/// points spread over the range. Opacity (per unit distance): 0 below `rampStart`, then linear
/// to 0.5 at range[1]; callers pass the volume's median as rampStart, so at least half of the
/// voxels are transparent (the background of a CT, the lower half of a simulation field).
/// rampStart is clamped into the range.
TransferFunction1D transferFunctionPreset(std::string_view name, std::array<double, 2> range,
                                          double rampStart);

}  // namespace udvr
