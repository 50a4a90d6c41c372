#pragma once
// The float RGBA image a frame renders into (SPEC §5): straight colour and accumulated opacity
// per pixel, pixel (0,0) the top-left, rows top to bottom. Its files are io/image.h's.
#include <cstddef>
#include <vector>

namespace udvr {

struct ImageRgba {
    int width = 0, height = 0;
    std::vector<float> rgba;  // width*height*4, row-major from the top row

    float* pixel(int x, int y) {
        return rgba.data() + 4 * (static_cast<std::size_t>(y) * width + x);
    }
    const float* pixel(int x, int y) const {
        return rgba.data() + 4 * (static_cast<std::size_t>(y) * width + x);
    }
};

}  // namespace udvr
