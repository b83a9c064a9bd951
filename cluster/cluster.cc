#include "cluster/cluster.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <climits>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <mutex>
#include <thread>

#include "base/parallel.h"

#if FESIM_WITH_MPI
#include <mpi.h>
#endif

namespace fesim::cluster {
namespace {

/// Runs one item, turning an exception into a failed outcome.
ItemOutcome RunItem(const ItemFn& fn, std::size_t i, int rank) {
  ItemOutcome o;
  o.rank = rank;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    o.payload = fn(i);
    o.ok = true;
  } catch (const std::exception& e) {
    o.payload = e.what();
  } catch (...) {
    o.payload = "unknown exception";
  }
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return o;
}

#if FESIM_WITH_MPI
/// The tags of the epoch-th Map: worker → rank 0 [int64 index][uint8 ok][double seconds][payload]
/// (index −1 on
/// the first request), and rank 0 → worker the int64 next index (−1 when none is left). Each Map
/// has its own tags: a worker done with one Map may already ask for work of the next while rank 0
/// still serves the slower workers of the previous one. Tags stay below 32 767 (the least upper
/// bound MPI guarantees).
int ResultTag(std::uint64_t epoch) { return 100 + 2 * static_cast<int>(epoch % 16000); }
int AssignTag(std::uint64_t epoch) { return ResultTag(epoch) + 1; }
constexpr std::size_t kSecondsAt = sizeof(std::int64_t) + 1;
constexpr std::size_t kHeaderBytes = kSecondsAt + sizeof(double);

void Check(int rc, const char* what) {
  if (rc != MPI_SUCCESS) {
    char msg[MPI_MAX_ERROR_STRING];
    int len = 0;
    MPI_Error_string(rc, msg, &len);
    throw std::runtime_error(std::string("MPI ") + what + ": " + std::string(msg, len));
  }
}

/// Waits for a request by polling with growing sleeps (50 µs … 2 ms) instead of MPI's busy wait.
void Wait(MPI_Request* request) {
  auto nap = std::chrono::microseconds(50);
  for (;;) {
    int flag = 0;
    Check(MPI_Test(request, &flag, MPI_STATUS_IGNORE), "test");
    if (flag) return;
    std::this_thread::sleep_for(nap);
    nap = std::min(nap * 2, std::chrono::microseconds(2000));
  }
}

int CountOf(std::size_t bytes) {
  if (bytes > static_cast<std::size_t>(INT_MAX)) {
    throw std::runtime_error("cluster: a work item's result of " + std::to_string(bytes) +
                             " bytes exceeds MPI's 2 GiB message limit");
  }
  return static_cast<int>(bytes);
}
#endif

}  // namespace

bool StartedByMpiLauncher() {
  const std::array<const char*, 3> launcher_variables = {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK",
                                                         "PMI_RANK"};
  return std::any_of(launcher_variables.begin(), launcher_variables.end(),
                     [](const char* v) { return std::getenv(v) != nullptr; });
}

std::unique_ptr<Cluster> Cluster::Single() { return std::unique_ptr<Cluster>(new Cluster()); }

std::unique_ptr<Cluster> Cluster::Start(int* argc, char*** argv) {
  std::unique_ptr<Cluster> c(new Cluster());
  if (!StartedByMpiLauncher()) return c;
#if FESIM_WITH_MPI
  int provided = 0;
  // Rank 0's dispatcher thread makes the MPI calls of a Map while its main thread computes:
  // one thread at a time, so SERIALIZED suffices.
  Check(MPI_Init_thread(argc, argv, MPI_THREAD_SERIALIZED, &provided), "init");
  if (provided < MPI_THREAD_SERIALIZED) {
    MPI_Finalize();
    throw std::runtime_error(
        "cluster: the MPI library does not provide MPI_THREAD_SERIALIZED (needed by rank 0's "
        "dispatcher thread)");
  }
  c->mpi_ = true;
  Check(MPI_Comm_rank(MPI_COMM_WORLD, &c->rank_), "rank");
  Check(MPI_Comm_size(MPI_COMM_WORLD, &c->size_), "size");
  return c;
#else
  (void)argc;
  (void)argv;
  throw std::runtime_error(
      "started by an MPI launcher, but this fesim was built without MPI (FESIM_WITH_MPI=OFF; "
      "install libopenmpi-dev and rebuild); run it without mpirun");
#endif
}

Cluster::~Cluster() {
#if FESIM_WITH_MPI
  if (mpi_) {
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (!finalized) MPI_Finalize();
  }
#endif
}

std::vector<ItemOutcome> Cluster::Map(std::size_t n, const ItemFn& fn, int threads,
                                      const ItemDone& done) {
  std::vector<ItemOutcome> out(n);
  std::mutex mutex;
  std::size_t finished = 0;
  const auto record = [&](std::size_t i, ItemOutcome o) {
    std::lock_guard<std::mutex> lock(mutex);
    out[i] = std::move(o);
    ++finished;
    if (done) done(finished, i, out[i]);
  };
  if (size_ == 1) {
    ParallelFor(n, std::max(threads, 1), [&](std::size_t i) { record(i, RunItem(fn, i, rank_)); });
    return out;
  }
#if FESIM_WITH_MPI
  const int result_tag = ResultTag(map_epoch_), assign_tag = AssignTag(map_epoch_);
  ++map_epoch_;
  if (rank_ == 0) {
    std::atomic<std::size_t> next{0};
    std::exception_ptr dispatcher_error;
    std::thread dispatcher([&] {
      try {
        int active = size_ - 1;
        std::vector<char> buffer;
        auto nap = std::chrono::microseconds(50);
        while (active > 0) {
          int flag = 0;
          MPI_Status status;
          Check(MPI_Iprobe(MPI_ANY_SOURCE, result_tag, MPI_COMM_WORLD, &flag, &status), "probe");
          if (!flag) {
            std::this_thread::sleep_for(nap);
            nap = std::min(nap * 2, std::chrono::microseconds(2000));
            continue;
          }
          nap = std::chrono::microseconds(50);
          int count = 0;
          Check(MPI_Get_count(&status, MPI_BYTE, &count), "count");
          buffer.resize(static_cast<std::size_t>(count));
          Check(MPI_Recv(buffer.data(), count, MPI_BYTE, status.MPI_SOURCE, result_tag,
                         MPI_COMM_WORLD, MPI_STATUS_IGNORE),
                "receive");
          std::int64_t index = -1;
          std::memcpy(&index, buffer.data(), sizeof index);
          if (index >= 0) {
            ItemOutcome o;
            o.rank = status.MPI_SOURCE;
            o.ok = buffer[sizeof index] != 0;
            std::memcpy(&o.seconds, buffer.data() + kSecondsAt, sizeof o.seconds);
            o.payload.assign(buffer.begin() + kHeaderBytes, buffer.end());
            record(static_cast<std::size_t>(index), std::move(o));
          }
          const std::size_t k = next++;
          std::int64_t assign = k < n ? static_cast<std::int64_t>(k) : -1;
          if (assign < 0) --active;
          // Eight bytes go eagerly: MPI_Send returns without waiting for the worker.
          Check(MPI_Send(&assign, 1, MPI_INT64_T, status.MPI_SOURCE, assign_tag, MPI_COMM_WORLD),
                "send");
        }
      } catch (...) {
        dispatcher_error = std::current_exception();
      }
    });
    for (std::size_t i = next++; i < n; i = next++) record(i, RunItem(fn, i, rank_));
    dispatcher.join();
    if (dispatcher_error) std::rethrow_exception(dispatcher_error);
    return out;
  }
  // Workers: ask for an item (sending the previous one's result), run it, repeat.
  std::vector<char> message(kHeaderBytes, 0);
  std::int64_t index = -1;
  std::memcpy(message.data(), &index, sizeof index);
  for (;;) {
    MPI_Request request;
    Check(MPI_Isend(message.data(), CountOf(message.size()), MPI_BYTE, 0, result_tag,
                    MPI_COMM_WORLD, &request),
          "send");
    Wait(&request);
    std::int64_t assign = -1;
    Check(MPI_Irecv(&assign, 1, MPI_INT64_T, 0, assign_tag, MPI_COMM_WORLD, &request), "receive");
    Wait(&request);
    if (assign < 0) break;
    const ItemOutcome o = RunItem(fn, static_cast<std::size_t>(assign), rank_);
    message.resize(kHeaderBytes + o.payload.size());
    std::memcpy(message.data(), &assign, sizeof assign);
    message[sizeof assign] = o.ok ? 1 : 0;
    std::memcpy(message.data() + kSecondsAt, &o.seconds, sizeof o.seconds);
    std::copy(o.payload.begin(), o.payload.end(), message.begin() + kHeaderBytes);
  }
  return {};
#else
  throw std::logic_error("cluster: more than one rank without MPI");
#endif
}

std::vector<ItemOutcome> Cluster::MapAll(std::size_t n, const ItemFn& fn, int threads,
                                         const ItemDone& done) {
  std::vector<ItemOutcome> out = Map(n, fn, threads, done);
  if (size_ == 1) return out;
  // Rank 0 packs [uint8 ok][int32 rank][double seconds][uint64 length][payload] per item.
  std::string packed;
  if (rank_ == 0) {
    for (const auto& o : out) {
      const std::uint8_t ok = o.ok ? 1 : 0;
      const std::int32_t rank = o.rank;
      const std::uint64_t length = o.payload.size();
      packed.append(reinterpret_cast<const char*>(&ok), sizeof ok);
      packed.append(reinterpret_cast<const char*>(&rank), sizeof rank);
      packed.append(reinterpret_cast<const char*>(&o.seconds), sizeof o.seconds);
      packed.append(reinterpret_cast<const char*>(&length), sizeof length);
      packed += o.payload;
    }
  }
  packed = Broadcast(packed);
  if (rank_ == 0) return out;
  out.assign(n, ItemOutcome());
  std::size_t at = 0;
  for (auto& o : out) {
    std::uint8_t ok = 0;
    std::int32_t rank = 0;
    std::uint64_t length = 0;
    std::memcpy(&ok, packed.data() + at, sizeof ok);
    at += sizeof ok;
    std::memcpy(&rank, packed.data() + at, sizeof rank);
    at += sizeof rank;
    std::memcpy(&o.seconds, packed.data() + at, sizeof o.seconds);
    at += sizeof o.seconds;
    std::memcpy(&length, packed.data() + at, sizeof length);
    at += sizeof length;
    o.ok = ok != 0;
    o.rank = rank;
    o.payload = packed.substr(at, length);
    at += length;
  }
  return out;
}

std::string Cluster::Broadcast(const std::string& value) const {
  if (size_ == 1) return value;
#if FESIM_WITH_MPI
  std::uint64_t length = value.size();
  MPI_Request request;
  Check(MPI_Ibcast(&length, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD, &request), "broadcast");
  Wait(&request);
  std::string out = rank_ == 0 ? value : std::string(length, '\0');
  Check(MPI_Ibcast(out.data(), CountOf(length), MPI_BYTE, 0, MPI_COMM_WORLD, &request),
        "broadcast");
  Wait(&request);
  return out;
#else
  return value;
#endif
}

std::vector<std::string> Cluster::Gather(const std::string& value) const {
  if (size_ == 1) return {value};
#if FESIM_WITH_MPI
  int length = CountOf(value.size());
  std::vector<int> lengths(rank_ == 0 ? size_ : 0);
  MPI_Request request;
  Check(MPI_Igather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, 0, MPI_COMM_WORLD, &request),
        "gather");
  Wait(&request);
  std::vector<int> offsets(lengths.size());
  std::size_t total = 0;
  for (std::size_t r = 0; r < lengths.size(); ++r) {
    offsets[r] = CountOf(total);
    total += static_cast<std::size_t>(lengths[r]);
  }
  std::string all(total, '\0');
  Check(MPI_Igatherv(value.data(), length, MPI_BYTE, all.data(), lengths.data(), offsets.data(),
                     MPI_BYTE, 0, MPI_COMM_WORLD, &request),
        "gather");
  Wait(&request);
  std::vector<std::string> out;
  for (std::size_t r = 0; r < lengths.size(); ++r) {
    out.push_back(
        all.substr(static_cast<std::size_t>(offsets[r]), static_cast<std::size_t>(lengths[r])));
  }
  return out;
#else
  return {value};
#endif
}

void Cluster::Barrier() const {
  if (size_ == 1) return;
#if FESIM_WITH_MPI
  MPI_Request request;
  Check(MPI_Ibarrier(MPI_COMM_WORLD, &request), "barrier");
  Wait(&request);
#endif
}

void Cluster::Abort(int code) const {
#if FESIM_WITH_MPI
  if (mpi_) MPI_Abort(MPI_COMM_WORLD, code);
#endif
  std::_Exit(code);
}

}  // namespace fesim::cluster
