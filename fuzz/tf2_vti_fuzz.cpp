// 2D transfer-function rasters as .vti (vti_io.cpp): W×H×1 points, a 4-component point array.
#include "checks.h"
#include "fuzz_target.h"
#include "udvr/io/transfer_function_2d_io.h"

UDVR_FUZZ_TARGET(tf2_vti) {
    using namespace udvr;
    const auto path = fuzz::freshFile("tf2.vti", fuzz::text(input));
    TransferFunction2D tf;
    if (fuzz::expectCleanResult([&] { tf = readTransferFunction2D(path); }))
        fuzz::mustHold([&] { tf.validate(); }, "2D TF from .vti");
}
