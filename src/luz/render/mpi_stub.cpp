// The MPI driver of a luz built without MPI (LUZ_MPI=OFF, or no MPI found).
#include <stdexcept>

#include "luz/render/mpi.h"

namespace luz {

struct MpiJob::Impl {};

bool mpi_built() { return false; }

MpiJob::MpiJob(int&, char**&) {
  throw std::runtime_error(
      "started by an MPI launcher, but this luz was built without MPI (install libopenmpi-dev and build with "
      "-DLUZ_MPI=ON)");
}
MpiJob::~MpiJob() = default;
int MpiJob::rank() const { return 0; }
int MpiJob::size() const { return 1; }
int MpiJob::default_threads() const { return 0; }
std::string MpiJob::agree(const std::string& error, int) { return error; }
RenderResult MpiJob::render(const Scene& scene, const RenderRequest& request) { return luz::render(scene, request); }
int MpiJob::work(const Scene*, int, const std::atomic<bool>*, const std::string&) { return 0; }
void MpiJob::broadcast(std::string&) {}
void MpiJob::end_frame(int) {}
void MpiJob::set_timeout(double) {}
bool MpiJob::timed_out() const { return false; }
bool MpiJob::lost_ranks() const { return false; }
int MpiJob::finish(int status, const std::string&) { return status; }

}  // namespace luz
