#pragma once
// ParaView transfer-function JSON (SPEC §7): a list of objects with "RGBPoints" [x,r,g,b,…]
// and "Points" [x,α,midpoint,sharpness,…] (a bare object is accepted too).
#include <filesystem>
#include <string>

#include "udvr/classify/transfer_function.h"

namespace udvr {

/// Read and validate; midpoint/sharpness other than 0.5/0 give one warning on stderr.
TransferFunction1D readTransferFunction(const std::filesystem::path& path);
/// Parse from JSON text (same rules); `what` names the source in errors.
TransferFunction1D parseTransferFunction(const std::string& json, const std::string& what);
/// Serialize as ParaView JSON (one object in a list).
std::string transferFunctionToJson(const TransferFunction1D& tf, const std::string& name);

}  // namespace udvr
