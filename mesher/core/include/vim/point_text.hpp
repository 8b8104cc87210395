// A point or vector as the error messages of every module write it: "(x, y[, z])", each coordinate in
// the stream's default format.
#pragma once

#include <sstream>
#include <string>

namespace vim {

inline std::string point_text(const double* x, int n) {
  std::ostringstream s;
  s << "(";
  for (int a = 0; a < n; ++a) s << (a ? ", " : "") << x[a];
  s << ")";
  return s.str();
}

}  // namespace vim
