#pragma once
// What a file holds, without reading its data: the arrays (VTK point data) or variables (NetCDF)
// with their stored value types, for `udvr info`.
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "udvr/io/field_io.h"

namespace udvr {

struct ArrayInfo {
    std::string name;
    std::string type;  // as stored: uint8 … float64 (VTK/NetCDF names mapped to these)
    int components = 1;
    std::vector<std::string> dimNames;  // NetCDF: the variable's dimensions, slowest first
    std::vector<std::size_t> dimSizes;
};

/// The numeric arrays of a .vti (point data), the variables of a .nc, the one array of a NRRD
/// header or of a raw file (its --type). Throws UdvrError for unreadable files.
std::vector<ArrayInfo> listArrays(const std::filesystem::path& path, const RawLayout& raw = {});

}  // namespace udvr
