// .npy files (npy.cpp): float images as `udvr compare` reads them (image.cpp) and 2D
// transfer-function rasters with a domain given (transfer_function_2d_io.cpp).
#include "checks.h"
#include "fuzz_target.h"
#include "udvr/io/image.h"
#include "udvr/io/npy.h"
#include "udvr/io/transfer_function_2d_io.h"

UDVR_FUZZ_TARGET(npy) {
    using namespace udvr;
    const std::string bytes = fuzz::text(input);
    const auto path = fuzz::freshFile("data.npy", bytes);
    fuzz::expectCleanResult([&] { parseNpyHeader(bytes, "data.npy"); });
    fuzz::expectCleanResult([&] {
        const ImageRgba image = readImage(path);
        if (image.width < 1 || image.height < 1 ||
            image.rgba.size() != static_cast<std::size_t>(image.width) * image.height * 4)
            fuzz::finding("npy image: pixel count does not match its size");
    });
    Tf2ReadOptions options;
    options.domain = std::array<double, 4>{0.0, 1.0, -2.0, 2.0};
    TransferFunction2D tf;
    if (fuzz::expectCleanResult([&] { tf = readTransferFunction2D(path, options); }))
        fuzz::mustHold([&] { tf.validate(); }, "2D TF from .npy");
}
