#pragma once
// One function per subcommand; each lives in its own file and registers a CLI11 subcommand
// whose callback parses, calls the library and prints. No algorithms here.
#include <CLI/CLI.hpp>

namespace udvr::cmd {

void addGenerateCommand(CLI::App& app);
void addPerturbCommand(CLI::App& app);
void addBuildCommand(CLI::App& app);
void addProbeCommand(CLI::App& app);
void addRenderCommand(CLI::App& app);
void addCompareCommand(CLI::App& app);
void addExperimentCommand(CLI::App& app);
void addTf2Command(CLI::App& app);
void addInfoCommand(CLI::App& app);
void addServeCommand(CLI::App& app);

}  // namespace udvr::cmd
