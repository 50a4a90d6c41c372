// tooth2d (Athawale et al. 2021, Fig. 10): 2D transfer functions over value × gradient
// magnitude on the tooth CT, full resolution against models of the volume reduced by bricks.
#include "udvr/eval/experiment_run.h"

namespace udvr::experiment_detail {

ExperimentResult runTooth2d(const fs::path&, const ExperimentOptions&) {
    UDVR_FAIL("experiment 'tooth2d' is not built yet");
}

}  // namespace udvr::experiment_detail
