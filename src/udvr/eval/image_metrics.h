#pragma once
// Image error metrics of the paper's §5.1 (SPEC §6) and the blue–yellow difference image.
#include <vector>

#include "udvr/io/image.h"

namespace udvr {

/// Per-pixel d = |mean(R,G,B of model) − mean(R,G,B of truth)|, row-major from the top row.
/// Throws UdvrError when the sizes differ.
std::vector<float> pixelDifferences(const ImageRgba& model, const ImageRgba& truth);
/// RMSE = sqrt(mean over pixels of d²) (SPEC §6); throws UdvrError when the sizes differ.
double imageRmse(const ImageRgba& model, const ImageRgba& truth);
/// Difference image: |d| mapped through a blue (0) – white – yellow (maxDiff) diverging map, as
/// the paper's figures (blue = low, yellow = high difference). maxDiff ≤ 0 uses the image's
/// largest d (a constant blue image when the images are equal). Alpha = 1.
ImageRgba differenceImage(const ImageRgba& model, const ImageRgba& truth, double maxDiff = 0.0);
/// The colour of the difference map at t ∈ [0, 1] (clamped): RGB in [0, 1].
void differenceColor(double t, float rgb[3]);

/// Connected pieces of the pixels with alpha > threshold (8-neighbourhood): how many, the mask's
/// pixel count and the largest piece's, and its holes (pieces of the other pixels,
/// 4-neighbourhood, that do not touch the image border). The paper's Fig. 11 asks whether a
/// fiber surface stays in one piece.
struct MaskComponents {
    int count = 0;
    std::size_t pixels = 0, largest = 0;
    int holes = 0;
};
MaskComponents opaqueComponents(const ImageRgba& image, float alphaThreshold);

}  // namespace udvr
