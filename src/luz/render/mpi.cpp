#include "luz/render/mpi.h"

#include <fcntl.h>
#include <sched.h>
#include <mpi.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>
#include <thread>
#include <vector>

#include "luz/device/cpu/render.h"
#include "luz/render/units.h"

namespace luz {

bool mpi_built() { return true; }

namespace {

enum Tag : int { kTagReady = 1, kTagUnit, kTagResult, kTagError, kTagStop, kTagAgree };

// Between polls of a rank that waits: MPI's blocking calls spin a core,
// which an oversubscribed node (more ranks than cores) cannot spare.
void nap() { std::this_thread::sleep_for(std::chrono::microseconds(200)); }

class Packer {
 public:
  template <class T>
  void pod(const T& v) {
    const char* p = reinterpret_cast<const char*>(&v);
    b_.insert(b_.end(), p, p + sizeof v);
  }
  template <class T>
  void array(const std::vector<T>& v) {
    const char* p = reinterpret_cast<const char*>(v.data());
    b_.insert(b_.end(), p, p + v.size() * sizeof(T));
  }
  std::vector<char>& bytes() { return b_; }

 private:
  std::vector<char> b_;
};

class Unpacker {
 public:
  explicit Unpacker(const std::vector<char>& b) : p_(b.data()), end_(b.data() + b.size()) {}
  template <class T>
  T pod() {
    T v;
    take(&v, sizeof v);
    return v;
  }
  template <class T>
  void array(std::vector<T>& v) {
    take(v.data(), v.size() * sizeof(T));
  }

 private:
  void take(void* to, size_t n) {
    if (size_t(end_ - p_) < n) throw std::runtime_error("MPI: a message shorter than its contents");
    if (n == 0) return;  // an empty array's data() may be null: no memcpy from or to it
    std::memcpy(to, p_, n);
    p_ += n;
  }
  const char* p_;
  const char* end_;
};

void pack_unit(Packer& p, const WorkUnit& u) {
  for (uint32_t v : {u.block, uint32_t(u.rect.x0), uint32_t(u.rect.y0), uint32_t(u.rect.x1), uint32_t(u.rect.y1),
                     u.first, u.end})
    p.pod(v);
}

WorkUnit unpack_unit(Unpacker& p) {
  WorkUnit u;
  u.block = p.pod<uint32_t>();
  u.rect.x0 = int(p.pod<uint32_t>());
  u.rect.y0 = int(p.pod<uint32_t>());
  u.rect.x1 = int(p.pod<uint32_t>());
  u.rect.y1 = int(p.pod<uint32_t>());
  u.first = p.pod<uint32_t>();
  u.end = p.pod<uint32_t>();
  if (u.rect.x1 < u.rect.x0 || u.rect.y1 < u.rect.y0 || u.end < u.first)
    throw std::runtime_error("MPI: a malformed work unit");
  return u;
}

void pack_film(Packer& p, const Film& f) {
  p.array(f.sum);
  p.array(f.sum_sq);
  p.array(f.count);
}

Film unpack_film(Unpacker& p, const PixelRect& r) {
  Film f(r.width(), r.height());
  p.array(f.sum);
  p.array(f.sum_sq);
  p.array(f.count);
  return f;
}

// The next message from `source` (MPI_ANY_SOURCE: any) with `tag`
// (MPI_ANY_TAG: any), polled.
MPI_Status wait_message(int source, int tag = MPI_ANY_TAG) {
  MPI_Status st;
  for (;;) {
    int flag = 0;
    MPI_Iprobe(source, tag, MPI_COMM_WORLD, &flag, &st);
    if (flag) return st;
    nap();
  }
}

std::vector<char> receive(const MPI_Status& st) {
  int n = 0;
  MPI_Get_count(&st, MPI_BYTE, &n);
  std::vector<char> b(size_t(std::max(n, 0)));
  MPI_Recv(b.data(), n, MPI_BYTE, st.MPI_SOURCE, st.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  return b;
}

void send(const std::vector<char>& b, int dest, int tag) {
  MPI_Send(b.data(), int(b.size()), MPI_BYTE, dest, tag, MPI_COMM_WORLD);
}

// Waits for the request, polled, at most `seconds`: whether it completed.
bool wait_for(MPI_Request& r, double seconds) {
  const auto start = std::chrono::steady_clock::now();
  for (int flag = 0;;) {
    MPI_Test(&r, &flag, MPI_STATUS_IGNORE);
    if (flag) return true;
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > seconds) return false;
    nap();
  }
}

void wait(MPI_Request& r) { wait_for(r, std::numeric_limits<double>::infinity()); }

}  // namespace

struct MpiJob::Impl {
  int rank = 0, size = 1, node_ranks = 1;
  bool agreed = false, stopped = false;
  // Rank 0, per rank: a unit out, the rank gone (left or failed), lost
  // (silent past the timeout), its threads, the unit message being sent to
  // it, that unit and when it went.
  std::vector<char> out, gone, lost;
  std::vector<int> threads;
  std::vector<std::vector<char>> sending;
  std::vector<MPI_Request> send_req;
  std::vector<WorkUnit> unit;
  std::vector<std::chrono::steady_clock::time_point> since;
  double timeout = 600;
  bool any_lost = false;
  bool timed_out = false;  // a rank silent past the timeout before the render
};

namespace {

// The ranks 1.. as render_units' remote workers (worker w is rank w + 1).
class RemoteRanks : public RemoteWorkers {
 public:
  explicit RemoteRanks(MpiJob::Impl& job) : j_(job) {}
  int count() const override { return j_.size - 1; }
  int threads(int w) const override { return j_.threads[size_t(w) + 1]; }
  bool available(int w) const override { return !j_.gone[size_t(w) + 1]; }
  void send(int w, const WorkUnit& u, const Film& in) override {
    const size_t r = size_t(w) + 1;
    if (j_.send_req[r] != MPI_REQUEST_NULL) wait(j_.send_req[r]);  // the last unit's message, long received
    Packer p;
    pack_unit(p, u);
    pack_film(p, in);
    j_.sending[r] = std::move(p.bytes());
    MPI_Isend(j_.sending[r].data(), int(j_.sending[r].size()), MPI_BYTE, int(r), kTagUnit, MPI_COMM_WORLD,
              &j_.send_req[r]);
    j_.out[r] = 1;
    j_.unit[r] = u;
    j_.since[r] = std::chrono::steady_clock::now();
  }
  bool poll(UnitResult& res) override {
    // A rank silent past the timeout (stopped, or dead under a launcher
    // that does not end the job) is lost: its unit goes back to the others.
    const auto now = std::chrono::steady_clock::now();
    for (size_t r = 1; r < size_t(j_.size); ++r)
      if (j_.out[r] && std::chrono::duration<double>(now - j_.since[r]).count() > j_.timeout) {
        j_.out[r] = 0;
        j_.gone[r] = j_.lost[r] = 1;
        j_.any_lost = true;
        std::fprintf(stderr, "\nluz: warning: rank %zu sent nothing for %g s: taken as lost, its units go to the other ranks\n",
                     r, j_.timeout);
        res.worker = int(r) - 1;
        res.unit = j_.unit[r];
        res.complete = false;
        res.rays = res.discarded = 0;
        return true;
      }
    int flag = 0;
    MPI_Status st;
    MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st);
    if (!flag) return false;
    const std::vector<char> b = receive(st);
    const size_t r = size_t(st.MPI_SOURCE);
    if (j_.lost[r]) return false;  // too late: its unit went to another rank
    j_.out[r] = 0;
    if (st.MPI_TAG == kTagError) {
      j_.gone[r] = 1;
      throw std::runtime_error("rank " + std::to_string(r) + ": " + std::string(b.begin(), b.end()));
    }
    if (st.MPI_TAG != kTagResult)
      throw std::runtime_error("MPI: rank " + std::to_string(r) + " sent an unexpected message (tag " +
                               std::to_string(st.MPI_TAG) + ")");
    Unpacker u(b);
    res.worker = int(r) - 1;
    res.unit = unpack_unit(u);
    res.complete = u.pod<uint32_t>() != 0;
    if (u.pod<uint32_t>() != 0) j_.gone[r] = 1;  // leaving
    res.rays = u.pod<uint64_t>();
    res.discarded = u.pod<uint64_t>();
    if (res.complete) res.film = unpack_film(u, res.unit.rect);
    return true;
  }

 private:
  MpiJob::Impl& j_;
};

}  // namespace

MpiJob::MpiJob(int& argc, char**& argv) : m_(std::make_unique<Impl>()) {
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &m_->rank);
  MPI_Comm_size(MPI_COMM_WORLD, &m_->size);
  MPI_Comm node;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
  MPI_Comm_size(node, &m_->node_ranks);
  MPI_Comm_free(&node);
  const size_t n = size_t(m_->size);
  m_->out.assign(n, 0);
  m_->gone.assign(n, 0);
  m_->lost.assign(n, 0);
  m_->unit.resize(n);
  m_->since.resize(n);
  m_->threads.assign(n, 1);
  m_->sending.resize(n);
  m_->send_req.assign(n, MPI_REQUEST_NULL);
  if (m_->rank != 0) {
    const int null = ::open("/dev/null", O_WRONLY);
    if (null >= 0) {
      ::dup2(null, 1);
      ::dup2(null, 2);
      ::close(null);
    }
  }
}

MpiJob::~MpiJob() {
  if (!m_->any_lost) MPI_Finalize();  // a lost rank would never join it
}

void MpiJob::set_timeout(double seconds) { m_->timeout = seconds; }
bool MpiJob::timed_out() const { return m_->timed_out; }
bool MpiJob::lost_ranks() const { return m_->any_lost; }

int MpiJob::rank() const { return m_->rank; }
int MpiJob::size() const { return m_->size; }

int MpiJob::default_threads() const {
  // A launcher that binds each rank to its cores (OpenMPI's default: a core
  // per rank for up to 2 ranks, a socket each beyond) has given this rank
  // its share; an unbound rank shares the node's cores with its neighbours.
  const int cores = int(std::max(std::thread::hardware_concurrency(), 1u));
  cpu_set_t set;
  CPU_ZERO(&set);
  if (::sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) < cores) return std::max(CPU_COUNT(&set), 1);
  return std::max(cores / std::max(m_->node_ranks, 1), 1);
}

std::string MpiJob::agree(const std::string& error, int threads) {
  Impl& j = *m_;
  j.agreed = true;
  int mine = error.empty() ? j.size : j.rank, first = j.size;
  MPI_Request req;
  // A rank still loading past the timeout (a hung file system, a stopped
  // process) would hold every other rank here: the job ends instead.
  MPI_Iallreduce(&mine, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD, &req);
  if (!wait_for(req, j.timeout)) {
    j.timed_out = true;
    char line[160];
    std::snprintf(line, sizeof line,
                  "luz: error: a rank had not loaded the scene after %g s (--mpi-timeout); ending the job", j.timeout);
    return line;
  }
  MPI_Igather(&threads, 1, MPI_INT, j.threads.data(), 1, MPI_INT, 0, MPI_COMM_WORLD, &req);
  wait(req);
  if (first == j.size) return "";
  if (first == 0) return j.rank == 0 ? error : "failed on rank 0";
  if (j.rank == first) send(std::vector<char>(error.begin(), error.end()), 0, kTagAgree);
  if (j.rank != 0) return "failed on rank " + std::to_string(first);
  const std::vector<char> b = receive(wait_message(first, kTagAgree));
  return "rank " + std::to_string(first) + ": " + std::string(b.begin(), b.end());
}

RenderResult MpiJob::render(const Scene& scene, const RenderRequest& req) {
  Impl& j = *m_;
  if (j.rank != 0) throw std::logic_error("MpiJob::render on a rank other than 0");
  // The others have built their devices (Embree's BVH): the render's time
  // starts, as a single process's does, after that. A rank not ready within
  // the timeout is lost, as a silent one during the render is, and the others
  // take its share. A stop meanwhile returns the start film as it is.
  const auto since = std::chrono::steady_clock::now();
  std::vector<char> ready(size_t(j.size), 0);
  for (int waiting = j.size - 1; waiting > 0;) {
    int flag = 0;
    MPI_Status st;
    MPI_Iprobe(MPI_ANY_SOURCE, kTagReady, MPI_COMM_WORLD, &flag, &st);
    if (flag) {
      receive(st);
      if (!ready[size_t(st.MPI_SOURCE)]) --waiting;
      ready[size_t(st.MPI_SOURCE)] = 1;
      continue;
    }
    if (req.cancel && req.cancel->load()) {
      RenderResult res;
      res.film = req.start ? *req.start : Film(scene.camera.width, scene.camera.height);
      return res;
    }
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count() > j.timeout) {
      for (size_t r = 1; r < size_t(j.size); ++r)
        if (!ready[r]) {
          j.gone[r] = j.lost[r] = 1;
          j.any_lost = true;
          std::fprintf(stderr,
                       "luz: warning: rank %zu had not built its scene after %g s (--mpi-timeout): taken as lost, its "
                       "share goes to the other ranks\n",
                       r, j.timeout);
        }
      break;
    }
    nap();
  }
  RemoteRanks remote(j);
  const Camera& cam = scene.camera;
  // Units of a quarter second of the ranks' threads (render_units), on average.
  uint64_t threads = 0;
  for (int t : j.threads) threads += uint64_t(std::max(t, 1));
  const uint32_t spp = req.end_sample.value_or(scene.settings.spp) - req.first_sample;
  return render_units(scene, req, &remote,
                      block_size_for(cam.width, cam.height, j.size, spp, kPassSamplesPerThread * threads / uint64_t(j.size),
                                     unit_block_start(scene.settings)));
}

void MpiJob::broadcast(std::string& bytes) {
  uint64_t n = bytes.size();
  MPI_Request req;
  MPI_Ibcast(&n, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD, &req);
  wait(req);
  bytes.resize(n);
  // In pieces: MPI counts are ints.
  constexpr uint64_t kPiece = uint64_t(1) << 30;
  for (uint64_t at = 0; at < n; at += kPiece) {
    MPI_Ibcast(bytes.data() + at, int(std::min(kPiece, n - at)), MPI_BYTE, 0, MPI_COMM_WORLD, &req);
    wait(req);
  }
}

int MpiJob::work(const Scene* scene, int threads, const std::atomic<bool>* cancel, const std::string& error) {
  Impl& j = *m_;
  auto cancelled = [&] { return cancel && cancel->load(std::memory_order_relaxed); };
  std::optional<CpuDevice> device;
  std::string failed = error;
  try {
    if (scene) device.emplace(*scene, threads);
  } catch (const std::exception& e) {
    failed = e.what();
  }
  send(std::vector<char>(), 0, kTagReady);
  for (;;) {
    MPI_Status st;
    for (int flag = 0; !flag;) {
      MPI_Iprobe(0, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st);
      if (!flag && cancelled()) return 1;  // signalled: the caller exits
      if (!flag) nap();
    }
    const std::vector<char> b = receive(st);
    Unpacker in(b);
    if (st.MPI_TAG == kTagStop) {
      j.stopped = true;
      return in.pod<int32_t>();
    }
    try {
      if (st.MPI_TAG != kTagUnit) throw std::runtime_error("MPI: an unexpected message (tag " + std::to_string(st.MPI_TAG) + ")");
      if (!device) throw std::runtime_error(failed);
      const WorkUnit u = unpack_unit(in);
      const Film start = unpack_film(in, u.rect);
      Film film(u.rect.width(), u.rect.height());
      PassResult p;
      if (!cancelled()) p = device->render_pass(start, film, u.rect, u.first, u.end, PassHooks{cancelled, nullptr});
      Packer out;
      pack_unit(out, u);
      out.pod(uint32_t(p.complete));
      out.pod(uint32_t(cancelled()));
      out.pod(uint64_t(p.rays));
      out.pod(uint64_t(p.discarded));
      if (p.complete) pack_film(out, film);
      send(out.bytes(), 0, kTagResult);
    } catch (const std::exception& e) {
      const std::string what = e.what();
      send(std::vector<char>(what.begin(), what.end()), 0, kTagError);
    }
  }
}

int MpiJob::finish(int status, const std::string& error) {
  Impl& j = *m_;
  if (!j.agreed) {
    const std::string first = agree(error);
    if (!first.empty()) {
      if (j.rank == 0 && error.empty()) std::fprintf(stderr, "%s\n", first.c_str());
      status = std::max(status, 2);
    }
  }
  if (j.timed_out) return std::max(status, 2);  // no word from a rank: nothing to wait for
  if (j.rank != 0) {
    while (!j.stopped) {
      const MPI_Status st = wait_message(0);
      const std::vector<char> b = receive(st);
      if (st.MPI_TAG == kTagStop) {
        Unpacker in(b);
        status = in.pod<int32_t>();
        j.stopped = true;
      }
    }
    return status;
  }
  if (!j.stopped) stop(status);
  return status;
}

void MpiJob::end_frame(int status) {
  Impl& j = *m_;
  if (j.rank == 0) stop(status);
  j.agreed = j.stopped = false;
}

void MpiJob::stop(int status) {
  Impl& j = *m_;
  // The units still out come back (a stop ends them within a unit), then
  // every rank gets the status.
  for (int r = 1; r < j.size; ++r) {
    if (j.lost[size_t(r)]) continue;
    while (j.out[size_t(r)]) {
      const MPI_Status st = wait_message(r);
      receive(st);
      if (st.MPI_TAG == kTagResult || st.MPI_TAG == kTagError) j.out[size_t(r)] = 0;
    }
    if (j.send_req[size_t(r)] != MPI_REQUEST_NULL) wait(j.send_req[size_t(r)]);
    j.gone[size_t(r)] = 0;
  }
  Packer message;
  message.pod(int32_t(status));
  for (int r = 1; r < j.size; ++r)
    if (!j.lost[size_t(r)]) send(message.bytes(), r, kTagStop);
  j.stopped = true;
}

}  // namespace luz
