#pragma once
// JSON text read whole (nlohmann::json, header-only): the one error for text that is not JSON.
#include <nlohmann/json.hpp>
#include <string>

namespace udvr {

/// The JSON document in `text`; a UdvrError "WHAT: not valid JSON (reason)" on one line for
/// text that is not JSON (a parse error, or a number out of range such as 1e999).
nlohmann::json parseJsonText(const std::string& text, const std::string& what);

}  // namespace udvr
