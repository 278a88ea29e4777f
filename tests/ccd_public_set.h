// The public CCD query set with exact ground truth (tests/data/ccd_public.txt): one query a line,
// "vf" or "ee", the four particles at t = 0 and then at t = 1 (24 numbers), and whether they meet.
#pragma once

#include <array>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "nucleon/types.h"

namespace nucleon::test {

struct CcdQuery {
  bool vertexFace =
      true;  // x[0] the point, x[1..3] the triangle; else the edges x[0]x[1], x[2]x[3]
  std::array<Vec3d, 8> x;  // x[0..3] at t = 0, x[4..7] at t = 1
  int truth = 0;           // 1: they meet during the motion
};

inline std::vector<CcdQuery> loadPublicCcdSet() {
  std::ifstream in(std::string(NUCLEON_TEST_DATA) + "/ccd_public.txt");
  std::vector<CcdQuery> queries;
  for (std::string line; std::getline(in, line);) {
    std::istringstream fields(line);
    std::string kind;
    if (!(fields >> kind) || kind[0] == '#') continue;
    CcdQuery q;
    q.vertexFace = kind == "vf";
    for (int i = 0; i < 24; ++i) fields >> q.x[i / 3][i % 3];
    fields >> q.truth;
    queries.push_back(q);
  }
  return queries;
}

}  // namespace nucleon::test
