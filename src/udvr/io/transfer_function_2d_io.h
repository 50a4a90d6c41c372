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
#include "udvr/classify/transfer_function_2d_widget_json.h"

namespace udvr {

/// Read any form by extension (.vti, .npy, .json, case-insensitive) and validate it; errors are
/// one-line UdvrErrors naming the file.
TransferFunction2D readTransferFunction2D(const std::filesystem::path& path,
                                          const Tf2ReadOptions& options = {});

/// Write the raster as .vti (float32 array "tf2", plus field data "tf2_domain" holding the exact
/// x0, x1, y0, y1), atomically.
void writeTransferFunction2DVti(const std::filesystem::path& path, const TransferFunction2D& tf);
/// Write the raster as .npy, shape (H, W, 4), '<f4', atomically (the domain is not stored).
void writeTransferFunction2DNpy(const std::filesystem::path& path, const TransferFunction2D& tf);
/// Write by extension (.vti or .npy).
void writeTransferFunction2D(const std::filesystem::path& path, const TransferFunction2D& tf);

}  // namespace udvr
