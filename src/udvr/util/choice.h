#pragma once
// Names of a small closed set of choices (CLI words such as `--noise bimodal`) and their values.
#include <initializer_list>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>

#include "udvr/util/check.h"

namespace udvr {

/// The value named `name` among `choices`; else UdvrError "<what> '<name>' is not known;
/// expected a, b or c" (`what`: how the user gave it, e.g. "--density").
template <class E>
E parseChoice(std::string_view name, std::initializer_list<std::pair<std::string_view, E>> choices,
              std::string_view what) {
    for (const auto& [word, value] : choices)
        if (name == word) return value;
    std::ostringstream expected;
    std::size_t i = 0;
    for (const auto& choice : choices) {
        if (i > 0) expected << (i + 1 == choices.size() ? " or " : ", ");
        expected << choice.first;
        ++i;
    }
    UDVR_FAIL(what << " '" << name << "' is not known; expected " << expected.str());
}

}  // namespace udvr
