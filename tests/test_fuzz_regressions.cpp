// Inputs that the fuzz targets (fuzz/, scripts/fuzz) found to crash, hang or
// trip a sanitizer, kept in tests/data/fuzz: each, read by the reader it
// broke, must end in an InputError that says what is wrong. Each is read in
// a child process under a time limit, so that a hang or a crash fails its
// test instead of the whole program. Some (undefined behaviour that does no
// visible harm) fail only under the sanitizers, as in the fuzz build.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>

#include "luz/io/error.h"
#include "luz/io/image.h"
#include "luz/io/load.h"
#include "luz/io/mesh_serialized.h"

namespace {

const std::string kData = LUZ_SOURCE_DIR "/tests/data/fuzz/";

// Child's exit codes: what the reader did.
enum Outcome { Expected = 0, OtherProblem = 1, Accepted = 2, OtherException = 3 };

// Reads `file` in a child process killed after `seconds`; the reader must
// throw an InputError whose problem contains `problem`.
void expect_refused(const std::string& file, const std::function<void(const std::string&)>& read,
                    const std::string& problem, unsigned seconds = 20) {
  const std::string path = kData + file;
  std::fflush(nullptr);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    alarm(seconds);
    int outcome = Accepted;
    try {
      read(path);
    } catch (const luz::InputError& e) {
      outcome = e.problem().find(problem) != std::string::npos ? Expected : OtherProblem;
      if (outcome != Expected) std::fprintf(stderr, "InputError: %s\n", e.what());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "exception: %s\n", e.what());
      outcome = OtherException;
    }
    _exit(outcome);
  }
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  if (WIFSIGNALED(status)) {
    ADD_FAILURE() << file << ": killed by signal " << WTERMSIG(status)
                  << (WTERMSIG(status) == SIGALRM ? " (no answer within the time limit)" : "");
    return;
  }
  ASSERT_TRUE(WIFEXITED(status));
  const char* what[] = {"", "another InputError (printed above)", "accepted", "an exception other than InputError"};
  EXPECT_EQ(WEXITSTATUS(status), Expected) << file << ": " << what[WEXITSTATUS(status) & 3] << " (wanted: " << problem
                                           << ")";
}

void read_image(const std::string& path) { luz::read_image_linear(path); }

// stb_image's HDR run-length decoder read zeros past the end as empty runs, forever.
// An MTL map statement whose file name starts with a NUL byte: the name,
// cut at the NUL, named the OBJ's folder, whose reading threw a standard
// library exception (fuzz_mtl).
TEST(FuzzRegressions, MtlMapNameWithNul) {
  expect_refused("mtl-nul-in-map-name.obj", [](const std::string& p) { luz::load_scene(p); },
                 "'map_Kd': the file name holds a NUL byte");
}

TEST(FuzzRegressions, HdrRunLengthDataCutShort) {
  expect_refused("hdr-rle-cut-short.hdr", read_image, "cannot read Radiance HDR image: truncated");
}

// A header cut short: stb's header reader never ended on a filler other
// than a line feed.
TEST(FuzzRegressions, HdrHeaderCutShort) {
  expect_refused("hdr-header-cut-short.hdr", read_image, "cannot read Radiance HDR image");
}

// A header ended by a line that starts with a NUL (stb takes it for the
// empty line), then run-length data cut short.
TEST(FuzzRegressions, HdrHeaderEndsAtNul) {
  expect_refused("hdr-header-ends-at-nul.hdr", read_image, "cannot read Radiance HDR image: truncated");
}

// A JPEG Huffman table of more than 256 codes: stb_image wrote past its tables.
TEST(FuzzRegressions, JpegHuffmanTableOverflow) {
  expect_refused("stb-jpeg-huffman-overflow.jpg", read_image, "a Huffman table of more than 256 codes");
}

// The same after a 0xFF fill byte before the start-of-image marker: stb
// skips it, the table check took the file for no JPEG.
TEST(FuzzRegressions, JpegFillByteBeforeStart) {
  expect_refused("stb-jpeg-fill-before-soi.jpg", read_image, "a Huffman table of more than 256 codes");
}

// A 141-byte TGA whose header claims 19536×17748 pixels: stb allocated and
// converted 1.4 GB (a fuzz smoke's timeout under ASan).
TEST(FuzzRegressions, TgaHeaderClaimsMoreThanTheFile) {
  expect_refused("stb-tga-huge-header.tga", read_image, "its header claims 19536×17748 pixels");
}

// A 10 KB run-length TGA whose header claims 65535×255 pixels, within the
// 2048 pixels per byte that deflate allows: stb decoded 16.7 million pixels
// from the zeros past its end (8.7 s under ASan).
TEST(FuzzRegressions, TgaRunLengthPastTheEnd) {
  expect_refused("stb-tga-rle-from-zeros.tga", read_image, "its header claims 65535×255 pixels");
}

// A shape of no vertices: the reader took the address of an empty vector's first element.
TEST(FuzzRegressions, SerializedShapeWithoutVertices) {
  expect_refused("serialized-no-vertices.serialized", [](const std::string& p) { luz::read_serialized(p, 0); },
                 "triangle 0 names vertex 0 of 0");
}

// An image in a bufferView reaching past its buffer: tinygltf decoded it
// from past the buffer's end.
TEST(FuzzRegressions, GlbImageViewPastBuffer) {
  expect_refused("glb-image-view-past-buffer.glb", [](const std::string& p) { luz::load_scene(p); },
                 "images[0]: bufferView 4 reaches past the end of its buffer");
}

// An attribute claiming a gigabyte in a file of 53 bytes: OpenEXR allocated it.
TEST(FuzzRegressions, ExrAttributePastEnd) {
  expect_refused("exr-attribute-past-end.exr", read_image, "of 1036239617 bytes runs past the end of the file");
}

// A PNG with an empty chunk after its data: stb memcpy'd zero bytes to a
// null buffer (UBSan's nonnull-attribute, in stb: exempted there), then
// failed without a reason.
TEST(FuzzRegressions, PngEmptyChunk) {
  expect_refused("stb-png-empty-chunk.png", read_image, "cannot read image: corrupt data");
}

// A channel list whose entries end before its stated size: OpenEXR reads on
// from where they end, into an attribute of 1.75 GB (allocated, then an
// early end of file; a second under ASan); the check read on from the size.
TEST(FuzzRegressions, ExrChannelListShorterThanStated) {
  expect_refused("exr-channel-list-shorter-than-stated.exr", read_image,
                 "attribute 'lineOrderv/1\\x01\\x02' of 1751318528 bytes runs past the end of the file");
}

// A data window far from the origin: the frame buffer's base pointer,
// moved back by the origin's offset, overflowed (UBSan).
TEST(FuzzRegressions, ExrFarDataWindow) {
  expect_refused("exr-far-data-window.exr", read_image, "cannot read OpenEXR: Error reading pixel data");
}

// The guards these fixes added refuse no good file: every image seed of the
// fuzz targets reads, at its size.
TEST(FuzzRegressions, ImageSeedsRead) {
  int read = 0;
  for (const char* target : {"fuzz_hdr", "fuzz_stb", "fuzz_exr", "fuzz_pfm"})
    for (const auto& f : std::filesystem::directory_iterator(LUZ_SOURCE_DIR "/fuzz/seeds/" + std::string(target))) {
      SCOPED_TRACE(f.path().string());
      luz::Image img;
      ASSERT_NO_THROW(img = luz::read_image_linear(f.path().string()));
      EXPECT_GT(img.width, 0);
      EXPECT_EQ(img.rgb.size(), size_t(img.width) * size_t(img.height) * 3);
      ++read;
    }
  EXPECT_GE(read, 20);
}

}  // namespace
