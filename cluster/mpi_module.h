// The MPI transport's plug-in interface (base/module.h). Cluster (cluster.h) talks to the other
// ranks through an MpiTransport made by the module fesim_cluster_mpi.so (cluster_mpi.cc), the only
// part of fesim linked with Open MPI (and through it hwloc, libevent, PMIx), so that a process not
// started by mpirun never loads them. Every call throws std::runtime_error("MPI <what>: <MPI's
// message>") when MPI fails. Waits poll with growing sleeps (50 µs … 2 ms) instead of MPI's busy
// wait (cluster.h). Calls come from one thread at a time (MPI_THREAD_SERIALIZED).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace fesim::cluster {

class MpiTransport {
 public:
  virtual ~MpiTransport() = default;  ///< finalises MPI unless it already is.

  virtual int rank() const = 0;  ///< in MPI_COMM_WORLD.
  virtual int size() const = 0;  ///< of MPI_COMM_WORLD.

  /// If a message with `tag` from any rank has arrived, receives it into `bytes`, sets `source`
  /// and returns true; otherwise returns false at once.
  virtual bool TryReceiveAny(int tag, int* source, std::vector<char>* bytes) = 0;
  /// Sends one int64 to `dest` (eagerly: returns without waiting for the receiver).
  virtual void SendInt64(std::int64_t value, int dest, int tag) = 0;
  /// Sends `n` bytes to `dest` and waits until the buffer may be reused.
  virtual void SendBytes(const char* data, std::size_t n, int dest, int tag) = 0;
  /// Receives one int64 from `source`, waiting for it.
  virtual std::int64_t ReceiveInt64(int source, int tag) = 0;
  /// Collectives over every rank, root 0: as Cluster::Broadcast, Gather and Barrier.
  virtual std::string Broadcast(const std::string& value) = 0;
  virtual std::vector<std::string> Gather(const std::string& value) = 0;
  virtual void Barrier() = 0;
  /// MPI_Abort of the whole job with `code`.
  virtual void Abort(int code) = 0;
};

/// The module's file, beside the `fesim` executable.
inline constexpr char kMpiModuleFile[] = "fesim_cluster_mpi.so";
/// Its factory's exported name and type: initialises MPI (MPI_THREAD_SERIALIZED) with the
/// program's arguments and returns the transport (the caller owns it).
inline constexpr char kMpiFactorySymbol[] = "fesim_cluster_mpi_start";
using MpiFactory = MpiTransport*(int* argc, char*** argv);

}  // namespace fesim::cluster
