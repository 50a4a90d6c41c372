// PNG and PFM images (image.cpp), as `udvr compare` reads them: the input as both.
#include "fuzz_target.h"
#include "udvr/io/image.h"

UDVR_FUZZ_TARGET(image) {
    using namespace udvr;
    auto& scratch = fuzz::Scratch::get();
    scratch.clear();
    const std::string bytes = fuzz::text(input);
    for (const char* name : {"image.png", "image.pfm"}) {
        const auto path = scratch.write(name, bytes);
        fuzz::expectCleanResult([&] {
            const ImageRgba image = readImage(path);
            if (image.width < 1 || image.height < 1 ||
                image.rgba.size() != static_cast<std::size_t>(image.width) * image.height * 4)
                fuzz::finding(std::string(name) + ": pixel count does not match its size");
        });
    }
}
