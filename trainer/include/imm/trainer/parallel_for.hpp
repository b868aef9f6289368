// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The trainer's one way to run independent work items in parallel (OpenMP).
///
/// An exception that leaves an OpenMP parallel region is std::terminate — an abort instead of an
/// error a user can act on. parallel_for catches every item's exception, lets the loop finish, and
/// rethrows the exception of the lowest failing index: the same error at any thread count.

#include <omp.h>

#include <exception>

namespace imm::trainer {

/// Calls body(i) for every i in [0, count), items handed out dynamically in chunks of `chunk`.
/// On one thread (or a single item) the loop runs without the OpenMP runtime, whose team of one
/// still makes a system call at each barrier.
template <class Body>
void parallel_for(long count, int chunk, Body&& body) {
  std::exception_ptr first_error;
  long first_index = count;
  // Item i, its exception kept where i is the lowest failing index so far.
  const auto run = [&](long i) {
    try {
      body(i);
    } catch (...) {
#pragma omp critical(imm_parallel_for_error)
      if (i < first_index) {
        first_index = i;
        first_error = std::current_exception();
      }
    }
  };
  if (count <= 1 || omp_get_max_threads() == 1) {
    for (long i = 0; i < count; ++i) run(i);
  } else {
#pragma omp parallel for schedule(dynamic, chunk)
    for (long i = 0; i < count; ++i) run(i);
  }
  if (first_error) std::rethrow_exception(first_error);
}

}  // namespace imm::trainer
