// GoogleTest main that initialises MPI through deal.II (Trilinos needs it even on one rank).
// Under mpirun only rank 0 prints; every rank runs every test and the exit code is the
// logical OR of all ranks' failures.
#include <deal.II/base/mpi.h>
#include <gtest/gtest.h>

int main(int argc, char** argv) {
  dealii::Utilities::MPI::MPI_InitFinalize mpi(argc, argv, 1);
  ::testing::InitGoogleTest(&argc, argv);
  const unsigned rank = dealii::Utilities::MPI::this_mpi_process(MPI_COMM_WORLD);
  if (rank != 0) {
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
  }
  const int local = RUN_ALL_TESTS();
  const int global = static_cast<int>(dealii::Utilities::MPI::max(static_cast<unsigned>(local != 0), MPI_COMM_WORLD));
  return global;
}
