// Files written whole or not at all (io/atomic_file.h):
//  * a file not committed leaves nothing, and the old file under the name
//    stays whole until the commit replaces it;
//  * a write that fails (the file-size limit: EFBIG) throws naming the
//    path and leaves nothing;
//  * a symbolic link (a chain, a dangling one) is written through to its
//    target and stays a link;
//  * probe_writable refuses what a write would fail on, before any work,
//    and leaves the directory as it was.
#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <csignal>
#include <fstream>
#include <set>
#include <sstream>

#include "luz/io/atomic_file.h"
#include "luz/io/error.h"
#include "temp_dir.h"

namespace {

namespace fs = std::filesystem;
using luz::AtomicFile;

class AtomicFileTest : public TempDirTest {
 protected:
  std::set<std::string> listing() const {
    std::set<std::string> names;
    for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
    return names;
  }
  std::string read(const fs::path& p) const {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }
  std::string problem_of_probe(const std::string& path) {
    try {
      luz::probe_writable(path);
    } catch (const luz::InputError& e) {
      EXPECT_EQ(e.file(), path);
      return e.problem();
    }
    return "";
  }
};

TEST_F(AtomicFileTest, NothingUntilCommitThenTheWholeFile) {
  const std::string path = write("out.bin", "old");
  {
    AtomicFile f(path);
    f.write("new contents", 12);
    EXPECT_EQ(read(path), "old") << "the old file stays whole until the commit";
    // Where the file system has O_TMPFILE, not even a named temporary while
    // writing: a kill leaves nothing.
    const int probe = ::open(dir.c_str(), O_TMPFILE | O_WRONLY, 0600);
    if (probe >= 0) {
      ::close(probe);
      EXPECT_EQ(listing(), std::set<std::string>{"out.bin"}) << "a named temporary while writing";
    }
  }  // not committed
  EXPECT_EQ(read(path), "old");
  EXPECT_EQ(listing(), std::set<std::string>{"out.bin"});
  luz::write_file_atomically(path, "new contents", 12);
  EXPECT_EQ(read(path), "new contents");
  EXPECT_EQ(listing(), std::set<std::string>{"out.bin"});
}

TEST_F(AtomicFileTest, FailedWriteThrowsAndLeavesNothing) {
  const std::string path = (dir / "big.bin").string();
  std::string problem;
  with_file_size_limit(4096, [&] {
    try {
      const std::string data(100000, 'x');
      luz::write_file_atomically(path, data.data(), data.size());
    } catch (const luz::InputError& e) {
      problem = e.what();
    }
  });
  EXPECT_EQ(problem.rfind(path + ": cannot write: write failed", 0), 0u) << problem;
  EXPECT_EQ(listing(), std::set<std::string>{});
}

TEST_F(AtomicFileTest, SymlinksAreWrittenThrough) {
  write("target.bin", "old");
  fs::create_symlink("target.bin", dir / "a");
  fs::create_symlink("a", dir / "b");                    // a chain
  fs::create_symlink("missing.bin", dir / "dangling");  // to a file not there yet
  luz::write_file_atomically((dir / "b").string(), "via b", 5);
  EXPECT_TRUE(fs::is_symlink(dir / "a"));
  EXPECT_TRUE(fs::is_symlink(dir / "b"));
  EXPECT_EQ(read(dir / "target.bin"), "via b");
  luz::write_file_atomically((dir / "dangling").string(), "made", 4);
  EXPECT_TRUE(fs::is_symlink(dir / "dangling"));
  EXPECT_EQ(read(dir / "missing.bin"), "made");
  EXPECT_EQ(luz::follow_symlinks((dir / "b").string()), (dir / "target.bin").string());
}

TEST_F(AtomicFileTest, ProbeRefusesWhatAWriteWouldFailOn) {
  write("exists.bin", "keep");
  fs::create_directory(dir / "sub");
  const auto before = listing();
  EXPECT_EQ(problem_of_probe((dir / "new.bin").string()), "");
  EXPECT_EQ(problem_of_probe((dir / "exists.bin").string()), "");
  EXPECT_EQ(read(dir / "exists.bin"), "keep");
  EXPECT_EQ(listing(), before) << "the probe leaves nothing";
  EXPECT_EQ(problem_of_probe((dir / "sub").string()), "is a directory");
  EXPECT_NE(problem_of_probe((dir / "none" / "x.bin").string()).find("does not exist"), std::string::npos);
  EXPECT_NE(problem_of_probe((dir / std::string(300, 'n')).string()).find("File name too long"), std::string::npos);
  EXPECT_EQ(problem_of_probe("/dev/null"), "is not a regular file");
  EXPECT_NE(problem_of_probe("/proc/luz-probe.bin").find("cannot"), std::string::npos);
}

}  // namespace
