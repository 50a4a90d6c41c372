#include "udvr/util/json_text.h"

#include "udvr/util/check.h"

namespace udvr {

nlohmann::json parseJsonText(const std::string& text, const std::string& what) {
    try {
        return nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {  // parse_error, or out_of_range
        std::string reason = e.what();
        for (char& ch : reason)
            if (ch == '\n') ch = ' ';
        UDVR_FAIL(what << ": not valid JSON (" << reason << ")");
    }
}

}  // namespace udvr
