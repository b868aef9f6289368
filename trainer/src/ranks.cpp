// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/ranks.hpp"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <mutex>
#include <stdexcept>
#include <thread>

#if IMM_WITH_MPI
#include <mpi.h>
#endif

namespace imm::trainer {
namespace {

Ranks& mutable_world() {
  static Ranks world;
  return world;
}

/// Adds the seconds of its scope to a total.
class Stopwatch {
 public:
  explicit Stopwatch(double& total) : total_(total), start_(std::chrono::steady_clock::now()) {}
  ~Stopwatch() {
    total_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  Stopwatch(const Stopwatch&) = delete;
  Stopwatch& operator=(const Stopwatch&) = delete;

 private:
  double& total_;
  std::chrono::steady_clock::time_point start_;
};

/// Rank `rank`'s share [first, last) of `count` items over `size` ranks.
std::pair<long, long> share_of(long count, int rank, int size) {
  const long base = count / size;
  const long extra = count % size;
  const long first = rank * base + std::min<long>(rank, extra);
  return {first, first + base + (rank < extra ? 1 : 0)};
}

#if IMM_WITH_MPI
/// Whether an MPI launcher started this process (OpenMPI's mpirun, a PMI or PMIx launcher such
/// as Slurm's srun). Without one the program stays a single process and never initializes MPI,
/// so a plain run costs nothing and needs no MPI runtime set up.
bool launched_by_mpi() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"}) {
    if (std::getenv(name) != nullptr) return true;
  }
  return false;
}

int checked_count(long value) {
  if (value > 0x7FFFFFFFL) throw std::length_error("MPI message of more than 2^31 values");
  return static_cast<int>(value);
}
#endif

}  // namespace

bool built_with_mpi() { return IMM_WITH_MPI != 0; }

namespace {
const Ranks* g_alone = nullptr;  // set while a sweep's job runs: see AloneInTheJob
}  // namespace

const Ranks& Ranks::world() { return g_alone != nullptr ? *g_alone : mutable_world(); }

AloneInTheJob::AloneInTheJob() : previous_(g_alone) {
  static const Ranks alone;
  g_alone = &alone;
}

AloneInTheJob::~AloneInTheJob() { g_alone = previous_; }

// NOLINTBEGIN(readability-convert-member-functions-to-static): they set the world's state
Ranks::Session::Session([[maybe_unused]] int& argc, [[maybe_unused]] char**& argv) {
#if IMM_WITH_MPI
  if (!launched_by_mpi()) return;
  int provided = 0;
  // SERIALIZED: the sweep's dispatcher thread on the root calls MPI while its main thread trains
  // (never both at once); everywhere else only the main thread does.
  MPI_Init_thread(&argc, &argv, MPI_THREAD_SERIALIZED, &provided);
  Ranks& world = mutable_world();
  MPI_Comm_rank(MPI_COMM_WORLD, &world.rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &world.size_);
  MPI_Comm local = MPI_COMM_NULL;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, world.rank_, MPI_INFO_NULL, &local);
  MPI_Comm_size(local, &world.local_size_);
  MPI_Comm_free(&local);
  world.distributed_ = true;
  world.serialized_threads_ = provided >= MPI_THREAD_SERIALIZED;
#endif
}

Ranks::Session::~Session() {
#if IMM_WITH_MPI
  if (mutable_world().distributed_) MPI_Finalize();
#endif
}
// NOLINTEND(readability-convert-member-functions-to-static)

std::pair<long, long> Ranks::share(long count) const { return share_of(count, rank_, size_); }

std::vector<double> Ranks::gather_all(std::span<const double> mine, [[maybe_unused]] long count,
                                      [[maybe_unused]] int width) const {
  if (!distributed_ || size_ == 1) return {mine.begin(), mine.end()};
#if IMM_WITH_MPI
  std::vector<int> counts(static_cast<std::size_t>(size_)), offsets(counts.size());
  for (int r = 0; r < size_; ++r) {
    const auto [first, last] = share_of(count, r, size_);
    counts[static_cast<std::size_t>(r)] = checked_count((last - first) * width);
    offsets[static_cast<std::size_t>(r)] = checked_count(first * width);
  }
  if (static_cast<long>(mine.size()) != counts[static_cast<std::size_t>(rank_)]) {
    throw std::logic_error("gather_all: this rank's share has the wrong size");
  }
  std::vector<double> all(static_cast<std::size_t>(count * width));
  const Stopwatch stopwatch(exchange_seconds_);
  MPI_Allgatherv(mine.data(), counts[static_cast<std::size_t>(rank_)], MPI_DOUBLE, all.data(),
                 counts.data(), offsets.data(), MPI_DOUBLE, MPI_COMM_WORLD);
  bytes_sent_ += mine.size() * sizeof(double) * static_cast<std::uint64_t>(size_ - 1);
  messages_sent_ += static_cast<std::uint64_t>(size_ - 1);
  return all;
#else
  return {mine.begin(), mine.end()};
#endif
}

std::vector<double> shared_items(
    long count, int width, const std::function<void(long item, std::span<double> terms)>& body) {
  const Ranks& ranks = Ranks::world();
  const Stopwatch stopwatch(ranks.shared_seconds_);
  const auto [first, last] = ranks.share(count);
  std::vector<double> mine(static_cast<std::size_t>((last - first) * width), 0.0);
  for (long item = first; item < last; ++item) {
    body(item,
         std::span<double>(mine.data() + (item - first) * width, static_cast<std::size_t>(width)));
  }
  return ranks.gather_all(mine, count, width);
}

bool Ranks::any(bool flag) const {
  if (!distributed_ || size_ == 1) return flag;
#if IMM_WITH_MPI
  int local = flag ? 1 : 0;
  int global = 0;
  const Stopwatch stopwatch(exchange_seconds_);
  MPI_Allreduce(&local, &global, 1, MPI_INT, MPI_LOR, MPI_COMM_WORLD);
  bytes_sent_ += sizeof(int) * static_cast<std::uint64_t>(size_ - 1);
  messages_sent_ += static_cast<std::uint64_t>(size_ - 1);
  return global != 0;
#else
  return flag;
#endif
}

void Ranks::abort_job(int code) const {
#if IMM_WITH_MPI
  if (distributed_ && size_ > 1) MPI_Abort(MPI_COMM_WORLD, code);
#else
  (void)code;
#endif
}

// --- JobQueue -------------------------------------------------------------------------------

struct JobQueue::State {
  const Ranks* ranks = nullptr;
  long jobs = 0;
  std::mutex mutex;
  long next_job = 0;                 ///< guarded by mutex: the next job not yet handed out
  std::vector<std::string> results;  ///< guarded by mutex
  std::thread dispatcher;
  bool root_works = true;  ///< the root trains too (MPI allows the dispatcher thread)

  long take() {
    const std::lock_guard lock(mutex);
    return next_job < jobs ? next_job++ : -1;
  }
  void record(long job, const std::string& result) {
    if (job < 0) return;
    const std::lock_guard lock(mutex);
    results[static_cast<std::size_t>(job)] = result;
  }
#if IMM_WITH_MPI
  static constexpr int kAsk = 701;
  static constexpr int kAnswer = 702;
  /// The root's side: answers every other rank until each has been told that nothing is left.
  /// Polls (MPI_Iprobe, then a short sleep) rather than blocking in MPI_Recv, which OpenMPI
  /// spins in: the root's own training keeps its core.
  void dispatch() {
    int finished = 0;
    while (finished < ranks->size() - 1) {
      int waiting = 0;
      MPI_Status status{};
      MPI_Iprobe(MPI_ANY_SOURCE, kAsk, MPI_COMM_WORLD, &waiting, &status);
      if (waiting == 0) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        continue;
      }
      int bytes = 0;
      MPI_Get_count(&status, MPI_CHAR, &bytes);
      std::string message(static_cast<std::size_t>(bytes), '\0');
      MPI_Recv(message.data(), bytes, MPI_CHAR, status.MPI_SOURCE, kAsk, MPI_COMM_WORLD,
               MPI_STATUS_IGNORE);
      // "<job> <result>" or "-1 " for a first request.
      const std::size_t space = message.find(' ');
      record(std::stol(message.substr(0, space)), message.substr(space + 1));
      long answer = take();
      MPI_Send(&answer, 1, MPI_LONG, status.MPI_SOURCE, kAnswer, MPI_COMM_WORLD);
      ranks->bytes_sent_ += sizeof answer;
      ++ranks->messages_sent_;
      if (answer < 0) ++finished;
    }
  }
#endif
};

JobQueue::JobQueue(const Ranks& ranks, long jobs) : state_(std::make_unique<State>()) {
  state_->ranks = &ranks;
  state_->jobs = jobs;
  state_->results.resize(static_cast<std::size_t>(jobs));
#if IMM_WITH_MPI
  if (ranks.distributed() && ranks.size() > 1 && ranks.root()) {
    state_->root_works = ranks.serialized_threads_;
    if (state_->root_works) state_->dispatcher = std::thread([this] { state_->dispatch(); });
  }
#endif
}

JobQueue::~JobQueue() {
  if (state_->dispatcher.joinable()) state_->dispatcher.join();
}

long JobQueue::next(long job, const std::string& result) {
  const Ranks& ranks = *state_->ranks;
  if (!ranks.distributed() || ranks.size() == 1) {
    state_->record(job, result);
    return state_->take();
  }
#if IMM_WITH_MPI
  if (ranks.root()) {
    state_->record(job, result);
    if (state_->root_works) return state_->take();
    state_->dispatch();  // no thread: the root only hands out jobs
    return -1;
  }
  std::string message = std::to_string(job) + " " + result;
  MPI_Send(message.data(), checked_count(static_cast<long>(message.size())), MPI_CHAR, 0,
           State::kAsk, MPI_COMM_WORLD);
  long answer = -1;
  MPI_Recv(&answer, 1, MPI_LONG, 0, State::kAnswer, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  ranks.bytes_sent_ += message.size();
  ++ranks.messages_sent_;
  return answer;
#else
  return -1;
#endif
}

std::vector<std::string> JobQueue::results() {
  if (state_->dispatcher.joinable()) state_->dispatcher.join();
  const std::lock_guard lock(state_->mutex);
  return state_->results;
}

}  // namespace imm::trainer
