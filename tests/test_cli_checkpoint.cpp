// Never losing a render, through the luz binary:
//  * kill -9 at several moments (checkpoints after every pass, so some kills
//    land during a write) and resume after each: the image is bit-identical
//    to the uninterrupted render, and no temporary file is ever left.
//  * A changed scene file, --spp or --seed is refused on resume naming what
//    differs; a truncated checkpoint is refused with one line.
//  * SIGINT and SIGTERM mid-render: exit 130 / 143, the image so far with its
//    spp in the EXR metadata, a checkpoint that resumes to the exact image.
//  * Outputs that cannot be written are refused before the render starts (a
//    path in /proc, an over-long name, a read-only directory or file system,
//    a device); an output that fails at the end (its directory removed, its
//    file system full: tmpfs mounted in a mount namespace of the test's own)
//    does not keep the others from being written; a symlinked output is
//    written through to its target.
//  * The light sampler in the EXR metadata, as --light-sampler sets it.
//  * luz --version.
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>
#include <signal.h>
#include <sys/stat.h>

#include <chrono>
#include <thread>

#include "cli_helpers.h"
#include "luz/io/image.h"

namespace {

using namespace luz_test;

const char* kCornell = LUZ_SOURCE_DIR "/scenes/cornell-box.xml";

class Resume : public LuzCliTest {
 protected:
  // Starts luz in dir without waiting; stdout and stderr to /dev/null.
  pid_t start(const std::vector<std::string>& args) { return spawn(args, "/dev/null", "/dev/null"); }
  // Waits for pid; its exit status, or 128 + the signal that killed it.
  static int finish(pid_t pid) {
    int st = 0;
    EXPECT_EQ(::waitpid(pid, &st, 0), pid);
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  }
  static void sleep_s(double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }
  bool exists(const std::string& name) const { return fs::exists(dir / name); }
  // Runs `sh -c script` in a mount namespace of its own (unshare -m), in dir,
  // with luz's path as $LUZ; the tmpfs it mounts vanish with it. Status 125
  // from the script: mounting is not allowed here.
  CliResult run_in_mount_namespace(const std::string& script) {
    return run_program("/usr/bin/unshare", {"-m", "/bin/sh", "-c", "LUZ=" LUZ_BINARY "; " + script});
  }

  // A small tmpfs mounted on `mnt` (options `opts`), or status 125.
  static std::string mount_tmpfs(const std::string& mnt, const std::string& opts) {
    return "mkdir -p " + mnt + " && mount -t tmpfs -o " + opts + " luz-test " + mnt + " 2>/dev/null || exit 125; ";
  }

  // Hidden files (luz's temporaries are ".luz-*") other than the test's own.
  std::vector<std::string> temporaries() const {
    std::vector<std::string> t;
    for (const std::string& n : listing())
      if (n.rfind(".luz-", 0) == 0) t.push_back(n);
    return t;
  }
};

std::map<std::string, std::string> exr_metadata(const fs::path& p) {
  Imf::InputFile f(p.c_str());
  std::map<std::string, std::string> m;
  for (auto it = f.header().begin(); it != f.header().end(); ++it)
    if (auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute())) m[it.name()] = s->value();
  return m;
}

// A render of several passes on one thread: 32×32 at 1536 spp is 6 passes of
// 256 spp (render.h's next_pass_spp), about half a second each here.
const std::vector<std::string> kLong = {"render", kCornell, "-D", "res=32", "--spp", "1536", "--threads", "1"};

std::vector<std::string> with(std::vector<std::string> a, const std::vector<std::string>& more) {
  a.insert(a.end(), more.begin(), more.end());
  return a;
}

TEST_F(Resume, KillNineAtSeveralMomentsThenResumeIsBitIdentical) {
  CliResult ref = run(with(kLong, {"-o", "ref.pfm"}));
  ASSERT_EQ(ref.status, 0) << ref.err;
  // Kills at different moments of successive runs, each resuming the last
  // checkpoint; a checkpoint after every pass makes some kills land in a write.
  pid_t pid = start(with(kLong, {"-o", "out.pfm", "--checkpoint", "c.ckpt", "--checkpoint-every", "0"}));
  for (int wait = 0; wait < 200 && !exists("c.ckpt"); ++wait) sleep_s(0.05);
  ASSERT_TRUE(exists("c.ckpt")) << "no checkpoint after 10 s";
  sleep_s(0.3);
  ::kill(pid, SIGKILL);
  EXPECT_EQ(finish(pid), 128 + SIGKILL);
  EXPECT_EQ(temporaries(), std::vector<std::string>{});
  EXPECT_FALSE(exists("out.pfm"));
  // A resume may finish before its kill: then it is the last.
  bool finished = false;
  for (double at : {0.45, 0.8, 0.05}) {
    pid = start({"render", "--resume", "c.ckpt", "--checkpoint-every", "0"});
    sleep_s(at);
    ::kill(pid, SIGKILL);
    const int status = finish(pid);
    EXPECT_TRUE(status == 128 + SIGKILL || status == 0) << status;
    EXPECT_EQ(temporaries(), std::vector<std::string>{}) << "after a kill at " << at << " s";
    // Killed after the image was written and the checkpoint removed (the
    // render's last steps): finished too.
    if ((finished = status == 0 || !exists("c.ckpt"))) break;
  }
  if (!finished) {
    CliResult r = run({"render", "--resume", "c.ckpt"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.err.find("resuming at sample "), std::string::npos) << r.err;
  }
  EXPECT_EQ(slurp(dir / "out.pfm"), slurp(dir / "ref.pfm")) << "the resumed image differs from the uninterrupted one";
  EXPECT_FALSE(exists("c.ckpt")) << "a finished render removes its checkpoint";
  EXPECT_EQ(listing(), (std::set<std::string>{"out.pfm", "ref.pfm"}));
}

TEST_F(Resume, ChangedSceneOrSettingsAndBadCheckpointsAreRefused) {
  std::string scene = slurp(kCornell);
  write("box.xml", scene);
  // Its meshes found through -a, which the checkpoint keeps.
  pid_t pid = start({"render", "box.xml", "-a", LUZ_SOURCE_DIR "/scenes", "-D", "res=32", "--spp", "1536", "--threads", "1", "-o", "out.pfm",
                     "--checkpoint", "c.ckpt", "--checkpoint-every", "0"});
  for (int wait = 0; wait < 200 && !exists("c.ckpt"); ++wait) sleep_s(0.05);
  ::kill(pid, SIGKILL);
  finish(pid);
  ASSERT_TRUE(exists("c.ckpt"));
  const std::string ckpt = slurp(dir / "c.ckpt");
  auto refused = [&](const std::vector<std::string>& args, const std::string& want) {
    CliResult r = run(args);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(want), std::string::npos) << r.err;
    EXPECT_FALSE(exists("out.pfm"));
  };
  refused({"render", "--resume", "c.ckpt", "--spp", "4096"}, "c.ckpt: error: cannot resume: spp: the checkpoint has 1536, this render 4096");
  refused({"render", "--resume", "c.ckpt", "--seed", "3"}, "cannot resume: seed: the checkpoint has 0, this render 3");
  refused({"render", "--resume", "c.ckpt", "--reconstruction", "filter"},
          "cannot resume: reconstruction: the checkpoint has splat, this render filter sampling");
  refused({"render", "--resume", "c.ckpt", "--env-guide", "off"},
          "cannot resume: environment guide: the checkpoint has on, this render off");
  refused({"render", "--resume", "c.ckpt", "-D", "res=33"}, "cannot resume: image size: the checkpoint has 32x32, this render 33x33");
  refused({"render", "box.xml", "--resume", "c.ckpt"}, "give no scene file with it");
  // The light made brighter in the scene file.
  const size_t at = scene.find("name=\"radiance\"");
  ASSERT_NE(at, std::string::npos);
  const size_t v = scene.find("value=\"", at) + 7;
  write("box.xml", scene.substr(0, v) + "2" + scene.substr(v));
  refused({"render", "--resume", "c.ckpt"}, "cannot resume: the lights differ from the checkpoint's");
  write("box.xml", scene);
  write("c.ckpt", ckpt.substr(0, ckpt.size() / 2));
  refused({"render", "--resume", "c.ckpt"}, "c.ckpt: error: the checkpoint is truncated");
  refused({"render", "--resume", "none.ckpt"}, "none.ckpt: error: cannot open the checkpoint");
  // The intact checkpoint still finishes the render.
  write("c.ckpt", ckpt);
  CliResult r = run({"render", "--resume", "c.ckpt"});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(exists("out.pfm"));
}

TEST_F(Resume, SigintAndSigtermWriteTheImageAndACheckpoint) {
  const auto ref_start = std::chrono::steady_clock::now();
  CliResult ref = run(with(kLong, {"-o", "ref.exr"}));
  ASSERT_EQ(ref.status, 0) << ref.err;
  // The signal comes at 40% of the uninterrupted render's time: mid-render
  // on a fast machine and on a slow one.
  const double signal_at = 0.4 * std::chrono::duration<double>(std::chrono::steady_clock::now() - ref_start).count();
  for (int sig : {SIGINT, SIGTERM}) {
    SCOPED_TRACE(sig == SIGINT ? "SIGINT" : "SIGTERM");
    pid_t pid = start(with(kLong, {"-o", "out.exr"}));
    sleep_s(signal_at);
    const auto t0 = std::chrono::steady_clock::now();
    ::kill(pid, sig);
    EXPECT_EQ(finish(pid), 128 + sig);
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0)
        << "stop within about a second";
    ASSERT_TRUE(exists("out.exr"));
    ASSERT_TRUE(exists("out.exr.checkpoint"));
    EXPECT_EQ(temporaries(), std::vector<std::string>{});
    auto meta = exr_metadata(dir / "out.exr");
    const int spp = std::stoi(meta["luz:spp"]);  // 0 when the first pass had not ended (a loaded machine)
    EXPECT_LT(spp, 1536);
    EXPECT_EQ(spp % 256, 0) << "whole passes";
    EXPECT_EQ(meta["luz:sppRequested"], "1536");
    EXPECT_EQ(meta["luz:seed"], "0");
    EXPECT_EQ(meta["luz:integrator"], "path");
    CliResult r = run({"render", "--resume", "out.exr.checkpoint"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(exr_metadata(dir / "out.exr")["luz:spp"], "1536");
    // Bitwise the same pixels (the render time in the metadata differs).
    EXPECT_EQ(luz::read_exr((dir / "out.exr").string()).rgb, luz::read_exr((dir / "ref.exr").string()).rgb);
    fs::remove(dir / "out.exr");
  }
  EXPECT_EQ(listing(), (std::set<std::string>{"ref.exr"}));
}

TEST_F(Resume, UnwritableOutputsAreRefusedBeforeTheRender) {
  auto refused_at_once = [&](const std::string& out, const std::string& want) {
    SCOPED_TRACE(out);
    CliResult r = run({"render", kCornell, "--spp", "100000", "-o", out});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(want), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("loaded in"), std::string::npos) << "the scene was loaded: " << r.err;
  };
  refused_at_once("/proc/luz-test.exr", "cannot write");
  refused_at_once(std::string(300, 'x') + ".exr", "File name too long");
  refused_at_once("missing/out.exr", "the directory 'missing' does not exist");
  fs::create_directory(dir / "d.exr");
  refused_at_once("d.exr", "is a directory");
  ASSERT_EQ(::symlink("/dev/null", (dir / "null.exr").c_str()), 0);
  refused_at_once("null.exr", "is not a regular file");
  if (::geteuid() != 0) {
    fs::create_directory(dir / "ro");
    fs::permissions(dir / "ro", fs::perms::owner_read | fs::perms::owner_exec);
    refused_at_once("ro/out.exr", "Permission denied");
    fs::permissions(dir / "ro", fs::perms::owner_all);
  }  // as root (who writes into mode 0555 directories): ReadOnlyFileSystemIsRefusedBeforeTheRender
}

// A read-only file system refuses even root: the output is refused before
// the scene loads. Needs a mount namespace (root, or CAP_SYS_ADMIN).
TEST_F(Resume, ReadOnlyFileSystemIsRefusedBeforeTheRender) {
  CliResult r = run_in_mount_namespace(
      mount_tmpfs("ro", "ro,size=64k") + "exec \"$LUZ\" render " + kCornell + " --spp 100000 -o ro/out.exr");
  if (r.status == 125 || (r.status == 1 && r.err.find("unshare") != std::string::npos))
    GTEST_SKIP() << "no mount namespace here: " << r.err;
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find("Read-only file system"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("loaded in"), std::string::npos) << "the scene was loaded: " << r.err;
}

// One output on a full file system (a 16 KiB tmpfs; the image is larger):
// the render runs (the output's probe fits), that output fails at the end
// with one line and leaves nothing there, the others are written, exit 1.
TEST_F(Resume, FullFileSystemFailsOneOutputAndTheOthersAreWritten) {
  CliResult r = run_in_mount_namespace(
      mount_tmpfs("full", "size=16k") + "\"$LUZ\" render " + kCornell +
                 " -D res=96 --spp 4 -q -o a.pfm -o full/b.exr -o c.png; rc=$?; ls -A full; exit $rc");
  if (r.status == 125 || (r.status == 1 && r.err.find("unshare") != std::string::npos))
    GTEST_SKIP() << "no mount namespace here: " << r.err;
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("full/b.exr"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("No space left on device"), std::string::npos) << r.err;
  EXPECT_EQ(r.out, "") << "files left on the full file system: " << r.out;
  EXPECT_GT(fs::file_size(dir / "a.pfm"), 96u * 96u * 12u);
  EXPECT_TRUE(exists("c.png"));
  EXPECT_TRUE(exists("a.pfm.checkpoint")) << "the render is kept to write the failed output again";
  EXPECT_EQ(temporaries(), std::vector<std::string>{});
}

TEST_F(Resume, OneFailedOutputDoesNotStopTheOthersAndSymlinksAreFollowed) {
  // The directory of the first output disappears during the render.
  fs::create_directory(dir / "gone");
  write("target.pfm", "old");
  ASSERT_EQ(::symlink("target.pfm", (dir / "link.pfm").c_str()), 0);
  // About 1.3 s of rendering in Release (512 spp took 0.43-0.5 s: the
  // removal below could come after the render's end).
  pid_t pid = start({"render", kCornell, "-D", "res=32", "--spp", "1536", "--threads", "1", "-o", "link.pfm", "-o",
                     "gone/a.pfm", "-o", "b.png"});
  sleep_s(0.4);
  fs::remove_all(dir / "gone");
  EXPECT_EQ(finish(pid), 1);
  EXPECT_TRUE(fs::is_symlink(dir / "link.pfm"));
  EXPECT_GT(fs::file_size(dir / "target.pfm"), 32u * 32u * 12u) << "written through the link";
  EXPECT_TRUE(exists("b.png"));
  // The render is kept to finish from when an output failed.
  EXPECT_EQ(temporaries(), std::vector<std::string>{});
  EXPECT_TRUE(exists("link.pfm.checkpoint")) << "no checkpoint kept after a failed output";
}

// Limits checked before the work: a scene path that is not a regular file,
// an image whose films would not fit in memory, and depth limits stated the
// same way whether set by -D or by a flag.
TEST_F(Resume, ResourcesAndLimitsAreCheckedFirst) {
  auto refused = [&](const std::vector<std::string>& args, const std::string& want) {
    CliResult r = run(args);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(want), std::string::npos) << r.err;
  };
  ASSERT_EQ(::mkfifo((dir / "fifo.xml").c_str(), 0644), 0);
  refused({"render", "fifo.xml", "-o", "x.pfm"}, "fifo.xml: error: is not a regular file");
  refused({"info", "fifo.xml"}, "fifo.xml: error: is not a regular file");
  refused({"render", "/dev/zero", "-o", "x.pfm"}, "/dev/zero: error: is not a regular file");
  refused({"render", kCornell, "--res", "65536x65536", "-o", "x.pfm"}, "GiB are available");
  refused({"render", kCornell, "-D", "max_depth=2147483646", "-o", "x.pfm"}, "from -1 to 1048576");
  refused({"render", kCornell, "--max-depth", "2147483646", "-o", "x.pfm"}, "from 1 to 1048576");
  EXPECT_EQ(listing(), std::set<std::string>{"fifo.xml"});
}

TEST_F(Resume, FlagsThatOverrideTheSceneAreSaidAndProgressIsLoggedToFiles) {
  // stderr is a file here: progress comes as lines every few seconds.
  CliResult r = run({"render", kCornell, "-D", "res=16", "--spp", "16000000", "--max-depth", "3", "--integrator",
                     "bsdf", "--time-limit", "7", "-o", "x.pfm"});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("luz: warning: --max-depth 3 overrides the scene's 65"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("luz: warning: --integrator bsdf overrides the scene's path"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("--spp 16000000 overrides"), std::string::npos) << "spp changes only the noise";
  EXPECT_NE(r.err.find(" elapsed  ETA "), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find('\r'), std::string::npos) << "no bar redrawn in place in a file";
  r = run({"render", kCornell, "-D", "res=8", "--spp", "4", "--max-depth", "2", "-q", "-o", "x.pfm"});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err, "luz: warning: --max-depth 2 overrides the scene's 65\n") << "-q: only warnings";
}

// The light sampler in the EXR metadata: the BVH by default, power when
// --light-sampler says so.
TEST_F(Resume, LightSamplerIsTheBvhUnlessTheFlagSaysPower) {
  for (const char* flag : {"", "power", "bvh"}) {
    std::vector<std::string> args = {"render", kCornell, "-D", "res=8", "--spp", "1", "-q", "-o", "x.exr"};
    if (*flag) args.insert(args.end(), {"--light-sampler", flag});
    CliResult r = run(args);
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(exr_metadata(dir / "x.exr")["luz:lightSampler"], *flag ? flag : "bvh") << flag;
  }
}

TEST_F(Resume, Version) {
  CliResult r = run({"--version"});
  EXPECT_EQ(r.status, 0);
  EXPECT_EQ(r.out.rfind("luz 0.", 0), 0u) << r.out;
}

}  // namespace
