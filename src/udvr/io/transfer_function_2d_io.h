#pragma once
// 2D transfer-function files (SPEC §9, docs/formats.md), chosen by extension:
//  - .vti: a raster of W×H×1 points with a 4-component float/double point array (r, g, b, α):
//    x along i, y along j, origin and spacing give the domain (VTK's
//    vtkVolumeProperty::SetTransferFunction2D form);
//  - .npy: a raster of shape (H, W, 4), '<f4', '<f8' or '|u1' (bytes scaled by 1/255), C order,
//    row j at y0 + j·(y1 − y0)/(H − 1); the domain comes from the options;
//  - .json: widgets (box, triangle, ellipse, band) rasterised onto W×H points.
#include <array>
#include <filesystem>
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

/// Read any form by extension (.vti, .npy, .json, case-insensitive) and validate it; errors are
/// one-line UdvrErrors naming the file.
TransferFunction2D readTransferFunction2D(const std::filesystem::path& path,
                                          const Tf2ReadOptions& options = {});

/// Parse widget JSON text; `what` names the source in errors (widget index and key).
Tf2WidgetFile parseTf2Widgets(const std::string& json, const std::string& what);
/// Parse and rasterise widget JSON text with the options' domain and resolution.
TransferFunction2D transferFunction2DFromWidgets(const std::string& json, const std::string& what,
                                                 const Tf2ReadOptions& options = {});

/// Write the raster as .vti (float32 array "tf2", plus field data "tf2_domain" holding the exact
/// x0, x1, y0, y1), atomically.
void writeTransferFunction2DVti(const std::filesystem::path& path, const TransferFunction2D& tf);
/// Write the raster as .npy, shape (H, W, 4), '<f4', atomically (the domain is not stored).
void writeTransferFunction2DNpy(const std::filesystem::path& path, const TransferFunction2D& tf);
/// Write by extension (.vti or .npy).
void writeTransferFunction2D(const std::filesystem::path& path, const TransferFunction2D& tf);

}  // namespace udvr
