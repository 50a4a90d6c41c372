// ParaView transfer-function JSON (transfer_function_io.cpp), as `--tf` reads it.
#include "checks.h"
#include "fuzz_target.h"
#include "udvr/io/transfer_function_io.h"

UDVR_FUZZ_TARGET(tf_json) {
    using namespace udvr;
    TransferFunction1D tf;
    if (fuzz::expectCleanResult([&] { tf = parseTransferFunction(fuzz::text(input), "tf.json"); }))
        fuzz::mustHold([&] { tf.validate(); }, "1D TF");
}
