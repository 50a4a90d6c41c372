// udvr compare (SPEC §8). Placeholder until its issue lands.
#include "udvr/cmd/commands.h"
#include "udvr/util/check.h"

namespace udvr::cmd {

void addCompareCommand(CLI::App& app) {
    auto* sub = app.add_subcommand("compare", "not implemented yet");
    sub->allow_extras();
    sub->callback([] { UDVR_FAIL("'udvr compare' is not implemented yet"); });
}

}  // namespace udvr::cmd
