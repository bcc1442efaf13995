// What the launcher's environment says, with or without MPI built in.
#include <cstdlib>
#include <string>

#include "luz/render/mpi.h"

namespace luz {

namespace {

// The rank variable of OpenMPI, PMIx (OpenMPI 5, Slurm) and PMI (MPICH, Intel MPI).
const char* rank_variable() {
  for (const char* v : {"OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"})
    if (const char* s = std::getenv(v)) return s;
  return nullptr;
}

}  // namespace

bool mpi_launched() { return rank_variable() != nullptr; }

int mpi_launched_rank() {
  const char* s = rank_variable();
  return s ? std::atoi(s) : 0;
}

}  // namespace luz
