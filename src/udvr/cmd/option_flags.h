#pragma once
// The CLI's flags for the library's option tables (render/render_options.h): one --NAME per
// OptionSpec with its help, parsed by setOption. A subcommand never lists these options by hand.
#include <CLI/CLI.hpp>
#include <span>

#include "udvr/render/render_options.h"

namespace udvr::cmd {

/// Register each option of `specs` on `sub` as --NAME (flags for bool fields), writing into
/// `options` as CLI11 parses (the error names the flag: "--zoom must lie in (0, 1000], got -1").
void addOptionFlags(CLI::App* sub, std::span<const OptionSpec> specs, RenderOptions& options);

}  // namespace udvr::cmd
