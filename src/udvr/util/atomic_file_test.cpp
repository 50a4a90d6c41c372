#include "udvr/util/atomic_file.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <fstream>
#include <sstream>
#include <string>

#include "udvr/util/check.h"

namespace udvr {
namespace {

namespace fs = std::filesystem;

fs::path freshDir(const std::string& name) {
    const fs::path dir =
        fs::temp_directory_path() / ("udvr_atomic_" + name + "_" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream os;
    os << in.rdbuf();
    return os.str();
}

void touch(const fs::path& p) { std::ofstream(p) << "partial"; }

/// A PID that no process has: a child that has exited and been reaped.
long deadPid() {
    const pid_t child = fork();
    if (child == 0) _exit(0);
    int status = 0;
    waitpid(child, &status, 0);
    return static_cast<long>(child);
}

}  // namespace

TEST(AtomicFile, TemporaryIsHiddenBesideTheDestinationWithItsExtension) {
    EXPECT_EQ(temporaryPathFor("out/model.vti", 1234), fs::path("out/.model.tmp1234.vti"));
    EXPECT_EQ(temporaryPathFor("img.png", 7), fs::path(".img.tmp7.png"));
}

TEST(AtomicFile, WritesWholeOrNothing) {
    const fs::path dir = freshDir("whole");
    const fs::path out = dir / "a.txt";
    writeFileAtomically(out, "first");
    EXPECT_EQ(slurp(out), "first");
    // A writer that fails leaves the previous file and no temporary.
    EXPECT_THROW(writeAtomically(out,
                                 [](const fs::path& tmp) {
                                     touch(tmp);
                                     UDVR_FAIL("disk on fire");
                                 }),
                 UdvrError);
    EXPECT_EQ(slurp(out), "first");
    EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
    fs::remove_all(dir);
}

TEST(AtomicFile, StaleTemporariesOfDeadProcessesAreRemoved) {
    const fs::path dir = freshDir("stale");
    const fs::path out = dir / "m.vti";
    const fs::path dead = temporaryPathFor(out, deadPid());
    const fs::path alive = temporaryPathFor(out, static_cast<long>(getppid()));
    const fs::path other = temporaryPathFor(dir / "n.vti", deadPid());  // another destination
    const fs::path lookalike = dir / ".m.tmpx1.vti";
    for (const fs::path& p : {dead, alive, other, lookalike}) touch(p);
    writeFileAtomically(out, "model");
    EXPECT_FALSE(fs::exists(dead));
    EXPECT_TRUE(fs::exists(alive));  // its process may still be writing it
    EXPECT_TRUE(fs::exists(other));
    EXPECT_TRUE(fs::exists(lookalike));
    EXPECT_EQ(slurp(out), "model");
    fs::remove_all(dir);
}

TEST(AtomicFile, MissingOrUnwritableDirectoryIsAOneLineFileError) {
    const fs::path dir = freshDir("dirs");
    try {
        writeFileAtomically(dir / "absent" / "x.txt", "x");
        ADD_FAILURE() << "no error";
    } catch (const FileError& e) {
        EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
    }
    // As root every directory is writable; the pytest runs this case as another user.
    if (geteuid() != 0) {
        fs::create_directories(dir / "ro");
        fs::permissions(dir / "ro", fs::perms::owner_read | fs::perms::owner_exec);
        try {
            writeFileAtomically(dir / "ro" / "x.txt", "x");
            ADD_FAILURE() << "no error";
        } catch (const FileError& e) {
            EXPECT_NE(std::string(e.what()).find("is not writable (Permission denied)"),
                      std::string::npos)
                << e.what();
        }
        fs::permissions(dir / "ro", fs::perms::owner_all);
    }
    fs::remove_all(dir);
}

TEST(AtomicFile, WriteErrorTextNamesFullDiskAndFileSizeLimit) {
    EXPECT_NE(writeErrorText(ENOSPC).find("the disk is full"), std::string::npos);
    EXPECT_NE(writeErrorText(EFBIG).find("ulimit -f"), std::string::npos);
    EXPECT_EQ(writeErrorText(0), "");
}

}  // namespace udvr
