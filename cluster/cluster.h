// Work spread over the processes of an MPI job (issue 9), or over the threads of one process when
// fesim was not started by mpirun. The engine is MPI (Debian's OpenMPI); this is the thin layer
// fesim's commands use: a dynamically balanced map over independent work items whose results come
// back to rank 0 in index order, and the few collectives the commands need.
//
// Model: every rank runs the same command (SPMD). At a Map, rank 0 hands out item indices one at
// a time to whichever rank asks next (rank 0 computes items too; a dispatcher thread of rank 0
// answers the others), so uneven items balance. Results travel to rank 0 as bytes. Which rank
// computes an item never changes its result: items carry their own seeds, and rank 0 orders the
// results by index.
//
// Waiting is by polling with short sleeps, not MPI's busy-waiting, so an oversubscribed job
// (more ranks than cores) does not steal the cores of the ranks that compute.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace fesim::cluster {

class MpiTransport;  // cluster/mpi_module.h

/// What happened to one work item.
struct ItemOutcome {
  bool ok = false;
  int rank = -1;         ///< the rank that ran it.
  double seconds = 0.0;  ///< its wall time there.
  std::string payload;   ///< fn's result when ok, else the error message.
};

/// An error every rank of a job throws at the same point of the run, with the same message (e.g.
/// the list of failed work items, which rank 0 broadcasts): rank 0 reports it and every rank ends
/// normally. Any other exception on a job is one rank's own, and ends the whole job (Abort).
class CollectiveError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Told on rank 0 as each item finishes: how many have finished, the item's index and outcome.
using ItemDone =
    std::function<void(std::size_t finished, std::size_t index, const ItemOutcome& outcome)>;

/// A work item's result bytes (any serialisation the caller likes; empty is fine).
using ItemFn = std::function<std::string(std::size_t)>;

class Cluster {
 public:
  /// The processes of this run. Under mpirun/mpiexec (detected from the launcher's environment:
  /// OMPI_COMM_WORLD_SIZE, PMIX_RANK or PMI_RANK) in a build with FESIM_WITH_MPI, loads the MPI
  /// module (cluster/mpi_module.h), initialises MPI and returns the job; otherwise one process.
  /// Throws std::runtime_error when started by mpirun but built without MPI (every rank would do
  /// the whole run) or when the module cannot be loaded.
  static std::unique_ptr<Cluster> Start(int* argc, char*** argv);
  /// One process (tests, library users).
  static std::unique_ptr<Cluster> Single();

  Cluster(const Cluster&) = delete;
  Cluster& operator=(const Cluster&) = delete;
  ~Cluster();  ///< finalises MPI when Start initialised it.

  int rank() const { return rank_; }
  int size() const { return size_; }
  bool is_root() const { return rank_ == 0; }
  bool is_mpi() const { return mpi_ != nullptr; }

  /// Runs fn(i) for i in [0, n), each exactly once on some rank (dynamic assignment; one item at
  /// a time per rank; on a single process, `threads` threads). An exception from fn makes that
  /// item's outcome failed with the message; the other items still run. Returns the n outcomes
  /// in index order on rank 0 and an empty vector on the other ranks. `done` (may be empty) is
  /// called on rank 0 as each item finishes, from one thread at a time (e.g. to write its result
  /// at once, so that an interrupted run keeps what finished).
  std::vector<ItemOutcome> Map(std::size_t n, const ItemFn& fn, int threads = 1,
                               const ItemDone& done = {});

  /// Map, then the n outcomes on every rank (for runs whose every rank continues from them).
  std::vector<ItemOutcome> MapAll(std::size_t n, const ItemFn& fn, int threads = 1,
                                  const ItemDone& done = {});

  /// Rank 0's `value` on every rank.
  std::string Broadcast(const std::string& value) const;
  /// Every rank's `value`, by rank, on rank 0 (empty on the others).
  std::vector<std::string> Gather(const std::string& value) const;
  void Barrier() const;
  /// Ends the whole job at once with `code` (after a rank-local failure that the other ranks
  /// would wait on forever); does not return.
  [[noreturn]] void Abort(int code) const;

 private:
  Cluster();
  int rank_ = 0, size_ = 1;
  /// The MPI module's transport when Start initialised MPI (loaded only then), else null.
  std::unique_ptr<MpiTransport> mpi_;
  std::uint64_t map_epoch_ = 0;  ///< Maps so far (every rank calls Map in the same order).
};

/// True when the process was started by an MPI launcher (see Cluster::Start).
bool StartedByMpiLauncher();

}  // namespace fesim::cluster
