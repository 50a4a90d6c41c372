#include "udvr/cmd/mpi_job.h"

#include <climits>
#include <cstdlib>
#include <vector>

#include "udvr/util/check.h"

#ifdef UDVR_HAVE_MPI
#include <mpi.h>
#endif

namespace udvr::cmd {
namespace {

MpiJob gJob;

/// Whether an MPI launcher started this process: each sets the rank in the environment.
bool launchedByMpi() {
    for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "MPI_LOCALNRANKS"})
        if (std::getenv(name) != nullptr) return true;
    return false;
}

}  // namespace

const MpiJob& mpiJob() { return gJob; }

#ifdef UDVR_HAVE_MPI

MpiScope::MpiScope(int* argc, char*** argv) {
    if (!launchedByMpi()) return;
    // The ranks call MPI from the main thread only (TBB's workers never do).
    int provided = 0;
    if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) return;
    gJob.active = true;
    MPI_Comm_rank(MPI_COMM_WORLD, &gJob.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &gJob.size);
}

MpiScope::~MpiScope() {
    if (gJob.active) MPI_Finalize();
    gJob = MpiJob{};
}

void agreeOrThrow(const std::string& error) {
    if (!gJob.active) {
        if (!error.empty()) UDVR_FAIL(error);
        return;
    }
    int mine = error.empty() ? INT_MAX : gJob.rank, first = INT_MAX;
    MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (first == INT_MAX) return;
    if (first == 0) {
        if (gJob.rank == 0) UDVR_FAIL(error);
        throw SilentFailure{};
    }
    // The first failing rank sends its message to rank 0, which says it.
    if (gJob.rank == first) {
        int length = static_cast<int>(error.size());
        MPI_Send(&length, 1, MPI_INT, 0, 0, MPI_COMM_WORLD);
        MPI_Send(error.data(), length, MPI_CHAR, 0, 1, MPI_COMM_WORLD);
    }
    if (gJob.rank != 0) throw SilentFailure{};
    int length = 0;
    MPI_Recv(&length, 1, MPI_INT, first, 0, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    std::vector<char> text(static_cast<std::size_t>(length));
    MPI_Recv(text.data(), length, MPI_CHAR, first, 1, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    UDVR_FAIL("rank " << first << ": " << std::string(text.begin(), text.end()));
}

#else  // built without MPI: always rank 0 of 1

MpiScope::MpiScope(int*, char***) {
    const char* size = std::getenv("OMPI_COMM_WORLD_SIZE");
    if (size == nullptr) size = std::getenv("PMI_SIZE");
    gJob.launchedWithoutMpi = launchedByMpi() && size != nullptr && std::atoi(size) > 1;
}
MpiScope::~MpiScope() = default;

void agreeOrThrow(const std::string& error) {
    if (!error.empty()) UDVR_FAIL(error);
}

#endif

}  // namespace udvr::cmd
