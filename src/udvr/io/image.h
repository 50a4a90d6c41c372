#pragma once
// Float RGBA images and their files (SPEC §5): PNG (8-bit, straight values), PFM and NPY
// (float32 RGBA). Pixel (0,0) is the top-left; rows top to bottom.
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "udvr/render/image_rgba.h"

namespace udvr {

/// Text chunks of a PNG (tEXt, Latin-1 keys of 1–79 characters): `udvr render` records its
/// settings in them (keys "udvr:model", "udvr:tf", …), which `udvr compare` reads.
using PngText = std::vector<std::pair<std::string, std::string>>;

/// PNG, 8 bits per channel RGBA, values clamped to [0,1] and rounded, with `text` as tEXt
/// chunks before the pixels; atomically.
void writePng(const std::filesystem::path& path, const ImageRgba& image, const PngText& text = {});
/// The tEXt/zTXt/iTXt chunks before a PNG's pixels (empty for a PNG without them); a
/// UdvrError for a file that is not a PNG.
PngText readPngText(const std::filesystem::path& path);
/// The PNG file writePng writes, in memory; zlib `level` 0–9 (-1: libpng's default; the pixels
/// are the same at every level).
std::vector<unsigned char> encodePng(const ImageRgba& image, int level = -1);
/// The 8-bit RGBA values writePng stores: each value clamped to [0, 1], ×255, rounded (NaN → 0).
std::vector<unsigned char> pngBytes8(const ImageRgba& image);
/// The image as written to a PNG and read back (8-bit values / 255): what `udvr compare` reads.
ImageRgba asWrittenToPng(const ImageRgba& image);
/// Read an 8-bit or 16-bit PNG (gray, RGB or RGBA) into [0,1] floats.
ImageRgba readPng(const std::filesystem::path& path);
/// float32 image by extension: .npy (shape height×width×4, '<f4', RGBA) or .pfm (colour "PF",
/// RGB only, rows bottom-to-top as the format requires); atomically.
void writeFloatImage(const std::filesystem::path& path, const ImageRgba& image);
/// Read .npy (h×w×4 or h×w×3 float32/float64) or .pfm back.
ImageRgba readFloatImage(const std::filesystem::path& path);
/// Read any image udvr writes, by extension (.png, .npy, .pfm).
ImageRgba readImage(const std::filesystem::path& path);

}  // namespace udvr
