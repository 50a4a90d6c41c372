// Model volumes (vti_io.cpp): a .vti as `udvr build` writes it (LZ4 appended arrays mean,
// stddev, min, max, quantiles, iqr, gmm and the field data), read as `render` and `probe` do.
#include "checks.h"
#include "fuzz_target.h"
#include "udvr/io/model_io.h"

UDVR_FUZZ_TARGET(model) {
    using namespace udvr;
    const auto path = fuzz::freshFile("model.vti", fuzz::text(input));
    fuzz::expectCleanResult([&] { fuzz::checkModel(readModelOrField(path), "model"); });
}
