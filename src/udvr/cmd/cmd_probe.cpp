// udvr probe (SPEC §8). Placeholder until its issue lands.
#include "udvr/cmd/commands.h"
#include "udvr/util/check.h"

namespace udvr::cmd {

void addProbeCommand(CLI::App& app) {
    auto* sub = app.add_subcommand("probe", "not implemented yet");
    sub->allow_extras();
    sub->callback([] { UDVR_FAIL("'udvr probe' is not implemented yet"); });
}

}  // namespace udvr::cmd
