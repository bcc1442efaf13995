// The MPI driver: `mpirun -np N luz render SCENE ...` renders one frame on
// N ranks (OpenMPI, or any MPI-3 library; LUZ_MPI in CMakeLists.txt).
//
// Every rank loads the scene itself, or (--broadcast) rank 0 loads it and
// sends it to the others, for files that exist only on its machine. Rank 0 holds the film and hands out
// work units (render/units.h: a block of pixels × a range of samples, with
// the block's sums so far) to whichever rank asks, and renders units
// itself on a thread of its own; the others render the units they are sent
// and send back the block's new sums. The film is therefore bit-identical
// to a single process's for any number of ranks and any schedule.
//
// Only rank 0 speaks: the other ranks' stdout and stderr are closed, and
// their errors reach rank 0 as one line ("rank 3: scene.xml: error: ...").
// Every rank calls agree() once, after loading and checking, so that bad
// input anywhere fails the whole job before any rendering; finish() ends
// the job with rank 0's exit status on every rank.
//
// A lost rank: the MPI launcher stops the job (OpenMPI sends the other
// ranks SIGTERM, then SIGKILL after odls_base_sigkill_timeout, 1 s by
// default); rank 0 writes the image and a checkpoint of its film (the
// units returned so far) as for any SIGTERM. `luz render --resume` then
// finishes it on any number of ranks, or one process.
#pragma once

#include <memory>
#include <string>

#include "luz/render/render.h"

namespace luz {

// Whether this luz was built with MPI.
bool mpi_built();
// Whether an MPI launcher (mpirun, mpiexec, srun) started this process:
// then main() starts an MpiJob; otherwise luz never initialises MPI.
bool mpi_launched();
// This process's rank as the launcher's environment gives it (before
// MPI_Init; 0 when not launched).
int mpi_launched_rank();

class MpiJob {
 public:
  // MPI_Init; on ranks other than 0, stdout and stderr go to /dev/null.
  // Throws std::runtime_error when built without MPI.
  MpiJob(int& argc, char**& argv);
  ~MpiJob();  // MPI_Finalize
  MpiJob(const MpiJob&) = delete;
  MpiJob& operator=(const MpiJob&) = delete;

  int rank() const;
  int size() const;
  // Worker threads a rank takes by default: this node's cores shared among its ranks.
  int default_threads() const;

  // Collective: every rank's error line ("" for none) and CPU threads in;
  // the first failing rank's line out on rank 0 ("rank N: " before it when
  // N is not 0), a non-empty string on the others when any rank failed.
  // Called once.
  std::string agree(const std::string& error, int threads = 1);

  // Collective, after a successful agree(): rank 0's `bytes` (a serialized
  // scene: luz render --broadcast) replace the others'.
  void broadcast(std::string& bytes);

  // Rank 0: the frame, with this process and every other rank as workers
  // (the request's CPU threads are this process's).
  RenderResult render(const Scene& scene, const RenderRequest& request);
  // The other ranks: render the units rank 0 sends until it says stop;
  // returns the exit status rank 0 gives. `cancel` (a signal) makes this
  // rank abandon its unit, tell rank 0 it leaves, and return 1. Without a
  // scene (one that failed to arrive), every unit is answered with `error`.
  int work(const Scene* scene, int threads, const std::atomic<bool>* cancel, const std::string& error = "");

  // Seconds a rank may hold a unit before it is taken as lost (rank 0), and
  // that agree() waits for every rank to have loaded the scene (default
  // 600; a unit is about a quarter second of work).
  void set_timeout(double seconds);
  // Whether agree() gave up waiting: the job cannot end cleanly (MPI_Finalize
  // would wait for the silent rank), so every rank exits at once, and the
  // launcher ends the silent one.
  bool timed_out() const;
  // Whether a rank was lost: the job cannot end cleanly (MPI_Finalize would
  // wait for it), so rank 0 exits without it and the launcher ends the rest.
  bool lost_ranks() const;

  // After a frame (luz render --frames): rank 0 collects the units still
  // out and sends `status` (the others' work() returns it); then the next
  // frame agree()s and renders afresh.
  void end_frame(int status);

  // Ends the job with `status` on every rank (agree()s first when a rank
  // failed before agreeing, with `error`): rank 0 collects the units still
  // out and sends the status; the others return it.
  int finish(int status, const std::string& error);

  struct Impl;  // mpi.cpp's

 private:
  void stop(int status);  // rank 0: collect the units out, send the status

  std::unique_ptr<Impl> m_;
};

}  // namespace luz
