// Private to study.cpp: the MPI ranks of a study (<mpi.h> stays in study_ranks.cpp). Started by an MPI
// launcher (Open MPI's or MPICH's mpirun) with several processes, the process joins MPI_COMM_WORLD;
// otherwise it is rank 0 of 1 and calls no MPI.
#pragma once

#include <string>
#include <vector>

namespace vim::pipeline {

// The rank and number of processes an MPI launcher started (from its environment, without MPI calls);
// 0 and 1 when the process was not started by one.
struct LauncherRanks {
  int rank = 0, size = 1;
};
LauncherRanks launcher_ranks();

class StudyRanks {
 public:
  // Initialises MPI when started by an MPI launcher with several processes and MPI is not yet
  // initialised; the destructor then finalises it.
  StudyRanks();
  ~StudyRanks();
  StudyRanks(const StudyRanks&) = delete;
  StudyRanks& operator=(const StudyRanks&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }
  // Every rank's communicator (MPI_COMM_WORLD) as an MPI_Comm*, for the solves of one simulation over
  // the ranks (SimulationOptions::mpi_comm).
  const void* world() const;
  // Collective: the largest / smallest of every rank's value.
  int max(int value) const;
  int min(int value) const;
  // Collective: on rank 0 every rank's text in rank order; elsewhere empty.
  std::vector<std::string> gather(const std::string& text) const;
  // The end of a run that every rank does alike (`error`: this rank's, "" if none); returns the exit
  // code. The ranks compare their outcomes on a communicator of their own: if any failed, every rank
  // returns 1 and the error is printed once (by rank 0 when it failed too, else by each failed rank).
  // A rank that fails while others still compute (they would wait for it in a solve) prints its error
  // and aborts all ranks after `grace_seconds`.
  int finish(const std::string& error, double grace_seconds = 30.0) const;

 private:
  int rank_ = 0, size_ = 1;
  void* outcome_comm_ = nullptr;  // MPI_Comm (kept out of this header), duplicated from MPI_COMM_WORLD
  bool finalize_ = false;
};

}  // namespace vim::pipeline
