// Numbers, points and vectors as the error messages of every module write them: "(x, y[, z])", each
// value in the stream's default format.
#pragma once

#include <sstream>
#include <string>

namespace vim {

inline std::string number_text(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

inline std::string point_text(const double* x, int n) {
  std::ostringstream s;
  s << "(";
  for (int a = 0; a < n; ++a) s << (a ? ", " : "") << x[a];
  s << ")";
  return s.str();
}

}  // namespace vim
