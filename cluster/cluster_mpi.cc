// The Open MPI back end of Cluster (cluster/cluster.h), built as the plug-in module
// fesim_cluster_mpi.so (cluster/mpi_module.h, base/module.h): only this file links MPI.
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <stdexcept>
#include <thread>
#include <type_traits>

#include "cluster/mpi_module.h"

namespace fesim::cluster {
namespace {

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

class OpenMpiTransport final : public MpiTransport {
 public:
  OpenMpiTransport() {
    Check(MPI_Comm_rank(MPI_COMM_WORLD, &rank_), "rank");
    Check(MPI_Comm_size(MPI_COMM_WORLD, &size_), "size");
  }
  ~OpenMpiTransport() override {
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (!finalized) MPI_Finalize();
  }

  int rank() const override { return rank_; }
  int size() const override { return size_; }

  bool TryReceiveAny(int tag, int* source, std::vector<char>* bytes) override {
    int flag = 0;
    MPI_Status status;
    Check(MPI_Iprobe(MPI_ANY_SOURCE, tag, MPI_COMM_WORLD, &flag, &status), "probe");
    if (!flag) return false;
    int count = 0;
    Check(MPI_Get_count(&status, MPI_BYTE, &count), "count");
    bytes->resize(static_cast<std::size_t>(count));
    Check(MPI_Recv(bytes->data(), count, MPI_BYTE, status.MPI_SOURCE, tag, MPI_COMM_WORLD,
                   MPI_STATUS_IGNORE),
          "receive");
    *source = status.MPI_SOURCE;
    return true;
  }

  void SendInt64(std::int64_t value, int dest, int tag) override {
    Check(MPI_Send(&value, 1, MPI_INT64_T, dest, tag, MPI_COMM_WORLD), "send");
  }

  void SendBytes(const char* data, std::size_t n, int dest, int tag) override {
    MPI_Request request;
    Check(MPI_Isend(data, CountOf(n), MPI_BYTE, dest, tag, MPI_COMM_WORLD, &request), "send");
    Wait(&request);
  }

  std::int64_t ReceiveInt64(int source, int tag) override {
    std::int64_t value = -1;
    MPI_Request request;
    Check(MPI_Irecv(&value, 1, MPI_INT64_T, source, tag, MPI_COMM_WORLD, &request), "receive");
    Wait(&request);
    return value;
  }

  std::string Broadcast(const std::string& value) override {
    std::uint64_t length = value.size();
    MPI_Request request;
    Check(MPI_Ibcast(&length, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD, &request), "broadcast");
    Wait(&request);
    std::string out = rank_ == 0 ? value : std::string(length, '\0');
    Check(MPI_Ibcast(out.data(), CountOf(length), MPI_BYTE, 0, MPI_COMM_WORLD, &request),
          "broadcast");
    Wait(&request);
    return out;
  }

  std::vector<std::string> Gather(const std::string& value) override {
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
  }

  void Barrier() override {
    MPI_Request request;
    Check(MPI_Ibarrier(MPI_COMM_WORLD, &request), "barrier");
    Wait(&request);
  }

  void Abort(int code) override { MPI_Abort(MPI_COMM_WORLD, code); }

 private:
  int rank_ = 0, size_ = 1;
};

}  // namespace
}  // namespace fesim::cluster

extern "C" fesim::cluster::MpiTransport* fesim_cluster_mpi_start(int* argc, char*** argv) {
  using fesim::cluster::Check;
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
  return new fesim::cluster::OpenMpiTransport();
}
static_assert(std::is_same_v<decltype(fesim_cluster_mpi_start), fesim::cluster::MpiFactory>,
              "the module's factory must have the type cluster/mpi_module.h declares");
