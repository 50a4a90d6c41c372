#pragma once
// The MPI job of `mpirun -np N udvr build … -o m.pvti` (issue 15 point 3; docs/formats.md,
// "Partitioned models"). udvr starts MPI only when it was built with it (-DUDVR_MPI=ON, the
// default where CMake finds MPI) and an MPI launcher started the process (its environment
// names a rank); otherwise it is rank 0 of 1 and makes no MPI call.
#include <string>

namespace udvr::cmd {

/// This process's place in the job: rank 0 of 1 outside MPI.
struct MpiJob {
    int rank = 0;
    int size = 1;
    bool active = false;  // MPI was started (and is finished by ~MpiScope)
    /// An MPI launcher started several copies of a udvr built without MPI: each would do the
    /// whole work and write the same output (`build` refuses).
    bool launchedWithoutMpi = false;
};

/// Starts MPI for the lifetime of main() when launched by mpirun/mpiexec (OpenMPI, MPICH or
/// PMIx environment) and built with MPI; finishes it on scope exit.
class MpiScope {
  public:
    MpiScope(int* argc, char*** argv);
    ~MpiScope();
    MpiScope(const MpiScope&) = delete;
    MpiScope& operator=(const MpiScope&) = delete;
};

/// The job this process runs in (rank 0 of 1 before MpiScope or without MPI).
const MpiJob& mpiJob();

/// Thrown on the ranks that are not to print the error of a failed collective step: main()
/// exits non-zero without a line, so that the error is printed once, by rank 0.
struct SilentFailure {};

/// Every rank calls this at the same point of its work, with its own error (empty: none). It
/// returns when no rank failed; otherwise rank 0 throws the error of the lowest failing rank as
/// a UdvrError ("rank R: …" when R is not 0) and every other rank throws SilentFailure. Outside
/// MPI: throws UdvrError(error) when error is not empty.
void agreeOrThrow(const std::string& error);

}  // namespace udvr::cmd
