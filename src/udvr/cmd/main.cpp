// udvr: uncertainty-aware direct volume rendering (SPEC §8).
#include <cstdio>
#include <exception>
#include <string>

#include "udvr/cmd/commands.h"
#include "udvr/util/check.h"
#include "udvr/util/parallel.h"

int main(int argc, char** argv) {
    CLI::App app{"udvr: direct volume rendering of uncertain data (Athawale et al., TVCG 2021)"};
    app.require_subcommand(1);
    app.set_version_flag("--version", "udvr 0.1.0");
    int threads = 0;
    app.add_option("--threads", threads, "worker threads (0 = all cores)")
        ->check(CLI::NonNegativeNumber);
    app.parse_complete_callback([&] { udvr::setThreadCount(threads); });

    udvr::cmd::addGenerateCommand(app);
    udvr::cmd::addPerturbCommand(app);
    udvr::cmd::addBuildCommand(app);
    udvr::cmd::addProbeCommand(app);
    udvr::cmd::addRenderCommand(app);
    udvr::cmd::addCompareCommand(app);
    udvr::cmd::addExperimentCommand(app);

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::string msg = e.what();
        for (char& c : msg)
            if (c == '\n') c = ' ';
        std::fprintf(stderr, "udvr: error: %s (see 'udvr --help')\n", msg.c_str());
        return 2;
    } catch (const udvr::UdvrError& e) {
        std::fprintf(stderr, "udvr: error: %s\n", e.what());
        return 2;
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "udvr: error: out of memory\n");
        return 3;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "udvr: internal error: %s\n", e.what());
        return 4;
    }
    return 0;
}
