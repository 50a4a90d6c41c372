#pragma once
// Names of a small closed set of choices (CLI words such as `--noise bimodal`) and their values.
#include <cstddef>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "udvr/util/check.h"
#include "udvr/util/text_parse.h"

namespace udvr {

/// The value named `name` among `choices`; else UdvrError "<what> '<name>' is not known (did
/// you mean 'b'?); expected a, b or c" (`what`: how the user gave it, e.g. "--density"; the
/// hint where a name is near, didYouMean).
template <class E, std::size_t N>
E parseChoice(std::string_view name, const std::pair<std::string_view, E> (&choices)[N],
              std::string_view what) {
    for (const auto& [word, value] : choices)
        if (name == word) return value;
    std::ostringstream expected;
    std::vector<std::string> names;
    for (std::size_t i = 0; i < N; ++i) {
        expected << (i == 0 ? "" : i + 1 == N ? " or " : ", ") << choices[i].first;
        names.emplace_back(choices[i].first);
    }
    UDVR_FAIL(what << " '" << clipForMessage(name) << "' is not known" << didYouMean(name, names)
                   << "; expected " << expected.str());
}

}  // namespace udvr
