// udvr: uncertainty-aware direct volume rendering (SPEC §8).
#include <cstdio>
#include <exception>
#include <string>

#include "udvr/cmd/commands.h"
#include "udvr/cmd/mpi_job.h"
#include "udvr/cmd/parse_util.h"
#include "udvr/util/atomic_file.h"
#include "udvr/util/build_info.h"
#include "udvr/util/check.h"
#include "udvr/util/parallel.h"
#include "udvr/util/text_parse.h"

namespace {

// The first word that is neither an option nor the value of --threads: the command name.
std::string firstCommandWord(int argc, char** argv) {
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--threads") {
            ++i;
            continue;
        }
        if (!a.empty() && a[0] == '-') continue;
        return a;
    }
    return {};
}

}  // namespace

int main(int argc, char** argv) {
    // Ctrl-C or a kill removes the temporary output being written; over the file size limit a
    // write fails (EFBIG) with an error line instead of SIGXFSZ killing the process.
    udvr::installInterruptCleanup();
    // MPI when an MPI launcher started this process (`mpirun -np N udvr build … -o m.pvti`).
    udvr::cmd::MpiScope mpi(&argc, &argv);
    CLI::App app{"udvr: direct volume rendering of uncertain data (Athawale et al., TVCG 2021)"};
    app.require_subcommand(1);
    // The version, the CPU target (UDVR_ARCH) and the vector registers in use.
    app.set_version_flag("--version", std::string(udvr::build::versionLine()));
    int threads = 0;
    const char* threadsHelp = "worker threads (0 = all cores; clamped to 4x the hardware threads)";
    app.add_option("--threads", threads, threadsHelp)->check(udvr::cmd::wholeNumberIn(0, 4096));
    app.parse_complete_callback([&] { udvr::setThreadCount(threads); });

    udvr::cmd::addGenerateCommand(app);
    udvr::cmd::addPerturbCommand(app);
    udvr::cmd::addBuildCommand(app);
    udvr::cmd::addProbeCommand(app);
    udvr::cmd::addRenderCommand(app);
    udvr::cmd::addCompareCommand(app);
    udvr::cmd::addExperimentCommand(app);
    udvr::cmd::addTf2Command(app);
    udvr::cmd::addInfoCommand(app);
    udvr::cmd::addServeCommand(app);
    // --threads also after the command word (`udvr render m.vti --threads 1`): every subcommand
    // takes it into the same variable, with the same check.
    for (CLI::App* sub : app.get_subcommands({}))
        sub->add_option("--threads", threads, threadsHelp)
            ->check(udvr::cmd::wholeNumberIn(0, 4096));

    // Under mpirun every rank runs the same command line, so an error before the ranks part is
    // every rank's: rank 0 says it (a rank's own error reaches rank 0 through agreeOrThrow).
    const udvr::cmd::MpiJob& job = udvr::cmd::mpiJob();
    if (job.active && job.rank != 0) {  // help, version, notes and errors: once, by rank 0
        if (std::freopen("/dev/null", "w", stdout) == nullptr) std::fclose(stdout);
        if (std::freopen("/dev/null", "w", stderr) == nullptr) std::fclose(stderr);
    }
    try {
        if (const std::string word = firstCommandWord(argc, argv);
            job.active && job.size > 1 && !word.empty() && word != "build")
            UDVR_FAIL(
                "under mpirun only `build -o m.pvti` runs on several ranks (each rank would "
                "do the whole work and write the same files); run '"
                << word << "' without mpirun");
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        // CLI11 reports `udvr frobnicate` as a missing subcommand; name the word instead.
        if (app.get_subcommands().empty()) {
            const std::string word = firstCommandWord(argc, argv);
            std::string names;
            bool known = false;
            for (const CLI::App* sub : app.get_subcommands({})) {
                names += (names.empty() ? "" : ", ") + sub->get_name();
                known = known || sub->get_name() == word;
            }
            if (!word.empty() && !known) {
                std::vector<std::string> all;
                for (const CLI::App* sub : app.get_subcommands({})) all.push_back(sub->get_name());
                std::fprintf(stderr, "udvr: error: unknown command '%s'%s (expected one of %s)\n",
                             word.c_str(), udvr::didYouMean(word, all).c_str(), names.c_str());
                return 2;
            }
        }
        std::string msg = e.what();
        // An option misspelt: name the nearest option of the command (issue 35).
        if (dynamic_cast<const CLI::ExtrasError*>(&e) != nullptr &&
            !app.get_subcommands().empty()) {
            const CLI::App* sub = app.get_subcommands().back();
            std::vector<std::string> flags;
            for (const CLI::Option* opt : sub->get_options())
                for (const std::string& l : opt->get_lnames()) flags.push_back("--" + l);
            for (const std::string& extra : sub->remaining())
                if (extra.rfind("--", 0) == 0)
                    msg += udvr::didYouMean(extra.substr(0, extra.find('=')), flags);
        }
        for (char& c : msg)
            if (c == '\n') c = ' ';
        std::fprintf(stderr, "udvr: error: %s (see 'udvr --help')\n", msg.c_str());
        return 2;
    } catch (const udvr::UdvrError& e) {
        std::fprintf(stderr, "udvr: error: %s\n", e.what());
        return 2;
    } catch (const udvr::cmd::SilentFailure&) {
        return 2;  // another MPI rank (rank 0) says the error
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "udvr: error: out of memory\n");
        return 3;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "udvr: internal error: %s\n", e.what());
        return 4;
    }
    return 0;
}
