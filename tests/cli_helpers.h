// Running the luz binary from tests: a fixture with a fresh temporary working
// directory, run() capturing exit status, signal, stdout and stderr, and
// listing() to check that nothing was written.
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "temp_dir.h"

namespace luz_test {

namespace fs = std::filesystem;

struct CliResult {
  bool exited = false;  // false: killed by a signal (a crash)
  int status = -1;      // exit status when exited
  int signal = 0;
  std::string out, err;
};

inline std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class LuzCliTest : public TempDirTest {
 protected:
  // Starts luz with args in dir, stdout and stderr to the files out and err
  // (created or truncated), without waiting for it.
  pid_t spawn(const std::vector<std::string>& args, const fs::path& out, const fs::path& err) {
    return spawn_program(LUZ_BINARY, args, out, err);
  }

  // The same for another program (e.g. mpirun), in a process group of its
  // own (its pid), so that a test can stop it and all its children.
  pid_t spawn_program(const std::string& program, const std::vector<std::string>& args, const fs::path& out,
                      const fs::path& err) {
    pid_t pid = ::fork();
    if (pid == 0) {
      ::setpgid(0, 0);
      if (::chdir(dir.c_str()) != 0) ::_exit(127);
      int o = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      int e = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (o < 0 || e < 0) ::_exit(127);
      ::dup2(o, 1);
      ::dup2(e, 2);
      std::vector<char*> argv;
      std::string bin = program;
      argv.push_back(bin.data());
      std::vector<std::string> copy = args;
      for (std::string& a : copy) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(bin.c_str(), argv.data());
      ::_exit(127);
    }
    return pid;
  }

  // Runs luz with args in dir; stdout and stderr go to files there, removed after.
  CliResult run(const std::vector<std::string>& args) { return run_program(LUZ_BINARY, args); }

  // The same for another program.
  CliResult run_program(const std::string& program, const std::vector<std::string>& args) {
    fs::path out_file = dir / ".stdout", err_file = dir / ".stderr";
    pid_t pid = spawn_program(program, args, out_file, err_file);
    CliResult r;
    int st = 0;
    EXPECT_EQ(::waitpid(pid, &st, 0), pid);
    r.exited = WIFEXITED(st);
    r.status = r.exited ? WEXITSTATUS(st) : -1;
    r.signal = WIFSIGNALED(st) ? WTERMSIG(st) : 0;
    r.out = slurp(out_file);
    r.err = slurp(err_file);
    fs::remove(out_file);
    fs::remove(err_file);
    return r;
  }

  std::set<std::string> listing() const {
    std::set<std::string> names;
    for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
    return names;
  }
};

}  // namespace luz_test
