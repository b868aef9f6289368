// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The processes of one training or evaluation job: MPI's world when the program was built with
/// MPI (`IMM_WITH_MPI`) and launched by `mpirun` or `srun`, one process otherwise.
///
/// Work is split by item, never by thread or rank count: a rank computes a contiguous share of the
/// items with OpenMP inside, and the results are exchanged whole (`gather_all`), so that every
/// rank holds every item's result bit for bit as a single process would have computed it. Every
/// reduction then runs on those results in item order, the same code at any rank count.
///
/// Only the main thread calls MPI, except for the sweep's job dispatcher (see job_queue.hpp).

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace imm::trainer {

class Ranks {
 public:
  /// Joins the job when launched by an MPI launcher (MPI_Init_thread), otherwise stays one
  /// process; ends MPI when destroyed. One per program, made first thing in main.
  class Session {
   public:
    Session(int& argc, char**& argv);
    ~Session();
    Session(const Session&) = delete;
    Session& operator=(const Session&) = delete;
  };

  /// The job's ranks (one, before or without a Session).
  [[nodiscard]] static const Ranks& world();

  [[nodiscard]] int rank() const { return rank_; }
  [[nodiscard]] int size() const { return size_; }
  [[nodiscard]] bool root() const { return rank_ == 0; }
  /// Ranks on this machine (for the OpenMP threads each may use).
  [[nodiscard]] int local_size() const { return local_size_; }
  /// Whether MPI is in use (built with it and launched by a launcher).
  [[nodiscard]] bool distributed() const { return distributed_; }

  /// This rank's share [first, last) of `count` items: contiguous, in rank order, sizes differing
  /// by one at most.
  [[nodiscard]] std::pair<long, long> share(long count) const;

  /// Every rank's `mine` (its share of `count` items, `width` doubles each, as share() gives it)
  /// concatenated in item order, on every rank.
  [[nodiscard]] std::vector<double> gather_all(std::span<const double> mine, long count,
                                               int width) const;

  /// Whether `flag` is true on any rank (on every rank).
  [[nodiscard]] bool any(bool flag) const;

  /// Ends every rank of the job with `code` after a failure only this rank may have seen (the
  /// others may be waiting for it). Returns only when not distributed.
  void abort_job(int code) const;

  /// Bytes and messages this rank sent through MPI so far (for the communication model).
  [[nodiscard]] std::uint64_t bytes_sent() const { return bytes_sent_; }
  [[nodiscard]] std::uint64_t messages_sent() const { return messages_sent_; }
  /// Wall seconds this rank spent in MPI's exchanges (waiting for the slowest rank included).
  [[nodiscard]] double exchange_seconds() const { return exchange_seconds_; }
  /// Wall seconds this rank spent in shared_items (its share of the items and the exchange): the
  /// part of a run that more ranks divide.
  [[nodiscard]] double shared_seconds() const { return shared_seconds_; }

 private:
  friend class JobQueue;
  int rank_ = 0;
  int size_ = 1;
  int local_size_ = 1;
  bool distributed_ = false;
  bool serialized_threads_ = false;  ///< MPI allows a second thread to call it (not at once)
  mutable std::uint64_t bytes_sent_ = 0;
  mutable std::uint64_t messages_sent_ = 0;
  mutable double exchange_seconds_ = 0.0;
  mutable double shared_seconds_ = 0.0;
  friend std::vector<double> shared_items(
      long count, int width, const std::function<void(long item, std::span<double> terms)>& body);
};

/// The `width` terms of each of `count` independent items (Monte Carlo runs, tracks), spread
/// over the job's ranks: `body(item, terms)` fills the terms of each item of this rank's share
/// (they start at 0), and every item's terms come back, item-major, on every rank. The caller then
/// sums its figures from them in item order: the same figures at any rank count.
[[nodiscard]] std::vector<double> shared_items(
    long count, int width, const std::function<void(long item, std::span<double> terms)>& body);

/// While alive, Ranks::world() on this process is one rank alone: a sweep's job trains by itself,
/// whatever the job's ranks are doing meanwhile.
class AloneInTheJob {
 public:
  AloneInTheJob();
  ~AloneInTheJob();
  AloneInTheJob(const AloneInTheJob&) = delete;
  AloneInTheJob& operator=(const AloneInTheJob&) = delete;

 private:
  const Ranks* previous_;
};

/// Jobs handed out dynamically: a rank asks for the next one when it has finished one, reporting
/// that one's result. The root answers from a dispatcher thread and works through jobs itself
/// meanwhile (when MPI allows the thread, MPI_THREAD_SERIALIZED; otherwise it only dispatches).
/// One process takes every job in order.
class JobQueue {
 public:
  JobQueue(const Ranks& ranks, long jobs);
  ~JobQueue();
  JobQueue(const JobQueue&) = delete;
  JobQueue& operator=(const JobQueue&) = delete;

  /// Reports the result of this rank's previous job (`job` < 0: none yet) and takes the next job,
  /// or −1 when none is left.
  long next(long job, const std::string& result);
  /// On the root, once next() has returned −1 there: every job's result (the others' results
  /// arrive when they ask for more), by job index.
  [[nodiscard]] std::vector<std::string> results();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

/// Whether this build can run distributed (IMM_WITH_MPI).
[[nodiscard]] bool built_with_mpi();

}  // namespace imm::trainer
