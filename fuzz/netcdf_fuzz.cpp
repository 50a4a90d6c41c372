// NetCDF (netcdf_io.cpp): classic, 64-bit offset, CDF-5 and NetCDF-4/HDF5 files, read as a
// field, as an ensemble (a variable with a member dimension) and listed as `udvr info` does.
// netCDF-C opens files by name, so the input is written to a file first.
#include "checks.h"
#include "fuzz_target.h"
#include "udvr/io/ensemble_io.h"
#include "udvr/io/field_io.h"
#include "udvr/io/file_info.h"
#include "udvr/io/io_detail.h"

UDVR_FUZZ_TARGET(netcdf) {
    using namespace udvr;
    // A damaged NetCDF-4 file on which HDF5 never returns costs 0.1 s, not 10.
    static const bool quickProbe = (detail::setHdf5ProbeSeconds(0.1), true);
    (void)quickProbe;
    const auto path = fuzz::freshFile("data.nc", fuzz::text(input));
    fuzz::expectCleanResult([&] { fuzz::checkField(readField(path), "NetCDF field"); });
    fuzz::expectCleanResult(
        [&] { fuzz::checkEnsemble(readEnsemble({path.string()}, {}), "NetCDF ensemble"); });
    fuzz::expectCleanResult([&] { listArrays(path); });
}
