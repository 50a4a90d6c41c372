#pragma once
// Named transfer-function presets (ParaView-like colour maps with an opacity ramp) spread over a
// value range: what `udvr render` uses when no --tf is given, and what `--tf NAME` picks.
#include <array>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "udvr/classify/transfer_function.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/grid.h"

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

/// A preset spread over data (what `render`/`probe` use without --tf): the TF and what it was
/// made from, for the note the front end prints.
struct PresetOverValues {
    TransferFunction1D tf;
    std::array<double, 2> range{};  // the values' 0.5–99.5th percentiles, or the given range
    double rampStart = 0.0;         // the values' median (range[0] for a constant volume)
    bool constant = false;          // all values equal: the ramp rises over the whole range
    std::string opacityRule;        // what the opacity follows, for the note ("" = the ramp)
};

/// What the default TF (no --tf) is made of, from a field on its grid: the colour range (the
/// values' robust range), their median, and the opacity curve (per unit distance). A model
/// built with --downsample records its full-resolution field's basis (field data
/// `default_tf`), so the model and its ground truth get the same default TF (issue 35).
struct DefaultTfBasis {
    std::array<double, 2> range{};
    double median = 0.0;
    bool constant = false;
    std::vector<double> opacityX, opacity;  // empty: the ramp from the median
    std::string rule;                       // how the opacity was chosen, for the note
};
/// The basis of `values` (finite, x fastest on `grid`).
DefaultTfBasis defaultTfBasis(const Grid3& grid, std::span<const float> values);
/// The basis as the doubles of field data `default_tf` and back (a UdvrError naming `what` for
/// a malformed one).
std::vector<double> encodeDefaultTfBasis(const DefaultTfBasis& basis);
DefaultTfBasis decodeDefaultTfBasis(std::span<const double> encoded, const std::string& what);
/// The basis of a model's default TF: the recorded one (field data `default_tf`), else that of
/// its means on its grid (a field's values; an ensemble's member means).
DefaultTfBasis defaultTfBasisOf(const ModelVolume& model);
/// The preset `name` over a basis: colours over `range` (default the basis's), the basis's
/// opacity (or, with a range given, the ramp from the median clamped into it).
PresetOverValues transferFunctionPresetOver(std::string_view name, const DefaultTfBasis& basis,
                                            const std::optional<std::array<double, 2>>& range);
/// The preset `name` over `range` (default: robustRange of `values`, which must be finite and
/// non-empty), its opacity ramp starting at the values' median. A constant volume would be
/// clear with the ramp starting at its value, so its ramp starts at the bottom of the range and
/// the volume shows as a translucent box.
PresetOverValues transferFunctionPresetOver(std::string_view name, std::span<const float> values,
                                            const std::optional<std::array<double, 2>>& range);

/// The peer harness's three-band tangle TF (bench/peer/make_tangle.py, data/tf/tangle.json):
/// opaque red cores at −4.5, a gold shell at 0, a faint blue shell at 3.
TransferFunction1D tangleTransferFunction();

}  // namespace udvr
