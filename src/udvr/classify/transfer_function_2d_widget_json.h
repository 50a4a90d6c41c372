#pragma once
// Widget JSON files of 2D transfer functions (SPEC §9, docs/formats.md): parsed and rasterised
// here, in the core, so that the CLI (io/'s readTransferFunction2D) and the ParaView plugin read
// them with one parser. nlohmann-json is header-only (as classify/probe's JSON).
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "udvr/classify/transfer_function_2d.h"
#include "udvr/classify/transfer_function_2d_widgets.h"

namespace udvr {

struct Tf2ReadOptions {
    /// x0, x1, y0, y1: required for .npy; overrides the domain of a .json; an error for .vti
    /// (the file carries its domain).
    std::optional<std::array<double, 4>> domain;
    /// W, H for widgets (.json): default the file's "resolution", else 256×256; an error for
    /// rasters.
    std::optional<std::array<int, 2>> resolution;
    /// Rasterise widgets even when that takes over kMaxTf2WidgetWorkWithoutForce evaluations.
    bool force = false;
};

/// Widget evaluations (points × widgets, a band counting one per segment) over which
/// rasterising a widget file needs Tf2ReadOptions::force (`--force`). 256 ellipses at 1024²
/// (2.7e8) took 41 s on 2 busy cores; a 26 KB file of 256 ellipses at 8192² is 1.7e10 (issue 34).
/// The default 256² takes 1e8 / 65536 ≈ 1500 widgets.
inline constexpr double kMaxTf2WidgetWorkWithoutForce = 1e8;

/// A widget file as parsed, before rasterisation.
struct Tf2WidgetFile {
    std::optional<std::array<double, 4>> domain;   // "domain" [x0, x1, y0, y1]
    std::optional<std::array<int, 2>> resolution;  // "resolution" [W, H]
    std::vector<Tf2Widget> widgets;
};

/// Widget raster per axis when neither the file nor the options give one.
inline constexpr int kDefaultTf2Resolution = 256;

/// The work of rasterising `widgets` onto width × height points: points × widgets, a band
/// counting one per segment (what kMaxTf2WidgetWorkWithoutForce and the server's cap bound).
double tf2WidgetWork(const std::vector<Tf2Widget>& widgets, int width, int height);

/// Parse widget JSON text; `what` names the source in errors (widget index and key).
Tf2WidgetFile parseTf2Widgets(const std::string& json, const std::string& what);
/// Parse and rasterise widget JSON text with the options' domain and resolution.
TransferFunction2D transferFunction2DFromWidgets(const std::string& json, const std::string& what,
                                                 const Tf2ReadOptions& options = {});

/// Throws UdvrError "WHAT: ..." unless the domain [x0, x1] × [y0, y1] is finite and non-empty.
void checkTf2Domain(const std::array<double, 4>& domain, const std::string& what);
/// Throws UdvrError "WHAT: ..." unless W and H lie in [2, kMaxTf2Resolution].
void checkTf2Resolution(const std::array<int, 2>& resolution, const std::string& what);

}  // namespace udvr
