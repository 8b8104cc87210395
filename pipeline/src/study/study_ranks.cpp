// The MPI ranks of a study (study_ranks.hpp).
#include "study/study_ranks.hpp"

#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <iostream>
#include <stdexcept>
#include <thread>
#include <utility>
#include <vim/pipeline/common/input_error.hpp>

namespace vim::pipeline {

namespace {

int environment_number(const char* name) {
  const char* v = std::getenv(name);
  return v ? std::atoi(v) : -1;
}

}  // namespace

LauncherRanks launcher_ranks() {
  LauncherRanks r;
  // Open MPI's and MPICH's (Hydra) launchers set these in every process they start.
  for (const auto& [size, rank] :
       {std::pair{"OMPI_COMM_WORLD_SIZE", "OMPI_COMM_WORLD_RANK"}, std::pair{"PMI_SIZE", "PMI_RANK"}})
    if (environment_number(size) > 0) {
      r.size = environment_number(size);
      r.rank = std::max(0, environment_number(rank));
      break;
    }
  return r;
}

const void* StudyRanks::world() const {
  static const MPI_Comm world = MPI_COMM_WORLD;
  return &world;
}

StudyRanks::StudyRanks() {
  if (launcher_ranks().size == 1) return;
  int initialized = 0;
  MPI_Initialized(&initialized);
  if (!initialized) {
    int provided = 0;
    // The fem solvers initialise MPI the same way when a serial run first needs it (solvers.cpp).
    if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_SERIALIZED, &provided) != MPI_SUCCESS)
      throw std::runtime_error("MPI_Init_thread failed: the study cannot run under mpirun");
    finalize_ = true;
  }
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  auto* comm = new MPI_Comm;
  MPI_Comm_dup(MPI_COMM_WORLD, comm);
  outcome_comm_ = comm;
}

StudyRanks::~StudyRanks() {
  delete static_cast<MPI_Comm*>(outcome_comm_);
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (finalize_ && !finalized) MPI_Finalize();
}

int StudyRanks::max(int value) const {
  if (size_ > 1) MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  return value;
}

int StudyRanks::min(int value) const {
  if (size_ > 1) MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  return value;
}

std::vector<std::string> StudyRanks::gather(const std::string& text) const {
  if (size_ == 1) return {text};
  int length = static_cast<int>(text.size());
  std::vector<int> lengths(rank_ == 0 ? size_ : 0), offsets(lengths.size());
  MPI_Gather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
  std::string all;
  if (rank_ == 0) {
    for (int r = 0, at = 0; r < size_; at += lengths[r], ++r) offsets[r] = at;
    all.resize(static_cast<std::size_t>(offsets.back() + lengths.back()));
  }
  MPI_Gatherv(text.data(), length, MPI_CHAR, all.data(), lengths.data(), offsets.data(), MPI_CHAR, 0,
              MPI_COMM_WORLD);
  std::vector<std::string> texts;
  if (rank_ == 0)
    for (int r = 0; r < size_; ++r) texts.push_back(all.substr(offsets[r], lengths[r]));
  return texts;
}

int StudyRanks::finish(const std::string& error, double grace_seconds) const {
  const bool failed = !error.empty();
  if (size_ == 1) {
    if (failed) print_error(error);
    return failed ? 1 : 0;
  }
  // {any rank failed, rank 0 failed}
  int mine[2] = {failed ? 1 : 0, rank_ == 0 && failed ? 1 : 0}, all[2] = {0, 0};
  MPI_Request request;
  MPI_Iallreduce(mine, all, 2, MPI_INT, MPI_MAX, *static_cast<MPI_Comm*>(outcome_comm_), &request);
  int done = 0;
  const auto start = std::chrono::steady_clock::now();
  while (!done) {
    MPI_Test(&request, &done, MPI_STATUS_IGNORE);
    if (done || !failed) continue;  // a rank that succeeded waits for the others
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > grace_seconds) {
      print_error(rank_ == 0 ? error : "rank " + std::to_string(rank_) + ": " + error);
      std::cerr.flush();
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (failed && (rank_ == 0 || !all[1]))
    print_error(rank_ == 0 ? error : "rank " + std::to_string(rank_) + ": " + error);
  return all[0] ? 1 : 0;
}

}  // namespace vim::pipeline
