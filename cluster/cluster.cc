#include "cluster/cluster.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <mutex>
#include <thread>

#include "base/module.h"
#include "base/parallel.h"
#include "cluster/mpi_module.h"

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

}  // namespace

bool StartedByMpiLauncher() {
  const std::array<const char*, 3> launcher_variables = {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK",
                                                         "PMI_RANK"};
  return std::any_of(launcher_variables.begin(), launcher_variables.end(),
                     [](const char* v) { return std::getenv(v) != nullptr; });
}

Cluster::Cluster() = default;

std::unique_ptr<Cluster> Cluster::Single() { return std::unique_ptr<Cluster>(new Cluster()); }

std::unique_ptr<Cluster> Cluster::Start(int* argc, char*** argv) {
  std::unique_ptr<Cluster> c(new Cluster());
  if (!StartedByMpiLauncher()) return c;
#if FESIM_WITH_MPI
  // RTLD_GLOBAL: Open MPI opens its own components, which look for its symbols globally.
  MpiFactory* start = ModuleFunction<MpiFactory>(kMpiModuleFile, kMpiFactorySymbol,
                                                 "cluster (MPI, started by mpirun)",
                                                 /*global=*/true);
  c->mpi_.reset(start(argc, argv));
  c->rank_ = c->mpi_->rank();
  c->size_ = c->mpi_->size();
  return c;
#else
  (void)argc;
  (void)argv;
  throw std::runtime_error(
      "started by an MPI launcher, but this fesim was built without MPI (FESIM_WITH_MPI=OFF; "
      "install libopenmpi-dev and rebuild); run it without mpirun");
#endif
}

Cluster::~Cluster() = default;  // the transport finalises MPI

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
  if (mpi_ == nullptr) throw std::logic_error("cluster: more than one rank without MPI");
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
          int source = -1;
          if (!mpi_->TryReceiveAny(result_tag, &source, &buffer)) {
            std::this_thread::sleep_for(nap);
            nap = std::min(nap * 2, std::chrono::microseconds(2000));
            continue;
          }
          nap = std::chrono::microseconds(50);
          std::int64_t index = -1;
          std::memcpy(&index, buffer.data(), sizeof index);
          if (index >= 0) {
            ItemOutcome o;
            o.rank = source;
            o.ok = buffer[sizeof index] != 0;
            std::memcpy(&o.seconds, buffer.data() + kSecondsAt, sizeof o.seconds);
            o.payload.assign(buffer.begin() + kHeaderBytes, buffer.end());
            record(static_cast<std::size_t>(index), std::move(o));
          }
          const std::size_t k = next++;
          std::int64_t assign = k < n ? static_cast<std::int64_t>(k) : -1;
          if (assign < 0) --active;
          // Eight bytes go eagerly: the send returns without waiting for the worker.
          mpi_->SendInt64(assign, source, assign_tag);
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
    mpi_->SendBytes(message.data(), message.size(), 0, result_tag);
    const std::int64_t assign = mpi_->ReceiveInt64(0, assign_tag);
    if (assign < 0) break;
    const ItemOutcome o = RunItem(fn, static_cast<std::size_t>(assign), rank_);
    message.resize(kHeaderBytes + o.payload.size());
    std::memcpy(message.data(), &assign, sizeof assign);
    message[sizeof assign] = o.ok ? 1 : 0;
    std::memcpy(message.data() + kSecondsAt, &o.seconds, sizeof o.seconds);
    std::copy(o.payload.begin(), o.payload.end(), message.begin() + kHeaderBytes);
  }
  return {};
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
  return mpi_->Broadcast(value);
}

std::vector<std::string> Cluster::Gather(const std::string& value) const {
  if (size_ == 1) return {value};
  return mpi_->Gather(value);
}

void Cluster::Barrier() const {
  if (size_ == 1) return;
  mpi_->Barrier();
}

void Cluster::Abort(int code) const {
  if (mpi_ != nullptr) mpi_->Abort(code);
  std::_Exit(code);
}

}  // namespace fesim::cluster
