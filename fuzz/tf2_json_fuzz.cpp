// 2D transfer-function widget files (transfer_function_2d_io.cpp), parsed and rasterised. A
// file may ask for up to 8192² points; beyond 64² the raster is made at 64² (the
// `resolution` option's override) so that one input stays fast.
#include "checks.h"
#include "fuzz_target.h"
#include "udvr/io/transfer_function_2d_io.h"

UDVR_FUZZ_TARGET(tf2_json) {
    using namespace udvr;
    const std::string json = fuzz::text(input);
    Tf2ReadOptions options;
    fuzz::expectCleanResult([&] {
        const Tf2WidgetFile file = parseTf2Widgets(json, "tf2.json");
        const auto r = file.resolution.value_or(std::array<int, 2>{kDefaultTf2Resolution, 0});
        if (static_cast<long long>(r[0]) * r[1] > 64 * 64)
            options.resolution = std::array<int, 2>{64, 64};
    });
    TransferFunction2D tf;
    if (fuzz::expectCleanResult(
            [&] { tf = transferFunction2DFromWidgets(json, "tf2.json", options); }))
        fuzz::mustHold([&] { tf.validate(); }, "2D TF from widgets");
}
