#pragma once
// Synthetic fields of the paper's experiments, sampled at grid points.
#include <string>
#include <string_view>
#include <vector>

#include "udvr/util/field.h"

namespace udvr {

/// Tangle (Knoll et al. 2009): x⁴−5x²+y⁴−5y²+z⁴−5z²+11.8 over [−2.5, 2.5]³ (the peer harness's
/// field exactly). Range [−6.95, 35.2375]; f < 0 is the tangle cube.
ScalarField makeTangle(int nx, int ny, int nz);

/// Teardrop (Knoll et al. 2009): 0.5x⁵ + 0.5x⁴ − y² − z², positive inside the drop, sampled over
/// x ∈ [−1.1, 0.1], y, z ∈ [−0.6, 0.6] (the drop spans x ∈ [−1, 0], radius ≤ 0.2); the field is
/// scaled by 100 so the isovalue band 0 sits in a range of a few units.
ScalarField makeTeardrop(int nx, int ny, int nz);

/// Nested spheres (Liu et al. 2012): four concentric shells of radii 0.2, 0.4, 0.6, 0.8 and
/// thickness 0.06 over [−1, 1]³, valued 25, 50, 75, 100 from the inside out, 0 elsewhere.
ScalarField makeNestedSpheres(int nx, int ny, int nz);

/// Marschner–Lobb test signal (1994) over [−1, 1]³, values in [0, 1]; a classic DVR benchmark.
ScalarField makeMarschnerLobb(int nx, int ny, int nz);

/// Field by name: tangle, teardrop, spheres, marschner-lobb. Throws UdvrError otherwise.
ScalarField makeSyntheticField(std::string_view name, int nx, int ny, int nz);
/// The names makeSyntheticField accepts.
const std::vector<std::string>& syntheticFieldNames();

}  // namespace udvr
