// Checkpoints: a render's film sums and counts, the next sample index, and
// what the render must still be to continue it exactly (the Luz version, the
// scene's content, every setting that changes the image), written whole or
// not at all (io/atomic_file.h). A render continued from a checkpoint is
// bit-identical to one never stopped (render.h: sample ranges).
//
// The file: "LUZCKPT2", then little-endian fields, strings as a u32 length
// and bytes, the film's arrays (per-pixel progress after a u32 flag, for a
// film rendered by blocks: Film::next), and a CRC-32 (zlib) of everything
// before it.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "luz/render/render.h"

namespace luz {

// Named values a render is identified by: ("spp", "64"), ("geometry",
// "hash 0123..."). Compared in order; the first difference is reported.
using RenderFields = std::vector<std::pair<std::string, std::string>>;

struct Checkpoint {
  RenderFields fields;            // what must match to resume
  std::vector<std::string> args;  // how the render was asked for (the CLI's flags), to ask again
  uint32_t next_sample = 0;       // the film holds samples [0, next_sample) of every pixel (at least: Film::next)
  RenderStats stats;              // over every run so far
  Film film;
};

// The fields of rendering `scene` on `device`: the Luz version, image size,
// spp, seed, sampler, integrator and its depths, filter, light sampler,
// device, and hashes of the camera, the geometry, the materials and
// textures, and the lights.
RenderFields render_fields(const Scene& scene, RenderDevice device);

// "what: the checkpoint has A, this render B" for the first field that
// differs (or is missing from either), or "" when all agree.
std::string fields_mismatch(const RenderFields& checkpoint, const RenderFields& now);

// Throws InputError naming the path on a failed write.
void write_checkpoint(const std::string& path, const Checkpoint& c);
// Throws InputError naming the path and the problem for a missing,
// truncated, corrupted or foreign file.
Checkpoint read_checkpoint(const std::string& path);

}  // namespace luz
