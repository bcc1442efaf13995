// Rendering by work units: a block of pixels × a range of sample indices,
// handed out one at a time to whichever worker is free (this process's
// device, or the ranks of an MPI job: render/mpi.h).
//
// A block's units follow each other in sample order, never two at once: a
// unit starts from the sums the block's last unit left and adds its samples
// to them one by one in index order, on whichever worker. Every pixel's sums
// are therefore built exactly as a single render() builds them (render.h),
// so the film is bit-identical to it for any number of workers and any
// schedule: no partial sums are ever added together, which would round
// differently for different splits. The price is that a block's sums travel
// with each of its units (52 bytes a pixel each way); see bench/RESULTS.md.
//
// Blocks advance independently, so a film stopped midway (a time limit, a
// signal, a lost rank) holds different sample counts per block: Film::next
// records them, a checkpoint keeps them, and a resumed render continues each
// block where it stopped. Host only.
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "luz/render/render.h"

namespace luz {

struct WorkUnit {
  uint32_t block = 0;
  PixelRect rect;
  uint32_t first = 0, end = 0;  // samples [first, end) of every pixel of rect
};

// Blocks of `size`² pixels (the last row and column cut by the image),
// aligned to multiples of size.
class UnitScheduler {
 public:
  // Every pixel starts at `next` (per pixel, or empty: all at `first`); the
  // render ends at `end`. The block size is `size` halved until the start is
  // uniform within every block (a checkpoint of smaller blocks).
  UnitScheduler(int width, int height, int size, uint32_t first, const std::vector<uint32_t>& next, uint32_t end);

  int block_size() const { return size_; }
  uint32_t blocks() const { return uint32_t(next_.size()); }
  // The idle block furthest behind, with up to `samples` pixel-samples (at
  // least one sample per pixel); false when every unfinished block is out.
  bool take(uint64_t samples, WorkUnit& u);
  // The unit's samples are in the film: its block goes on from u.end.
  void done(const WorkUnit& u);
  // The unit was not done (abandoned, or its worker lost): the block is
  // handed out again from u.first.
  void undo(const WorkUnit& u);
  bool finished() const { return idle_.empty() && out_ == 0; }
  int out() const { return out_; }
  // The fewest samples any pixel holds.
  uint32_t frontier() const;
  // Per-pixel progress (Film::next), or empty when every pixel is at the same sample.
  std::vector<uint32_t> pixel_next() const;
  PixelRect rect(uint32_t block) const;

 private:
  int width_, height_, size_, bx_;
  uint32_t end_;
  std::vector<uint32_t> next_;                    // per block
  std::set<std::pair<uint32_t, uint32_t>> idle_;  // (next, block) of blocks neither out nor finished
  std::map<uint32_t, uint32_t> at_;               // how many blocks are at each next sample (frontier: the first)
  int out_ = 0;
};

// A power-of-two block size: `start` (kUnitBlock; larger for splatting,
// whose units also render a border of pixels around their block), doubled
// (up to 64) while a whole block's `spp` samples are fewer than a unit's
// `unit_samples` (many-thread ranks, few samples) and every worker keeps 16
// blocks, halved while the workers would have fewer than 4 blocks each (a
// small image on many ranks).
int block_size_for(int width, int height, int workers, uint32_t spp = 0, uint64_t unit_samples = 0,
                   int start = kUnitBlock);
// The block size units start from for a scene: kUnitBlock, or 32 when it
// splats (a unit then takes 13% more samples than its pixels' for the
// tent's border, against 27% at 16).
int unit_block_start(const RenderSettings& s);

// A finished (or abandoned) unit.
struct UnitResult {
  int worker = 0;
  WorkUnit unit;
  Film film;  // the unit's rect: the block's sums after it
  bool complete = false;
  uint64_t rays = 0, discarded = 0;
};

// Workers beyond this process (the ranks of an MPI job). Host code.
class RemoteWorkers {
 public:
  virtual ~RemoteWorkers() = default;
  virtual int count() const = 0;
  virtual int threads(int worker) const = 0;
  // False for a worker that left: it gets no more units.
  virtual bool available(int) const { return true; }
  // Sends unit `u` with the block's sums so far to an idle worker.
  virtual void send(int worker, const WorkUnit& u, const Film& in) = 0;
  // A unit some worker finished, if any has (never blocks). Throws
  // std::runtime_error for a worker's failure, naming it.
  virtual bool poll(UnitResult& r) = 0;
};

// render() by units: this process's CPU device as one worker (unless
// `local` is false), `remote`'s as the others. The request's start film may
// carry per-pixel progress (Film::next). The result's film carries its own
// when the render stopped with blocks at different samples; its stats.spp
// is the frontier's advance. Units still out at a stop are not waited for
// (the caller's RemoteWorkers collects them).
RenderResult render_units(const Scene& scene, const RenderRequest& req, RemoteWorkers* remote, int block_size,
                          bool local = true);

}  // namespace luz
