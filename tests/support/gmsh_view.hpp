// What Gmsh kept after reading a .msh file (tests only): `gmsh FILE -save -format msh22` re-saves every
// element of a physical group; the MSH 2.2 it writes lists nodes, elements (type, physical tag) and
// names, which this reads back.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

namespace vim::test {

struct GmshView {
  long nodes = 0;
  std::map<int, long> elements_of_type;
  std::map<std::string, long> elements_of_group;
};

inline GmshView gmsh_view(const std::filesystem::path& msh) {
  const std::filesystem::path out = msh.parent_path() / "resaved.msh";
  const std::string cmd = "gmsh '" + msh.string() + "' -save -format msh22 -o '" + out.string() + "' > '" +
                          (msh.parent_path() / "gmsh.log").string() + "' 2>&1";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << "gmsh failed; see gmsh.log";
  std::ifstream in(out);
  GmshView v;
  std::map<int, std::string> names;
  std::string line;
  while (std::getline(in, line)) {
    if (line == "$PhysicalNames") {
      int n;
      in >> n;
      for (int i = 0; i < n; ++i) {
        int d, tag;
        std::string name;
        in >> d >> tag >> name;
        names[tag] = name.substr(1, name.size() - 2);
      }
    } else if (line == "$Nodes") {
      in >> v.nodes;
    } else if (line == "$Elements") {
      long n;
      in >> n;
      std::getline(in, line);
      for (long i = 0; i < n && std::getline(in, line); ++i) {
        std::istringstream s(line);
        long id;
        int type, ntags, phys;
        s >> id >> type >> ntags >> phys;
        ++v.elements_of_type[type];
        ++v.elements_of_group[names.at(phys)];
      }
    }
  }
  return v;
}

}  // namespace vim::test
