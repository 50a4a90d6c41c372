// udvr render (SPEC §8). Placeholder until its issue lands.
#include "udvr/cmd/commands.h"
#include "udvr/util/check.h"

namespace udvr::cmd {

void addRenderCommand(CLI::App& app) {
    auto* sub = app.add_subcommand("render", "not implemented yet");
    sub->allow_extras();
    sub->callback([] { UDVR_FAIL("'udvr render' is not implemented yet"); });
}

}  // namespace udvr::cmd
