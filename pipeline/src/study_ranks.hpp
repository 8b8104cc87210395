// Private to study.cpp: the MPI ranks of a study (<mpi.h> stays in study_ranks.cpp). Started by an MPI
// launcher (mpirun), the process joins MPI_COMM_WORLD; otherwise it is rank 0 of 1 and calls no MPI.
#pragma once

#include <string>
#include <vector>

namespace vim::pipeline {

class StudyRanks {
 public:
  // Initialises MPI when started by an MPI launcher and MPI is not yet initialised; the destructor
  // then finalises it.
  StudyRanks();
  ~StudyRanks();
  StudyRanks(const StudyRanks&) = delete;
  StudyRanks& operator=(const StudyRanks&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }
  // Collective: the largest / smallest of every rank's value.
  int max(int value) const;
  int min(int value) const;
  // Collective: on rank 0 every rank's text in rank order; elsewhere empty.
  std::vector<std::string> gather(const std::string& text) const;

 private:
  int rank_ = 0, size_ = 1;
  bool finalize_ = false;
};

}  // namespace vim::pipeline
