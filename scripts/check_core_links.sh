#!/bin/bash
# Fails when a program linked only with udvr_core loads a library the core must not reach
# (VTK, NetCDF, HDF5, PNG, zlib, Cairo, pybind11/Python, MPI): the dynamic section's NEEDED
# entries, as the loader would see them.
#   bash scripts/check_core_links.sh build/udvr_core_only_test
set -euo pipefail
binary=$1
needed=$(readelf -d "$binary" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p')
echo "$binary needs: $(echo "$needed" | tr '\n' ' ')"
bad=$(echo "$needed" | grep -Ei 'vtk|netcdf|hdf5|png|libz\.|cairo|python|mpi' || true)
if [ -n "$bad" ]; then
    echo "check_core_links: the core reaches foreign libraries: $(echo "$bad" | tr '\n' ' ')" >&2
    exit 1
fi
echo "check_core_links: ok"
